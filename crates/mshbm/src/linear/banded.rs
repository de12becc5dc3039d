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

    pub fn is_singular(&self) -> bool {
        self.singular
    }
}

/// The LU factors of several band matrices of the same sizes (the dynamic stiffness of each
/// harmonic), stored side by side: entry `(i, j)` of matrix `m` at
/// `position(i, j) · lanes + m`, real and imaginary parts apart. Each step of the
/// elimination is done for every matrix in one pass over contiguous numbers, so that the
/// processor works on the matrices' independent chains of divisions and products together
/// (and in vector registers). The arithmetic per matrix is [`BandedLu`]'s, operation for
/// operation: the factors and solutions are the same to the last bit.
#[derive(Clone, Debug)]
pub struct BandedLuBatch {
    n: usize,
    kl: usize,
    ku: usize,
    lanes: usize,
    re: Vec<f64>,
    im: Vec<f64>,
    /// The row interchanged with row `j` of matrix `m`, at `j · lanes + m`.
    pivots: Vec<usize>,
    inverse_re: Vec<f64>,
    inverse_im: Vec<f64>,
    singular: Vec<bool>,
}

impl BandedLuBatch {
    /// Storage for `lanes` matrices `n × n` with `kl` sub- and `ku` superdiagonals.
    pub fn new(n: usize, kl: usize, ku: usize, lanes: usize) -> Self {
        let values = BandedLu::values(n, kl, ku) * lanes;
        BandedLuBatch {
            n,
            kl,
            ku,
            lanes,
            re: vec![0.0; values],
            im: vec![0.0; values],
            pivots: vec![0; n * lanes],
            inverse_re: vec![0.0; n * lanes],
            inverse_im: vec![0.0; n * lanes],
            singular: vec![false; lanes],
        }
    }

    /// The number of matrices.
    pub fn lanes(&self) -> usize {
        self.lanes
    }

    /// Whether the batch has these sizes.
    pub fn fits(&self, n: usize, kl: usize, ku: usize, lanes: usize) -> bool {
        (self.n, self.kl, self.ku, self.lanes) == (n, kl, ku, lanes)
    }

    fn leading(&self) -> usize {
        2 * self.kl + self.ku + 1
    }

