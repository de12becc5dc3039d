//! LU factorization with partial pivoting of a complex band matrix (the algorithm of
//! LAPACK's `zgbtf2`/`zgbtrs`), for the dynamic stiffness `A_k(ω)` of a structure whose DOFs
//! are numbered along it (a bar, a beam, a chain): `kl` sub- and `ku` superdiagonals cost
//! `O(n kl (kl + ku))` per factorization and `O(n (2kl + ku))` per solve, with no symbolic
//! phase and no allocation once the storage exists.
//!
//! Storage: column `j` of `A` holds rows `j − ku − kl ..= j + kl` (the `kl` extra rows above
//! take the fill-in of the row interchanges); entry `(i, j)` is at
//! `(kl + ku + i − j) + j · (2kl + ku + 1)`.

use faer::c64;

/// The LU factors of a band matrix, refactored in place for new values of the same band.
#[derive(Clone, Debug)]
pub struct BandedLu {
    n: usize,
    kl: usize,
    ku: usize,
    band: Vec<c64>,
    pivots: Vec<usize>,
    /// `1 / U[j, j]`.
    inverse_diagonal: Vec<c64>,
    /// Whether the last factorization met a zero pivot.
    singular: bool,
}

impl BandedLu {
    /// Storage for an `n × n` matrix with `kl` sub- and `ku` superdiagonals.
    pub fn new(n: usize, kl: usize, ku: usize) -> Self {
        BandedLu {
            n,
            kl,
            ku,
            band: vec![c64::new(0.0, 0.0); n * (2 * kl + ku + 1)],
            pivots: vec![0; n],
            inverse_diagonal: vec![c64::new(0.0, 0.0); n],
            singular: false,
        }
    }

    /// Values that [`BandedLu::new`] of these sizes holds (for memory estimates).
    pub fn values(n: usize, kl: usize, ku: usize) -> usize {
        n * (2 * kl + ku + 1)
    }

    fn leading(&self) -> usize {
        2 * self.kl + self.ku + 1
    }

    fn at(&self, i: usize, j: usize) -> usize {
        (self.kl + self.ku + i - j) + j * self.leading()
    }

    /// Factor the matrix whose entries `set` writes: it is called with a function that
    /// stores `A[i, j]` (within the band, `i + ku ≥ j`, `j + kl ≥ i`; repeated entries add).
    /// `false` when a pivot is zero (the matrix is singular).
    pub fn factor(&mut self, set: impl FnOnce(&mut dyn FnMut(usize, usize, c64))) -> bool {
        self.band.iter_mut().for_each(|v| *v = c64::new(0.0, 0.0));
        let (kl, ku) = (self.kl, self.ku);
        let leading = self.leading();
        {
            let band = &mut self.band;
            let mut store = |i: usize, j: usize, v: c64| {
                debug_assert!(i + ku >= j && j + kl >= i, "({i}, {j}) outside the band");
                band[(kl + ku + i - j) + j * leading] += v;
            };
            set(&mut store);
        }
        let n = self.n;
        let kv = kl + ku;
        let mut ju = 0;
        self.singular = false;
        for j in 0..n {
            let km = kl.min(n - 1 - j);
            // the pivot: the largest entry of column j on and below the diagonal (in
            // |Re| + |Im|, as LAPACK)
            let mut p = 0;
            let mut largest = -1.0;
            for r in 0..=km {
                let v = self.band[kv + r + j * leading];
                let v = v.re.abs() + v.im.abs();
                if v > largest {
                    largest = v;
                    p = r;
                }
            }
            self.pivots[j] = j + p;
            if largest == 0.0 || !largest.is_finite() {
                self.singular = true;
                self.inverse_diagonal[j] = c64::new(f64::NAN, f64::NAN);
                continue;
            }
            ju = ju.max((j + ku + p).min(n - 1));
            if p != 0 {
                for c in j..=ju {
                    let (a, b) = (self.at(j, c), self.at(j + p, c));
                    self.band.swap(a, b);
                }
            }
            let inverse = c64::new(1.0, 0.0) / self.band[kv + j * leading];
            self.inverse_diagonal[j] = inverse;
            if km > 0 {
                for r in 1..=km {
                    self.band[kv + r + j * leading] *= inverse;
                }
                for c in j + 1..=ju {
                    let f = self.band[self.at(j, c)];
                    if f == c64::new(0.0, 0.0) {
                        continue;
                    }
                    let column = self.at(j, c);
                    for r in 1..=km {
                        let l = self.band[kv + r + j * leading];
                        self.band[column + r] -= l * f;
                    }
                }
            }
        }
        !self.singular
    }

