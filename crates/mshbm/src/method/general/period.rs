//! One period of the N-subsystem (docs/theory.md (T57)–(T62)): its Moreau–Jean integration
//! with the periodic load of the condensed linear part, and the residual (T58) built from it.

use super::GeneralMsHbm;
use crate::error::Result;
use crate::harmonic::{n_coefficients, Sampling};
use crate::integrate::{Integrator, Scheme, Settings};
use crate::linear::CondensedFrequency;

/// The time history of the nonlinear subsystem over one period for given unknowns.
#[derive(Clone, Debug)]
pub struct Trajectory {
    /// `q_N` at the step times `t_j = jT/N_s`, `j = 0..N_s` (row `j`, N numbering).
    pub displacement: Vec<Vec<f64>>,
    /// `q̇_N` at the step times.
    pub velocity: Vec<Vec<f64>>,
    /// Contact gaps at the step times.
    pub gaps: Vec<Vec<f64>>,
    /// Contact forces (impulse / h) of the step ending at `t_j` (row 0: the last step of
    /// the period, `t_{N_s} ≡ t_0`).
    pub contact_forces: Vec<Vec<f64>>,
    /// Friction forces (impulse / h), same convention.
    pub friction_forces: Vec<Vec<f64>>,
    /// State at `t = T`.
    pub end_q: Vec<f64>,
    pub end_v: Vec<f64>,
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
        let mut tr = Trajectory {
            displacement: Vec::with_capacity(ns),
            velocity: Vec::with_capacity(ns),
            gaps: Vec::with_capacity(ns),
            contact_forces: vec![vec![]; ns],
            friction_forces: vec![vec![]; ns],
            end_q: vec![],
            end_v: vec![],
        };
        for j in 0..ns {
            tr.displacement.push(it.q().to_vec());
            tr.velocity.push(it.v().to_vec());
            tr.gaps.push(it.gaps().to_vec());
            it.step()?;
            let slot = (j + 1) % ns;
            tr.contact_forces[slot] = it.forces().to_vec();
            tr.friction_forces[slot] = it.friction_forces().to_vec();
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
        let sampling = Sampling::new(self.harmonics, self.steps);
        let mut r = vec![0.0; n * (nc + 2)];
        for i in 0..n {
            let samples: Vec<f64> = tr.displacement.iter().map(|q| q[i]).collect();
            let dft = sampling.dft(&samples);
            for c in 0..nc {
                r[c * n + i] = x[c * n + i] - dft[c];
            }
            r[nc * n + i] = tr.end_q[i] - x[nc * n + i];
            r[(nc + 1) * n + i] = tr.end_v[i] / fd.omega() - x[(nc + 1) * n + i];
        }
        for (f, i) in self.stuck_frictions(&tr) {
            // a continuum of periodic solutions (any stuck position): select the one with
            // zero mean friction force instead of the (dependent) position periodicity
            let fr = &self.subsystem.frictions[f];
            let w_i: f64 = fr.w.iter().filter(|(d, _)| *d == i).map(|(_, w)| w).sum();
            let mean = tr.friction_forces.iter().map(|p| p[f]).sum::<f64>() / self.steps as f64;
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
        self.integrate(fd, x)
    }
}
