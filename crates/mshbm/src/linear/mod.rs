//! The linear subsystem in the frequency domain (paper eqs. 6–8, 25; docs/theory.md §3).
//!
//! * [`dynamic_stiffness`]: the complex dynamic stiffness `A_k(ω) = K − (kω)² M + i kω C`
//!   of harmonic `k` (the complex form of eq. 8, docs/theory.md (T13)) and
//!   `∂A_k/∂ω = −2k²ω M + i k C` (docs/theory.md (T14)) applied to vectors
//!   ([`StructuralBlock`]), and its sparse LU on the linear part ([`LinearPart`]);
//! * [`partitioned`]: the `L | N` blocks and loads of a system ([`PartitionedSystem`]);
//! * [`condensation`]: the condensation of the linear part onto the `N` DOFs per frequency,
//!   `G_k = A_NL,k A_LL,k⁻¹ A_LN,k`, `u0_k = A_NL,k A_LL,k⁻¹ f_L,k` (docs/theory.md (T20))
//!   and what follows from them ([`Condensation`], [`ExactCondensation`]);
//! * [`receptance`]: the condensation of the whole structure onto its contact coordinates,
//!   `R_k = Wᵀ A_k⁻¹ W` (docs/theory.md (T125); [`Receptance`], [`ExactReceptance`]);
//! * [`modal_receptance`]: the same by modes with the exact static part, for large models
//!   (docs/theory.md (T130); [`ModalReceptance`]).
//!
//! Complex amplitudes are `z_k = a_k − i b_k` of `a_k cos kτ + b_k sin kτ` (`z_0 = a_0`;
//! docs/theory.md (T11)); real Fourier coefficients are stored harmonic-major, coefficient
//! `c` of `[a0, a1, b1, …]` of DOF `i` of `n` at `c·n + i` (docs/theory.md (T8)).

pub mod banded;
pub mod condensation;
pub mod dynamic_stiffness;
pub mod exact_receptance;
pub mod modal_receptance;
pub mod partitioned;
pub mod receptance;

use faer::c64;

pub use condensation::{Condensation, CondensedFrequency, ExactCondensation, LinearResponse};
pub use dynamic_stiffness::{HarmonicFactors, LinearPart, StructuralBlock};
pub use exact_receptance::ExactReceptance;
pub use modal_receptance::ModalReceptance;
pub use partitioned::{PartLoad, PartitionedSystem};
pub use receptance::{ContactCoordinates, Receptance, ReceptanceAtFrequency, StaticPlusLowRank};

/// The complex zero.
pub(crate) const ZERO: c64 = c64::new(0.0, 0.0);

/// Complex amplitude `z_k = a_k − i b_k` of harmonic `k` of the harmonic-major coefficients
/// `x` of `n` DOFs (`z_0 = a_0`).
pub fn complex_harmonic(x: &[f64], n: usize, k: usize) -> Vec<c64> {
    if k == 0 {
        x[..n].iter().map(|&v| c64::new(v, 0.0)).collect()
    } else {
        let (ci, si) = ((2 * k - 1) * n, 2 * k * n);
        (0..n).map(|i| c64::new(x[ci + i], -x[si + i])).collect()
    }
}

/// [`complex_harmonic`] into `out` (`n`).
pub fn complex_harmonic_into(x: &[f64], n: usize, k: usize, out: &mut [c64]) {
    if k == 0 {
        (0..n).for_each(|i| out[i] = c64::new(x[i], 0.0));
    } else {
        let (ci, si) = ((2 * k - 1) * n, 2 * k * n);
        (0..n).for_each(|i| out[i] = c64::new(x[ci + i], -x[si + i]));
    }
}

/// Write the complex amplitude `v` of harmonic `k` of `n` DOFs into the harmonic-major real
/// coefficients `out` (`a = Re`, `b = −Im`; the mean takes the real part), the inverse of
/// [`complex_harmonic`].
pub fn store_harmonic(v: &[c64], n: usize, k: usize, out: &mut [f64]) {
    if k == 0 {
        (0..n).for_each(|i| out[i] = v[i].re);
    } else {
        let (ci, si) = ((2 * k - 1) * n, 2 * k * n);
        for i in 0..n {
            out[ci + i] = v[i].re;
            out[si + i] = -v[i].im;
        }
    }
}
