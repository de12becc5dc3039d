//! [`GeneralMsHbm`] as a [`PeriodicProblem`]: dimension, residual, Jacobian, Floquet
//! multipliers and the periodic solution that Newton and the continuation see.

use faer::Mat;
use rayon::prelude::*;

use super::super::partition::DofLocation;
use super::super::{fixed_response, n_dof_coefficients};
use super::super::{periodic_solution, SolutionParts};
use super::GeneralMsHbm;
use crate::error::Result;
use crate::harmonic::{evaluate, n_coefficients};
use crate::problem::{Jacobian, Linearization, PeriodicProblem};
use crate::solution::{ContactSeries, DofResponse, FrictionSeries, PeriodicSolution};
use crate::stability::Floquet;

impl PeriodicProblem for GeneralMsHbm {
    /// Finite-difference Jacobian: Newton does not contract quadratically. The time-stepped
    /// residual is piecewise affine with pieces one time step wide, so the branch is a
    /// staircase of corners ≈ 1e-7 apart in scaled arclength (module docs): the continuation
    /// steps in frequency once the arclength step falls below 1e-4, well above them.
    fn continuation_policy(&self) -> crate::problem::ContinuationPolicy {
        if self.is_event_driven() {
            // a residual smooth between events with its exact Jacobian; at a grazing impact
            // the critical time's complementarity (T147) has a corner, where the branch
            // may turn, as at the redistributed method's grazing contacts
            return crate::problem::ContinuationPolicy {
                newton_contraction: crate::problem::NewtonContraction::Quadratic,
                where_arclength_fails: crate::problem::ArclengthFallback::EscapeCorner,
                signals: self.n(),
            };
        }
        crate::problem::ContinuationPolicy {
            newton_contraction: crate::problem::NewtonContraction::Unchecked,
            where_arclength_fails: crate::problem::ArclengthFallback::StepInFrequency {
                min_arclength_step: 1e-4,
            },
            signals: self.n(),
        }
    }

    fn dimension(&self) -> usize {
        // the event-driven unknowns end with contact 0's critical time (T147)
        self.n() * (n_coefficients(self.harmonics) + 2)
            + usize::from(self.is_event_driven() && self.with_critical_time)
    }

    fn length_scale(&self) -> f64 {
        self.partition.length_scale()
    }

    /// The linear response; event-driven, the pre-solved start
    /// ([`GeneralMsHbm::presolved_start`]), or where Newton does not converge from it, the
    /// start found by a homotopy in an added damping (`homotopy.rs`, docs/theory.md
    /// (T147b)). The Newton iterations spent here are not counted in the solve's
    /// ([`GeneralMsHbm::guess_iterations`]).
    fn initial_guess(&mut self, omega: f64) -> Result<Vec<f64>> {
        if !self.is_event_driven() {
            return self.linear_response(omega);
        }
        let x0 = self.presolved_start(omega)?;
        self.robust_start(x0, omega)
    }

    fn residual(&mut self, x: &[f64], omega: f64) -> Result<Vec<f64>> {
        self.check_x(x)?;
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        if self.is_event_driven() {
            return Ok(self.event_residual(fd, x, false)?.residual);
        }
        Ok(self.residual_with(fd, x)?.0)
    }

    fn linearize(&mut self, x: &[f64], omega: f64) -> Result<Linearization> {
        self.check_x(x)?;
        self.prepare(omega)?;
        if self.is_event_driven() {
            return self.event_linearization(x, omega);
        }
        let this = &*self;
        let fd = this.frequency.as_deref().expect("prepared");
        let dim = this.dimension();
        let dw = 0.1 * this.fd_step * omega;
        let fdp = this.frequency_data(omega + dw)?;
        let dw = (omega + dw) - omega;
        // the point, each column's step and the frequency's step: one parallel batch of
        // period integrations (the differences are taken afterwards)
        let perturbed = |j: usize| {
            let h = this.fd_step * x[j].abs().max(this.partition.length_scale());
            let mut xp = x.to_vec();
            xp[j] += h;
            xp
        };
        let mut evaluations = (0..dim + 2)
            .into_par_iter()
            .map(|e| match e {
                0 => this.residual_with(fd, x).map(|r| r.0),
                e if e <= dim => this.residual_with(fd, &perturbed(e - 1)).map(|r| r.0),
                _ => this.residual_with(&*fdp, x).map(|r| r.0),
            })
            .collect::<Result<Vec<Vec<f64>>>>()?;
        let rp_omega = evaluations.pop().expect("dim + 2 evaluations");
        let residual = evaluations.remove(0);
        let mut jacobian = Mat::<f64>::zeros(dim, dim);
        for (j, rp) in evaluations.iter().enumerate() {
            let h = perturbed(j)[j] - x[j];
            for (i, (a, b)) in rp.iter().zip(&residual).enumerate() {
                jacobian[(i, j)] = (a - b) / h;
            }
        }
        let d_omega = rp_omega
            .iter()
            .zip(&residual)
            .map(|(a, b)| (a - b) / dw)
            .collect();
        Ok(Linearization {
            residual,
            jacobian: Jacobian::Dense(jacobian),
            d_omega,
        })
    }

