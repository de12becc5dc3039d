//! The general MS-HBM residual from event-driven integration (docs/theory.md (T146)) and
//! its Jacobian from sensitivities.
//!
//! The period is integrated from the **section** `t_s`, the time at which the first
//! harmonic of contact 0's gap is largest: `τ_s = ω t_s = atan2(b, a)` for the first
//! harmonic `a cos τ + b sin τ` of `w_0ᵀ q_N`. The unknowns' initial state is the state at
//! `t_s`, far from the impacts, so that no impact crosses the section along a branch (an
//! impact at the section would make the state there jump). In the section frame
//! `θ = t − t_s` the load's coefficients are rotated by `τ_s`, and the samples' DFT is
//! rotated back.
//!
//! The last unknown is contact 0's critical time `θ_c` (docs/theory.md (T147)), scaled to
//! `ℓ ω θ_c`: the integration applies the impact law to contact 0 at `θ_c`, and the last
//! row of the residual is the Fischer–Burmeister function of its gap and approach velocity
//! there, so that grazing is a corner of the branch and not a square-root singularity.

use faer::Mat;

use super::event_period::{integrate, CriticalTime, EventPeriod, EventProblem};
use super::period::Trajectory;
use super::GeneralMsHbm;
use crate::error::Result;
use crate::harmonic::{basis, basis_derivative, n_coefficients, weight};
use crate::linear::CondensedFrequency;

/// `y ↦ Rot(τ) y` on harmonic-major coefficients (`n` signals): the coefficients of
/// `y(τ + ·)`; with `derivative`, `∂/∂τ` of it.
fn rotate(y: &mut [f64], n: usize, harmonics: usize, tau: f64, derivative: bool) {
    if derivative {
        y[..n].iter_mut().for_each(|v| *v = 0.0);
    }
    for k in 1..=harmonics {
        let kf = k as f64;
        let (s, c) = (kf * tau).sin_cos();
        for i in 0..n {
            let (a, b) = (y[(2 * k - 1) * n + i], y[2 * k * n + i]);
            let (ra, rb) = if derivative {
                (kf * (-a * s + b * c), kf * (-b * s - a * c))
            } else {
                (a * c + b * s, b * c - a * s)
            };
            y[(2 * k - 1) * n + i] = ra;
            y[2 * k * n + i] = rb;
        }
    }
}

/// [`rotate`] applied to every column of `m`.
fn rotate_columns(m: &mut Mat<f64>, n: usize, harmonics: usize, tau: f64) {
    let mut col = vec![0.0; m.nrows()];
    for j in 0..m.ncols() {
        (0..m.nrows()).for_each(|i| col[i] = m[(i, j)]);
        rotate(&mut col, n, harmonics, tau, false);
        (0..m.nrows()).for_each(|i| m[(i, j)] = col[i]);
    }
}

/// Everything one event-driven residual evaluation produces.
pub(super) struct EventResidual {
    pub residual: Vec<f64>,
    pub jacobian: Option<Mat<f64>>,
}

impl GeneralMsHbm {
    /// The section phase `τ_s` and its gradient with respect to `q̂_N` (nonzero on the
    /// first harmonic only): where the first harmonic `a cos τ + b sin τ` of contact 0's
    /// `w_0ᵀ q_N` — and so its gap — is largest, `τ_s = atan2(b, a)`.
    pub(super) fn section_phase(&self, x: &[f64]) -> (f64, Vec<(usize, f64)>) {
        let n = self.n();
        let sub = self.dense.as_ref().expect("event-driven");
        let (mut a, mut b) = (0.0, 0.0);
        for i in 0..n {
            a += sub.normals[(i, 0)] * x[n + i];
            b += sub.normals[(i, 0)] * x[2 * n + i];
        }
        let r2 = a * a + b * b;
        if r2 == 0.0 {
            return (0.0, vec![]);
        }
        let grad = (0..n)
            .flat_map(|i| {
                let w = sub.normals[(i, 0)];
                [(n + i, -b * w / r2), (2 * n + i, a * w / r2)]
            })
            .collect();
        (b.atan2(a), grad)
    }

