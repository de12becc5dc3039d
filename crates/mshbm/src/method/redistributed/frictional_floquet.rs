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
use crate::stability::{Floquet, HeldPhase, RealModalForm};

/// One set of modes' data for the Floquet analysis (T182): the phase's matrices, the real
/// modal form `𝔄 = V B V⁻¹` of its first-order matrix when it has one, and `V⁻¹ 𝔅`.
pub(super) struct FrictionPhase {
    held: HeldPhase,
    form: Option<RealModalForm>,
    modal_forcing: Mat<f64>,
}

/// `(F, G)` of a set of modes (T152).
type ForceMaps<'a> = (&'a [f64], &'a [f64]);

/// The sets' data by the contacts' modes; it depends on the modes only, so it is kept
/// along a diagram (cleared when the stability options or the harmonics change, and when it
/// reaches [`PHASE_CACHE_BYTES`]).
#[derive(Default)]
pub(super) struct PhaseCache {
    sets: HashMap<Vec<Mode>, Rc<FrictionPhase>>,
    bytes: usize,
}

/// The memory the kept sets may take: on the friction damper (full space, 380 coordinates)
/// a set takes 2.4 MB and a diagram meets ~90 sets.
const PHASE_CACHE_BYTES: usize = 256 << 20;

impl PhaseCache {
    pub(super) fn clear(&mut self) {
        self.sets.clear();
        self.bytes = 0;
    }

    fn insert(&mut self, modes: Vec<Mode>, data: Rc<FrictionPhase>) {
        let bytes = data.bytes();
        if self.bytes + bytes > PHASE_CACHE_BYTES {
            self.clear();
        }
        self.bytes += bytes;
        self.sets.insert(modes, data);
    }
}

impl FrictionPhase {
    fn bytes(&self) -> usize {
        let h = &self.held;
        let mut values = [
            &h.state,
            &h.forcing,
            &h.load_z,
            &h.load_a,
            &h.rate_z,
            &self.modal_forcing,
        ]
        .iter()
        .map(|m| m.nrows() * m.ncols())
        .sum::<usize>();
        if let Some(form) = &self.form {
            values += 2 * form.v().nrows() * form.v().ncols();
        }
        8 * values
    }
}

impl RedistributedMsHbm {
    /// The multipliers of the frictional solution at `(x, ω)` (T182)–(T184): the monodromy of
    /// the state `(w η, η̇, δa)` as the product of the phases' exact propagators (T182) and
    /// the anchors' jumps (T183), restricted to the linear part and the anchors of the
    /// contacts stuck at `τ = 0` that slip or open during the period; a contact stuck all
    /// period adds the neutral multiplier 1 of the family of its anchors, left out (T184).
    pub(super) fn frictional_floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<Floquet>> {
        let reduced = self.stability_system()?;
        let periodic = self
            .evaluation(x, omega)?
            .friction
            .clone()
            .expect("a frictional evaluation holds its law");
        let Some(law) = periodic.plane() else {
            return Err(Error::argument(
                "stability",
                "the Floquet multipliers of friction in the Coulomb cone (3D interfaces) are not implemented yet; compute the response without stability",
            ));
        };
        let r2 = 2 * reduced.dimension();
        let n_c = law.phases.first().map_or(0, |p| p.modes.len());
        let m = 2 * n_c;
        // the modes of each set index the law met (events refer to the set before them)
        let mut modes_of: HashMap<usize, &[Mode]> = HashMap::new();
        for phase in &law.phases {
            modes_of.insert(PeriodicContact::mode_set(phase), &phase.modes);
        }
        let mut k_inv: Option<Mat<f64>> = None;
        let mut sets: HashMap<usize, Rc<FrictionPhase>> = HashMap::new();
        let mut needed: Vec<(usize, ForceMaps)> = law
            .phases
            .iter()
            .map(|p| (PeriodicContact::mode_set(p), law.force_maps(p)))
            .collect();
        needed.extend(law.events.iter().map(|e| {
            (
                PeriodicContact::mode_set_before(e),
                law.force_maps_before(e),
            )
        }));
        for (set, (f, g)) in needed {
            if sets.contains_key(&set) {
                continue;
            }
            let modes = modes_of.get(&set).ok_or_else(|| {
                Error::Numerical("friction: an anchor's modes were not a phase's".into())
            })?;
            if let Some(data) = self.friction_phases.sets.get(*modes) {
                sets.insert(set, data.clone());
                continue;
            }
            // P = K_NN⁻¹ + Y F Yᵀ, Q = Y G
            let y = self.contact.force_compliance();
            let k_inv = k_inv.get_or_insert_with(|| self.contact.stiffness_inverse());
            let f = Mat::<f64>::from_fn(m, m, |i, j| f[i * m + j]);
            let g = Mat::<f64>::from_fn(m, n_c, |i, j| g[i * n_c + j]);
            let p = &*k_inv + y * (&f * y.transpose());
            let q = y * &g;
            let mut held = reduced.held_phase(p.as_ref(), q.as_ref())?;
            let form = RealModalForm::new(&held.state);
            let modal_forcing = match &form {
                Some(form) => {
                    let modal = form.v_inv() * &held.forcing;
                    // the modal form replaces the phase's matrices
                    held.state = Mat::zeros(0, 0);
                    held.forcing = Mat::zeros(0, 0);
                    modal
                }
                None => Mat::zeros(0, 0),
            };
            let data = Rc::new(FrictionPhase {
                held,
                form,
                modal_forcing,
            });
            self.friction_phases.insert(modes.to_vec(), data.clone());
            sets.insert(set, data);
        }
        let y = self.contact.force_compliance();
        let size = r2 + n_c;
        let mut state = Mat::<f64>::identity(size, size);
        let mut before = state.clone();
        for (k, phase) in law.phases.iter().enumerate() {
            let dt = (phase.end - phase.start) / omega;
            if dt > 0.0 {
                propagate(&sets[&PeriodicContact::mode_set(phase)], dt, r2, &mut state);
                before.copy_from(&state);
            }
            for event in law.events.iter().filter(|e| e.after == k + 1) {
                let data = &sets[&PeriodicContact::mode_set_before(event)].held;
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

/// `X ← exp([[𝔄, 𝔅], [0, 0]] Δt) X` for the state `X = (z, δa)` (its first `r2` rows `z`)
/// (T182): in the set's modal form `z ← V (e^{BΔt} V⁻¹ z + (e^{BΔt} − I) B⁻¹ V⁻¹ 𝔅 δa)`, two
/// products; by a dense exponential where the set has no modal form.
fn propagate(data: &FrictionPhase, dt: f64, r2: usize, state: &mut Mat<f64>) {
    let size = state.nrows();
    let Some(form) = &data.form else {
        let h = &data.held;
        let augmented = Mat::<f64>::from_fn(size, size, |i, j| match (i < r2, j < r2) {
            (true, true) => h.state[(i, j)] * dt,
            (true, false) => h.forcing[(i, j - r2)] * dt,
            _ => 0.0,
        });
        *state = crate::dense::expm(&augmented) * &*state;
        return;
    };
    let mut modal = form.v_inv() * state.as_ref().subrows(0, r2);
    form.exp_times(dt, modal.as_mut());
    if size > r2 {
        let mut forced = &data.modal_forcing * state.as_ref().subrows(r2, size - r2);
        form.integral_times(dt, forced.as_mut());
        modal += &forced;
    }
    let z = form.v() * &modal;
    state.as_mut().subrows_mut(0, r2).copy_from(&z);
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
