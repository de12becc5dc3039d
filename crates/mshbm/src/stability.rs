//! Floquet multipliers of periodic solutions (METHODS §7.2).
//!
//! A periodic solution is asymptotically stable when every Floquet multiplier (eigenvalue
//! of the monodromy matrix, the linearised map over one period) lies inside the unit
//! circle. A real multiplier leaving through +1 is a fold (turning point of the FRD),
//! through −1 a period doubling, a complex pair a Neimark–Sacker bifurcation.

use faer::{c64, Mat};
use serde::{Deserialize, Serialize};

/// Floquet multipliers of one periodic solution.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Floquet {
    /// Multipliers as `[re, im]` pairs, largest modulus first.
    pub multipliers: Vec<[f64; 2]>,
    /// Largest modulus.
    pub max_multiplier: f64,
    /// All multipliers inside the unit circle (to `1e-9`).
    pub stable: bool,
}

impl Floquet {
    /// From the eigenvalues of a monodromy matrix.
    pub fn from_eigenvalues(mut values: Vec<c64>) -> Self {
        values.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
        let max_multiplier = values.first().map_or(0.0, |v| v.norm());
        Floquet {
            multipliers: values.iter().map(|v| [v.re, v.im]).collect(),
            max_multiplier,
            stable: max_multiplier < 1.0 - 1e-9,
        }
    }
}

/// Monodromy of `ż = A_i z` over consecutive intervals of lengths `Δt_i` (seconds):
/// `Φ = exp(A_m Δt_m) ⋯ exp(A_1 Δt_1)`. Exact for piecewise-constant systems.
pub fn piecewise_monodromy(pieces: &[(&Mat<f64>, f64)]) -> Mat<f64> {
    let n = pieces.first().map_or(0, |(a, _)| a.nrows());
    let mut phi = Mat::<f64>::identity(n, n);
    for (a, dt) in pieces {
        let step = crate::dense::expm(&(*a * *dt));
        phi = &step * &phi;
    }
    phi
}

/// `exp(A t)` for many `t` from one eigendecomposition `A = V Λ V⁻¹` (used when the same
/// piecewise-constant system matrices recur along a frequency response diagram).
#[derive(Clone, Debug)]
pub struct ModalExponential {
    v: Mat<c64>,
    lambda: Vec<c64>,
    v_inv: Mat<c64>,
}

impl ModalExponential {
    /// Eigendecomposition of `a`; `None` when it is too ill-conditioned to reproduce `a`
    /// to `1e-10` (then use [`crate::dense::expm`]).
    pub fn new(a: &Mat<f64>) -> Option<Self> {
        use faer::linalg::solvers::Solve;
        let n = a.nrows();
        let eig = a.eigen().ok()?;
        let v = eig.U().to_owned();
        let lambda: Vec<c64> = (0..n).map(|i| eig.S().column_vector()[i]).collect();
        let v_inv = v.partial_piv_lu().solve(Mat::<c64>::identity(n, n));
        let scaled = Mat::<c64>::from_fn(n, n, |i, j| v[(i, j)] * lambda[j]);
        let back = &scaled * &v_inv;
        let norm = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max(a[(i, j)].abs()));
        let err = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .fold(0.0f64, |m, (i, j)| {
                m.max((back[(i, j)] - c64::new(a[(i, j)], 0.0)).norm())
            });
        (err <= 1e-10 * norm.max(f64::MIN_POSITIVE) && err.is_finite())
            .then_some(ModalExponential { v, lambda, v_inv })
    }

    /// `exp(A t)`.
    pub fn exp(&self, t: f64) -> Mat<c64> {
        let n = self.lambda.len();
        let scaled = Mat::<c64>::from_fn(n, n, |i, j| self.v[(i, j)] * (self.lambda[j] * t).exp());
        &scaled * &self.v_inv
    }
}

/// Monodromy of a piecewise-constant system from cached exponentials: `pieces` are
/// `(exponential, Δt)` in time order. The (real) result is returned.
pub fn modal_monodromy(pieces: &[(&ModalExponential, f64)]) -> Mat<f64> {
    let n = pieces.first().map_or(0, |(e, _)| e.lambda.len());
    let mut phi = Mat::<c64>::identity(n, n);
    for (e, dt) in pieces {
        phi = &e.exp(*dt) * &phi;
    }
    Mat::<f64>::from_fn(n, n, |i, j| phi[(i, j)].re)
}

/// How a multiplier leaves (or enters) the unit circle between two neighbouring solutions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Crossing {
    /// A real multiplier through +1 (fold, or branch point).
    Fold,
    /// A real multiplier through −1 (period doubling).
    PeriodDoubling,
    /// A complex pair through the unit circle (Neimark–Sacker, quasi-periodic motion).
    NeimarkSacker,
}

/// Numbers of multipliers outside the unit circle: (real positive, real negative, complex).
pub fn outside_counts(f: &Floquet) -> (usize, usize, usize) {
    let tol = 1e-9;
    let mut counts = (0, 0, 0);
    for m in &f.multipliers {
        if m[0].hypot(m[1]) <= 1.0 + tol {
            continue;
        }
        if m[1].abs() > 1e-9 * m[0].hypot(m[1]) {
            counts.2 += 1;
        } else if m[0] > 0.0 {
            counts.0 += 1;
        } else {
            counts.1 += 1;
        }
    }
    counts
}

/// The crossings of the unit circle between two neighbouring solutions of a branch.
pub fn crossings(before: &Floquet, after: &Floquet) -> Vec<Crossing> {
    let (a, b) = (outside_counts(before), outside_counts(after));
    let mut out = Vec::new();
    if a.0 != b.0 {
        out.push(Crossing::Fold);
    }
    if a.1 != b.1 {
        out.push(Crossing::PeriodDoubling);
    }
    if a.2 != b.2 {
        out.push(Crossing::NeimarkSacker);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn floquet(values: &[(f64, f64)]) -> Floquet {
        Floquet::from_eigenvalues(values.iter().map(|&(re, im)| c64::new(re, im)).collect())
    }

    #[test]
    fn crossings_are_classified_by_where_the_multiplier_leaves() {
        let inside = floquet(&[(0.9, 0.0), (-0.5, 0.0), (0.3, 0.4), (0.3, -0.4)]);
        assert!(inside.stable);
        assert_eq!(
            crossings(
                &inside,
                &floquet(&[(1.1, 0.0), (-0.5, 0.0), (0.3, 0.4), (0.3, -0.4)])
            ),
            vec![Crossing::Fold]
        );
        assert_eq!(
            crossings(
                &inside,
                &floquet(&[(0.9, 0.0), (-1.2, 0.0), (0.3, 0.4), (0.3, -0.4)])
            ),
            vec![Crossing::PeriodDoubling]
        );
        assert_eq!(
            crossings(
                &inside,
                &floquet(&[(0.9, 0.0), (-0.5, 0.0), (0.6, 0.9), (0.6, -0.9)])
            ),
            vec![Crossing::NeimarkSacker]
        );
        assert!(crossings(&inside, &inside).is_empty());
    }
}
