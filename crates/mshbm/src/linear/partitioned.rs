//! The `L | N` partition of a structural system into the blocks the condensation works on
//! (paper eq. 3: `N` the DOFs the set-valued force laws act on, `L` the rest).

use faer::c64;

use super::dynamic_stiffness::StructuralBlock;
use crate::model::System;

/// The constant and `cos ωt` load amplitudes restricted to one part (`L` or `N`) of the
/// partition, in that part's numbering.
#[derive(Clone, Debug)]
pub struct PartLoad {
    /// Constant load (harmonic 0).
    pub constant: Vec<f64>,
    /// Cosine amplitude of the harmonic load (harmonic 1).
    pub harmonic: Vec<f64>,
}

impl PartLoad {
    /// The loads of `system` on the system DOFs `dofs`.
    pub fn restrict(system: &System, dofs: &[usize]) -> Self {
        let pick = |v: &[f64]| -> Vec<f64> { dofs.iter().map(|&i| v[i]).collect() };
        PartLoad {
            constant: pick(&system.constant_load),
            harmonic: pick(&system.harmonic_load),
        }
    }

    /// The real amplitude of harmonic `k` (cosine part; the loads have no sine part), `None`
    /// for `k ≥ 2`.
    pub fn real(&self, k: usize) -> Option<&[f64]> {
        match k {
            0 => Some(&self.constant),
            1 => Some(&self.harmonic),
            _ => None,
        }
    }

    /// The complex amplitude `f_k` of harmonic `k` (`z = a − i b`), `None` when it is zero.
    pub fn complex(&self, k: usize) -> Option<Vec<c64>> {
        let v = self.real(k)?;
        v.iter()
            .any(|&x| x != 0.0)
            .then(|| v.iter().map(|&x| c64::new(x, 0.0)).collect())
    }

    /// [`PartLoad::complex`] into `out` (left as it is when the load is zero); whether it
    /// is nonzero.
    pub fn complex_into(&self, k: usize, out: &mut [c64]) -> bool {
        let Some(v) = self.real(k) else {
            return false;
        };
        if v.iter().all(|&x| x == 0.0) {
            return false;
        }
        out.iter_mut()
            .zip(v)
            .for_each(|(o, &x)| *o = c64::new(x, 0.0));
        true
    }
}

/// A structural system `M q̈ + C q̇ + K q = f` split into the linear part `L` and the
/// nonlinear part `N`:
///
/// ```text
/// [A_LL,k  A_LN,k] [q̂_L,k]   [f_L,k]   [  0  ]
/// [A_NL,k  A_NN,k] [q̂_N,k] = [f_N,k] + [λ̂_N,k]      A_k(ω) = K − (kω)² M + i kω C
/// ```
///
/// per harmonic `k` (paper eqs. 4–8 in complex form; docs/theory.md (T1), (T13)). Each
/// block holds its `K`, `M`, `C`.
#[derive(Clone, Debug)]
pub struct PartitionedSystem {
    pub ll: StructuralBlock,
    pub ln: StructuralBlock,
    pub nl: StructuralBlock,
    pub nn: StructuralBlock,
    /// Loads on `L`.
    pub load_l: PartLoad,
    /// Loads on `N`.
    pub load_n: PartLoad,
}

impl PartitionedSystem {
    /// The partition of `system` into [`System::linear_dofs`] and [`System::nonlinear_dofs`].
    pub fn new(system: &System) -> Self {
        let (l, n) = (&system.linear_dofs, &system.nonlinear_dofs);
        let block = |rows: &[usize], cols: &[usize]| {
            StructuralBlock::of(&system.stiffness, &system.mass, &system.damping, rows, cols)
        };
        PartitionedSystem {
            ll: block(l, l),
            ln: block(l, n),
            nl: block(n, l),
            nn: block(n, n),
            load_l: PartLoad::restrict(system, l),
            load_n: PartLoad::restrict(system, n),
        }
    }

    /// Number of DOFs of the linear part `L`.
    pub fn n_linear(&self) -> usize {
        self.ll.nrows()
    }

    /// Number of DOFs of the nonlinear part `N`.
    pub fn n_nonlinear(&self) -> usize {
        self.nn.nrows()
    }
}
