//! Floquet multipliers of piecewise-constant linear systems `ż = 𝔄_{g(t)} z`, the
//! variational equation of the redistributed MS-HBM (docs/theory.md (T80), (T81)), from
//! real modal forms of the recurring system matrices (docs/theory.md (T141)).
//!
//! Along a frequency response diagram the same few matrices `𝔄_g` (one per active set)
//! recur at every point with new interval lengths. Each is brought once to its real modal
//! form `𝔄 = V B V⁻¹` (`B` block diagonal with 1 × 1 and 2 × 2 blocks), and each ordered
//! pair of consecutive systems once to its transfer `T_{g←h} = V_g⁻¹ V_h`. The monodromy
//! is then similar to the cyclic product `T_{g_1←g_p} e^{B_p Δt_p} ⋯ T_{g_2←g_1} e^{B_1 Δt_1}`,
//! whose exponentials are block diagonal: a point costs `p − 1` real matrix products and one
//! real eigenvalue problem.

use std::collections::HashMap;

use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatMut};

use crate::dense::sequential_product;
use crate::error::Result;

/// Monodromy of `ż = A_i z` over consecutive intervals of lengths `Δt_i` (seconds):
/// `Φ = exp(A_m Δt_m) ⋯ exp(A_1 Δt_1)` (docs/theory.md (T81)). Exact for piecewise-constant
/// systems; the reference of [`PiecewiseLinearSystems`] and its fallback.
pub fn piecewise_monodromy(pieces: &[(&Mat<f64>, f64)]) -> Mat<f64> {
    let n = pieces.first().map_or(0, |(a, _)| a.nrows());
    let mut phi = Mat::<f64>::identity(n, n);
    for (a, dt) in pieces {
        let step = crate::dense::expm(&(*a * *dt));
        phi = &step * &phi;
    }
    phi
}

/// One diagonal block of a real modal form.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ModalBlock {
    /// A real eigenvalue (one column).
    Real(f64),
    /// The pair `re ± i·im` (`im > 0`), two columns `(p, q)` with `𝔄 (p + iq) = (re + i·im)(p + iq)`,
    /// block `[[re, im], [−im, re]]`.
    Pair { re: f64, im: f64 },
}

/// The real modal form `𝔄 = V B V⁻¹` of a real square matrix (docs/theory.md (T141)).
#[derive(Clone, Debug)]
pub struct RealModalForm {
    v: Mat<f64>,
    v_inv: Mat<f64>,
    blocks: Vec<ModalBlock>,
}