    /// Contact 0's critical time `θ_c` (docs/theory.md (T147)) held by the last unknown
    /// `ℓ ω θ_c` (a phase times the length scale, so that it weighs like a length), kept
    /// inside the period.
    fn critical_time(&self, x: &[f64], omega: f64) -> CriticalTime {
        let period = 2.0 * std::f64::consts::PI / omega;
        let phase = x[x.len() - 1] / self.partition.length_scale();
        CriticalTime {
            time: (phase / omega).clamp(0.02 * period, 0.98 * period),
            window: 0.25 * period,
        }
    }

    /// One period from the section state in `x` (see [`EventProblem`]), with the critical
    /// time in `x` when the unknowns hold one.
    fn event_period(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
        tau_s: f64,
        sample_offset: f64,
        duration: Option<f64>,
        sensitivities: bool,
    ) -> Result<EventPeriod> {
        let critical = self
            .with_critical_time
            .then(|| self.critical_time(x, fd.omega()));
        self.period_with(
            fd,
            x,
            tau_s,
            sample_offset,
            duration,
            critical,
            sensitivities,
        )
    }

    /// One period from the section state in `x` with the given critical time (`None`:
    /// every impact located by the scan).
    #[allow(clippy::too_many_arguments)]
    fn period_with(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
        tau_s: f64,
        sample_offset: f64,
        duration: Option<f64>,
        critical: Option<CriticalTime>,
        sensitivities: bool,
    ) -> Result<EventPeriod> {
        let n = self.n();
        let h = self.harmonics;
        let nq = n * n_coefficients(h);
        let omega = fd.omega();
        let mut load = fd.interface_load_coefficients(x);
        rotate(&mut load, n, h, tau_s, false);
        let sub = self.dense.as_ref().expect("event-driven");
        let pb = EventProblem {
            sub,
            flows: &self.flows,
            harmonics: h,
            omega,
            load: &load,
            restitution: self.restitution,
            steps: self.steps,
            sample_offset,
            duration: duration.unwrap_or(2.0 * std::f64::consts::PI / omega),
            gap_tolerance: 1e-12 * self.partition.length_scale(),
            critical,
            sensitivities,
        };
        let v0: Vec<f64> = x[nq + n..nq + 2 * n].iter().map(|v| v * omega).collect();
        integrate(&pb, &x[nq..nq + n], &v0)
    }

