//! Fourier coefficients of the contact forces `λ(τ)` (the contact part of the paper's
//! eqs. 33–35 in the contact coordinates, docs/theory.md (T128)), by either quadrature:
//!
//! * **sampled** — the DFT over `N_s` equidistant samples (the paper's implementation);
//! * **exact** — the period is cut at the switching times of the active set (roots of the
//!   gaps of open contacts and of the forces of closed ones, which are trigonometric
//!   polynomials between switches), and the Fourier integrals are done in closed form on
//!   each interval. No aliasing; the residual is continuously differentiable.
//!
//! Both give, per distinct active set `A`, a Gram block `Γ_A` (see [`crate::harmonic`]) such
//! that `λ̂ = Σ_A F_A U Γ_Aᵀ`, where `U` holds the Fourier coefficients of the free gap
//! `γ(τ)` (docs/theory.md (T123)) and `F_A = ∂λ/∂γ` is the force map of the set. The
//! semi-analytical Jacobian follows the same sum (eqs. 36–38: the interval end points drop
//! out because `λ` is continuous in time for the static contact problem).
//!
//! Switching times are located cell by cell on a grid of `N_s` points: a gap or force that is
//! negative at the end of a cell, or dips below zero at an interior minimum (grazing, or a
//! release shorter than a cell), starts a new interval at its first root.

use std::collections::HashMap;
use std::rc::Rc;

use crate::contact::static_contact::{ActiveSet, StaticContact};
use crate::error::Result;
use crate::harmonic::{
    add_interval_gram, basis_into, evaluate, n_coefficients, Quadrature, Sampling,
};
use crate::roots::find_sign_change;

/// Samples sharing one active set, with their summed Gram block.
pub struct Group {
    pub set: Rc<ActiveSet>,
    /// `Γ_A`, `(2H+1)²`, row-major.
    pub gram: Vec<f64>,
}

/// A located change of active set.
#[derive(Clone, Copy, Debug)]
pub struct Switch {
    /// Normalised time `τ ∈ [0, 2π)`.
    pub tau: f64,
}

/// The active-set decomposition of one period.
pub struct Integration {
    pub groups: Vec<Group>,
    /// Group of each grid sample.
    pub sample_group: Vec<usize>,
    /// Located switching times (exact quadrature only).
    pub switches: Vec<Switch>,
    /// The period cut into intervals of constant active set, `(τ_start, τ_end, group)`,
    /// in order (exact: at the switching times; sampled: runs of grid cells).
    pub intervals: Vec<(f64, f64, usize)>,
}

/// The signal of `n` components at `τ` from its coefficients (`load[c·n + i]`).
pub fn signal_at(
    load: &[f64],
    n: usize,
    harmonics: usize,
    tau: f64,
    basis: &mut [f64],
) -> Vec<f64> {
    basis_into(harmonics, tau, basis);
    let mut b = vec![0.0; n];
    for (c, &bc) in basis.iter().enumerate() {
        for i in 0..n {
            b[i] += load[c * n + i] * bc;
        }
    }
    b
}

struct Groups {
    index: HashMap<Vec<bool>, usize>,
    groups: Vec<Group>,
    size: usize,
}

impl Groups {
    fn of(&mut self, set: &Rc<ActiveSet>) -> usize {
        if let Some(&g) = self.index.get(&set.closed) {
            return g;
        }
        self.groups.push(Group {
            set: set.clone(),
            gram: vec![0.0; self.size * self.size],
        });
        self.index.insert(set.closed.clone(), self.groups.len() - 1);
        self.groups.len() - 1
    }
}

/// Trigonometric coefficients of the validity indicators of `set` under the free gap with
/// coefficients `gamma` (`n_c` rows of `2H+1`).
fn indicator_coefficients(
    set: &ActiveSet,
    gamma: &[f64],
    nc: usize,
    ncoef: usize,
) -> Vec<Vec<f64>> {
    (0..nc)
        .map(|c| {
            (0..ncoef)
                .map(|m| set.indicator_dot(c, &gamma[m * nc..(m + 1) * nc]))
                .collect()
        })
        .collect()
}

/// Derivative coefficients of a trigonometric polynomial.
fn derivative(coef: &[f64]) -> Vec<f64> {
    let h = (coef.len() - 1) / 2;
    let mut d = vec![0.0; coef.len()];
    for k in 1..=h {
        let kf = k as f64;
        d[2 * k - 1] = kf * coef[2 * k];
        d[2 * k] = -kf * coef[2 * k - 1];
    }
    d
}

/// The first time in `(left, right]` at which the trigonometric polynomial `coef` is
/// negative, to round-off, given `coef(right) < 0`: the negative end of the final bracket of
/// [`find_sign_change`]. `left` is where the active set was found valid, so it is taken as
/// the non-negative end even when round-off makes `coef(left)` slightly negative there.
fn first_negative_time(coef: &[f64], left: f64, right: f64, f_right: f64) -> f64 {
    let f_left = evaluate(coef, left).max(0.0);
    find_sign_change(|t| evaluate(coef, t), left, right, f_left, f_right).negative
}

