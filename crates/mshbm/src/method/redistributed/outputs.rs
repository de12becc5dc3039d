//! What the frictionless and the frictional solutions of the redistributed MS-HBM report
//! alike: the harmonics of the contact-node DOFs and their load (paper eq. 31), the
//! response DOF's harmonics and extremes, and the [`PeriodicSolution`] of their parts.

use super::*;
use crate::error::Result;
use crate::harmonic::{evaluate, n_coefficients};
use crate::method::partition::DofLocation;
use crate::method::{fixed_response, periodic_solution, SolutionParts};
use crate::solution::{ContactSeries, DofResponse, FrictionSeries, PeriodicSolution};

/// What a solution's outputs start from ([`RedistributedMsHbm::node_harmonics`]).
pub(super) struct NodeHarmonics {
    /// The harmonics of the contact-node DOFs, then of the response DOF when it is linear
    /// (`width` per coefficient).
    pub q_rows: Vec<f64>,
    pub width: usize,
    /// The paper's unknowns `q̂_N` (`n_N` per coefficient).
    pub q_n: Vec<f64>,
    /// The coefficients of the load on the contact nodes,
    /// `b̂ = f_N − K_NL q̂_L = K_NN q̂_N − W λ̂` (`n_N` per coefficient).
    pub load: Vec<f64>,
}

impl RedistributedMsHbm {
    /// The structure's response at the contact nodes (and at a linear response DOF) under the
    /// contact forces `forces` (`λ̂`), and the load on the contact nodes.
    pub(super) fn node_harmonics(
        &self,
        forces: &[f64],
        location: DofLocation,
    ) -> Result<NodeHarmonics> {
        let n = self.n();
        let ncoef = n_coefficients(self.harmonics);
        let nonlinear = &self.system.nonlinear_dofs;
        let n_n = nonlinear.len();
        let mut rows = nonlinear.clone();
        if let DofLocation::Linear(l) = location {
            rows.push(self.system.linear_dofs[l]);
        }
        let q_rows = self.structure_rows(forces, &rows)?;
        let width = rows.len();
        let q_n: Vec<f64> = (0..ncoef)
            .flat_map(|m| (0..n_n).map(move |i| (m, i)))
            .map(|(m, i)| q_rows[m * width + i])
            .collect();
        let mut load = vec![0.0; n_n * ncoef];
        for m in 0..ncoef {
            let kq = self.stiffness_nn.mul_vec(&q_n[m * n_n..(m + 1) * n_n]);
            let lambda = &forces[m * n..(m + 1) * n];
            for i in 0..n_n {
                let w = &self.directions[i * n..(i + 1) * n];
                load[m * n_n + i] = kq[i] - w.iter().zip(lambda).map(|(w, l)| w * l).sum::<f64>();
            }
        }
        Ok(NodeHarmonics {
            q_rows,
            width,
            q_n,
            load,
        })
    }
}

/// The response DOF's harmonics and extremes: zeros for a fixed DOF; for a contact-node
/// DOF `i` its coefficients in `q_n` (`n_n` per coefficient) with the extremes of its time
/// signal from `extremes(i)`; for a linear DOF the series in the last column of `q_rows`
/// (`width` per coefficient), its extremes refined between the samples at `taus`.
pub(super) fn dof_response(
    location: DofLocation,
    response_dof: usize,
    (q_n, n_n): (&[f64], usize),
    (q_rows, width): (&[f64], usize),
    taus: &[f64],
    extremes: impl FnOnce(usize) -> (f64, f64),
) -> DofResponse {
    let ncoef = q_rows.len() / width;
    let h = (ncoef - 1) / 2;
    match location {
        DofLocation::Fixed => fixed_response(response_dof, h),
        DofLocation::Nonlinear(i) => {
            let (max, min) = extremes(i);
            DofResponse {
                dof: response_dof,
                coefficients: n_dof_coefficients(q_n, n_n, h, i),
                max,
                min,
            }
        }
        DofLocation::Linear(_) => {
            let coefficients: Vec<f64> = (0..ncoef).map(|m| q_rows[m * width + n_n]).collect();
            let samples: Vec<f64> = taus.iter().map(|&t| evaluate(&coefficients, t)).collect();
            let max = refine_extremum(taus, &samples, 1.0, |t| evaluate(&coefficients, t));
            let min = refine_extremum(taus, &samples, -1.0, |t| evaluate(&coefficients, t));
            DofResponse {
                dof: response_dof,
                coefficients,
                max,
                min,
            }
        }
    }
}