    /// The residual (T58) with the event-driven period (T146) and the critical time's
    /// complementarity (T147), and its Jacobian with respect to the unknowns when
    /// `jacobian`.
    pub(super) fn event_residual(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
        jacobian: bool,
    ) -> Result<EventResidual> {
        let n = self.n();
        let h = self.harmonics;
        let nc = n_coefficients(h);
        let nq = n * nc;
        let with_critical = self.with_critical_time;
        let dim = nq + 2 * n + usize::from(with_critical);
        let omega = fd.omega();
        let (tau, grad) = self.section_phase(x);
        let period = self.event_period(fd, x, tau, 0.0, None, jacobian)?;
        let mut dft = self.sampling.dft_set(&period.samples, n);
        let section_dft = dft.clone();
        rotate(&mut dft, n, h, -tau, false);
        let mut residual = vec![0.0; dim];
        for c in 0..nq {
            residual[c] = x[c] - dft[c];
        }
        for i in 0..n {
            residual[nq + i] = period.end_q[i] - x[nq + i];
            residual[nq + n + i] = period.end_v[i] / omega - x[nq + n + i];
        }
        // (T147): the Fischer–Burmeister function of g and s = −ġ⁻/ω,
        // g + s − √(g² + s²) = 0 ⇔ g ≥ 0, s ≥ 0, g s = 0, and its gradient
        let critical = period.critical.as_ref().map(|c| {
            let (g, s) = (c.gap, -c.rate / omega);
            let r = g.hypot(s);
            let gradient = if r > 0.0 {
                (1.0 - g / r, 1.0 - s / r)
            } else {
                (1.0, 1.0)
            };
            (c, g + s - r, gradient)
        });
        if let Some((_, value, _)) = critical {
            residual[dim - 1] = value;
        }
        if !jacobian {
            return Ok(EventResidual {
                residual,
                jacobian: None,
            });
        }
        let samples = period.sample_sensitivity.as_ref().expect("asked for");
        let end = period.end_sensitivity.as_ref().expect("asked for");
        let params = samples.ncols();
        // the DFT of the samples' sensitivities: ∂q̃/∂p (nq × p)
        let ns = self.steps as f64;
        let mut dq = Mat::<f64>::zeros(nq, params);
        for (j, b) in self.sampling.basis.iter().enumerate() {
            for (m, &bm) in b.iter().enumerate() {
                let f = weight(m) * bm / ns;
                for i in 0..n {
                    for p in 0..params {
                        dq[(m * n + i, p)] += f * samples[(j * n + i, p)];
                    }
                }
            }
        }
        // ∂p/∂x (p × dim): the load's coefficients φ̃ = Rot(τ) (L x + u) through (T20) and
        // the section phase, ∂φ̃/∂x = [Rot(τ) L, 0, 0, 0] + (∂Rot/∂τ φ) ∇τᵀ; the initial
        // state q_0 = x_q, q̇_0 = ω x_v; θ_c = x_c / (ℓ ω)
        let mut linear_map = self.load_map(fd);
        rotate_columns(&mut linear_map, n, h, tau);
        let mut params_map = Mat::<f64>::zeros(params, dim);
        params_map
            .submatrix_mut(0, 0, nq, nq)
            .copy_from(&linear_map);
        let mut load_rate = fd.interface_load_coefficients(x);
        rotate(&mut load_rate, n, h, tau, true);
        for &(c, g) in &grad {
            for r in 0..nq {
                params_map[(r, c)] += load_rate[r] * g;
            }
        }
        for i in 0..n {
            params_map[(nq + i, nq + i)] = 1.0;
            params_map[(nq + n + i, nq + n + i)] = omega;
        }
        if with_critical {
            params_map[(params - 1, dim - 1)] = 1.0 / (self.partition.length_scale() * omega);
        }
        let mut jac = Mat::<f64>::zeros(dim, dim);
        // connectivity rows: I − Rot(−τ) ∂q̃/∂x + (∂Rot(−τ)/∂τ' q̃ at −τ) ∇τᵀ
        let mut dq_x = &dq * &params_map;
        rotate_columns(&mut dq_x, n, h, -tau);
        let mut back_rate = section_dft;
        rotate(&mut back_rate, n, h, -tau, true);
        for r in 0..nq {
            for c in 0..dim {
                jac[(r, c)] = -dq_x[(r, c)];
            }
            jac[(r, r)] += 1.0;
            for &(c, g) in &grad {
                // d/dτ of Rot(−τ) q̃ = −(∂Rot/∂τ')(−τ) q̃
                jac[(r, c)] += back_rate[r] * g;
            }
        }
        // periodicity rows
        let end_x = end * &params_map;
        for i in 0..2 * n {
            let row = nq + i;
            let scale = if i < n { 1.0 } else { 1.0 / omega };
            for c in 0..dim {
                jac[(row, c)] = end_x[(i, c)] * scale;
            }
            jac[(row, row)] -= 1.0;
        }
        // the critical time's row
        if let Some((critical, _, (dg, ds))) = critical {
            for c in 0..dim {
                jac[(dim - 1, c)] = (0..params)
                    .map(|p| {
                        (dg * critical.gap_sensitivity[p]
                            - ds / omega * critical.rate_sensitivity[p])
                            * params_map[(p, c)]
                    })
                    .sum::<f64>();
            }
        }
        Ok(EventResidual {
            residual,
            jacobian: Some(jac),
        })
    }

    /// `∂φ/∂q̂_N` of the load (T20): `G_k` as real `2 × 2` blocks per harmonic (T21).
    fn load_map(&self, fd: &dyn CondensedFrequency) -> Mat<f64> {
        let n = self.n();
        let h = self.harmonics;
        let nq = n * n_coefficients(h);
        let mut l = Mat::<f64>::zeros(nq, nq);
        let g0 = fd.interface_stiffness(0);
        for i in 0..n {
            for j in 0..n {
                l[(i, j)] = g0[i * n + j].re;
            }
        }
        for k in 1..=h {
            let (ci, si) = ((2 * k - 1) * n, 2 * k * n);
            let g = fd.interface_stiffness(k);
            for i in 0..n {
                for j in 0..n {
                    let (gr, gi) = (g[i * n + j].re, g[i * n + j].im);
                    l[(ci + i, ci + j)] = gr;
                    l[(ci + i, si + j)] = gi;
                    l[(si + i, ci + j)] = -gi;
                    l[(si + i, si + j)] = gr;
                }
            }
        }
        l
    }