    /// Factor the dynamic stiffnesses `A_m = K − Ω_m² M + iΩ_m C` (docs/theory.md (T13)) at
    /// the frequencies `frequencies[m]` (one per matrix), with the entries `stiffness[e]`,
    /// `mass[e]`, `damping[e]` at the storage positions `positions[e]`
    /// ([`BandedLu::position`]). `false` when any is singular (its solutions are then not
    /// finite).
    pub fn factor_dynamic_stiffness(
        &mut self,
        positions: &[usize],
        stiffness: &[f64],
        mass: &[f64],
        damping: &[f64],
        frequencies: &[f64],
    ) -> bool {
        let (n, kl, ku, lanes) = (self.n, self.kl, self.ku, self.lanes);
        assert_eq!(frequencies.len(), lanes, "one frequency per matrix");
        let leading = self.leading();
        let kv = kl + ku;
        let along_row = leading - 1;
        self.re.fill(0.0);
        self.im.fill(0.0);
        let squares: Vec<f64> = frequencies.iter().map(|w| w * w).collect();
        for (e, &p) in positions.iter().enumerate() {
            let (k, m, c) = (stiffness[e], mass[e], damping[e]);
            let at = p * lanes;
            for (re, w2) in self.re[at..at + lanes].iter_mut().zip(&squares) {
                *re += k - w2 * m;
            }
            for (im, w) in self.im[at..at + lanes].iter_mut().zip(frequencies) {
                *im += w * c;
            }
        }
        self.singular.fill(false);
        let mut reach = vec![0usize; lanes];
        let mut largest = vec![0.0f64; lanes];
        let mut pivot_row = vec![0usize; lanes];
        let (mut multipliers_re, mut multipliers_im) = (Vec::new(), Vec::new());
        let (mut f_re, mut f_im) = (Vec::new(), Vec::new());
        for j in 0..n {
            let km = kl.min(n - 1 - j);
            let diagonal = kv + j * leading;
            // the pivot of each matrix: the largest |Re| + |Im| on and below the diagonal
            largest.fill(-1.0);
            pivot_row.fill(0);
            for r in 0..=km {
                let at = (diagonal + r) * lanes;
                let (re, im) = (&self.re[at..at + lanes], &self.im[at..at + lanes]);
                for (((l, p), x), y) in largest.iter_mut().zip(&mut pivot_row).zip(re).zip(im) {
                    let size = x.abs() + y.abs();
                    let better = size > *l;
                    *l = if better { size } else { *l };
                    *p = if better { r } else { *p };
                }
            }
            let mut ju = 0;
            for m in 0..lanes {
                let p = pivot_row[m];
                self.pivots[j * lanes + m] = j + p;
                // a zero pivot makes this matrix's factors (and solutions) not finite
                self.singular[m] |= largest[m] == 0.0 || !largest[m].is_finite();
                reach[m] = reach[m].max((j + ku + p).min(n - 1));
                ju = ju.max(reach[m]);
            }
            // the row interchanges, as selects across the matrices (beyond a matrix's own
            // reach both rows are zero)
            for r in 1..=km {
                let mut at = diagonal;
                for _ in j..=ju {
                    let (upper, lower) = (at * lanes, (at + r) * lanes);
                    for part in [&mut self.re, &mut self.im] {
                        let (head, tail) = part.split_at_mut(lower);
                        let rows = head[upper..upper + lanes]
                            .iter_mut()
                            .zip(&mut tail[..lanes]);
                        for ((x, y), &p) in rows.zip(&pivot_row) {
                            let swap = p == r;
                            let (a, b) = (*x, *y);
                            *x = if swap { b } else { a };
                            *y = if swap { a } else { b };
                        }
                    }
                    at += along_row;
                }
            }
            {
                let at = diagonal * lanes;
                let inverse = self.inverse_re[j * lanes..(j + 1) * lanes]
                    .iter_mut()
                    .zip(&mut self.inverse_im[j * lanes..(j + 1) * lanes]);
                let pivots = self.re[at..at + lanes].iter().zip(&self.im[at..at + lanes]);
                for ((ir, ii), (pr, pi)) in inverse.zip(pivots) {
                    let scale = 1.0 / (pr * pr + pi * pi);
                    *ir = pr * scale;
                    *ii = -pi * scale;
                }
            }
            if km == 0 {
                continue;
            }
            let (inverse_re, inverse_im) = (
                &self.inverse_re[j * lanes..(j + 1) * lanes],
                &self.inverse_im[j * lanes..(j + 1) * lanes],
            );
            // the multipliers: column j below the diagonal times the pivot's inverse
            for r in 1..=km {
                let at = (diagonal + r) * lanes;
                let (re, im) = (&mut self.re[at..at + lanes], &mut self.im[at..at + lanes]);
                for (((lr, li), ir), ii) in re.iter_mut().zip(im).zip(inverse_re).zip(inverse_im) {
                    let (a, b) = (*lr, *li);
                    *lr = a * ir - b * ii;
                    *li = a * ii + b * ir;
                }
            }
            // the rank-one update of the rows below j, columns j + 1..=ju (for a matrix
            // whose reach is shorter, its row j is zero beyond it: nothing changes)
            // (the multipliers are copied once per column: they and the targets share storage)
            multipliers_re.clear();
            multipliers_im.clear();
            for r in 1..=km {
                let at = (diagonal + r) * lanes;
                multipliers_re.extend_from_slice(&self.re[at..at + lanes]);
                multipliers_im.extend_from_slice(&self.im[at..at + lanes]);
            }
            let mut at = diagonal + along_row;
            for _ in j + 1..=ju {
                let source = at * lanes;
                f_re.clear();
                f_im.clear();
                f_re.extend_from_slice(&self.re[source..source + lanes]);
                f_im.extend_from_slice(&self.im[source..source + lanes]);
                for r in 1..=km {
                    let target = (at + r) * lanes;
                    let (lr, li) = (
                        &multipliers_re[(r - 1) * lanes..r * lanes],
                        &multipliers_im[(r - 1) * lanes..r * lanes],
                    );
                    let targets = self.re[target..target + lanes]
                        .iter_mut()
                        .zip(&mut self.im[target..target + lanes]);
                    for ((((tr, ti), fr), fi), (lr, li)) in
                        targets.zip(&f_re).zip(&f_im).zip(lr.iter().zip(li))
                    {
                        *tr -= lr * fr - li * fi;
                        *ti -= lr * fi + li * fr;
                    }
                }
                at += along_row;
            }
        }
        !self.singular.iter().any(|&s| s)
    }