    /// Solve `A x = b` in place (`b` of length `n`) with the factors of the last
    /// [`BandedLu::factor`].
    pub fn solve_in_place(&self, b: &mut [c64]) {
        let n = self.n;
        let kv = self.kl + self.ku;
        let leading = self.leading();
        // L: the row interchanges and the eliminations, column by column
        for j in 0..n {
            let l = self.pivots[j];
            if l != j {
                b.swap(l, j);
            }
            let bj = b[j];
            if bj == c64::new(0.0, 0.0) {
                continue;
            }
            for r in 1..=self.kl.min(n - 1 - j) {
                b[j + r] -= self.band[kv + r + j * leading] * bj;
            }
        }
        // U: back substitution over its kl + ku superdiagonals
        for j in (0..n).rev() {
            b[j] *= self.inverse_diagonal[j];
            let bj = b[j];
            // rows j − kv .. j of column j are contiguous in the band
            let first = j.saturating_sub(kv);
            let base = self.at(first, j);
            b[first..j]
                .iter_mut()
                .zip(&self.band[base..base + (j - first)])
                .for_each(|(bi, u)| *bi -= u * bj);
        }
    }

    pub fn is_singular(&self) -> bool {
        self.singular
    }
}

/// The lower and upper bandwidths `(kl, ku)` of a matrix given by its entries' positions.
pub fn bandwidths(entries: impl Iterator<Item = (usize, usize)>) -> (usize, usize) {
    entries.fold((0, 0), |(kl, ku), (i, j)| {
        if i > j {
            (kl.max(i - j), ku)
        } else {
            (kl, ku.max(j - i))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::linalg::solvers::Solve;
    use faer::Mat;

    /// A banded complex matrix with small diagonals (so that pivoting happens) against
    /// faer's dense LU: the solutions agree to round-off.
    #[test]
    fn the_band_solution_is_the_dense_solution() {
        for (n, kl, ku) in [(1, 0, 0), (7, 1, 1), (30, 2, 3), (25, 4, 1), (12, 0, 2)] {
            let entry = |i: usize, j: usize| -> c64 {
                let (a, b) = (i as f64, j as f64);
                let diagonal = if i == j { 0.05 } else { 0.0 };
                c64::new(
                    (1.3 * a + 0.7 * b).sin() + diagonal,
                    (0.4 * a - 1.1 * b).cos(),
                )
            };
            let in_band = |i: usize, j: usize| i + ku >= j && j + kl >= i;
            let dense = Mat::<c64>::from_fn(n, n, |i, j| {
                if in_band(i, j) {
                    entry(i, j)
                } else {
                    c64::new(0.0, 0.0)
                }
            });
            let mut lu = BandedLu::new(n, kl, ku);
            assert!(lu.factor(|store| {
                for j in 0..n {
                    for i in 0..n {
                        if in_band(i, j) {
                            store(i, j, entry(i, j));
                        }
                    }
                }
            }));
            let rhs: Vec<c64> = (0..n)
                .map(|i| c64::new((0.3 * i as f64).cos(), 1.0 - 0.1 * i as f64))
                .collect();
            let mut x = rhs.clone();
            lu.solve_in_place(&mut x);
            let exact = dense
                .partial_piv_lu()
                .solve(Mat::<c64>::from_fn(n, 1, |i, _| rhs[i]));
            let size = (0..n).map(|i| exact[(i, 0)].norm()).fold(0.0, f64::max);
            for i in 0..n {
                assert!(
                    (x[i] - exact[(i, 0)]).norm() <= 1e-12 * size,
                    "n = {n}, kl = {kl}, ku = {ku}, row {i}: {:?} vs {:?}",
                    x[i],
                    exact[(i, 0)]
                );
            }
        }
    }

    #[test]
    fn a_zero_column_is_singular() {
        let mut lu = BandedLu::new(3, 1, 1);
        let ok = lu.factor(|store| {
            store(0, 0, c64::new(1.0, 0.0));
            store(2, 2, c64::new(1.0, 0.0));
        });
        assert!(!ok && lu.is_singular());
    }

    #[test]
    fn bandwidths_of_a_tridiagonal_pattern() {
        let entries = (0..5).flat_map(|i| [(i, i), (i + 1, i), (i, i + 1)]);
        assert_eq!(bandwidths(entries), (1, 1));
    }
}