impl RealModalForm {
    /// The form of `a`; `None` when its eigenvectors are too ill-conditioned to reproduce
    /// `a` to `1e-10` relative (defective or nearly defective matrices).
    pub fn new(a: &Mat<f64>) -> Option<Self> {
        let n = a.nrows();
        let (s, u) = crate::dense::eigen(a.as_ref()).ok()?;
        let scale = (0..n).fold(0.0f64, |m, i| m.max(s[i].norm()));
        let is_real = |l: c64| l.im.abs() <= 1e-13 * scale;
        let mut v = Mat::<f64>::zeros(n, n);
        let mut blocks = Vec::with_capacity(n);
        let mut col = 0;
        for k in 0..n {
            let l = s[k];
            if is_real(l) {
                // the eigenvector of a real eigenvalue is real up to a phase: rotate its
                // largest entry onto the real axis
                let big = (0..n).fold(0, |b, i| {
                    if u[(i, k)].norm() > u[(b, k)].norm() {
                        i
                    } else {
                        b
                    }
                });
                let phase = u[(big, k)].conj() / u[(big, k)].norm();
                if col >= n {
                    return None;
                }
                for i in 0..n {
                    v[(i, col)] = (u[(i, k)] * phase).re;
                }
                blocks.push(ModalBlock::Real(l.re));
                col += 1;
            } else if l.im > 0.0 {
                if col + 2 > n {
                    return None;
                }
                for i in 0..n {
                    v[(i, col)] = u[(i, k)].re;
                    v[(i, col + 1)] = u[(i, k)].im;
                }
                blocks.push(ModalBlock::Pair { re: l.re, im: l.im });
                col += 2;
            }
        }
        if col != n {
            return None;
        }
        let v_inv = v.partial_piv_lu().solve(Mat::<f64>::identity(n, n));
        let form = RealModalForm { v, v_inv, blocks };
        // V B V⁻¹ must give back a
        let mut vb = form.v.clone();
        form.scale_columns(vb.as_mut(), |block| match block {
            ModalBlock::Real(re) => (re, 0.0),
            ModalBlock::Pair { re, im } => (re, im),
        });
        let back = &vb * &form.v_inv;
        let norm = (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max(a[(i, j)].abs()));
        let err = (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .fold(0.0f64, |m, (i, j)| m.max((back[(i, j)] - a[(i, j)]).abs()));
        (err.is_finite() && err <= 1e-10 * norm.max(f64::MIN_POSITIVE)).then_some(form)
    }

    /// `X ← X C` with `C` block diagonal, each block given by `coefficients(block) = (c, s)`:
    /// `[[c, s], [−s, c]]` for a pair, `c` for a real eigenvalue.
    fn scale_columns(&self, mut x: MatMut<f64>, coefficients: impl Fn(ModalBlock) -> (f64, f64)) {
        let mut col = 0;
        for &block in &self.blocks {
            let (c, s) = coefficients(block);
            match block {
                ModalBlock::Real(_) => {
                    for i in 0..x.nrows() {
                        x[(i, col)] *= c;
                    }
                    col += 1;
                }
                ModalBlock::Pair { .. } => {
                    for i in 0..x.nrows() {
                        let (p, q) = (x[(i, col)], x[(i, col + 1)]);
                        x[(i, col)] = c * p - s * q;
                        x[(i, col + 1)] = s * p + c * q;
                    }
                    col += 2;
                }
            }
        }
    }

    /// `X ← e^{B t} X` (rows by blocks).
    /// `V`.
    pub(crate) fn v(&self) -> &Mat<f64> {
        &self.v
    }

    /// `V⁻¹`.
    pub(crate) fn v_inv(&self) -> &Mat<f64> {
        &self.v_inv
    }

    /// `X ← (e^{B t} − I) B⁻¹ X` (the integral `∫₀ᵗ e^{B s} ds`, also where `B` is
    /// singular), the response to a constant forcing held over `t` (docs/theory.md (T182)).
    pub(crate) fn integral_times(&self, t: f64, mut x: MatMut<f64>) {
        // (e^{z t} − 1)/z for z = re + i·im, by its series where z t is small
        let phi = |z: c64| -> c64 {
            let w = z * t;
            if w.norm() < 1e-4 {
                c64::new(t, 0.0) * (c64::new(1.0, 0.0) + w / 2.0 + w * w / 6.0 + w * w * w / 24.0)
            } else {
                (w.exp() - c64::new(1.0, 0.0)) / z
            }
        };
        let mut row = 0;
        for &block in &self.blocks {
            match block {
                ModalBlock::Real(re) => {
                    let e = phi(c64::new(re, 0.0)).re;
                    for j in 0..x.ncols() {
                        x[(row, j)] *= e;
                    }
                    row += 1;
                }
                ModalBlock::Pair { re, im } => {
                    let z = phi(c64::new(re, im));
                    let (c, s) = (z.re, z.im);
                    for j in 0..x.ncols() {
                        let (p, q) = (x[(row, j)], x[(row + 1, j)]);
                        x[(row, j)] = c * p + s * q;
                        x[(row + 1, j)] = -s * p + c * q;
                    }
                    row += 2;
                }
            }
        }
    }

    pub(crate) fn exp_times(&self, t: f64, mut x: MatMut<f64>) {
        let mut row = 0;
        for &block in &self.blocks {
            match block {
                ModalBlock::Real(re) => {
                    let e = (re * t).exp();
                    for j in 0..x.ncols() {
                        x[(row, j)] *= e;
                    }
                    row += 1;
                }
                ModalBlock::Pair { re, im } => {
                    let e = (re * t).exp();
                    let (s, c) = (im * t).sin_cos();
                    let (c, s) = (e * c, e * s);
                    for j in 0..x.ncols() {
                        let (p, q) = (x[(row, j)], x[(row + 1, j)]);
                        x[(row, j)] = c * p + s * q;
                        x[(row + 1, j)] = -s * p + c * q;
                    }
                    row += 2;
                }
            }
        }
    }

    /// The eigenvalues `e^{λ t}` of `e^{𝔄 t}`.
    fn exp_eigenvalues(&self, t: f64) -> Vec<c64> {
        let mut out = Vec::with_capacity(self.v.nrows());
        for &block in &self.blocks {
            match block {
                ModalBlock::Real(re) => out.push(c64::new((re * t).exp(), 0.0)),
                ModalBlock::Pair { re, im } => {
                    let z = (c64::new(re, im) * t).exp();
                    out.push(z);
                    out.push(z.conj());
                }
            }
        }
        out
    }
}

/// The system matrices of a piecewise-constant linear system that recur along a diagram,
/// one per active set (a set of closed contacts), with their real modal forms and the
/// transfers between them, for the multipliers of many interval sequences
/// (docs/theory.md (T141)).
#[derive(Clone, Debug, Default)]
pub struct PiecewiseLinearSystems {
    systems: Vec<(Mat<f64>, Option<RealModalForm>)>,
    /// Index into `systems` by active set.
    by_set: HashMap<Vec<bool>, usize>,
    /// `V_g⁻¹ V_h` by `(g, h)`.
    transfers: HashMap<(usize, usize), Mat<f64>>,
}

impl PiecewiseLinearSystems {
    /// No systems yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The index of the system matrix `𝔄` of the active set `set`, built by `matrix` (all
    /// of the same size) the first time the set is met.
    pub fn index_of(
        &mut self,
        set: &[bool],
        matrix: impl FnOnce() -> Result<Mat<f64>>,
    ) -> Result<usize> {
        if let Some(&index) = self.by_set.get(set) {
            return Ok(index);
        }
        let a = matrix()?;
        let modal = RealModalForm::new(&a);
        self.systems.push((a, modal));
        let index = self.systems.len() - 1;
        self.by_set.insert(set.to_vec(), index);
        Ok(index)
    }

