//! The convention for a contact stuck all period (docs/theory.md (T157)): centred in its
//! cone, with the condition's sensitivity by the envelope theorem.

use super::march::March;
use super::Phase;
use crate::harmonic::n_coefficients;

impl March<'_> {
    /// `h(τ) = (e_T,c + s μ_c e_N,c)ᵀ λ(τ)` in `phase`, and its sensitivity to `[γ̂, a₀]` at
    /// fixed `τ` when `row` is given.
    fn cone_side(&self, phase: &Phase, c: usize, s: f64, tau: f64, row: Option<&mut [f64]>) -> f64 {
        let (n, m) = (self.contacts.n, 2 * self.contacts.n);
        let ncoef = n_coefficients(self.harmonics);
        let nu = m * ncoef;
        let nv = nu + n;
        let d = &self.data[phase.data];
        let mu = self.contacts.mu[c];
        let kappa: Vec<f64> = (0..m)
            .map(|r| d.f[(n + c) * m + r] + s * mu * d.f[c * m + r])
            .collect();
        let theta: Vec<f64> = (0..n)
            .map(|k| d.g[(n + c) * n + k] + s * mu * d.g[c * n + k])
            .collect();
        let (value, _, b) = self.combination_at(&kappa, tau);
        if let Some(row) = row {
            for k in 0..ncoef {
                for r in 0..m {
                    row[k * m + r] += b[k] * kappa[r];
                }
            }
            for (k, &t) in theta.iter().enumerate() {
                if t != 0.0 {
                    for col in 0..nv {
                        row[col] += t * phase.d_anchors[k * nv + col];
                    }
                }
            }
        }
        value
            + theta
                .iter()
                .zip(&phase.anchors)
                .map(|(t, a)| t * a)
                .sum::<f64>()
    }

    /// The largest of `sign · h` over the period (`h` of [`March::cone_side`]): the phase and
    /// the instant. Each phase is sampled at `max(8, 4H·width/π)` points (a trigonometric
    /// polynomial of degree `H` has at most `2H` maxima per period), and every sampled
    /// local maximum is refined by golden-section search: refining only the largest sample
    /// can pick the lower of two nearly equal peaks, which makes (T157) jump as the anchors
    /// move and the fixed point's Newton cycle.
    fn extreme(&self, phases: &[Phase], c: usize, s: f64, sign: f64) -> (usize, f64) {
        let mut best = (0, 0.0, f64::NEG_INFINITY);
        for (p, phase) in phases.iter().enumerate() {
            if phase.end <= phase.start {
                continue;
            }
            let width = phase.end - phase.start;
            let points = ((4 * self.harmonics) as f64 * width / std::f64::consts::PI)
                .ceil()
                .max(8.0) as usize;
            let taus: Vec<f64> = (0..=points)
                .map(|l| phase.start + width * l as f64 / points as f64)
                .collect();
            let values: Vec<f64> = taus
                .iter()
                .map(|&t| sign * self.cone_side(phase, c, s, t, None))
                .collect();
            for l in 0..=points {
                let left = if l > 0 {
                    values[l - 1]
                } else {
                    f64::NEG_INFINITY
                };
                let right = if l < points {
                    values[l + 1]
                } else {
                    f64::NEG_INFINITY
                };
                if values[l] < left || values[l] < right {
                    continue;
                }
                if values[l] > best.2 {
                    best = (p, taus[l], values[l]);
                }
                let (lo, hi) = (taus[l.saturating_sub(1)], taus[(l + 1).min(points)]);
                let (t, v) = crate::harmonic::golden_section_argmax(
                    |t| sign * self.cone_side(phase, c, s, t, None),
                    lo,
                    hi,
                );
                if v > best.2 {
                    best = (p, t, v);
                }
            }
        }
        (best.0, best.1)
    }

    /// (T157): for a contact stuck all period, `max_τ (λ_T − μ λ_N) + min_τ (λ_T + μ λ_N)`
    /// (zero when the force is centred between the cone's extreme excursions), and its
    /// sensitivity to `[γ̂, a₀]` at the two instants (the envelope theorem).
    pub(super) fn centring(&self, phases: &[Phase], c: usize) -> (f64, Vec<f64>) {
        let nv = 2 * self.contacts.n * n_coefficients(self.harmonics) + self.contacts.n;
        let mut row = vec![0.0; nv];
        let (p1, t1) = self.extreme(phases, c, -1.0, 1.0);
        let (p2, t2) = self.extreme(phases, c, 1.0, -1.0);
        let upper = self.cone_side(&phases[p1], c, -1.0, t1, Some(&mut row));
        let lower = self.cone_side(&phases[p2], c, 1.0, t2, Some(&mut row));
        (upper + lower, row)
    }
}
