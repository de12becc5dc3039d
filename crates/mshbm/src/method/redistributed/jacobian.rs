//! The semi-analytical Jacobian of the redistributed MS-HBM in contact coordinates
//! (docs/theory.md (T129)),
//!
//! ```text
//! J = blockdiag(Λ R_k⁻¹) − (I ⊗ Λ) S blockdiag(C_k),   C_k = I − D R_k⁻¹,   S = Σ_A Γ_A ⊗ F_A,
//! ```
//!
//! in two forms: the dense matrix ([`dense_jacobian`]), and the operator
//! ([`ContactJacobian`]) that applies it in `O(n_c²(2H+1))` plus the force maps' sums,
//! preconditioned by the factors of an earlier dense Jacobian (docs/theory.md §18).

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use faer::{c64, Mat};

use super::frequency_maps::{FrequencyMatrices, Map};
use super::frictional::PeriodicFriction;
use super::quadrature::Integration;
use crate::harmonic::n_coefficients;
use crate::problem::JacobianOperator;

/// Contacts (closed contacts of a set) up to which the products of this module are direct
/// loops, which allocate nothing (above, faer's products).
const DIRECT_CONTACTS: usize = 8;

/// `M z` per coefficient for a real `n_c × n_c` matrix `M` (row-major): one product
/// `M Z` with `Z` the `n_c × (2H+1)` matrix of the coefficients.
pub(super) fn times_each_coefficient(n: usize, d: &[f64], z: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; z.len()];
    times_each_coefficient_into(n, d, z, &mut out);
    out
}

/// [`times_each_coefficient`] into `out` (as long as `z`).
pub(super) fn times_each_coefficient_into(n: usize, d: &[f64], z: &[f64], out: &mut [f64]) {
    if n <= DIRECT_CONTACTS {
        for (zc, oc) in z.chunks_exact(n).zip(out.chunks_exact_mut(n)) {
            for (o, row) in oc.iter_mut().zip(d.chunks_exact(n)) {
                *o = row.iter().zip(zc).map(|(a, b)| a * b).sum();
            }
        }
        return;
    }
    let m = faer::MatRef::from_row_major_slice(d, n, n);
    let columns = z.len() / n;
    let product = m * faer::MatRef::from_column_major_slice(z, n, columns);
    for (q, o) in out.iter_mut().enumerate() {
        *o = product[(q % n, q / n)];
    }
}

/// `λ̂ = Σ_A (Γ_A ⊗ F_A) u` (harmonic-major, `n_c` per coefficient; docs/theory.md
/// (T124)–(T125)): linear in the free-gap coefficients `u`. Per active set, on its `n_A`
/// closed contacts only (the force map's other rows vanish): `Λ_A += F_AA (U_A Γ_Aᵀ)`, with
/// `U` the `n_c × (2H+1)` matrix of the coefficients — two matrix products.
pub(super) fn assemble_forces(
    n: usize,
    harmonics: usize,
    integration: &Integration,
    u: &[f64],
) -> Vec<f64> {
    let mut forces = vec![0.0; n * n_coefficients(harmonics)];
    assemble_forces_into(n, harmonics, integration, u, &mut forces, &mut Vec::new());
    forces
}

