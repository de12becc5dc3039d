//! LU factorization with partial pivoting of a complex band matrix (the algorithm of
//! LAPACK's `zgbtf2`/`zgbtrs`; docs/theory.md (T138)), for the dynamic stiffness `A_k(ω)` of a structure whose DOFs
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
        self.fill(positions, value);
        let mut reach = 0;
        for j in 0..self.n {
            self.eliminate(j, &mut reach);
        }
        !self.singular
    }

    /// [`BandedLu::factor`] of several matrices of the same sizes, entry `e` of matrix `m`
    /// being `value(m, e)`: column by column across the matrices, so that their independent
    /// eliminations overlap in the processor (one matrix's elimination is a chain of
    /// dependent divisions and products). `false` when any is singular.
    pub fn factor_batch(
        matrices: &mut [BandedLu],
        positions: &[usize],
        value: impl Fn(usize, usize) -> c64,
    ) -> bool {
        for (m, lu) in matrices.iter_mut().enumerate() {
            lu.fill(positions, |e| value(m, e));
        }
        let n = matrices.first().map_or(0, |lu| lu.n);
        let mut reach = vec![0; matrices.len()];
        for j in 0..n {
            for (lu, reach) in matrices.iter_mut().zip(&mut reach) {
                lu.eliminate(j, reach);
            }
        }
        matrices.iter().all(|lu| !lu.singular)
    }

    /// Store the entries of a new matrix (the band zeroed first).
    fn fill(&mut self, positions: &[usize], value: impl Fn(usize) -> c64) {
        let band = &mut self.band[..];
        band.fill(c64::new(0.0, 0.0));
        for (e, &p) in positions.iter().enumerate() {
            band[p] += value(e);
        }
        self.singular = false;
    }

    /// Step `j` of the elimination (`zgbtf2`): the pivot of column `j`, the row interchange,
    /// the multipliers and the rank-one update of the rows below. `reach` is the last column
    /// that the interchanges so far have filled (`ju`).
    fn eliminate(&mut self, j: usize, reach: &mut usize) {
        let zero = c64::new(0.0, 0.0);
        let (n, kl, ku) = (self.n, self.kl, self.ku);
        let leading = self.leading();
        let kv = kl + ku;
        // from entry (i, c) to (i, c + 1) in the storage
        let along_row = leading - 1;
        let band = &mut self.band[..];
        let km = kl.min(n - 1 - j);
        let diagonal = kv + j * leading;
        // the pivot: the largest entry of column j on and below the diagonal (in
        // |Re| + |Im|, as LAPACK)
        let mut p = 0;
        let mut largest = -1.0;
        for (r, v) in band[diagonal..=diagonal + km].iter().enumerate() {
            let size = v.re.abs() + v.im.abs();
            if size > largest {
                largest = size;
                p = r;
            }
        }
        self.pivots[j] = j + p;
        if largest == 0.0 || !largest.is_finite() {
            self.singular = true;
            self.inverse_diagonal[j] = c64::new(f64::NAN, f64::NAN);
            return;
        }
        let ju = (*reach).max((j + ku + p).min(n - 1));
        *reach = ju;
        if p != 0 {
            // rows j and j + p, columns j..=ju
            let mut at = diagonal;
            for _ in j..=ju {
                band.swap(at, at + p);
                at += along_row;
            }
        }
        let pivot = band[diagonal];
        let scale = 1.0 / (pivot.re * pivot.re + pivot.im * pivot.im);
        let inverse = c64::new(pivot.re * scale, -pivot.im * scale);
        self.inverse_diagonal[j] = inverse;
        if km == 0 {
            return;
        }
        for l in &mut band[diagonal + 1..=diagonal + km] {
            *l *= inverse;
        }
        // the rank-one update of the rows below j, columns j + 1..=ju
        let (multipliers, rest) = band.split_at_mut(diagonal + km + 1);
        let multipliers = &multipliers[diagonal + 1..];
        let mut at = along_row - km - 1;
        for _ in j + 1..=ju {
            let f = rest[at];
            if f != zero {
                rest[at + 1..=at + km]
                    .iter_mut()
                    .zip(multipliers)
                    .for_each(|(a, l)| *a -= l * f);
            }
            at += along_row;
        }
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

    /// Solve one system per right-hand side, `A_m x = b` for each `(m, b)` of `systems`
    /// (`m` an index into `matrices`), column by column across them so that the
    /// independent substitutions overlap in the processor.
    pub fn solve_batch(matrices: &[BandedLu], systems: &mut [(usize, &mut [c64])]) {
        let references: Vec<&BandedLu> = matrices.iter().collect();
        Self::solve_batch_of(&references, systems);
    }

    /// [`BandedLu::solve_batch`] with the matrices given by reference.
    pub fn solve_batch_of(matrices: &[&BandedLu], systems: &mut [(usize, &mut [c64])]) {
        let Some(first) = matrices.first() else {
            return;
        };
        let (n, kl, kv) = (first.n, first.kl, first.kl + first.ku);
        let leading = first.leading();
        for j in 0..n {
            let below = kl.min(n - 1 - j);
            for (m, b) in systems.iter_mut() {
                let lu = matrices[*m];
                let l = lu.pivots[j];
                if l != j {
                    b.swap(l, j);
                }
                let bj = b[j];
                let multipliers = &lu.band[kv + 1 + j * leading..kv + 1 + below + j * leading];
                b[j + 1..j + 1 + below]
                    .iter_mut()
                    .zip(multipliers)
                    .for_each(|(bi, m)| *bi -= m * bj);
            }
        }
        for j in (0..n).rev() {
            let first_row = j.saturating_sub(kv);
            let base = (kv + first_row) + j * leading - j;
            for (m, b) in systems.iter_mut() {
                let lu = matrices[*m];
                b[j] *= lu.inverse_diagonal[j];
                let bj = b[j];
                b[first_row..j]
                    .iter_mut()
                    .zip(&lu.band[base..base + (j - first_row)])
                    .for_each(|(bi, u)| *bi -= u * bj);
            }
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

    /// The batch factorization and solves give each matrix's own factors and solutions.
    #[test]
    fn a_batch_factors_each_matrix_as_alone() {
        let (n, kl, ku) = (20, 2, 1);
        let entries: Vec<(usize, usize)> = (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .filter(|&(i, j)| i + ku >= j && j + kl >= i)
            .collect();
        let positions: Vec<usize> = entries
            .iter()
            .map(|&(i, j)| BandedLu::position(kl, ku, i, j))
            .collect();
        let value = |m: usize, e: usize| {
            let (i, j) = entries[e];
            c64::new(
                (0.7 * (i + 2 * j + m) as f64).sin(),
                (0.3 * (i * j + m) as f64).cos(),
            )
        };
        let mut batch = vec![BandedLu::new(n, kl, ku); 3];
        assert!(BandedLu::factor_batch(&mut batch, &positions, value));
        let rhs = |m: usize| -> Vec<c64> {
            (0..n)
                .map(|i| c64::new(1.0 + (i + m) as f64, -0.5 * i as f64))
                .collect()
        };
        let mut solved: Vec<Vec<c64>> = (0..3).map(rhs).collect();
        let mut systems: Vec<(usize, &mut [c64])> = solved
            .iter_mut()
            .enumerate()
            .map(|(m, b)| (m, b.as_mut_slice()))
            .collect();
        BandedLu::solve_batch(&batch, &mut systems);
        for (m, lu) in batch.iter().enumerate() {
            let mut alone = BandedLu::new(n, kl, ku);
            assert!(alone.factor(&positions, |e| value(m, e)));
            assert_eq!(alone.band, lu.band);
            assert_eq!(alone.pivots, lu.pivots);
            let mut x = rhs(m);
            alone.solve_in_place(&mut x);
            assert_eq!(x, solved[m]);
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
