//! One period of the N-subsystem (docs/theory.md (T57)–(T62)): its Moreau–Jean integration
//! with the periodic load of the condensed linear part, and the residual (T58) built from it.

use super::GeneralMsHbm;
use crate::error::Result;
use crate::harmonic::n_coefficients;
use crate::integrate::{Integrator, Scheme, Settings};
use crate::linear::CondensedFrequency;

/// The time history of the nonlinear subsystem over one period for given unknowns, at the
/// step times `t_j = jT/N_s`, `j = 0..N_s` (rows of `n_N`, `n_c` or `n_f` values, stored
/// row after row).
#[derive(Clone, Debug)]
pub struct Trajectory {
    n: usize,
    n_contacts: usize,
    n_frictions: usize,
    displacement: Vec<f64>,
    gaps: Vec<f64>,
    contact_forces: Vec<f64>,
    friction_forces: Vec<f64>,
    end_q: Vec<f64>,
    end_v: Vec<f64>,
}

/// Row `j` of `values` stored in rows of `width`.
fn row(values: &[f64], width: usize, j: usize) -> &[f64] {
    &values[j * width..(j + 1) * width]
}

/// Column `i` of `values` stored in rows of `width`.
fn column(values: &[f64], width: usize, i: usize) -> Vec<f64> {
    values.chunks_exact(width.max(1)).map(|r| r[i]).collect()
}

impl Trajectory {
    /// A frictionless trajectory from samples on the step grid (rows of `n` displacements
    /// and of `n_contacts` gaps and forces) and the state at `t = T`.
    pub(super) fn from_samples(
        n: usize,
        displacement: Vec<f64>,
        gaps: Vec<f64>,
        contact_forces: Vec<f64>,
        (end_q, end_v): (Vec<f64>, Vec<f64>),
    ) -> Self {
        let steps = displacement.len() / n.max(1);
        Trajectory {
            n,
            n_contacts: gaps.len() / steps.max(1),
            n_frictions: 0,
            displacement,
            gaps,
            contact_forces,
            friction_forces: vec![],
            end_q,
            end_v,
        }
    }

    /// Steps per period `N_s`.
    pub fn steps(&self) -> usize {
        self.displacement.len() / self.n.max(1)
    }
    /// `q_N(t_j)` (N numbering).
    pub fn displacement(&self, j: usize) -> &[f64] {
        row(&self.displacement, self.n, j)
    }
    /// Contact gaps at `t_j`.
    pub fn gaps(&self, j: usize) -> &[f64] {
        row(&self.gaps, self.n_contacts, j)
    }
    /// Contact forces (impulse / h) of the step ending at `t_j` (row 0: the last step of
    /// the period, `t_{N_s} ≡ t_0`).
    pub fn contact_forces(&self, j: usize) -> &[f64] {
        row(&self.contact_forces, self.n_contacts, j)
    }
    /// Friction forces (impulse / h), same convention.
    pub fn friction_forces(&self, j: usize) -> &[f64] {
        row(&self.friction_forces, self.n_frictions, j)
    }
    /// `q_N(t_j)` of N-DOF `i` over the period.
    pub fn displacement_series(&self, i: usize) -> Vec<f64> {
        column(&self.displacement, self.n, i)
    }
    /// The gap of contact `c` over the period.
    pub fn gap_series(&self, c: usize) -> Vec<f64> {
        column(&self.gaps, self.n_contacts, c)
    }
    /// The force of contact `c` over the period.
    pub fn contact_force_series(&self, c: usize) -> Vec<f64> {
        column(&self.contact_forces, self.n_contacts, c)
    }
    /// The force of friction element `f` over the period.
    pub fn friction_force_series(&self, f: usize) -> Vec<f64> {
        column(&self.friction_forces, self.n_frictions, f)
    }
    /// State at `t = T`.
    pub fn end_q(&self) -> &[f64] {
        &self.end_q
    }
    /// Velocity at `t = T`.
    pub fn end_v(&self) -> &[f64] {
        &self.end_v
    }
}

