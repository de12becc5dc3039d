//! faer's LU with partial pivoting for the dense systems of [`super`] (`solve_small_lu`,
//! `solve_small_lu_columns`): small ones factored and applied on the calling thread, large
//! ones (an LCP's active block on a 3D interface) with faer's global parallelism.

use faer::Mat;

/// Below this order the factorisation and its solves stay on the calling thread.
const SEQUENTIAL_BELOW: usize = 128;

/// faer's LU with partial pivoting of a row-major matrix. Below [`SEQUENTIAL_BELOW`] rows
/// it is factored and applied on the calling thread: the global parallelism would hand
/// these tiny factorisations and their many right-hand sides to rayon, whose workers then
/// spin (the friction cone's tangent solved millions of them; a third of its time went to
/// `sched_yield`).
pub(super) struct SmallLu {
    factors: Mat<f64>,
    forward: Vec<usize>,
    inverse: Vec<usize>,
}

impl SmallLu {
    pub(super) fn new(a: &[f64], n: usize) -> Self {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::lu::partial_pivoting::factor::{lu_in_place, lu_in_place_scratch};
        let mut factors = Mat::<f64>::from_fn(n, n, |i, j| a[i * n + j]);
        let (mut forward, mut inverse) = (vec![0usize; n], vec![0usize; n]);
        let par = parallelism(n);
        let mut mem = MemBuffer::new(lu_in_place_scratch::<usize, f64>(
            n,
            n,
            par,
            Default::default(),
        ));
        lu_in_place(
            factors.as_mut(),
            &mut forward,
            &mut inverse,
            par,
            MemStack::new(&mut mem),
            Default::default(),
        );
        SmallLu {
            factors,
            forward,
            inverse,
        }
    }

    /// The first column whose pivot `U_kk` is `singular`.
    pub(super) fn singular_column(&self, singular: impl Fn(f64) -> bool) -> Option<usize> {
        (0..self.factors.nrows()).find(|&k| singular(self.factors[(k, k)]))
    }

    /// `B ← A⁻¹ B`.
    pub(super) fn solve_in_place(&self, b: faer::MatMut<'_, f64>) {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::lu::partial_pivoting::solve::{solve_in_place, solve_in_place_scratch};
        let n = self.factors.nrows();
        let par = parallelism(n);
        let mut mem = MemBuffer::new(solve_in_place_scratch::<usize, f64>(n, b.ncols(), par));
        let permutation = faer::perm::PermRef::new_checked(&self.forward, &self.inverse, n);
        solve_in_place(
            self.factors.as_ref(),
            self.factors.as_ref(),
            permutation,
            b,
            par,
            MemStack::new(&mut mem),
        );
    }
}

/// The parallelism of an LU of order `n`.
fn parallelism(n: usize) -> faer::Par {
    if n < SEQUENTIAL_BELOW {
        faer::Par::Seq
    } else {
        faer::get_global_parallelism()
    }
}