/// First time in `(a, end]` at which the trigonometric polynomial `coef` becomes negative,
/// if it does: either it is negative at `end`, or it dips below zero at an interior
/// minimum (a grazing contact or a brief release shorter than the grid cell).
fn first_negative(coef: &[f64], a: f64, end: f64) -> Option<f64> {
    const SCAN: usize = 8;
    let mut left = a;
    for l in 1..=SCAN {
        let p = a + (end - a) * l as f64 / SCAN as f64;
        let value = evaluate(coef, p);
        if value < 0.0 {
            return Some(first_negative_time(coef, left, p, value));
        }
        left = p;
    }
    // positive at the scan points: look for a negative interior minimum
    let d = derivative(coef);
    let mut prev = a;
    let mut dprev = evaluate(&d, a);
    for l in 1..=SCAN {
        let p = a + (end - a) * l as f64 / SCAN as f64;
        let dp = evaluate(&d, p);
        if dprev < 0.0 && dp > 0.0 {
            // minimum in (prev, p): the root of the derivative
            let tmin = find_sign_change(|t| evaluate(&d, t), prev, p, dprev, dp).midpoint();
            let value = evaluate(coef, tmin);
            if value < 0.0 {
                return Some(first_negative_time(coef, prev, tmin, value));
            }
        }
        prev = p;
        dprev = dp;
    }
    None
}

/// Decompose one period into active-set groups for the free gap with coefficients `gamma`
/// (harmonic-major, `n_c` per coefficient).
#[allow(clippy::needless_range_loop)] // cells j use the grid points j and j + 1
pub fn integrate(
    contact: &mut StaticContact,
    gamma: &[f64],
    sampling: &Sampling,
    quadrature: Quadrature,
) -> Result<Integration> {
    let h = sampling.harmonics;
    let ncoef = n_coefficients(h);
    let nc = contact.n_contacts();
    let mut basis = vec![0.0; ncoef];
    let mut groups = Groups {
        index: HashMap::new(),
        groups: Vec::new(),
        size: ncoef,
    };
    let mut sets = Vec::with_capacity(sampling.len());
    let mut sample_group = Vec::with_capacity(sampling.len());
    for &tau in &sampling.taus {
        let g = signal_at(gamma, nc, h, tau, &mut basis);
        let set = contact.solve(&g)?;
        sample_group.push(groups.of(&set));
        sets.push(set);
    }
    let mut switches = Vec::new();
    let mut intervals: Vec<(f64, f64, usize)> = Vec::new();
    match quadrature {
        Quadrature::Sampled => {
            let two_pi = 2.0 * std::f64::consts::PI;
            for (j, &g) in sample_group.iter().enumerate() {
                sampling.add_sample_gram(j, &mut groups.groups[g].gram);
                // the sample's set holds on its cell [τ_j, τ_j+1)
                let end = sampling.taus.get(j + 1).copied().unwrap_or(two_pi);
                match intervals.last_mut() {
                    Some(last) if last.2 == g => last.1 = end,
                    _ => intervals.push((sampling.taus[j], end, g)),
                }
            }
        }
        Quadrature::Exact => {
            let ns = sampling.len();
            let two_pi = 2.0 * std::f64::consts::PI;
            let mut set = sets[0].clone();
            let mut run_start = 0.0;
            for j in 0..ns {
                let mut a = sampling.taus[j];
                let end = if j + 1 < ns {
                    sampling.taus[j + 1]
                } else {
                    two_pi
                };
                // a set carried over from the previous cell that the LCP disagrees with at
                // this grid point is replaced by the LCP's (a double switch was missed)
                if !Rc::ptr_eq(&set, &sets[j]) && !indicator_holds(&set, gamma, nc, ncoef, a) {
                    let g = groups.of(&set);
                    add_interval_gram(h, run_start, a, &mut groups.groups[g].gram);
                    intervals.push((run_start, a, g));
                    run_start = a;
                    set = sets[j].clone();
                }
                let mut guard = 0;
                loop {
                    let coefs = indicator_coefficients(&set, gamma, nc, ncoef);
                    let mut earliest: Option<(f64, usize)> = None;
                    for (c, coef) in coefs.iter().enumerate() {
                        if let Some(r) = first_negative(coef, a, end) {
                            if earliest.is_none_or(|(t, _)| r < t) {
                                earliest = Some((r, c));
                            }
                        }
                    }
                    let Some((root, component)) = earliest else {
                        break;
                    };
                    let g = groups.of(&set);
                    add_interval_gram(h, run_start, root, &mut groups.groups[g].gram);
                    intervals.push((run_start, root, g));
                    switches.push(Switch { tau: root });
                    run_start = root;
                    guard += 1;
                    let next = if root - a <= 1e-13 * two_pi || guard > 2 * nc + 4 {
                        // no progress: ask the LCP just after the root
                        let t = root + 1e-9 * (end - root);
                        let g = signal_at(gamma, nc, h, t, &mut basis);
                        contact.solve(&g)?
                    } else {
                        let mut closed = set.closed.clone();
                        closed[component] = !closed[component];
                        contact.active_set(&closed)?
                    };
                    a = root;
                    if guard > 4 * nc + 8 {
                        set = next;
                        break;
                    }
                    set = next;
                }
            }
            let g = groups.of(&set);
            add_interval_gram(h, run_start, two_pi, &mut groups.groups[g].gram);
            intervals.push((run_start, two_pi, g));
        }
    }
    Ok(Integration {
        groups: groups.groups,
        sample_group,
        switches,
        intervals,
    })
}

fn indicator_holds(set: &ActiveSet, gamma: &[f64], nc: usize, ncoef: usize, tau: f64) -> bool {
    indicator_coefficients(set, gamma, nc, ncoef)
        .iter()
        .all(|c| evaluate(c, tau) >= -1e-12 * (1.0 + c.iter().fold(0.0f64, |m, v| m.max(v.abs()))))
}
