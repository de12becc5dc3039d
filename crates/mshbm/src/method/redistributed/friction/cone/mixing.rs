//! Anderson mixing of the period's march (docs/theory.md (T224)): the next start of the
//! fixed-point iteration `x = G(x)` of (T190) from the last few starts and ends, instead of
//! the last end alone.

use crate::dense::solve_small_lu_columns;

/// The last `memory + 1` pairs `(x_i, G(x_i))` of one run of constant modes.
#[derive(Debug)]
pub(super) struct Anderson {
    memory: usize,
    starts: Vec<Vec<f64>>,
    ends: Vec<Vec<f64>>,
}

impl Anderson {
    pub(super) fn new(memory: usize) -> Self {
        Anderson {
            memory,
            starts: Vec::new(),
            ends: Vec::new(),
        }
    }

    /// Forget the history (the modes at the period's start changed, and with them the
    /// unknowns).
    pub(super) fn reset(&mut self) {
        self.starts.clear();
        self.ends.clear();
    }

    /// The next start after the march from `x` ended at `g` (T224): `g − ΔG γ` with `γ`
    /// minimising `|f − ΔF γ|` over the differences of the kept residuals `f_i = G(x_i) − x_i`
    /// and ends. The plain `g` with no history, and where the residual grew (the history
    /// is then restarted from this pair).
    pub(super) fn next(&mut self, x: &[f64], g: &[f64]) -> Vec<f64> {
        let norm = |a: &[f64], b: &[f64]| -> f64 {
            a.iter()
                .zip(b)
                .map(|(p, q)| (p - q) * (p - q))
                .sum::<f64>()
                .sqrt()
        };
        if let (Some(xl), Some(gl)) = (self.starts.last(), self.ends.last()) {
            if xl.len() != x.len() || norm(g, x) >= norm(gl, xl) {
                self.reset();
            }
        }
        self.starts.push(x.to_vec());
        self.ends.push(g.to_vec());
        if self.starts.len() > self.memory + 1 {
            self.starts.remove(0);
            self.ends.remove(0);
        }
        let k = self.starts.len() - 1;
        if k == 0 {
            return g.to_vec();
        }
        let p = x.len();
        let residual = |i: usize, r: usize| -> f64 { self.ends[i][r] - self.starts[i][r] };
        // the differences ΔF (p × k) and the normal equations ΔFᵀΔF γ = ΔFᵀ f
        let df: Vec<Vec<f64>> = (0..k)
            .map(|j| {
                (0..p)
                    .map(|r| residual(j + 1, r) - residual(j, r))
                    .collect()
            })
            .collect();
        let mut a = vec![0.0; k * k];
        let mut b = vec![0.0; k];
        for i in 0..k {
            for j in 0..k {
                a[i * k + j] = df[i].iter().zip(&df[j]).map(|(u, v)| u * v).sum();
            }
            b[i] = (0..p).map(|r| df[i][r] * residual(k, r)).sum();
        }
        // a ridge at round-off of the diagonal keeps nearly dependent differences solvable
        let trace: f64 = (0..k).map(|i| a[i * k + i]).sum();
        if trace <= 0.0 {
            return g.to_vec();
        }
        for i in 0..k {
            a[i * k + i] += 1e-13 * trace;
        }
        let Ok(gamma) =
            solve_small_lu_columns(&a, faer::MatRef::from_column_major_slice(&b, k, 1), 1e-15)
        else {
            self.reset();
            return g.to_vec();
        };
        (0..p)
            .map(|r| {
                g[r] - (0..k)
                    .map(|j| gamma[(j, 0)] * (self.ends[j + 1][r] - self.ends[j][r]))
                    .sum::<f64>()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On an affine contraction `G(x) = M x + c` of `ℝ²` Anderson mixing with two
    /// differences is exact after three evaluations (the secant condition spans the space),
    /// where the plain iteration contracts by the spectral radius 0.95 per step.
    #[test]
    fn mixing_solves_an_affine_contraction_in_a_few_steps() {
        let g = |x: &[f64]| {
            vec![
                0.9 * x[0] + 0.05 * x[1] + 1.0,
                -0.02 * x[0] + 0.95 * x[1] - 2.0,
            ]
        };
        // the fixed point: (I − M) x = c
        let (a, b, c, d) = (0.1, -0.05, 0.02, 0.05);
        let det = a * d - b * c;
        let exact = [(d * 1.0 - b * -2.0) / det, (-c * 1.0 + a * -2.0) / det];
        let mut mixing = Anderson::new(5);
        let mut x = vec![0.0, 0.0];
        for _ in 0..4 {
            let gx = g(&x);
            x = mixing.next(&x, &gx);
        }
        let error = (x[0] - exact[0]).hypot(x[1] - exact[1]) / exact[0].hypot(exact[1]);
        assert!(error < 1e-8, "mixing: {error:e}");
        let mut plain = vec![0.0, 0.0];
        for _ in 0..4 {
            plain = g(&plain);
        }
        let error = (plain[0] - exact[0]).hypot(plain[1] - exact[1]) / exact[0].hypot(exact[1]);
        assert!(error > 0.5, "plain: {error:e}");
    }
}
