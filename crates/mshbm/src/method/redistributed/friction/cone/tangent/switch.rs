//! The tangent across a switch (docs/theory.md (T216), (T217)): the instant's sensitivity,
//! the displacements' saltation and the coefficients' boundary term.

// the small dense matrices of the law are indexed as the equations write them
#![allow(clippy::needless_range_loop)]

use super::super::march::{Closed, March, Watch};
use super::super::*;
use super::flow::{series_at, Rates};

impl March<'_> {
    /// Across the switch that ends `phase` and starts `next` (T216), (T217): `δa` continued
    /// with the saltation of the rates, the coefficients' boundary term added.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn switch_tangent(
        &mut self,
        phase: &ConePhase,
        next: &ConePhase,
        end_anchors: &[f64],
        closed: &Closed,
        d_gamma: &[Vec<f64>],
        d_anchors: &mut [Vec<f64>],
        d_forces: &mut [Vec<f64>],
    ) -> Result<()> {
        let n = self.law.n;
        let m = 3 * n;
        let ncoef = n_coefficients(self.harmonics);
        let tau = phase.end;
        let before = self.rates(tau, &phase.modes, end_anchors, closed, d_gamma, d_anchors)?;
        let closed_next = self.closed(&next.modes)?;
        let after = self.rates(tau, &next.modes, &next.anchors, &closed_next, &[], &[])?;
        let (_, gamma_rate) = series_at(self.harmonics, self.gamma, m, tau);
        // the indicator that ended the phase and its rate
        let Some((c, watch)) = phase.event else {
            return Ok(());
        };
        let coupling = |row: usize, v: &[f64]| -> f64 {
            closed.rows.iter().map(|&r| self.law.d(row, r) * v[r]).sum()
        };
        let unit = {
            let (t1, t2) = (before.lambda[n + c], before.lambda[2 * n + c]);
            let norm = t1.hypot(t2);
            if norm > 0.0 {
                [t1 / norm, t2 / norm]
            } else {
                [0.0, 0.0]
            }
        };
        let mu = self.law.mu[c];
        let rate_of_h =
            self.indicator_rate(tau, &phase.modes, end_anchors, closed, &before, c, watch)?;
        let mut b = vec![0.0; ncoef];
        basis_into(self.harmonics, tau, &mut b);
        let weight = |q: usize| if q == 0 { 1.0 / (2.0 * PI) } else { 1.0 / PI };
        for j in 0..d_gamma.len() {
            let (dg, _) = series_at(self.harmonics, &d_gamma[j], m, tau);
            let dl = before.d_lambda.col_as_slice(j);
            let dh = match watch {
                Watch::Gap => dg[c] + coupling(c, dl),
                Watch::Normal => dl[c],
                Watch::Cone => mu * dl[c] - unit[0] * dl[n + c] - unit[1] * dl[2 * n + c],
                Watch::Speed => before.d_speed[(c, j)],
            };
            let d_tau = if rate_of_h != 0.0 {
                -dh / rate_of_h
            } else {
                0.0
            };
            // the coefficients' boundary term
            for q in 0..ncoef {
                for r in 0..m {
                    d_forces[j][q * m + r] +=
                        weight(q) * (before.lambda[r] - after.lambda[r]) * b[q] * d_tau;
                }
            }
            // the displacements (T217)
            let mut da = vec![0.0; 2 * n];
            for d in 0..n {
                if closed_next.tangent_row[d].is_none() {
                    continue;
                }
                for t in 0..2 {
                    let i = t * n + d;
                    da[i] = if closed.tangent_row[d].is_some() {
                        d_anchors[j][i] + (before.rate[i] - after.rate[i]) * d_tau
                    } else {
                        let row = (1 + t) * n + d;
                        let dy = dg[row] + coupling(row, dl);
                        let y_rate = gamma_rate[row] + coupling(row, &before.lambda_rate);
                        dy + (y_rate - after.rate[i]) * d_tau
                    };
                }
            }
            d_anchors[j] = da;
        }
        Ok(())
    }
}

impl March<'_> {
    /// The rate `ḣ` of contact `c`'s indicator `watch` (T188) along the march at `τ`, with
    /// `rates` the law's rates there (T216): for the gap, the normal force and the cone margin
    /// from `λ̇`, for the slip speed by a central difference in time along the flow.
    #[allow(clippy::too_many_arguments)]
    pub(in super::super) fn indicator_rate(
        &self,
        tau: f64,
        modes: &[ConeMode],
        anchors: &[f64],
        closed: &Closed,
        rates: &Rates,
        c: usize,
        watch: Watch,
    ) -> Result<f64> {
        let n = self.law.n;
        let mu = self.law.mu[c];
        let lambda_rate = &rates.lambda_rate;
        Ok(match watch {
            Watch::Gap => {
                let (_, gamma_rate) = series_at(self.harmonics, self.gamma, 3 * n, tau);
                gamma_rate[c]
                    + closed
                        .rows
                        .iter()
                        .map(|&r| self.law.d(c, r) * lambda_rate[r])
                        .sum::<f64>()
            }
            Watch::Normal => lambda_rate[c],
            Watch::Cone => {
                let (t1, t2) = (rates.lambda[n + c], rates.lambda[2 * n + c]);
                let norm = t1.hypot(t2);
                let unit = if norm > 0.0 {
                    [t1 / norm, t2 / norm]
                } else {
                    [0.0, 0.0]
                };
                mu * lambda_rate[c]
                    - unit[0] * lambda_rate[n + c]
                    - unit[1] * lambda_rate[2 * n + c]
            }
            Watch::Speed => {
                let eps = 1e-6;
                let speed_at = |t: f64, sign: f64| -> Result<f64> {
                    let a: Vec<f64> = anchors
                        .iter()
                        .zip(&rates.rate)
                        .map(|(a, r)| a + sign * eps * r)
                        .collect();
                    Ok(self.rates(t, modes, &a, closed, &[], &[])?.speed[c])
                };
                (speed_at(tau + eps, 1.0)? - speed_at(tau - eps, -1.0)?) / (2.0 * eps)
            }
        })
    }
}