    /// Solve `A_m x = b` in place for each `(m, b)` of `systems`, column by column across
    /// them.
    pub fn solve_batch(&self, systems: &mut [(usize, &mut [c64])]) {
        let (n, kl, lanes) = (self.n, self.kl, self.lanes);
        let kv = kl + self.ku;
        let leading = self.leading();
        let entry = |position: usize, m: usize| {
            c64::new(self.re[position * lanes + m], self.im[position * lanes + m])
        };
        for j in 0..n {
            let below = kl.min(n - 1 - j);
            for (m, b) in systems.iter_mut() {
                let l = self.pivots[j * lanes + *m];
                if l != j {
                    b.swap(l, j);
                }
                let bj = b[j];
                for r in 1..=below {
                    b[j + r] -= entry(kv + r + j * leading, *m) * bj;
                }
            }
        }
        for j in (0..n).rev() {
            let first = j.saturating_sub(kv);
            let base = kv + first + j * leading - j;
            for (m, b) in systems.iter_mut() {
                let inverse = c64::new(
                    self.inverse_re[j * lanes + *m],
                    self.inverse_im[j * lanes + *m],
                );
                b[j] *= inverse;
                let bj = b[j];
                for (i, bi) in b[first..j].iter_mut().enumerate() {
                    *bi -= entry(base + i, *m) * bj;
                }
            }
        }
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

    /// The batch factorization and solves give each matrix's own factors and solutions,
    /// to the last bit.
    #[test]
    fn a_batch_factors_and_solves_each_matrix_as_alone() {
        for (n, kl, ku) in [(20, 2, 1), (15, 1, 1), (9, 0, 2)] {
            let entries: Vec<(usize, usize)> = (0..n)
                .flat_map(|j| (0..n).map(move |i| (i, j)))
                .filter(|&(i, j)| i + ku >= j && j + kl >= i)
                .collect();
            let positions: Vec<usize> = entries
                .iter()
                .map(|&(i, j)| BandedLu::position(kl, ku, i, j))
                .collect();
            let part = |e: usize, s: f64| {
                let (i, j) = entries[e];
                (s * (i + 2 * j) as f64 + 0.1 * (i * j) as f64).sin()
            };
            let stiffness: Vec<f64> = (0..entries.len()).map(|e| 3.0 + part(e, 0.7)).collect();
            let mass: Vec<f64> = (0..entries.len()).map(|e| part(e, 0.3)).collect();
            let damping: Vec<f64> = (0..entries.len()).map(|e| 0.2 * part(e, 1.1)).collect();
            let lanes = 5;
            let frequencies: Vec<f64> = (0..lanes).map(|m| 0.9 * m as f64).collect();
            let value = |m: usize, e: usize| {
                let w = frequencies[m];
                c64::new(stiffness[e] - w * w * mass[e], w * damping[e])
            };
            let mut batch = BandedLuBatch::new(n, kl, ku, lanes);
            assert!(batch.factor_dynamic_stiffness(
                &positions,
                &stiffness,
                &mass,
                &damping,
                &frequencies
            ));
            let rhs = |m: usize| -> Vec<c64> {
                (0..n)
                    .map(|i| c64::new(1.0 + (i + m) as f64, -0.5 * i as f64))
                    .collect()
            };
            let mut solved: Vec<Vec<c64>> = (0..lanes).map(rhs).collect();
            let mut systems: Vec<(usize, &mut [c64])> = solved
                .iter_mut()
                .enumerate()
                .map(|(m, b)| (m, b.as_mut_slice()))
                .collect();
            batch.solve_batch(&mut systems);
            for (m, solution) in solved.iter().enumerate() {
                let mut alone = BandedLu::new(n, kl, ku);
                assert!(alone.factor(&positions, |e| value(m, e)));
                let mut x = rhs(m);
                alone.solve_in_place(&mut x);
                assert_eq!(&x, solution, "n = {n}, kl = {kl}, ku = {ku}, matrix {m}");
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