impl GeneralMsHbm {
    /// Coefficients (harmonic-major) of the load `F(t)` of eq. (10) on N for `q̂_N`.
    fn load_coefficients(&self, fd: &dyn CondensedFrequency, x: &[f64]) -> Vec<f64> {
        fd.interface_load_coefficients(x)
    }

    /// Integrate the nonlinear subsystem over one period (eq. 10) from the state in `x`.
    pub(super) fn integrate(&self, fd: &dyn CondensedFrequency, x: &[f64]) -> Result<Trajectory> {
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let omega = fd.omega();
        let period = 2.0 * std::f64::consts::PI / omega;
        let ns = self.steps;
        let mut it = Integrator::new(
            &self.subsystem,
            &Settings {
                dt: period / ns as f64,
                scheme: Scheme::MoreauJean {
                    theta: self.theta,
                    restitution: self.restitution,
                },
                omega: Some(omega),
                energy_offset: 0.0,
            },
        )?;
        it.set_contact_anticipation(self.anticipate);
        it.set_contact_projection(self.project);
        it.set_periodic_load(self.harmonics, self.load_coefficients(fd, x))?;
        let q0 = &x[n * nc..n * nc + n];
        let v0: Vec<f64> = x[n * nc + n..n * nc + 2 * n]
            .iter()
            .map(|v| v * omega)
            .collect();
        it.set_state(0.0, q0, &v0)?;
        let (nc, nf) = (it.forces().len(), it.friction_forces().len());
        let mut tr = Trajectory {
            n,
            n_contacts: nc,
            n_frictions: nf,
            displacement: Vec::with_capacity(ns * n),
            gaps: Vec::with_capacity(ns * nc),
            contact_forces: vec![0.0; ns * nc],
            friction_forces: vec![0.0; ns * nf],
            end_q: vec![],
            end_v: vec![],
        };
        for j in 0..ns {
            // element by element: rows of one or two values, where a copy call costs more
            tr.displacement.extend(it.q().iter().copied());
            tr.gaps.extend(it.gaps().iter().copied());
            it.step()?;
            let slot = (j + 1) % ns;
            tr.contact_forces[slot * nc..(slot + 1) * nc].copy_from_slice(it.forces());
            tr.friction_forces[slot * nf..(slot + 1) * nf].copy_from_slice(it.friction_forces());
        }
        tr.end_q = it.q().to_vec();
        tr.end_v = it.v().to_vec();
        Ok(tr)
    }

    pub(super) fn residual_with(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
    ) -> Result<(Vec<f64>, Trajectory)> {
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let tr = self.integrate(fd, x)?;
        let dft = self.sampling.dft_set(&tr.displacement, n);
        let mut r = vec![0.0; n * (nc + 2)];
        for i in 0..n {
            for c in 0..nc {
                r[c * n + i] = x[c * n + i] - dft[c * n + i];
            }
            r[nc * n + i] = tr.end_q[i] - x[nc * n + i];
            r[(nc + 1) * n + i] = tr.end_v[i] / fd.omega() - x[(nc + 1) * n + i];
        }
        for (f, i) in self.stuck_frictions(&tr) {
            // a continuum of periodic solutions (any stuck position): select the one with
            // zero mean friction force instead of the (dependent) position periodicity
            let fr = &self.subsystem.frictions[f];
            let w_i: f64 = fr.w.iter().filter(|(d, _)| *d == i).map(|(_, w)| w).sum();
            let mean = tr.friction_force_series(f).iter().sum::<f64>() / self.steps as f64;
            r[nc * n + i] = w_i * mean / self.stiffness_nn_diagonal[i];
        }
        Ok((r, tr))
    }

    /// The trajectory of the nonlinear subsystem over one period for `x` at `ω`
    /// (diagnostics: friction forces, contact forces, gaps).
    pub fn trajectory(&mut self, x: &[f64], omega: f64) -> Result<Trajectory> {
        self.check_x(x)?;
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        if self.is_event_driven() {
            return self.event_trajectory(fd, x);
        }
        self.integrate(fd, x)
    }
}
