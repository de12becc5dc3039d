//! Test models shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use mshbm::model::{Contact, Damping, Model};
use mshbm::sparse::SparseMatrix;

pub fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// The lattice lives in the library so that the benchmarks can use it too.
#[allow(unused_imports)]
pub use mshbm::model::lattice::lattice_model;

/// The bilinear oscillator: a mass `m` on a spring `k` to ground, and a massless contact
/// node attached to it by a spring `k_c` that hits a rigid stop after a gap `g`
/// (`g_N = g − q_1`). In contact the stiffness is `k + k_c`: the classic piecewise-linear
/// oscillator whose free frequency depends on the amplitude. Harmonic force `F cos ωt` on
/// the mass; mass-proportional damping `alpha`.
pub fn bilinear_oscillator(m: f64, k: f64, k_c: f64, gap: f64, force: f64, alpha: f64) -> Model {
    Model {
        source: PathBuf::from("bilinear oscillator"),
        name: "bilinear oscillator".into(),
        mass: SparseMatrix::from_triplets(2, 2, &[(0, 0, m)]),
        stiffness: SparseMatrix::from_triplets(
            2,
            2,
            &[(0, 0, k + k_c), (0, 1, -k_c), (1, 0, -k_c), (1, 1, k_c)],
        ),
        damping_matrix: None,
        coordinates: vec![vec![0.0], vec![1.0]],
        dofs_per_node: 1,
        dirichlet: vec![],
        contacts: vec![Contact {
            dofs: vec![1],
            w: vec![-1.0],
            gap,
        }],
        harmonic_load: vec![force, 0.0],
        constant_load: vec![0.0, 0.0],
        frictions: vec![],
        acceleration: None,
        damping: Damping {
            alpha,
            ..Damping::default()
        },
    }
}

/// Analytic backbone of the undamped bilinear oscillator: angular frequency of the free
/// periodic motion with maximum displacement `a > gap` (contact phase about the shifted
/// equilibrium `k_c g/(k + k_c)` at `ω₂`, free phase at `ω₁`).
pub fn bilinear_backbone(m: f64, k: f64, k_c: f64, gap: f64, a: f64) -> f64 {
    let (w1, w2) = ((k / m).sqrt(), ((k + k_c) / m).sqrt());
    if a <= gap {
        return w1;
    }
    let qe = k_c * gap / (k + k_c);
    let tc = ((gap - qe) / (a - qe)).acos() / w2;
    let v = (a - qe) * w2 * (w2 * tc).sin();
    let b = (gap * gap + (v / w1).powi(2)).sqrt();
    let period = 2.0 * tc + 2.0 * (std::f64::consts::PI - (gap / b).acos()) / w1;
    2.0 * std::f64::consts::PI / period
}
