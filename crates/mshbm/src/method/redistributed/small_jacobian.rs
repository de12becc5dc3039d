//! The dense Jacobian (T129) of an interface of few contacts, formed directly (docs/theory.md
//! §19):
//!
//! ```text
//! J = blockdiag(Λ R_k⁻¹) − (I ⊗ Λ) S blockdiag(C_k),   S = Σ_A Γ_A ⊗ F_A,   C_k = I − D R_k⁻¹,
//! ```
//!
//! with `S` formed whole (`(n_c(2H+1))²` numbers) and the two products done harmonic block
//! by harmonic block (`O(n_c³ (2H+1)²)`). On one contact (the paper's bar) every block is a
//! number, and the [`super::jacobian::DenseRows`] path, made for thousands of contacts
//! (restricted rows, one row block at a time), spends its time in allocations. The matrix
//! is written into the caller's storage.

use faer::{c64, Mat};

use super::frequency_maps::{FrequencyMatrices, Map};
use super::quadrature::Integration;
use crate::harmonic::n_coefficients;

/// Contacts up to which [`jacobian_into`] forms the dense Jacobian (above them
/// [`super::jacobian::DenseRows`] is faster: it touches only the rows of closed contacts).
pub(super) const SMALL_INTERFACE_CONTACTS: usize = 8;

/// Scratch space of [`jacobian_into`], reused from one linearization to the next.
pub(super) struct SmallJacobianWork {
    /// `S` (`dim × dim`).
    forces: Mat<f64>,
    /// `S blockdiag(C_k)` (`dim × dim`).
    product: Mat<f64>,
    /// `F_A` of one set (`n_c × n_c`, row-major).
    force_map: Vec<f64>,
}

impl Default for SmallJacobianWork {
    fn default() -> Self {
        SmallJacobianWork {
            forces: Mat::zeros(0, 0),
            product: Mat::zeros(0, 0),
            force_map: Vec::new(),
        }
    }
}

/// The real form `[[Re M, Im M], [−Im M, Re M]]` of a complex `M` acting on the `(cos, sin)`
/// coefficients of a harmonic (docs/theory.md (T15)): entry `(r, c)` of the `2 × 2` block
/// pattern, `r, c ∈ {0 (cos), 1 (sin)}`.
fn real_form(m: c64, r: usize, c: usize) -> f64 {
    match (r, c) {
        (0, 0) | (1, 1) => m.re,
        (0, 1) => m.im,
        _ => -m.im,
    }
}

/// The coefficients `(first, count)` of harmonic `k`: `(0, 1)` for the mean, `(2k − 1, 2)`.
fn harmonic_coefficients(k: usize) -> (usize, usize) {
    if k == 0 {
        (0, 1)
    } else {
        (2 * k - 1, 2)
    }
}

/// Visit every entry of the real form (T15) of the map `P R_k⁻¹` of harmonic `k`: its row
/// and column in the `n_c(2H+1)` unknowns and its value.
fn real_form_entries(
    f: &FrequencyMatrices,
    map: Map,
    k: usize,
    n: usize,
    mut visit: impl FnMut(usize, usize, f64),
) {
    let m = f.matrix(map, k);
    let (first, count) = harmonic_coefficients(k);
    for rr in 0..count {
        for cp in 0..count {
            for i in 0..n {
                for j in 0..n {
                    visit(
                        (first + rr) * n + i,
                        (first + cp) * n + j,
                        real_form(m[(i, j)], rr, cp),
                    );
                }
            }
        }
    }
}

