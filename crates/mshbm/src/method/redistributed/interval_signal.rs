//! The exact time signal of one contact-node DOF over a period, from the active-set
//! intervals of the exact quadrature ([`super::quadrature::Integration`]; docs/theory.md
//! (T140)).
//!
//! On an interval of constant active set `A` the contact forces are
//! `λ(τ) = F_A γ(τ)` (docs/theory.md (T124)) and the contact nodes' displacement is
//! `q_N(τ) = K_NN⁻¹ b(τ) + K_NN⁻¹ W λ(τ)` (eq. 26), so `q_i(τ)` is a trigonometric
//! polynomial of degree `H` there, with coefficients formed once per set: its value at any
//! instant costs one basis row instead of a static contact solve. Its extremes are searched
//! as [`super::refine_extremum`] does with the static contact solve: the best grid sample,
//! refined by golden-section search, and the values at the switching times.

use super::quadrature::Integration;
use super::refine_extremum;
use crate::harmonic::{basis_into, evaluate, Sampling};

/// `q_i(τ)` of one contact-node DOF, piecewise a trigonometric polynomial.
pub(super) struct IntervalSignal<'a> {
    integration: &'a Integration,
    /// Per group, the coefficients of `q_i` while its set holds (`2H + 1`).
    coefficients: Vec<Vec<f64>>,
}

impl<'a> IntervalSignal<'a> {
    /// `q_i` for the free gap with coefficients `gamma` (harmonic-major, `n_c` per
    /// coefficient, `g0` included), the coefficients `load_displacement_i` of
    /// `(K_NN⁻¹ b)_i`, and row `i` of `K_NN⁻¹ W` (`compliance_row`, `n_c`).
    pub(super) fn new(
        integration: &'a Integration,
        gamma: &[f64],
        load_displacement_i: &[f64],
        compliance_row: &[f64],
    ) -> Self {
        let n = compliance_row.len();
        let coefficients = integration
            .groups
            .iter()
            .map(|group| {
                let mut c = load_displacement_i.to_vec();
                for &a in group.set.closed_contacts() {
                    let weight = compliance_row[a];
                    if weight == 0.0 {
                        continue;
                    }
                    let (columns, values) = group.set.force_row(a);
                    for (m, cm) in c.iter_mut().enumerate() {
                        let force: f64 = columns
                            .iter()
                            .zip(values)
                            .map(|(&col, v)| v * gamma[m * n + col])
                            .sum();
                        *cm += weight * force;
                    }
                }
                c
            })
            .collect();
        IntervalSignal {
            integration,
            coefficients,
        }
    }

    /// The group whose set holds at `τ` (the interval containing it).
    fn group_at(&self, tau: f64) -> usize {
        let intervals = &self.integration.intervals;
        let k = intervals.partition_point(|&(_, end, _)| end <= tau);
        intervals[k.min(intervals.len() - 1)].2
    }

    /// `q_i(τ)`.
    pub(super) fn value(&self, tau: f64) -> f64 {
        evaluate(&self.coefficients[self.group_at(tau)], tau)
    }

    /// The maximum and minimum of `q_i` over the period: the best grid sample refined by
    /// golden-section search, and the values at the switching times.
    pub(super) fn extremes(&self, sampling: &Sampling) -> (f64, f64) {
        let mut basis = vec![0.0; self.coefficients.first().map_or(1, Vec::len)];
        let samples: Vec<f64> = sampling
            .taus
            .iter()
            .zip(&sampling.basis)
            .map(|(&tau, row)| {
                let c = &self.coefficients[self.group_at(tau)];
                c.iter().zip(row).map(|(a, b)| a * b).sum()
            })
            .collect();
        let mut max = refine_extremum(&sampling.taus, &samples, 1.0, |t| self.value(t));
        let mut min = refine_extremum(&sampling.taus, &samples, -1.0, |t| self.value(t));
        for s in &self.integration.switches {
            basis_into(sampling.harmonics, s.tau, &mut basis);
            let c = &self.coefficients[self.group_at(s.tau)];
            let v: f64 = c.iter().zip(&basis).map(|(a, b)| a * b).sum();
            max = max.max(v);
            min = min.min(v);
        }
        (max, min)
    }
}
