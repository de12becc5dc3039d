//! What the frictionless and the frictional solutions of the redistributed MS-HBM report
//! alike: the harmonics of the contact-node DOFs and their load (paper eq. 31), the
//! response DOF's harmonics and extremes, and the [`PeriodicSolution`] of their parts.

use super::{n_dof_coefficients, refine_extremum, RedistributedMsHbm};
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