impl RedistributedMsHbm {
    /// The [`PeriodicSolution`] of this method with its parts.
    pub(super) fn solution_of(
        &self,
        omega: f64,
        taus: &[f64],
        residual: &[f64],
        contacts: Vec<ContactSeries>,
        frictions: Vec<FrictionSeries>,
        response: DofResponse,
    ) -> PeriodicSolution {
        periodic_solution(
            &self.system,
            &self.partition,
            omega,
            SolutionParts {
                method: crate::solution::MethodKind::Redistributed,
                quadrature: self.quadrature,
                harmonics: self.harmonics,
                taus,
                residual,
                contacts,
                frictions,
                response,
            },
        )
    }
}

impl RedistributedMsHbm {
    /// [`PeriodicProblem::solution`], with the series and extremes of every contact
    /// (`every_contact`) or with no contact series (the response DOF alone, for a diagram).
    pub(super) fn solution_with(
        &mut self,
        x: &[f64],
        omega: f64,
        response_dof: usize,
        every_contact: bool,
    ) -> Result<PeriodicSolution> {
        let location = self.partition.locate_response(&self.system, response_dof)?;
        let (residual, integration, forces) = self.evaluate(x, omega)?;
        let n = self.n();
        let h = self.harmonics;
        let ncoef = n_coefficients(h);
        let NodeHarmonics {
            q_rows,
            width,
            q_n,
            load: b,
        } = self.node_harmonics(&forces, location)?;
        let n_n = self.system.nonlinear_dofs.len();
        let mut basis_buf = vec![0.0; ncoef];
        let mut q_s = Vec::with_capacity(self.sampling.len());
        let mut f_s = Vec::with_capacity(self.sampling.len());
        let mut g_s = Vec::with_capacity(self.sampling.len());
        // the static contact problem at τ for the load b(τ) of the response: (q_N, λ, g)
        // (its free gap equals that of the unknowns to the residual; solved from b(τ), the
        // reported q_N, λ, g satisfy Signorini to round-off). b(τ) enters only through
        // K_NN⁻¹ b(τ) and the free gap (T123), whose coefficients are formed once.
        let contact = &mut self.contact;
        let zero_force = vec![0.0; n];
        let mut load_displacement = Vec::with_capacity(n_n * ncoef);
        let mut free_gap = Vec::with_capacity(n * ncoef);
        for m in 0..ncoef {
            let b_m = &b[m * n_n..(m + 1) * n_n];
            load_displacement.extend(contact.displacement(b_m, &zero_force));
            let gap_m = contact.free_gap(b_m);
            free_gap.extend(
                gap_m
                    .iter()
                    .zip(contact.initial_gap())
                    .map(|(g, g0)| g - g0),
            );
        }
        let initial_gap = contact.initial_gap().to_vec();
        // (a diagram point of a contact-node DOF with the exact quadrature takes its signal
        // from the active-set intervals of this free gap instead: no static contact solve
        // per instant)
        let from_intervals = !every_contact && self.quadrature == Quadrature::Exact;
        let interval_extremes = match location {
            DofLocation::Nonlinear(i) if from_intervals => {
                let gamma: Vec<f64> = free_gap
                    .iter()
                    .enumerate()
                    .map(|(e, g)| if e < n { g + initial_gap[e] } else { *g })
                    .collect();
                let load_i: Vec<f64> = (0..ncoef).map(|m| load_displacement[m * n_n + i]).collect();
                // the active sets of this free gap (not of the unknowns': near a resonance
                // the two differ by the residual times the receptance)
                let own = integrate(contact, &gamma, &self.sampling, Quadrature::Exact)?;
                let signal = IntervalSignal::new(&own, &gamma, &load_i, contact.compliance_row(i));
                Some(signal.extremes(&self.sampling))
            }
            _ => None,
        };
        // the free gap and the state at the instant whose basis row is given
        let gap_at = |basis: &[f64]| -> Vec<f64> {
            let mut gamma = signal_with_basis(&free_gap, n, basis);
            gamma
                .iter_mut()
                .zip(&initial_gap)
                .for_each(|(g, g0)| *g += g0);
            gamma
        };
        let mut state_at = |basis: &[f64]| -> Result<(Vec<f64>, Vec<f64>, Vec<f64>)> {
            let gamma = gap_at(basis);
            let set = contact.solve(&gamma)?;
            let lambda = set.force(&gamma);
            let mut q = contact.force_displacement(&lambda);
            let u = signal_with_basis(&load_displacement, n_n, basis);
            q.iter_mut().zip(&u).for_each(|(q, u)| *q += u);
            Ok((q, lambda, set.gap(&gamma)))
        };
        // the contacts' time signals: for the series, or for a contact-node response DOF
        // (the grid samples' basis rows from the sampling's table)
        let time_signals = every_contact
            || (matches!(location, DofLocation::Nonlinear(_)) && interval_extremes.is_none());
        for row in self.sampling.basis.iter().filter(|_| time_signals) {
            let (q, lambda, gap) = state_at(row)?;
            q_s.push(q);
            f_s.push(lambda);
            g_s.push(gap);
        }
        let taus = self.sampling.taus.clone();
        // the N displacements at every switching time, once for all DOFs (a switch is an
        // extremum candidate of every DOF, and each costs a static contact solve)
        let mut q_switches = Vec::with_capacity(integration.switches.len());
        for s in integration.switches.iter().filter(|_| time_signals) {
            basis_into(h, s.tau, &mut basis_buf);
            q_switches.push(match state_at(&basis_buf) {
                Ok((q, _, _)) => q,
                Err(_) => vec![f64::NAN; n_n],
            });
        }
        // exact displacement of N-DOF i at τ (the time signal, not the truncated series).
        // The golden-section searches of neighbouring DOFs mostly probe the same instants:
        // the contact forces there (a static contact solve each) are kept, up to a bound.
        let mut forces_at: std::collections::HashMap<u64, Option<Vec<f64>>> =
            std::collections::HashMap::new();
        let mut q_at = |i: usize, tau: f64| -> f64 {
            let key = tau.to_bits();
            if !forces_at.contains_key(&key) {
                basis_into(h, tau, &mut basis_buf);
                let gamma = gap_at(&basis_buf);
                let lambda = contact.solve(&gamma).ok().map(|set| set.force(&gamma));
                if forces_at.len() >= MAX_CACHED_INSTANTS {
                    forces_at.clear();
                }
                forces_at.insert(key, lambda);
            }
            basis_into(h, tau, &mut basis_buf);
            let u: f64 = (0..ncoef)
                .map(|m| basis_buf[m] * load_displacement[m * n_n + i])
                .sum();
            match &forces_at[&key] {
                Some(lambda) => u + contact.force_displacement_of(i, lambda),
                None => f64::NAN,
            }
        };
        let mut n_extremes = |i: usize| -> (f64, f64) {
            let samples: Vec<f64> = q_s.iter().map(|q| q[i]).collect();
            let mut mx = refine_extremum(&taus, &samples, 1.0, |t| q_at(i, t));
            let mut mn = refine_extremum(&taus, &samples, -1.0, |t| q_at(i, t));
            for q in &q_switches {
                mx = mx.max(q[i]);
                mn = mn.min(q[i]);
            }
            (mx, mn)
        };
        let mut contacts = Vec::with_capacity(self.system.contacts.len());
        for (c, sc) in self
            .system
            .contacts
            .iter()
            .enumerate()
            .filter(|_| every_contact)
        {
            let i = self.partition.contact_n_index(&self.system, c);
            let (max, min) = n_extremes(i);
            contacts.push(ContactSeries {
                dof: self.system.model_dof[sc.w[0].0],
                coefficients: n_dof_coefficients(&q_n, n_n, h, i),
                displacement: q_s.iter().map(|q| q[i]).collect(),
                gap: g_s.iter().map(|g| g[c]).collect(),
                force: f_s.iter().map(|l| l[c]).collect(),
                max,
                min,
            });
        }
        let response = dof_response(
            location,
            response_dof,
            (&q_n, n_n),
            (&q_rows, width),
            &taus,
            |i| interval_extremes.unwrap_or_else(|| n_extremes(i)),
        );
        let mut solution = self.solution_of(omega, &taus, &residual, contacts, vec![], response);
        solution.contact_node_harmonics = Some(q_n);
        Ok(solution)
    }
}

/// The maximum (`sign = 1`) or minimum (`sign = −1`) of a periodic signal sampled at `taus`
/// (`values`), refined by golden-section search of `f` around the best sample (so that the
/// extreme is that of the time signal, not of the sample grid).
pub(super) fn refine_extremum(
    taus: &[f64],
    values: &[f64],
    sign: f64,
    mut f: impl FnMut(f64) -> f64,
) -> f64 {
    let n = taus.len();
    let (j, best) = values
        .iter()
        .enumerate()
        .fold((0, f64::NEG_INFINITY), |(bj, bv), (j, &v)| {
            if sign * v > bv {
                (j, sign * v)
            } else {
                (bj, bv)
            }
        });
    let step = 2.0 * std::f64::consts::PI / n as f64;
    let refined = golden_section_max(|t| sign * f(t), taus[j] - step, taus[j] + step);
    sign * best.max(refined)
}