    /// The critical time of a start `x` (its last entry, set here): where the period
    /// integrated from `x` with every impact located by the scan first meets the stop, or
    /// where its gap is smallest when it does not — so that the residual there is that of
    /// the period without a critical time, with (T147) satisfied.
    pub(super) fn initial_critical_time(
        &self,
        fd: &dyn CondensedFrequency,
        x: &mut [f64],
    ) -> Result<()> {
        let omega = fd.omega();
        let (tau, _) = self.section_phase(x);
        let period = self.period_with(fd, x, tau, 0.0, None, None, false)?;
        let time = period.first_impact.unwrap_or_else(|| {
            let nc = self.dense.as_ref().expect("event-driven").n_contacts();
            let step = 2.0 * std::f64::consts::PI / omega / self.steps as f64;
            let lowest = (0..self.steps)
                .min_by(|&a, &b| period.gaps[a * nc].total_cmp(&period.gaps[b * nc]))
                .unwrap_or(0);
            lowest as f64 * step
        });
        let last = x.len() - 1;
        x[last] = omega * time * self.partition.length_scale();
        Ok(())
    }

    /// The state `(q_N, q̇_N/ω)` at the section of the harmonic motion `q̂_N` in `x`.
    pub(super) fn harmonic_section_state(&self, x: &mut [f64]) {
        let n = self.n();
        let h = self.harmonics;
        let nq = n * n_coefficients(h);
        let (tau, _) = self.section_phase(x);
        let (b, db) = (basis(h, tau), basis_derivative(h, tau));
        for i in 0..n {
            let (mut q, mut v) = (0.0, 0.0);
            for c in 0..n_coefficients(h) {
                q += b[c] * x[c * n + i];
                v += db[c] * x[c * n + i];
            }
            x[nq + i] = q;
            x[nq + n + i] = v;
        }
    }

    /// The trajectory of the solution `x` on the step grid `t_j = jT/N_s` of absolute time
    /// (samples from the section frame reordered).
    pub(super) fn event_trajectory(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
    ) -> Result<Trajectory> {
        let n = self.n();
        let ns = self.steps;
        let omega = fd.omega();
        let period = 2.0 * std::f64::consts::PI / omega;
        let step = period / ns as f64;
        let (tau, _) = self.section_phase(x);
        let t_s = tau.rem_euclid(2.0 * std::f64::consts::PI) / omega;
        let first = ((t_s / step).ceil() as usize).min(ns);
        let offset = (first as f64 * step - t_s).clamp(0.0, step * (1.0 - 1e-12));
        let p = self.event_period(fd, x, tau, offset, None, false)?;
        let nc = self.dense.as_ref().expect("event-driven").n_contacts();
        let reorder = |values: &[f64], width: usize| -> Vec<f64> {
            let mut out = vec![0.0; values.len()];
            for i in 0..ns {
                let j = (first + i) % ns;
                out[j * width..(j + 1) * width]
                    .copy_from_slice(&values[i * width..(i + 1) * width]);
            }
            out
        };
        // the state at t = 0 ≡ T: the end of the integration over T − t_s
        Ok(Trajectory::from_samples(
            n,
            reorder(&p.samples, n),
            reorder(&p.gaps, nc),
            reorder(&p.forces, nc),
            self.event_state_at_zero(fd, x)?,
        ))
    }

    /// The N-state `(q, q̇)` at `t = 0` of the solution `x`.
    pub(super) fn event_state_at_zero(
        &self,
        fd: &dyn CondensedFrequency,
        x: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let omega = fd.omega();
        let (tau, _) = self.section_phase(x);
        let two_pi = 2.0 * std::f64::consts::PI;
        let rest = (two_pi - tau.rem_euclid(two_pi)) / omega;
        let p = self.event_period(fd, x, tau, 0.0, Some(rest), false)?;
        Ok((p.end_q, p.end_v))
    }
}