/// [`assemble_forces`] into `forces` (`n (2H+1)`), with `scratch` for `U_A Γ_Aᵀ`: sets of
/// up to [`DIRECT_CONTACTS`] closed contacts allocate nothing once `scratch` has grown.
pub(super) fn assemble_forces_into(
    n: usize,
    harmonics: usize,
    integration: &Integration,
    u: &[f64],
    forces: &mut [f64],
    scratch: &mut Vec<f64>,
) {
    let nc = n_coefficients(harmonics);
    forces.fill(0.0);
    for group in &integration.groups {
        let closed = group.set.closed_contacts();
        let na = closed.len();
        if na == 0 {
            continue;
        }
        if na <= DIRECT_CONTACTS {
            // filtered[r][m] = Σ_c U[closed r, c] Γ[m, c]
            scratch.clear();
            scratch.resize(na * nc, 0.0);
            for (r, &a) in closed.iter().enumerate() {
                for (m, gram_row) in group.gram.chunks_exact(nc).enumerate() {
                    scratch[r * nc + m] = gram_row
                        .iter()
                        .enumerate()
                        .map(|(c, g)| u[c * n + a] * g)
                        .sum();
                }
            }
            for &a in closed {
                let row = group.set.force_row(a).1;
                for m in 0..nc {
                    forces[m * n + a] += row
                        .iter()
                        .enumerate()
                        .map(|(q, f)| f * scratch[q * nc + m])
                        .sum::<f64>();
                }
            }
            continue;
        }
        let u_closed = Mat::<f64>::from_fn(na, nc, |r, c| u[c * n + closed[r]]);
        let gram = faer::MatRef::from_row_major_slice(&group.gram, nc, nc);
        let filtered = &u_closed * gram.transpose();
        scratch.clear();
        for &a in closed {
            scratch.extend_from_slice(group.set.force_row(a).1);
        }
        let block = faer::MatRef::from_row_major_slice(scratch, na, na) * &filtered;
        for m in 0..nc {
            for (r, &a) in closed.iter().enumerate() {
                forces[m * n + a] += block[(r, m)];
            }
        }
    }
}

/// The dense `J` of (T129) in the real form (T15), row block by row block
/// ([`DenseRows`]).
pub(super) fn dense_jacobian(
    n: usize,
    harmonics: usize,
    f: &FrequencyMatrices,
    residual_scale: &[f64],
    integration: &Integration,
) -> Mat<f64> {
    let rows = DenseRows::new(n, harmonics, f, residual_scale, integration);
    let dim = n * n_coefficients(harmonics);
    let mut jac = Mat::<f64>::zeros(dim, dim);
    for m in 0..n_coefficients(harmonics) {
        jac.as_mut().subrows_mut(m * n, n).copy_from(rows.block(m));
    }
    jac
}

/// The rows of the dense `J` of (T129) in the real form (T15), one coefficient's block
/// (`n_c × n_c(2H+1)`) at a time, so that the preconditioner's single-precision factors can
/// be filled without the whole double-precision matrix. A complex `M` acting on the
/// `(cos, sin)` coefficients of a harmonic is `[[Re M, Im M], [−Im M, Re M]]`.
/// `S_mc = Σ_A Γ_A[m, c] F_A` has rows only for the `r` contacts closed in some active set
/// that row block `m` sees, so the block costs `2(2H + 1)` products `(r × n_c)(n_c × n_c)`
/// for `U = Σ ± S C` and `2H + 1` products `Λ[:, r] U`, whatever the number of active sets.
pub(super) struct DenseRows<'a> {
    n: usize,
    harmonics: usize,
    /// Per harmonic, `(Re, Im)` of `C_k = I − D R_k⁻¹` (the real form's parts).
    complement: Vec<(Mat<f64>, Mat<f64>)>,
    /// Per harmonic, `(Re, Im)` of `Λ R_k⁻¹`.
    direct: Vec<(Mat<f64>, Mat<f64>)>,
    residual_scale: &'a [f64],
    integration: &'a Integration,
}

impl<'a> DenseRows<'a> {
    pub(super) fn new(
        n: usize,
        harmonics: usize,
        f: &FrequencyMatrices,
        residual_scale: &'a [f64],
        integration: &'a Integration,
    ) -> Self {
        let real_form = |m: &Mat<c64>| -> (Mat<f64>, Mat<f64>) {
            (
                Mat::from_fn(n, n, |i, j| m[(i, j)].re),
                Mat::from_fn(n, n, |i, j| m[(i, j)].im),
            )
        };
        let complement = (0..=harmonics)
            .map(|k| {
                let (re, im) = real_form(&f.matrix(Map::Scaled, k));
                (Mat::<f64>::identity(n, n) - re, -im)
            })
            .collect();
        let direct = (0..=harmonics)
            .map(|k| real_form(&f.matrix(Map::Residual, k)))
            .collect();
        DenseRows {
            n,
            harmonics,
            complement,
            direct,
            residual_scale,
            integration,
        }
    }