/// Write the dense `J` of (T129) in the real form (T15) into `out` (`n_c(2H+1)` square).
pub(super) fn jacobian_into(
    n: usize,
    harmonics: usize,
    f: &FrequencyMatrices,
    residual_scale: &[f64],
    integration: &Integration,
    work: &mut SmallJacobianWork,
    out: &mut Mat<f64>,
) {
    let ncoef = n_coefficients(harmonics);
    let dim = n * ncoef;
    if out.nrows() != dim || out.ncols() != dim {
        *out = Mat::zeros(dim, dim);
    }
    if work.forces.nrows() != dim {
        work.forces = Mat::zeros(dim, dim);
        work.product = Mat::zeros(dim, dim);
    }
    // S = Σ_A Γ_A ⊗ F_A
    let s = &mut work.forces;
    s.fill(0.0);
    work.force_map.clear();
    work.force_map.resize(n * n, 0.0);
    for group in &integration.groups {
        let closed = group.set.closed_contacts();
        if closed.is_empty() {
            continue;
        }
        let fa = &mut work.force_map;
        fa.iter_mut().for_each(|v| *v = 0.0);
        for &a in closed {
            let (columns, values) = group.set.force_row(a);
            columns
                .iter()
                .zip(values)
                .for_each(|(&j, &v)| fa[a * n + j] = v);
        }
        for m in 0..ncoef {
            for c in 0..ncoef {
                let g = group.gram[m * ncoef + c];
                if g == 0.0 {
                    continue;
                }
                for &a in closed {
                    for j in 0..n {
                        s[(m * n + a, c * n + j)] += g * fa[a * n + j];
                    }
                }
            }
        }
    }
    // S blockdiag(C_k): the column block of coefficient c' of harmonic k takes the column
    // blocks of harmonic k times the real form of C_k = I − D R_k⁻¹
    let p = &mut work.product;
    p.fill(0.0);
    for k in 0..=harmonics {
        real_form_entries(f, Map::Scaled, k, n, |from, to, scaled| {
            let c = if from == to { 1.0 } else { 0.0 } - scaled;
            if c != 0.0 {
                for r in 0..dim {
                    p[(r, to)] += s[(r, from)] * c;
                }
            }
        });
    }
    // J = blockdiag(Λ R_k⁻¹) − (I ⊗ Λ) S blockdiag(C_k)
    out.fill(0.0);
    for k in 0..=harmonics {
        real_form_entries(f, Map::Residual, k, n, |row, col, v| out[(row, col)] = v);
    }
    for m in 0..ncoef {
        for i in 0..n {
            for l in 0..n {
                let scale = residual_scale[i * n + l];
                if scale == 0.0 {
                    continue;
                }
                for col in 0..dim {
                    out[(m * n + i, col)] -= scale * p[(m * n + l, col)];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{RedistributedMsHbm, RedistributedOptions};
    use super::*;
    use crate::problem::PeriodicProblem;

    /// On a lattice with seven contacts, some closed over part of the period, the directly
    /// formed Jacobian equals the one formed by row blocks
    /// ([`super::super::jacobian::dense_jacobian`], itself checked against finite
    /// differences on larger interfaces).
    #[test]
    fn the_direct_jacobian_is_the_row_block_jacobian() {
        let model = crate::model::lattice::lattice_model(6, 8, 25.0, 5.0);
        let mut method = RedistributedMsHbm::new(&model, &RedistributedOptions::new(3)).unwrap();
        let omega = 2.0 * std::f64::consts::PI * 5.0;
        let x = method.initial_guess(omega).unwrap();
        method.residual(&x, omega).unwrap();
        let n = method.n();
        assert_eq!(n, 7);
        let evaluation = method.last_evaluation.as_ref().unwrap();
        let integration = &evaluation.integration;
        let closed: usize = integration
            .groups
            .iter()
            .map(|g| g.set.closed_contacts().len())
            .sum();
        assert!(
            closed > 0 && integration.groups.len() > 1,
            "some contacts switch"
        );
        let matrices = &method.prepared().matrices;
        let rows = super::super::jacobian::dense_jacobian(
            n,
            3,
            matrices,
            &method.residual_scale,
            integration,
        );
        let mut work = SmallJacobianWork::default();
        let mut direct = Mat::zeros(0, 0);
        jacobian_into(
            n,
            3,
            matrices,
            &method.residual_scale,
            integration,
            &mut work,
            &mut direct,
        );
        let size = rows
            .col_iter()
            .flat_map(|c| c.iter().map(|v| v.abs()).collect::<Vec<_>>())
            .fold(0.0, f64::max);
        let error = (&rows - &direct)
            .col_iter()
            .flat_map(|c| c.iter().map(|v| v.abs()).collect::<Vec<_>>())
            .fold(0.0, f64::max);
        assert!(error <= 1e-13 * size, "{error:e} of {size:e}");
    }
}
