//! Where an active set stops being valid on a cell: the earliest root of its validity
//! indicators (trigonometric polynomials) by a scan of the cell and safeguarded Newton.

use crate::harmonic::{basis_into, evaluate, evaluate_with_slope, n_coefficients};
use crate::roots::find_sign_change_with_slope;

/// Derivative coefficients of a trigonometric polynomial, into `d`.
pub(in crate::method::redistributed) fn derivative_into(coef: &[f64], d: &mut Vec<f64>) {
    let h = (coef.len() - 1) / 2;
    d.clear();
    d.resize(coef.len(), 0.0);
    for k in 1..=h {
        let kf = k as f64;
        d[2 * k - 1] = kf * coef[2 * k];
        d[2 * k] = -kf * coef[2 * k - 1];
    }
}

/// The first time in `(left, right]` at which the trigonometric polynomial `coef` is
/// negative, to round-off, given `coef(right) < 0`: the negative end of the final bracket of
/// [`find_sign_change`]. `left` is where the active set was found valid, so it is taken as
/// the non-negative end even when round-off makes `coef(left)` slightly negative there.
/// Located by safeguarded Newton ([`find_sign_change_with_slope`]).
fn first_negative_time(coef: &[f64], left: f64, right: f64, f_right: f64) -> f64 {
    let f_left = evaluate(coef, left).max(0.0);
    find_sign_change_with_slope(
        |t| evaluate_with_slope(coef, t),
        left,
        right,
        f_left,
        f_right,
    )
    .negative
}

/// Scan points per cell: `a + (end − a) l / SCAN`, `l = 0..=SCAN`.
const SCAN: usize = 8;

/// The validity indicators of one active set on a cell's scan points: their values and
/// slopes (`n_c × (SCAN + 1)`, row-major), from the trigonometric basis at the points, which
/// every contact shares — products with the basis instead of a `sin_cos` per contact and
/// point. The buffers are reused from cell to cell.
pub(in crate::method::redistributed) struct CellScan {
    pub(super) harmonics: usize,
    points: [f64; SCAN + 1],
    /// The basis and its derivative at the points (`(SCAN + 1) × (2H+1)`, row-major).
    basis: Vec<f64>,
    slope_basis: Vec<f64>,
    values: Vec<f64>,
    slopes: Vec<f64>,
    /// `(sub-interval, contact, is a minimum)` of the indicators still to be located.
    candidates: Vec<(usize, usize, bool)>,
    /// The derivative's coefficients of an indicator with a minimum in a sub-interval.
    derivative: Vec<f64>,
}

impl CellScan {
    pub(in crate::method::redistributed) fn new(harmonics: usize) -> Self {
        let ncoef = n_coefficients(harmonics);
        CellScan {
            harmonics,
            points: [0.0; SCAN + 1],
            basis: vec![0.0; (SCAN + 1) * ncoef],
            slope_basis: vec![0.0; (SCAN + 1) * ncoef],
            values: Vec::new(),
            slopes: Vec::new(),
            candidates: Vec::new(),
            derivative: Vec::new(),
        }
    }

    /// Scan `(a, end]` for the indicators with coefficients `coefs` (rows of `2H+1`).
    pub(in crate::method::redistributed) fn fill(&mut self, coefs: &[f64], a: f64, end: f64) {
        let h = self.harmonics;
        let ncoef = n_coefficients(h);
        for l in 0..=SCAN {
            let p = a + (end - a) * l as f64 / SCAN as f64;
            self.points[l] = p;
            let b = &mut self.basis[l * ncoef..(l + 1) * ncoef];
            basis_into(h, p, b);
            // d/dτ (a cos kτ + b sin kτ) = −k a sin kτ + k b cos kτ
            let d = &mut self.slope_basis[l * ncoef..(l + 1) * ncoef];
            d[0] = 0.0;
            for k in 1..=h {
                let kf = k as f64;
                d[2 * k - 1] = -kf * b[2 * k];
                d[2 * k] = kf * b[2 * k - 1];
            }
        }
        let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>();
        self.values.clear();
        self.slopes.clear();
        for coef in coefs.chunks_exact(ncoef) {
            for l in 0..=SCAN {
                self.values
                    .push(dot(coef, &self.basis[l * ncoef..(l + 1) * ncoef]));
                self.slopes
                    .push(dot(coef, &self.slope_basis[l * ncoef..(l + 1) * ncoef]));
            }
        }
    }

