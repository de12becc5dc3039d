//! Reference solution of the static contact problem by brute force over all active sets.

use super::residual::{compute_gap, natural_residual, positive_part, residual_tolerance};
use super::{LcpMatrix, ENUMERATION_MAX_SIZE, SINGULAR_PIVOT_REL_TOL};

/// Reference solution by brute force over all `2ⁿ` active sets, for tests and as a
/// reference. Returns the candidate with the smallest natural residual if it satisfies the
/// same tolerance as [`LcpSolver`], with rounding-level negative forces set to zero; `None`
/// when no active set qualifies (which cannot happen for a well-conditioned P-matrix).
///
/// # Panics
/// If `q.len() != matrix.n()` or `matrix.n() > 16`.
pub fn solve_by_enumeration(matrix: &LcpMatrix, q: &[f64]) -> Option<Vec<f64>> {
    let n = matrix.n();
    assert_eq!(q.len(), n, "solve_by_enumeration: q has the wrong length");
    assert!(
        n <= ENUMERATION_MAX_SIZE,
        "solve_by_enumeration: n = {n} exceeds {ENUMERATION_MAX_SIZE}"
    );
    let diagonal = matrix.diagonal();
    let mut best: Option<(f64, Vec<f64>, Vec<bool>)> = None;
    for mask in 0u32..(1u32 << n) {
        let active: Vec<bool> = (0..n).map(|i| mask & (1 << i) != 0).collect();
        let active_indices: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
        let block: Vec<f64> = active_indices
            .iter()
            .flat_map(|&i| active_indices.iter().map(move |&j| matrix.get(i, j)))
            .collect();
        let rhs: Vec<f64> = active_indices.iter().map(|&i| -q[i]).collect();
        let Some(block_force) = crate::dense::solve_small(&block, &rhs, SINGULAR_PIVOT_REL_TOL)
        else {
            continue;
        };
        let mut contact_force = vec![0.0; n];
        for (&i, &force) in active_indices.iter().zip(&block_force) {
            contact_force[i] = force;
        }
        let mut gap = vec![0.0; n];
        let term_scale = compute_gap(matrix, q, &active_indices, &contact_force, &mut gap);
        let tolerance = residual_tolerance(term_scale);
        let ratio = natural_residual(&diagonal, &contact_force, &gap) / tolerance;
        if !ratio.is_nan()
            && best
                .as_ref()
                .is_none_or(|(best_ratio, ..)| ratio < *best_ratio)
        {
            best = Some((ratio, contact_force, active));
        }
    }
    let (ratio, mut contact_force, active) = best?;
    if ratio > 1.0 {
        return None;
    }
    for (force, &is_active) in contact_force.iter_mut().zip(&active) {
        *force = if is_active {
            positive_part(*force)
        } else {
            0.0
        };
    }
    Some(contact_force)
}