    /// The Floquet multipliers of `ż = 𝔄_{g_s} z` on consecutive intervals `(g_s, Δt_s)`
    /// (time order, lengths in seconds, the sequence covering one period): the eigenvalues
    /// of the monodromy (T81), from the cyclic modal product (T141), or from dense
    /// exponentials when a system has no well-conditioned modal form. A multiplier that is
    /// not finite (an exponential that overflowed) is an error: the stability is unknown,
    /// not "unstable with modulus inf".
    pub fn multipliers(&mut self, pieces: &[(usize, f64)]) -> Result<Vec<c64>> {
        let values = self.multipliers_unchecked(pieces)?;
        if values.iter().all(|v| v.re.is_finite() && v.im.is_finite()) {
            Ok(values)
        } else {
            Err(crate::error::Error::Numerical(
                "Floquet multipliers: the monodromy over one period is not finite (an exponential overflowed)".into(),
            ))
        }
    }

    fn multipliers_unchecked(&mut self, pieces: &[(usize, f64)]) -> Result<Vec<c64>> {
        let pieces = merged_cycle(pieces);
        let eigenvalues = |m: Mat<f64>| crate::dense::eigenvalues(m.as_ref());
        if pieces.iter().any(|&(g, _)| self.systems[g].1.is_none()) {
            let dense: Vec<(&Mat<f64>, f64)> = pieces
                .iter()
                .map(|&(g, dt)| (&self.systems[g].0, dt))
                .collect();
            return eigenvalues(piecewise_monodromy(&dense));
        }
        let form = |g: usize| self.systems[g].1.as_ref().expect("checked above");
        match pieces.as_slice() {
            [] => Ok(Vec::new()),
            &[(g, dt)] => Ok(form(g).exp_eigenvalues(dt)),
            _ => {
                let p = pieces.len();
                for s in 0..p {
                    let (h, g) = (pieces[s].0, pieces[(s + 1) % p].0);
                    self.transfers.entry((g, h)).or_insert_with(|| {
                        sequential_product(form(g).v_inv.as_ref(), form(h).v.as_ref())
                    });
                }
                // P = T_{g_2←g_1} e^{B_1 Δt_1}, then e^{B_s Δt_s} and T_{g_{s+1}←g_s} in turn
                let (g1, dt1) = pieces[0];
                let mut product = self.transfers[&(pieces[1].0, g1)].clone();
                form(g1).scale_columns(product.as_mut(), |block| exp_block(block, dt1));
                for s in 1..p {
                    let (g, dt) = pieces[s];
                    form(g).exp_times(dt, product.as_mut());
                    product = sequential_product(
                        self.transfers[&(pieces[(s + 1) % p].0, g)].as_ref(),
                        product.as_ref(),
                    );
                }
                eigenvalues(product)
            }
        }
    }
}

/// `(c, s)` of the block of `e^{B t}`: `e^{re t}(cos im t, sin im t)`, `(e^{re t}, 0)` when real.
fn exp_block(block: ModalBlock, t: f64) -> (f64, f64) {
    match block {
        ModalBlock::Real(re) => ((re * t).exp(), 0.0),
        ModalBlock::Pair { re, im } => {
            let e = (re * t).exp();
            let (s, c) = (im * t).sin_cos();
            (e * c, e * s)
        }
    }
}

/// The intervals with consecutive equal systems joined, also across the end of the period
/// (the monodromy's eigenvalues do not depend on where the period starts); empty intervals
/// dropped.
fn merged_cycle(pieces: &[(usize, f64)]) -> Vec<(usize, f64)> {
    let mut out: Vec<(usize, f64)> = Vec::with_capacity(pieces.len());
    for &(g, dt) in pieces.iter().filter(|(_, dt)| *dt > 0.0) {
        match out.last_mut() {
            Some(last) if last.0 == g => last.1 += dt,
            _ => out.push((g, dt)),
        }
    }
    if out.len() > 1 && out[0].0 == out[out.len() - 1].0 {
        let (_, dt) = out.pop().expect("len > 1");
        out[0].1 += dt;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// First-order matrix of a 3-mass chain `ẍ + c ẋ + K x = 0` with the first spring
    /// `k1` (the "active set").
    fn chain(k1: f64, c: f64) -> Mat<f64> {
        let k = [[k1 + 2.0, -2.0, 0.0], [-2.0, 5.0, -3.0], [0.0, -3.0, 3.5]];
        Mat::from_fn(6, 6, |i, j| match (i < 3, j < 3) {
            (true, true) => 0.0,
            (true, false) => f64::from(u8::from(j - 3 == i)),
            (false, true) => -k[i - 3][j],
            (false, false) => -c * f64::from(u8::from(i == j)),
        })
    }

    fn sorted(mut values: Vec<c64>) -> Vec<c64> {
        values.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
        values
    }

    /// Largest distance from each of `values` to the nearest of `reference`.
    fn distance(values: &[c64], reference: &[c64]) -> f64 {
        values
            .iter()
            .map(|v| {
                reference
                    .iter()
                    .map(|r| (v - r).norm())
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn cyclic_modal_product_has_the_eigenvalues_of_the_monodromy_of_dense_exponentials() {
        let (open, closed, stiff) = (chain(0.0, 0.05), chain(4.0, 0.05), chain(30.0, 0.05));
        let mut systems = PiecewiseLinearSystems::new();
        // three active sets, one matrix each
        let sets = [[false, false], [true, false], [true, true]];
        let ids = [&open, &closed, &stiff]
            .iter()
            .zip(&sets)
            .map(|(a, set)| systems.index_of(set, || Ok((*a).clone())).unwrap())
            .collect::<Vec<_>>();
        // a set met again is not built again
        assert_eq!(
            systems.index_of(&sets[1], || unreachable!()).unwrap(),
            ids[1]
        );
        let matrices = [&open, &closed, &stiff];
        assert!(
            systems.systems.iter().all(|(_, form)| form.is_some()),
            "the modal path is tested"
        );
        for pieces in [
            vec![(0, 0.7), (1, 0.4)],
            vec![(1, 0.3), (0, 0.5), (2, 0.2), (1, 0.35)],
            vec![(0, 0.2), (0, 0.3), (2, 0.25), (1, 0.0), (1, 0.6), (0, 0.1)],
            vec![(2, 1.3)],
        ] {
            let pieces: Vec<(usize, f64)> = pieces.iter().map(|&(g, dt)| (ids[g], dt)).collect();
            let dense: Vec<(&Mat<f64>, f64)> =
                pieces.iter().map(|&(g, dt)| (matrices[g], dt)).collect();
            let reference = piecewise_monodromy(&dense).eigenvalues().unwrap();
            let values = systems.multipliers(&pieces).unwrap();
            assert_eq!(values.len(), 6);
            // both ways round: the same set of values
            let err = distance(&values, &reference).max(distance(&reference, &values));
            assert!(
                err < 1e-11,
                "{pieces:?}: {:?} vs {:?}",
                sorted(values),
                sorted(reference)
            );
        }
    }

    #[test]
    fn the_integral_of_the_modal_exponential_is_the_block_of_the_augmented_exponential() {
        // exp([[A, B], [0, 0]] t) = [[e^{At}, ∫₀ᵗ e^{As} ds B], [0, I]] (docs/theory.md (T182)),
        // for real and complex eigenvalues, at a long and a tiny t (the series branch)
        let a = chain(1.0, 2.5);
        let form = RealModalForm::new(&a).expect("diagonalisable");
        let b = Mat::<f64>::from_fn(6, 2, |i, j| (1 + i + 3 * j) as f64 * 0.1);
        for t in [0.37, 1e-7] {
            let mut integral = &form.v_inv * &b;
            form.integral_times(t, integral.as_mut());
            let integral = &form.v * &integral;
            let augmented = Mat::<f64>::from_fn(8, 8, |i, j| match (i < 6, j < 6) {
                (true, true) => a[(i, j)] * t,
                (true, false) => b[(i, j - 6)] * t,
                _ => 0.0,
            });
            let reference = crate::dense::expm(&augmented);
            let scale = (0..6).fold(0.0f64, |m, i| m.max(reference[(i, 6)].abs()));
            let err = (0..6)
                .flat_map(|i| (0..2).map(move |j| (i, j)))
                .fold(0.0f64, |m, (i, j)| {
                    m.max((integral[(i, j)] - reference[(i, 6 + j)]).abs())
                });
            assert!(
                scale > 0.0 && err <= 1e-11 * scale,
                "t = {t}: {err} of {scale}"
            );
        }
    }

    #[test]
    fn a_real_form_reproduces_a_matrix_with_real_and_complex_eigenvalues() {
        // overdamped and underdamped modes together: real and complex eigenvalues
        let a = chain(1.0, 2.5);
        let form = RealModalForm::new(&a).expect("diagonalisable");
        assert!(form.blocks.iter().any(|b| matches!(b, ModalBlock::Real(_))));
        assert!(form
            .blocks
            .iter()
            .any(|b| matches!(b, ModalBlock::Pair { .. })));
        let t = 0.37;
        let mut e = Mat::<f64>::identity(6, 6);
        form.exp_times(t, e.as_mut());
        let expm = &(&form.v * &e) * &form.v_inv;
        let reference = crate::dense::expm(&(&a * t));
        let err = (0..6)
            .flat_map(|i| (0..6).map(move |j| (i, j)))
            .fold(0.0f64, |m, (i, j)| {
                m.max((expm[(i, j)] - reference[(i, j)]).abs())
            });
        assert!(err < 1e-12, "{err}");
    }

    #[test]
    fn an_overflowing_monodromy_is_an_error_not_an_infinite_multiplier() {
        // negative damping: growth e^{1000} over the period
        let mut systems = PiecewiseLinearSystems::new();
        let g = systems
            .index_of(&[true], || Ok(chain(1.0, -2000.0)))
            .unwrap();
        let h = systems
            .index_of(&[false], || Ok(chain(0.0, -2000.0)))
            .unwrap();
        for pieces in [vec![(g, 1.0)], vec![(g, 0.5), (h, 0.5)]] {
            let err = systems.multipliers(&pieces).unwrap_err().to_string();
            assert!(err.contains("not finite"), "{pieces:?}: {err}");
        }
    }

    #[test]
    fn a_defective_matrix_has_no_modal_form_and_falls_back_to_dense_exponentials() {
        // a Jordan block: critically damped single mass
        let a = Mat::from_fn(2, 2, |i, j| [[0.0, 1.0], [-1.0, -2.0]][i][j]);
        assert!(RealModalForm::new(&a).is_none());
        let mut systems = PiecewiseLinearSystems::new();
        let g = systems.index_of(&[true], || Ok(a.clone())).unwrap();
        let values = systems.multipliers(&[(g, 0.5), (g, 0.5)]).unwrap();
        // double eigenvalue −1: multipliers e^{−1}
        for v in values {
            assert!((v - c64::new((-1.0f64).exp(), 0.0)).norm() < 1e-7, "{v}");
        }
    }
}
