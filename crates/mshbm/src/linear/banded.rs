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

    /// The storage position of entry `(i, j)` of a matrix with `kl` sub- and `ku`
    /// superdiagonals (within the band: `i + ku ≥ j`, `j + kl ≥ i`), for [`BandedLu::factor`].
    pub fn position(kl: usize, ku: usize, i: usize, j: usize) -> usize {
        assert!(i + ku >= j && j + kl >= i, "({i}, {j}) outside the band");
        (kl + ku + i - j) + j * (2 * kl + ku + 1)
    }

    /// Factor the matrix with entries `value(e)` at the storage positions `positions[e]`
    /// ([`BandedLu::position`] of this matrix's `kl`, `ku`; repeated positions add). `false` when a pivot is zero (the
    /// matrix is singular; solutions are then not finite).
    pub fn factor(&mut self, positions: &[usize], value: impl Fn(usize) -> c64) -> bool {
        self.band.iter_mut().for_each(|v| *v = c64::new(0.0, 0.0));
        for (e, &p) in positions.iter().enumerate() {
            self.band[p] += value(e);
        }
        let (kl, ku) = (self.kl, self.ku);
        let leading = self.leading();
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
            let pivot = self.band[kv + j * leading];
            let scale = 1.0 / (pivot.re * pivot.re + pivot.im * pivot.im);
            let inverse = c64::new(pivot.re * scale, -pivot.im * scale);
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
        let zero = c64::new(0.0, 0.0);
        // L: the row interchanges and the eliminations, column by column
        for j in 0..n {
            let l = self.pivots[j];
            let below = self.kl.min(n - 1 - j);
            let multipliers = &self.band[kv + 1 + j * leading..kv + 1 + below + j * leading];
            if l != j {
                b.swap(l, j);
            }
            let bj = b[j];
            if bj != zero {
                b[j + 1..j + 1 + below]
                    .iter_mut()
                    .zip(multipliers)
                    .for_each(|(bi, m)| *bi -= m * bj);
            }
        }
        // U: back substitution over its kl + ku superdiagonals; rows j − kv .. j of column
        // j are contiguous in the band
        for j in (0..n).rev() {
            let first = j.saturating_sub(kv);
            let base = self.at(first, j);
            let upper = &self.band[base..base + (j - first)];
            let inverse = self.inverse_diagonal[j];
            b[j] *= inverse;
            let bj = b[j];
            b[first..j]
                .iter_mut()
                .zip(upper)
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
            let entries: Vec<(usize, usize)> = (0..n)
                .flat_map(|j| (0..n).map(move |i| (i, j)))
                .filter(|&(i, j)| in_band(i, j))
                .collect();
            let positions: Vec<usize> = entries
                .iter()
                .map(|&(i, j)| BandedLu::position(kl, ku, i, j))
                .collect();
            assert!(lu.factor(&positions, |e| entry(entries[e].0, entries[e].1)));
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
        let positions = [
            BandedLu::position(1, 1, 0, 0),
            BandedLu::position(1, 1, 2, 2),
        ];
        let ok = lu.factor(&positions, |_| c64::new(1.0, 0.0));
        assert!(!ok && lu.is_singular());
    }

    #[test]
    fn bandwidths_of_a_tridiagonal_pattern() {
        let entries = (0..5).flat_map(|i| [(i, i), (i + 1, i), (i, i + 1)]);
        assert_eq!(bandwidths(entries), (1, 1));
    }
}
