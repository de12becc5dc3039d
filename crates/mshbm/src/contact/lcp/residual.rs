//! The optimality test shared by every LCP algorithm: the gaps of an active set, the natural
//! residual `|min(Dᵢᵢ λᵢ, wᵢ)|` and its tolerance.

use super::{LcpMatrix, RESIDUAL_REL_TOL};

/// `gap = D λ + q` using only the columns of the active contacts (`λ` is zero elsewhere).
/// Returns the largest term magnitude `|qᵢ| + Σⱼ |Dᵢⱼ λⱼ|`, the scale of rounding in `gap`.
pub(super) fn compute_gap(
    matrix: &LcpMatrix,
    q: &[f64],
    active_indices: &[usize],
    contact_force: &[f64],
    gap: &mut [f64],
) -> f64 {
    let mut term_scale = 0.0f64;
    for (i, (gap_i, &q_i)) in gap.iter_mut().zip(q).enumerate() {
        let row = matrix.row(i);
        let mut sum = q_i;
        let mut magnitude = q_i.abs();
        for &j in active_indices {
            let term = row[j] * contact_force[j];
            sum += term;
            magnitude += term.abs();
        }
        *gap_i = sum;
        term_scale = term_scale.max(magnitude);
    }
    term_scale
}

/// Largest natural residual `|min(Dᵢᵢ λᵢ, wᵢ)|`; NaN if any entry is NaN. It is zero exactly
/// at solutions; the diagonal puts forces into gap units.
pub(super) fn natural_residual(diagonal: &[f64], contact_force: &[f64], gap: &[f64]) -> f64 {
    let mut largest = 0.0f64;
    for ((&d, &force), &gap_i) in diagonal.iter().zip(contact_force).zip(gap) {
        let scaled_force = d * force;
        let residual = if scaled_force < gap_i {
            scaled_force.abs()
        } else {
            gap_i.abs()
        };
        if residual.is_nan() || scaled_force.is_nan() {
            return f64::NAN;
        }
        largest = largest.max(residual);
    }
    largest
}

/// Residual tolerance for terms of magnitude `term_scale` (always positive).
pub(super) fn residual_tolerance(term_scale: f64) -> f64 {
    RESIDUAL_REL_TOL * term_scale.max(f64::MIN_POSITIVE)
}

/// `max(x, 0)` returning `+0.0` (never `-0.0`).
pub(super) fn positive_part(x: f64) -> f64 {
    if x > 0.0 {
        x
    } else {
        0.0
    }
}
