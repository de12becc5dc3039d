//! The Fourier coefficients of one phase of the cone law (docs/theory.md (T189)): the Gram
//! blocks for the free gap and the stuck contacts, the integrals carried by the slip flow for
//! the slipping ones.

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use super::march::{Closed, March};
use super::*;

impl March<'_> {
    /// Add the phase `[a, b]`'s part of `λ̂` (T189).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn accumulate(
        &self,
        a: f64,
        b: f64,
        modes: &[ConeMode],
        start_anchors: &[f64],
        slipping: &[usize],
        x: &[f64],
        closed: &Closed,
        forces: &mut [f64],
    ) {
        let n = self.law.n;
        let m = 3 * n;
        let ncoef = n_coefficients(self.harmonics);
        if b <= a {
            return;
        }
        let mut gram = vec![0.0; ncoef * ncoef];
        add_interval_gram(self.harmonics, a, b, &mut gram);
        let k = closed.rows.len();
        let s = slipping.len();
        let weight = |q: usize| if q == 0 { 1.0 / (2.0 * PI) } else { 1.0 / PI };
        let mut rhs = vec![0.0; k];
        for q in 0..ncoef {
            // [0; ∫ a b_q] − Σ_c Γ_qc γ̂_K,c
            for (i, &r) in closed.rows.iter().enumerate() {
                rhs[i] = -(0..ncoef)
                    .map(|c2| gram[q * ncoef + c2] * self.gamma[c2 * m + r])
                    .sum::<f64>();
            }
            for c in 0..n {
                let Some(t) = closed.tangent_row[c] else {
                    continue;
                };
                if modes[c] == ConeMode::Stick {
                    rhs[t] += start_anchors[c] * gram[q * ncoef];
                    rhs[t + 1] += start_anchors[n + c] * gram[q * ncoef];
                }
            }
            for (i, &c) in slipping.iter().enumerate() {
                let t = closed.tangent_row[c].unwrap();
                rhs[t] += weight(q) * x[2 * s + (2 * i) * ncoef + q];
                rhs[t + 1] += weight(q) * x[2 * s + (2 * i + 1) * ncoef + q];
            }
            for i in 0..k {
                forces[q * m + closed.rows[i]] +=
                    (0..k).map(|j| closed.y[i * k + j] * rhs[j]).sum::<f64>();
            }
        }
    }
}
