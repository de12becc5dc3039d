//! LU factorization with partial pivoting of complex band matrices (the algorithm of
//! LAPACK's `zgbtf2`/`zgbtrs`; docs/theory.md (T138)), for the dynamic stiffness `A_k(ω)`
//! of a structure whose DOFs are numbered along it (a bar, a beam, a chain): `kl` sub- and
//! `ku` superdiagonals cost `O(n kl (kl + ku))` per factorization and `O(n (2kl + ku))` per
//! solve, with no symbolic phase and no allocation once the storage exists. The matrices of
//! all harmonics are factored together ([`BandedLu`]).
//!
//! Storage: column `j` of `A` holds rows `j − ku − kl ..= j + kl` (the `kl` extra rows above
//! take the fill-in of the row interchanges); entry `(i, j)` is at [`band_position`]
//! `= (kl + ku + i − j) + j · (2kl + ku + 1)`.

use faer::c64;

/// The storage position of entry `(i, j)` of a matrix with `kl` sub- and `ku`
/// superdiagonals (within the band: `i + ku ≥ j`, `j + kl ≥ i`), for
/// [`BandedLu::factor_dynamic_stiffness`].
pub fn band_position(kl: usize, ku: usize, i: usize, j: usize) -> usize {
    assert!(i + ku >= j && j + kl >= i, "({i}, {j}) outside the band");
    (kl + ku + i - j) + j * (2 * kl + ku + 1)
}

/// The LU factors of `lanes` band matrices of the same sizes (the dynamic stiffness of each
/// harmonic), stored side by side: entry `(i, j)` of matrix `m` at
/// `band_position(i, j) · lanes + m`, real and imaginary parts apart. Each step of the
/// elimination is done for every matrix in one pass over contiguous numbers: one matrix's
/// elimination is a chain of dependent divisions and products, and the processor works on
/// the matrices' independent chains together (and in vector registers).
#[derive(Clone, Debug)]
pub struct BandedLu {
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
    /// The factorization's working vectors, kept so that factoring again allocates nothing.
    scratch: FactorScratch,
}

/// Working vectors of [`BandedLu::factor_dynamic_stiffness`] (per matrix, and one column's
/// multipliers and source row).
#[derive(Clone, Debug, Default)]
struct FactorScratch {
    squares: Vec<f64>,
    reach: Vec<usize>,
    largest: Vec<f64>,
    pivot_row: Vec<usize>,
    multipliers_re: Vec<f64>,
    multipliers_im: Vec<f64>,
    f_re: Vec<f64>,
    f_im: Vec<f64>,
}