    /// The rows of coefficient `m` (`n_c × n_c(2H+1)`).
    pub(super) fn block(&self, m: usize) -> Mat<f64> {
        use faer::linalg::matmul::matmul;
        use faer::{Accum, Par};
        let (n, harmonics) = (self.n, self.harmonics);
        let nc = n_coefficients(harmonics);
        let mut rows = Mat::<f64>::zeros(n, n * nc);
        // the diagonal block(s) of Λ R_k⁻¹ of this coefficient's harmonic
        let k = m.div_ceil(2);
        let (re, im) = &self.direct[k];
        if k == 0 {
            rows.as_mut().submatrix_mut(0, 0, n, n).copy_from(re);
        } else if m == 2 * k - 1 {
            // cos row: [Re, Im] in the (cos, sin) columns
            rows.as_mut().submatrix_mut(0, m * n, n, n).copy_from(re);
            rows.as_mut()
                .submatrix_mut(0, (m + 1) * n, n, n)
                .copy_from(im);
        } else {
            // sin row: [−Im, Re]
            rows.as_mut()
                .submatrix_mut(0, (m - 1) * n, n, n)
                .copy_from(-im);
            rows.as_mut().submatrix_mut(0, m * n, n, n).copy_from(re);
        }
        let integration = self.integration;
        // the contacts closed in some group that row block m sees: only their rows of S_mc
        // (the force maps) are nonzero
        let mut position = vec![usize::MAX; n];
        let mut closed_rows: Vec<usize> = Vec::new();
        for group in &integration.groups {
            if (0..nc).all(|c| group.gram[m * nc + c] == 0.0) {
                continue;
            }
            for &a in group.set.closed_contacts() {
                if position[a] == usize::MAX {
                    position[a] = closed_rows.len();
                    closed_rows.push(a);
                }
            }
        }
        let r = closed_rows.len();
        if r == 0 {
            return rows;
        }
        // S_mc restricted to those rows (r × n_c), summed row-major (each force row is
        // scattered into one contiguous row) and then made a matrix
        let mut forces: Vec<Option<Mat<f64>>> = (0..nc).map(|_| None).collect();
        let mut sum: Vec<f64> = Vec::new();
        for (c, s_c) in forces.iter_mut().enumerate() {
            let mut any = false;
            for group in &integration.groups {
                let g = group.gram[m * nc + c];
                if g == 0.0 {
                    continue;
                }
                if !any {
                    sum.clear();
                    sum.resize(r * n, 0.0);
                    any = true;
                }
                for &a in group.set.closed_contacts() {
                    let (columns, values) = group.set.force_row(a);
                    let row = &mut sum[position[a] * n..(position[a] + 1) * n];
                    columns
                        .iter()
                        .zip(values)
                        .for_each(|(&j, v)| row[j] += g * v);
                }
            }
            if any {
                *s_c = Some(faer::MatRef::from_row_major_slice(&sum, r, n).to_owned());
            }
        }
        // U_col = Σ_c ± S_mc · realform(C_k) (r × n_c per output column block), then
        // the rows get −Λ[:, rows] U_col
        let mut products: Vec<Option<Mat<f64>>> = (0..nc).map(|_| None).collect();
        let mut add = |col: usize, s: &Mat<f64>, c: &Mat<f64>, sign: f64| {
            let u = products[col].get_or_insert_with(|| Mat::<f64>::zeros(r, n));
            matmul(u.as_mut(), Accum::Add, s, c, sign, Par::Seq);
        };
        if let Some(s0) = &forces[0] {
            add(0, s0, &self.complement[0].0, -1.0);
        }
        for (k, (c_re, c_im)) in self.complement.iter().enumerate().skip(1) {
            let (cc, ss) = (2 * k - 1, 2 * k);
            // output column cos: S_cos Re C − S_sin Im C; column sin: S_cos Im C + S_sin Re C
            if let Some(sc) = &forces[cc] {
                add(cc, sc, c_re, -1.0);
                add(ss, sc, c_im, -1.0);
            }
            if let Some(s_s) = &forces[ss] {
                add(cc, s_s, c_im, 1.0);
                add(ss, s_s, c_re, -1.0);
            }
        }
        let scale = faer::MatRef::from_row_major_slice(self.residual_scale, n, n);
        let scale_rows = Mat::<f64>::from_fn(n, r, |i, q| scale[(i, closed_rows[q])]);
        for (col, u) in products.iter().enumerate() {
            if let Some(u) = u {
                let block = rows.as_mut().subcols_mut(col * n, n);
                matmul(block, Accum::Add, &scale_rows, u, 1.0, Par::Seq);
            }
        }
        rows
    }
}

