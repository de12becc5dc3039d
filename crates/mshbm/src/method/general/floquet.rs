//! The whole system's state and period map at the solution (docs/theory.md §11, (T83)):
//! the initial state of all DOFs from the unknowns, and the monodromy matrix by finite
//! differences of the Moreau–Jean period map, whose eigenvalues are the Floquet multipliers.

use faer::{c64, Mat};
use rayon::prelude::*;

use super::GeneralMsHbm;
use crate::error::{Error, Result};
use crate::harmonic::n_coefficients;
use crate::integrate::{Integrator, Scheme, Settings};
use crate::linear::CondensedFrequency;
use crate::method::complex_harmonic;

/// Largest system (DOFs) for which [`GeneralMsHbm`] computes Floquet multipliers: the
/// monodromy is dense, `2n × 2n`, and costs `2n + 1` full-system period integrations.
pub const MAX_FLOQUET_DOFS: usize = 1500;

impl GeneralMsHbm {
    /// Complex amplitudes `z_k` (`q_L(t) = Re Σ_k z_k e^{ikωt}`) of all L DOFs, `k = 0..=H`
    /// (eq. 6).
    fn linear_part_amplitudes(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
    ) -> Result<Vec<Vec<c64>>> {
        let n = self.n();
        (0..=self.harmonics)
            .map(|k| fd.linear_amplitudes(k, &complex_harmonic(x, n, k)))
            .collect()
    }

    /// State `(q, q̇)` of the whole system (system numbering) at `t = 0` of the solution
    /// `x`: the N part from `x`, the L part from its harmonics (eq. 6).
    pub fn initial_state(&mut self, x: &[f64], omega: f64) -> Result<(Vec<f64>, Vec<f64>)> {
        self.check_x(x)?;
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        self.full_initial_state(fd, x)
    }

    pub(super) fn full_initial_state(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let n = self.n();
        let nc = n_coefficients(self.harmonics);
        let mut q = vec![0.0; self.system.n_dofs()];
        let mut v = vec![0.0; self.system.n_dofs()];
        if self.is_event_driven() {
            // the unknowns hold the state at the section, not at t = 0
            let (qn, vn) = self.event_state_at_zero(fd, x)?;
            for (i, &d) in self.system.nonlinear_dofs.iter().enumerate() {
                q[d] = qn[i];
                v[d] = vn[i];
            }
        } else {
            for (i, &d) in self.system.nonlinear_dofs.iter().enumerate() {
                q[d] = x[nc * n + i];
                v[d] = x[(nc + 1) * n + i] * fd.omega();
            }
        }
        let z = self.linear_part_amplitudes(fd, x)?;
        for (l, &d) in self.system.linear_dofs.iter().enumerate() {
            for (k, zk) in z.iter().enumerate() {
                q[d] += zk[l].re;
                v[d] -= k as f64 * fd.omega() * zk[l].im;
            }
        }
        Ok((q, v))
    }

    /// The monodromy matrix used by [`crate::problem::PeriodicProblem::floquet`] (see there):
    /// forward differences of the whole system's Moreau–Jean period map at the solution's
    /// initial state, in the scaled state `(q, q̇/ω)` of the DOFs with mass (system numbering),
    /// `2n × 2n`.
    pub fn monodromy(&mut self, x: &[f64], omega: f64) -> Result<Mat<f64>> {
        self.check_x(x)?;
        self.prepare(omega)?;
        let n_dofs = self.system.n_dofs();
        if n_dofs > MAX_FLOQUET_DOFS {
            return Err(Error::argument(
                "stability",
                format!("the model has {n_dofs} DOFs; the dense monodromy of the general MS-HBM is limited to {MAX_FLOQUET_DOFS} (use --no-stability)"),
            ));
        }
        let this = &*self;
        let fd = this.frequency.as_deref().expect("prepared");
        let (q0, v0) = this.full_initial_state(fd, x)?;
        let steps = this.steps;
        let settings = Settings {
            dt: 2.0 * std::f64::consts::PI / omega / steps as f64,
            scheme: Scheme::MoreauJean {
                theta: this.theta,
                restitution: this.restitution,
            },
            omega: Some(omega),
            energy_offset: 0.0,
        };
        let new_integrator = || -> Result<Integrator> {
            let mut it = Integrator::new(&this.system, &settings)?;
            it.set_contact_anticipation(this.anticipate);
            it.set_contact_projection(this.project);
            Ok(it)
        };
        let mut first = new_integrator()?;
        let massive = first.massive_dofs().to_vec();
        let m = massive.len();
        let period_map = |it: &mut Integrator, q: &[f64], v: &[f64]| -> Result<Vec<f64>> {
            it.set_state(0.0, q, v)?;
            for _ in 0..steps {
                it.step()?;
            }
            Ok(massive
                .iter()
                .map(|&i| it.q()[i])
                .chain(massive.iter().map(|&i| it.v()[i]))
                .collect())
        };
        let base = period_map(&mut first, &q0, &v0)?;
        let columns: Vec<Result<Vec<f64>>> = (0..2 * m)
            .into_par_iter()
            .map_init(
                || None,
                |slot: &mut Option<Integrator>, j| {
                    if slot.is_none() {
                        *slot = Some(new_integrator()?);
                    }
                    let it = slot.as_mut().expect("created");
                    let (mut q, mut v) = (q0.clone(), v0.clone());
                    let (target, scale) = if j < m {
                        (&mut q[massive[j]], this.partition.length_scale())
                    } else {
                        (
                            &mut v[massive[j - m]],
                            this.partition.length_scale() * omega,
                        )
                    };
                    let before = *target;
                    *target += this.fd_step * before.abs().max(scale);
                    let h = *target - before;
                    let end = period_map(it, &q, &v)?;
                    Ok(end.iter().zip(&base).map(|(a, b)| (a - b) / h).collect())
                },
            )
            .collect();
        // in the scaled state (q, q̇/ω): a similarity (same eigenvalues) that balances the
        // blocks, so that the eigenvalues are computed accurately
        let d = |i: usize| if i < m { 1.0 } else { omega };
        let mut phi = Mat::<f64>::zeros(2 * m, 2 * m);
        for (j, col) in columns.into_iter().enumerate() {
            for (i, v) in col?.into_iter().enumerate() {
                phi[(i, j)] = v * d(j) / d(i);
            }
        }
        Ok(phi)
    }
}
