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