impl BandedLu {
    /// Storage for `lanes` matrices `n × n` with `kl` sub- and `ku` superdiagonals.
    pub fn new(n: usize, kl: usize, ku: usize, lanes: usize) -> Self {
        let values = n * (2 * kl + ku + 1) * lanes;
        BandedLu {
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
            scratch: FactorScratch::default(),
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
    /// ([`band_position`]). `false` when any is singular (its solutions are then not
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
        let mut scratch = std::mem::take(&mut self.scratch);
        let FactorScratch {
            squares,
            reach,
            largest,
            pivot_row,
            multipliers_re,
            multipliers_im,
            f_re,
            f_im,
        } = &mut scratch;
        squares.clear();
        squares.extend(frequencies.iter().map(|w| w * w));
        for (e, &p) in positions.iter().enumerate() {
            let (k, m, c) = (stiffness[e], mass[e], damping[e]);
            let at = p * lanes;
            for (re, w2) in self.re[at..at + lanes].iter_mut().zip(squares.iter()) {
                *re += k - w2 * m;
            }
            for (im, w) in self.im[at..at + lanes].iter_mut().zip(frequencies) {
                *im += w * c;
            }
        }
        self.singular.fill(false);
        reach.clear();
        reach.resize(lanes, 0);
        largest.clear();
        largest.resize(lanes, 0.0);
        pivot_row.clear();
        pivot_row.resize(lanes, 0);
        for j in 0..n {
            let km = kl.min(n - 1 - j);
            let diagonal = kv + j * leading;
            // the pivot of each matrix: the largest |Re| + |Im| on and below the diagonal
            largest.fill(-1.0);
            pivot_row.fill(0);
            for r in 0..=km {
                let at = (diagonal + r) * lanes;
                let (re, im) = (&self.re[at..at + lanes], &self.im[at..at + lanes]);
                for (((l, p), x), y) in largest.iter_mut().zip(pivot_row.iter_mut()).zip(re).zip(im)
                {
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
                        for ((x, y), &p) in rows.zip(pivot_row.iter()) {
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
                    for ((((tr, ti), fr), fi), (lr, li)) in targets
                        .zip(f_re.iter())
                        .zip(f_im.iter())
                        .zip(lr.iter().zip(li))
                    {
                        *tr -= lr * fr - li * fi;
                        *ti -= lr * fi + li * fr;
                    }
                }
                at += along_row;
            }
        }
        self.scratch = scratch;
        !self.singular.iter().any(|&s| s)
    }

    /// Solve `A_m x = b` in place for each `(m, b)` of `systems`, column by column across
    /// them.
    pub fn solve_batch(&self, systems: &mut [(usize, &mut [c64])]) {
        self.solve_systems(systems);
    }

    /// [`BandedLu::solve_batch`] for any collection of right-hand sides.
    pub fn solve_systems<S: BatchSystems + ?Sized>(&self, systems: &mut S) {
        let (n, kl, lanes) = (self.n, self.kl, self.lanes);
        let kv = kl + self.ku;
        let leading = self.leading();
        let entry = |position: usize, m: usize| {
            c64::new(self.re[position * lanes + m], self.im[position * lanes + m])
        };
        for j in 0..n {
            let below = kl.min(n - 1 - j);
            for s in 0..systems.count() {
                let m = systems.matrix(s);
                let b = systems.column(s);
                let l = self.pivots[j * lanes + m];
                if l != j {
                    b.swap(l, j);
                }
                let bj = b[j];
                for r in 1..=below {
                    b[j + r] -= entry(kv + r + j * leading, m) * bj;
                }
            }
        }
        for j in (0..n).rev() {
            let first = j.saturating_sub(kv);
            let base = kv + first + j * leading - j;
            for s in 0..systems.count() {
                let m = systems.matrix(s);
                let b = systems.column(s);
                let inverse = c64::new(
                    self.inverse_re[j * lanes + m],
                    self.inverse_im[j * lanes + m],
                );
                b[j] *= inverse;
                let bj = b[j];
                for (i, bi) in b[first..j].iter_mut().enumerate() {
                    *bi -= entry(base + i, m) * bj;
                }
            }
        }
    }
}

/// Right-hand sides that a batch of factored matrices solves in place
/// ([`BandedLu::solve_systems`]): each a column and the matrix it belongs to.
pub trait BatchSystems {
    /// Number of right-hand sides.
    fn count(&self) -> usize;
    /// The matrix of right-hand side `s`.
    fn matrix(&self, s: usize) -> usize;
    /// Right-hand side `s`.
    fn column(&mut self, s: usize) -> &mut [c64];
    /// The right-hand sides `s .. s + count` as one column-major block, where they belong to
    /// one matrix and lie next to each other in memory (sparse factors then solve them
    /// together, by matrix products instead of one product with a vector per column);
    /// `None` (the default) solves them one by one.
    fn block(&mut self, s: usize, count: usize) -> Option<&mut [c64]> {
        let _ = (s, count);
        None
    }
}

impl BatchSystems for [(usize, &mut [c64])] {
    fn count(&self) -> usize {
        self.len()
    }

    fn matrix(&self, s: usize) -> usize {
        self[s].0
    }

    fn column(&mut self, s: usize) -> &mut [c64] {
        self[s].1
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

    /// Band matrices `K − Ω² M + iΩ C` with small diagonals (so that pivoting happens),
    /// several frequencies at once, against faer's dense LU of each: the solutions agree to
    /// round-off.
    #[test]
    fn the_band_solutions_are_the_dense_solutions() {
        for (n, kl, ku) in [(1, 0, 0), (7, 1, 1), (30, 2, 3), (25, 4, 1), (12, 0, 2)] {
            let entries: Vec<(usize, usize)> = (0..n)
                .flat_map(|j| (0..n).map(move |i| (i, j)))
                .filter(|&(i, j)| i + ku >= j && j + kl >= i)
                .collect();
            let positions: Vec<usize> = entries
                .iter()
                .map(|&(i, j)| band_position(kl, ku, i, j))
                .collect();
            let part = |e: usize, s: f64| {
                let (i, j) = entries[e];
                let diagonal = if i == j { 0.05 } else { 0.0 };
                (s * (i + 2 * j) as f64 + 0.1 * (i * j) as f64).sin() + diagonal
            };
            let stiffness: Vec<f64> = (0..entries.len()).map(|e| part(e, 0.7)).collect();
            let mass: Vec<f64> = (0..entries.len()).map(|e| part(e, 0.3)).collect();
            let damping: Vec<f64> = (0..entries.len()).map(|e| 0.2 * part(e, 1.1)).collect();
            let lanes = 5;
            let frequencies: Vec<f64> = (0..lanes).map(|m| 0.9 * m as f64).collect();
            let mut lu = BandedLu::new(n, kl, ku, lanes);
            assert!(lu.factor_dynamic_stiffness(
                &positions,
                &stiffness,
                &mass,
                &damping,
                &frequencies
            ));
            let rhs = |m: usize| -> Vec<c64> {
                (0..n)
                    .map(|i| c64::new((0.3 * (i + m) as f64).cos(), 1.0 - 0.1 * i as f64))
                    .collect()
            };
            let mut solved: Vec<Vec<c64>> = (0..lanes).map(rhs).collect();
            let mut systems: Vec<(usize, &mut [c64])> = solved
                .iter_mut()
                .enumerate()
                .map(|(m, b)| (m, b.as_mut_slice()))
                .collect();
            lu.solve_batch(&mut systems);
            for (m, x) in solved.iter().enumerate() {
                let w = frequencies[m];
                let mut dense = Mat::<c64>::zeros(n, n);
                for (e, &(i, j)) in entries.iter().enumerate() {
                    dense[(i, j)] += c64::new(stiffness[e] - w * w * mass[e], w * damping[e]);
                }
                let b = rhs(m);
                let exact = dense
                    .partial_piv_lu()
                    .solve(Mat::<c64>::from_fn(n, 1, |i, _| b[i]));
                let size = (0..n).map(|i| exact[(i, 0)].norm()).fold(0.0, f64::max);
                for i in 0..n {
                    assert!(
                        (x[i] - exact[(i, 0)]).norm() <= 1e-12 * size,
                        "n = {n}, kl = {kl}, ku = {ku}, matrix {m}, row {i}: {:?} vs {:?}",
                        x[i],
                        exact[(i, 0)]
                    );
                }
            }
        }
    }

    /// A matrix with a zero column is reported singular, and its solutions are not finite;
    /// the other matrices of the batch are unaffected.
    #[test]
    fn a_zero_column_is_singular() {
        // K = diag(1, 0, 1), no mass or damping on the second DOF: singular at every
        // frequency; the second matrix has K = diag(1, 1, 1)
        let positions = [
            band_position(1, 1, 0, 0),
            band_position(1, 1, 1, 1),
            band_position(1, 1, 2, 2),
        ];
        let mut lu = BandedLu::new(3, 1, 1, 1);
        assert!(!lu.factor_dynamic_stiffness(
            &positions,
            &[1.0, 0.0, 1.0],
            &[0.0; 3],
            &[0.0; 3],
            &[1.0]
        ));
        let mut b = vec![c64::new(1.0, 0.0); 3];
        lu.solve_batch(&mut [(0, b.as_mut_slice())]);
        assert!(b.iter().any(|v| !v.re.is_finite()), "{b:?}");
        let mut regular = BandedLu::new(3, 1, 1, 1);
        assert!(regular.factor_dynamic_stiffness(
            &positions,
            &[1.0; 3],
            &[0.0; 3],
            &[0.0; 3],
            &[1.0]
        ));
    }

    #[test]
    fn bandwidths_of_a_tridiagonal_pattern() {
        let entries = (0..5).flat_map(|i| [(i, i), (i + 1, i), (i, i + 1)]);
        assert_eq!(bandwidths(entries), (1, 1));
    }
}