    fn value(&self, c: usize, l: usize) -> f64 {
        self.values[c * (SCAN + 1) + l]
    }

    fn slope(&self, c: usize, l: usize) -> f64 {
        self.slopes[c * (SCAN + 1) + l]
    }

    /// The first scan sub-interval `(p[l − 1], p[l]]`, `l ≥ from`, where indicator `c` may
    /// become negative: it is negative at `p[l]`, or its slope turns from negative to
    /// positive there (an interior minimum that may dip below zero: a grazing contact or a
    /// release shorter than the grid cell). `true` for a minimum.
    fn candidate(&self, c: usize, from: usize) -> Option<(usize, bool)> {
        (from..=SCAN).find_map(|l| {
            if self.value(c, l) < 0.0 {
                Some((l, false))
            } else if self.slope(c, l - 1) < 0.0 && self.slope(c, l) > 0.0 {
                Some((l, true))
            } else {
                None
            }
        })
    }

    /// The first time in `(a, end]` at which an indicator (rows of `coefs`) becomes
    /// negative, and which: the switching time (T47). Sub-interval by sub-interval: only the indicators whose first
    /// candidate lies in the earliest sub-interval are located to round-off (when many
    /// contacts switch within one cell, locating each of them at every switch would cost
    /// their number squared).
    pub(in crate::method::redistributed) fn earliest_root(
        &mut self,
        coefs: &[f64],
        ncoef: usize,
    ) -> Option<(f64, usize)> {
        let mut candidates = std::mem::take(&mut self.candidates);
        candidates.clear();
        for c in 0..coefs.len() / ncoef {
            if let Some((l, dip)) = self.candidate(c, 1) {
                candidates.push((l, c, dip));
            }
        }
        let p = self.points;
        let mut earliest: Option<(f64, usize)> = None;
        while let Some(l) = candidates.iter().map(|&(l, _, _)| l).min() {
            // locate the indicators of sub-interval l; a minimum that stays non-negative
            // moves on to its next candidate
            let mut q = 0;
            while q < candidates.len() {
                let (m, c, dip) = candidates[q];
                if m != l {
                    q += 1;
                    continue;
                }
                let coef = &coefs[c * ncoef..(c + 1) * ncoef];
                let root = if dip {
                    // the minimum in (p[l − 1], p[l]): the root of the derivative
                    let mut d = std::mem::take(&mut self.derivative);
                    derivative_into(coef, &mut d);
                    let (dprev, dp) = (self.slope(c, l - 1), self.slope(c, l));
                    let tmin = find_sign_change_with_slope(
                        |t| evaluate_with_slope(&d, t),
                        p[l - 1],
                        p[l],
                        dprev,
                        dp,
                    )
                    .midpoint();
                    self.derivative = d;
                    let value = evaluate(coef, tmin);
                    (value < 0.0).then(|| first_negative_time(coef, p[l - 1], tmin, value))
                } else {
                    Some(first_negative_time(coef, p[l - 1], p[l], self.value(c, l)))
                };
                match root {
                    Some(r) => {
                        if earliest.is_none_or(|(t, _)| r < t) {
                            earliest = Some((r, c));
                        }
                        candidates.swap_remove(q);
                    }
                    None => match self.candidate(c, l + 1) {
                        Some((m, d)) => {
                            candidates[q] = (m, c, d);
                            q += 1;
                        }
                        None => {
                            candidates.swap_remove(q);
                        }
                    },
                }
            }
            if earliest.is_some() {
                break;
            }
        }
        self.candidates = candidates;
        earliest
    }
}