    /// Floquet multipliers (docs/theory.md (T79), (T83)) as the eigenvalues of the monodromy
    /// matrix of the **whole system's** period map — the state `(q, q̇)` of all DOFs at `t = 0`
    /// mapped to the state at `t = T` by the same Moreau–Jean integrator (same steps, θ, `e_N`,
    /// anticipation and projection) — by forward finite differences around the solution's
    /// initial state ([`Self::initial_state`]), columns in parallel (rayon).
    ///
    /// Why the whole system and not the N-subsystem: the N-subsystem sees the linear part
    /// only through the harmonics `q̂_N` (eq. 6), a non-causal frequency-domain coupling
    /// with no state of its own; a perturbation `e^{st} p(t)` of the orbit needs the L
    /// states anyway. The full-system map is the physical one, and for a linear system it is
    /// linear, so its finite-difference monodromy is exact up to rounding and equals the
    /// discrete (trapezoidal, θ = ½) transition matrix, whose eigenvalues approximate
    /// `exp(s_k T)` to the integrator's accuracy. With contacts the map is piecewise
    /// affine (`e_N = 0`, anticipation, projection): the finite difference gives the slope
    /// of the piece the solution lies in, including the effect of impacts (a persistent
    /// contact with `e_N = 0` contributes zero multipliers). Caveats: the MS-HBM orbit is a
    /// fixed point of the *harmonically truncated* problem, not exactly of the full
    /// discrete map (the multipliers are those of the full map linearised at the orbit's
    /// initial state); near grazing the piece can be smaller than the step and the
    /// multipliers unreliable (docs/theory.md §11, caveats after (T83)). So they describe the
    /// full model near the orbit, not the H-truncated branch: at a fold pair of the truncated
    /// branch no multiplier need approach +1 (the bar with impacts at H = 5, measured in
    /// docs/general-mshbm.md §5). Cost: `2n + 1` period integrations of the whole model and a
    /// dense `2n × 2n` eigenproblem (`n ≤` [`MAX_FLOQUET_DOFS`]) — one reason the general
    /// method is expensive for FE models.
    fn floquet(&mut self, x: &[f64], omega: f64) -> Result<Option<Floquet>> {
        let phi = self.monodromy(x, omega)?;
        let values = crate::dense::eigenvalues(phi.as_ref())?;
        Ok(Some(Floquet::from_eigenvalues(values)))
    }

    fn solution(&mut self, x: &[f64], omega: f64, response_dof: usize) -> Result<PeriodicSolution> {
        let location = self.partition.locate_response(&self.system, response_dof)?;
        self.check_x(x)?;
        self.prepare(omega)?;
        let fd = self.frequency.as_deref().expect("prepared");
        let (residual, tr) = if self.is_event_driven() {
            (
                self.event_residual(fd, x, false)?.residual,
                self.event_trajectory(fd, x)?,
            )
        } else {
            self.residual_with(fd, x)?
        };
        let n = self.n();
        let h = self.harmonics;
        let ns = self.steps;
        let sampling = &self.sampling;
        let extremes = |v: &[f64]| -> (f64, f64) {
            v.iter()
                .fold((f64::NEG_INFINITY, f64::INFINITY), |(mx, mn), &x| {
                    (mx.max(x), mn.min(x))
                })
        };
        let series = |i: usize| -> Vec<f64> { tr.displacement_series(i) };
        let mut contacts = Vec::with_capacity(self.system.contacts.len());
        for (c, sc) in self.system.contacts.iter().enumerate() {
            let i = self.partition.contact_n_index(&self.system, c);
            let disp = series(i);
            let (max, min) = extremes(&disp);
            contacts.push(ContactSeries {
                dof: self.system.model_dof[sc.w[0].0],
                coefficients: n_dof_coefficients(x, n, h, i),
                displacement: disp,
                gap: tr.gap_series(c),
                force: tr.contact_force_series(c),
                max,
                min,
            });
        }
        let frictions: Vec<FrictionSeries> = self
            .subsystem
            .frictions
            .iter()
            .enumerate()
            .map(|(f, fr)| {
                let force: Vec<f64> = tr.friction_force_series(f);
                let (max, min) = extremes(&force);
                FrictionSeries {
                    force2: Vec::new(),
                    dof: self.subsystem.model_dof[fr.w[0].0],
                    limit: (0..ns).map(|j| self.friction_limit(&tr, f, j)).collect(),
                    force,
                    max,
                    min,
                    state: Vec::new(),
                }
            })
            .collect();
        let response = match location {
            DofLocation::Fixed => fixed_response(response_dof, h),
            DofLocation::Nonlinear(i) => {
                let (max, min) = extremes(&series(i));
                DofResponse {
                    dof: response_dof,
                    coefficients: n_dof_coefficients(x, n, h, i),
                    max,
                    min,
                }
            }
            DofLocation::Linear(l) => {
                let coefficients = fd.linear_dof_coefficients(x, l)?;
                // the truncated series on a grid 4× finer than the steps
                let fine: Vec<f64> = (0..4 * ns)
                    .map(|j| {
                        evaluate(
                            &coefficients,
                            2.0 * std::f64::consts::PI * j as f64 / (4 * ns) as f64,
                        )
                    })
                    .collect();
                let (max, min) = extremes(&fine);
                DofResponse {
                    dof: response_dof,
                    coefficients,
                    max,
                    min,
                }
            }
        };
        Ok(periodic_solution(
            &self.system,
            &self.partition,
            omega,
            SolutionParts {
                method: crate::solution::MethodKind::General,
                quadrature: crate::harmonic::Quadrature::Sampled,
                harmonics: h,
                taus: &sampling.taus,
                residual: &residual,
                contacts,
                frictions,
                response,
            },
        ))
    }
}
