//! Floquet multipliers of a periodic solution with Coulomb friction on its contacts
//! (docs/theory.md (T182)–(T184)): the variational equation per phase of constant modes,
//! with the stuck contacts' anchor perturbations as held states, and the jumps of the
//! anchors where contacts stick.

use std::collections::HashMap;
use std::rc::Rc;

use faer::Mat;

use super::friction::PeriodicContact;
use super::friction::{AnchorEvent, Mode};
use super::RedistributedMsHbm;
use crate::error::{Error, Result};
use crate::stability::{Floquet, HeldPhase};

impl RedistributedMsHbm {
    /// The multipliers of the frictional solution at `(x, ω)` (T182)–(T184): the monodromy of
    /// the state `(w η, η̇, δa)` as the product of the phases' exponentials (T182) and the
    /// anchors' jumps (T183), restricted to the linear part and the anchors of the contacts
    /// stuck at `τ = 0` that slip or open during the period; a contact stuck all period
    /// adds the neutral multiplier 1 of the family of its anchors, left out (T184).
    pub(super) fn frictional_floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<Floquet>> {
        let reduced = self.stability_system()?;
        let law: Rc<PeriodicContact> = self
            .evaluation(x, omega)?
            .friction
            .clone()
            .expect("a frictional evaluation holds its law");
        let r2 = 2 * reduced.dimension();
        let n_c = law.phases.first().map_or(0, |p| p.modes.len());
        let m = 2 * n_c;
        let y = self.contact.force_compliance();
        let k_inv = self.contact.stiffness_inverse();
        // the phase data of each mode set met (T182): P = K_NN⁻¹ + Y F Yᵀ, Q = Y G
        let mut held: HashMap<usize, HeldPhase> = HashMap::new();
        let mut phase_of = |set: usize, (f, g): (&[f64], &[f64])| -> Result<()> {
            if held.contains_key(&set) {
                return Ok(());
            }
            let f = Mat::<f64>::from_fn(m, m, |i, j| f[i * m + j]);
            let g = Mat::<f64>::from_fn(m, n_c, |i, j| g[i * n_c + j]);
            let p = &k_inv + y * (&f * y.transpose());
            let q = y * &g;
            held.insert(set, reduced.held_phase(p.as_ref(), q.as_ref())?);
            Ok(())
        };
        for phase in &law.phases {
            phase_of(PeriodicContact::mode_set(phase), law.force_maps(phase))?;
        }
        for event in &law.events {
            phase_of(
                PeriodicContact::mode_set_before(event),
                law.force_maps_before(event),
            )?;
        }
        let size = r2 + n_c;
        let mut state = Mat::<f64>::identity(size, size);
        let mut before = state.clone();
        for (k, phase) in law.phases.iter().enumerate() {
            let dt = (phase.end - phase.start) / omega;
            if dt > 0.0 {
                let data = &held[&PeriodicContact::mode_set(phase)];
                let augmented = Mat::<f64>::from_fn(size, size, |i, j| match (i < r2, j < r2) {
                    (true, true) => data.state[(i, j)] * dt,
                    (true, false) => data.forcing[(i, j - r2)] * dt,
                    _ => 0.0,
                });
                state = crate::dense::expm(&augmented) * &state;
                before = state.clone();
            }
            for event in law.events.iter().filter(|e| e.after == k + 1) {
                let data = &held[&PeriodicContact::mode_set_before(event)];
                let row = jump_row(event, data, y, omega);
                // the new anchor from the state before the switches at this instant (T183)
                let new = row.as_ref() * &before;
                for j in 0..size {
                    state[(r2 + event.contact, j)] = new[(0, j)];
                }
            }
        }
        // (T184): the linear part, and the anchors at τ = 0 that the period renews
        let first = &law.phases[0].modes;
        let renewed: Vec<usize> = (0..n_c)
            .filter(|&c| first[c] == Mode::Stick && law.events.iter().any(|e| e.contact == c))
            .collect();
        let keep: Vec<usize> = (0..r2).chain(renewed.iter().map(|c| r2 + c)).collect();
        let monodromy =
            Mat::<f64>::from_fn(keep.len(), keep.len(), |i, j| state[(keep[i], keep[j])]);
        if monodromy
            .col_iter()
            .any(|c| c.iter().any(|v| !v.is_finite()))
        {
            return Err(Error::Numerical(
                "Floquet multipliers: the monodromy over one period is not finite (an exponential overflowed)".into(),
            ));
        }
        let values = crate::dense::eigenvalues(monodromy.as_ref())?;
        Ok(Some(Floquet::from_eigenvalues(values)))
    }
}

/// The row of the anchor's jump (T183) on the state `(z, δa)` before the switches:
/// `δa_c = gᵀ δγ + vᵀ δγ' + sᵀ δa` with `δγ = −Yᵀ (L_z z + L_a δa)` and
/// `δγ' = −Yᵀ R_z z / ω`.
fn jump_row(
    event: &AnchorEvent,
    data: &HeldPhase,
    y: faer::MatRef<'_, f64>,
    omega: f64,
) -> Mat<f64> {
    let m = event.gap.len();
    let g = Mat::<f64>::from_fn(1, m, |_, j| event.gap[j]);
    let v = Mat::<f64>::from_fn(1, m, |_, j| event.rate[j] / omega);
    let gy = &g * y.transpose();
    let vy = &v * y.transpose();
    let row_z = -(&gy * &data.load_z) - &vy * &data.rate_z;
    let row_a = -(&gy * &data.load_a);
    let (r2, n_a) = (row_z.ncols(), row_a.ncols());
    Mat::<f64>::from_fn(1, r2 + n_a, |_, j| {
        if j < r2 {
            row_z[(0, j)]
        } else {
            row_a[(0, j - r2)] + event.anchors[j - r2]
        }
    })
}