/// The LU factors of a dense Jacobian, kept by the method between linearizations as the
/// preconditioner of the next ones (docs/theory.md §18).
pub(super) type PreconditionerSlot = Rc<RefCell<Option<Rc<InPlaceLu>>>>;

/// LU factors with partial pivoting of a dense Jacobian, in single precision and in the
/// matrix's own storage (LAPACK's layout: the unit lower `L` and `U` in one matrix). As a
/// preconditioner they need not be exact (GMRES corrects them, docs/theory.md (T134)); in
/// single precision they hold half the memory and each application, which reads them whole,
/// takes about half the time.
pub(super) struct InPlaceLu {
    factors: Mat<f32>,
    forward: Vec<usize>,
    inverse: Vec<usize>,
}

impl InPlaceLu {
    /// The factors of the matrix whose rows `rows` gives in `blocks` blocks of equal height,
    /// each rounded to single precision as it comes (the double-precision matrix is never
    /// whole).
    fn new(n: usize, blocks: usize, rows: impl Fn(usize) -> Mat<f64>) -> Self {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::lu::partial_pivoting::factor::{lu_in_place, lu_in_place_scratch};
        let mut factors = Mat::<f32>::zeros(n, n);
        let height = n / blocks;
        for b in 0..blocks {
            let block = rows(b);
            factors
                .as_mut()
                .subrows_mut(b * height, height)
                .copy_from(block.as_ref().map(|v| *v as f32));
        }
        let par = faer::get_global_parallelism();
        let (mut forward, mut inverse) = (vec![0usize; n], vec![0usize; n]);
        let mut mem = MemBuffer::new(lu_in_place_scratch::<usize, f32>(
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
        InPlaceLu {
            factors,
            forward,
            inverse,
        }
    }

    /// `out ≈ A⁻¹ r` (single-precision factors).
    fn solve(&self, r: &[f64], out: &mut [f64]) {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::lu::partial_pivoting::solve::{solve_in_place, solve_in_place_scratch};
        let n = r.len();
        let mut x: Vec<f32> = r.iter().map(|&v| v as f32).collect();
        let par = faer::Par::Seq;
        let mut mem = MemBuffer::new(solve_in_place_scratch::<usize, f32>(n, 1, par));
        let permutation = faer::perm::PermRef::new_checked(&self.forward, &self.inverse, n);
        solve_in_place(
            self.factors.as_ref(),
            self.factors.as_ref(),
            permutation,
            faer::MatMut::from_column_major_slice_mut(&mut x, n, 1),
            par,
            MemStack::new(&mut mem),
        );
        out.iter_mut().zip(&x).for_each(|(o, &v)| *o = f64::from(v));
    }
}

/// The Jacobian (T129) as an operator, preconditioned by the LU factors of the dense
/// Jacobian at an earlier linearization (docs/theory.md §18): along a continuation the
/// active sets and the frequency change little between corrector iterations and points, so
/// GMRES needs a few applications where a new LU would cost `O((n_c(2H+1))³)`. The factors
/// are formed on the first use and again when GMRES stops converging quickly
/// ([`JacobianOperator::refresh_preconditioner`]).
pub(super) struct ContactJacobian {
    n: usize,
    harmonics: usize,
    matrices: Rc<FrequencyMatrices>,
    /// `Λ` (`n_c × n_c`, row-major).
    residual_scale: Rc<Vec<f64>>,
    integration: Rc<Integration>,
    /// The frictional law whose `S = dλ̂/du` (T158) replaces the quadrature's force maps,
    /// when the contacts have friction.
    law: Option<Rc<PeriodicFriction>>,
    /// The method's factors, shared with later linearizations.
    slot: PreconditionerSlot,
    /// The factors this operator preconditions with, and whether they are its own.
    current: RefCell<Option<Rc<InPlaceLu>>>,
    exact: Cell<bool>,
}

impl ContactJacobian {
    pub(super) fn new(
        n: usize,
        harmonics: usize,
        matrices: Rc<FrequencyMatrices>,
        residual_scale: Rc<Vec<f64>>,
        integration: Rc<Integration>,
        law: Option<Rc<PeriodicFriction>>,
        slot: PreconditionerSlot,
    ) -> Self {
        let current = RefCell::new(slot.borrow().clone());
        ContactJacobian {
            n,
            harmonics,
            matrices,
            residual_scale,
            integration,
            law,
            slot,
            current,
            exact: Cell::new(false),
        }
    }

    /// Factor this operator's own dense matrix and share the factors. The earlier factors
    /// are released first, and the matrix is rounded to single precision block by block, so
    /// that a refresh holds the single-precision matrix and one row block, not three dense
    /// matrices.
    fn factor(&self) -> Rc<InPlaceLu> {
        *self.current.borrow_mut() = None;
        *self.slot.borrow_mut() = None;
        let blocks = n_coefficients(self.harmonics);
        let lu = Rc::new(if self.law.is_some() {
            // with friction `S` is dense (T158): the matrix is formed whole
            let full = self.dense();
            InPlaceLu::new(self.dimension(), blocks, |m| {
                full.as_ref().subrows(m * self.n, self.n).to_owned()
            })
        } else {
            let rows = DenseRows::new(
                self.n,
                self.harmonics,
                &self.matrices,
                &self.residual_scale,
                &self.integration,
            );
            InPlaceLu::new(self.dimension(), blocks, |m| rows.block(m))
        });
        *self.current.borrow_mut() = Some(Rc::clone(&lu));
        *self.slot.borrow_mut() = Some(Rc::clone(&lu));
        self.exact.set(true);
        lu
    }
}

impl JacobianOperator for ContactJacobian {
    fn dimension(&self) -> usize {
        self.n * n_coefficients(self.harmonics)
    }

    fn apply(&self, x: &[f64], out: &mut [f64]) {
        let n = self.n;
        let direct = self.matrices.apply(Map::Residual, n, x);
        let d_x = self.matrices.apply(Map::Scaled, n, x);
        let complement: Vec<f64> = x.iter().zip(&d_x).map(|(a, b)| a - b).collect();
        let forces = match &self.law {
            // (T133) with the frictional law: S u = dλ̂/du · u (T158), (T225); a law that
            // fails here makes the product not a number, which GMRES and the dense
            // fallback report as a singular Jacobian
            Some(law) => law
                .product(&complement, true)
                .unwrap_or_else(|_| vec![f64::NAN; complement.len()]),
            None => assemble_forces(n, self.harmonics, &self.integration, &complement),
        };
        let scaled = times_each_coefficient(n, &self.residual_scale, &forces);
        out.iter_mut()
            .zip(direct.iter().zip(&scaled))
            .for_each(|(o, (a, b))| *o = a - b);
    }

    fn precondition(&self, r: &[f64], out: &mut [f64]) {
        let current = self.current.borrow().clone();
        let lu = current.unwrap_or_else(|| self.factor());
        lu.solve(r, out);
    }

    fn dense(&self) -> Mat<f64> {
        if let Some(law) = &self.law {
            let size = self.dimension();
            return match law.jacobian() {
                Ok(s) => super::frictional::dense_jacobian(
                    self.n,
                    self.harmonics,
                    &self.matrices,
                    &self.residual_scale,
                    s,
                ),
                // not a number: reported as a singular Jacobian (see `apply`)
                Err(_) => Mat::from_fn(size, size, |_, _| f64::NAN),
            };
        }
        dense_jacobian(
            self.n,
            self.harmonics,
            &self.matrices,
            &self.residual_scale,
            &self.integration,
        )
    }

    fn refresh_preconditioner(&self) -> bool {
        if self.exact.get() {
            return false;
        }
        self.factor();
        true
    }
}
