//! The scalar root finder of the library: a sign change of a continuous function bracketed
//! in `[a, b]` is narrowed to two adjacent floating-point numbers (the switching times of
//! the exact quadratures, paper eqs. 33–35, and the extrema of the gaps between them).
//!
//! Illinois (modified regula falsi) steps, safeguarded by bisection whenever two steps have
//! not halved the bracket, so that it never needs more than about twice the steps of
//! bisection and usually far fewer. The two classes of the bracket are `f < 0` and
//! `f ≥ 0` (an exact zero is in the non-negative class), so the result does not depend on
//! the path taken: wherever the computed `f` changes class only once in the bracket, the
//! final bracket is the same pair of neighbouring numbers that bisection finds.

/// The final bracket of [`find_sign_change`]: `negative` and `non_negative` are adjacent
/// floating-point numbers (or as close as 200 steps get), with `f(negative) < 0 ≤
/// f(non_negative)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SignChange {
    /// The end where `f < 0`, and its value.
    pub negative: f64,
    pub f_negative: f64,
    /// The end where `f ≥ 0`, and its value.
    pub non_negative: f64,
    pub f_non_negative: f64,
}

impl SignChange {
    /// The end with the smaller `|f|` (the root to the precision of `f`).
    pub fn nearest(&self) -> f64 {
        if self.f_negative.abs() < self.f_non_negative.abs() {
            self.negative
        } else {
            self.non_negative
        }
    }

    /// The midpoint of the final bracket (one of its ends when they are adjacent numbers).
    pub fn midpoint(&self) -> f64 {
        0.5 * (self.negative + self.non_negative)
    }
}

/// Narrow the sign change of `f` between `a` and `b` (either order of signs) with the
/// known values `fa = f(a)`, `fb = f(b)`, one negative and one not (a value that is not a
/// number counts as non-negative, as in a test `f < 0`).
///
/// # Panics
/// If `fa` and `fb` are both negative or both non-negative.
pub fn find_sign_change(
    mut f: impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    fa: f64,
    fb: f64,
) -> SignChange {
    assert!(
        (fa < 0.0) != (fb < 0.0),
        "find_sign_change: f({a}) = {fa} and f({b}) = {fb} do not bracket a sign change"
    );
    // lo < hi; the Illinois rule scales the retained end's working value
    let (mut lo, mut hi, mut f_lo, mut f_hi) = if a < b {
        (a, b, fa, fb)
    } else {
        (b, a, fb, fa)
    };
    let lo_negative = f_lo < 0.0;
    let (mut true_lo, mut true_hi) = (f_lo, f_hi);
    let mut side = 0i8;
    // bracket widths before the last two steps (none yet)
    let mut widths = [f64::INFINITY; 2];
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        let falsi = (lo * f_hi - hi * f_lo) / (f_hi - f_lo);
        // bisection when the falsi point is not inside or two steps have not halved the bracket
        let x = if falsi > lo && falsi < hi && hi - lo <= 0.5 * widths[0] {
            falsi
        } else {
            mid
        };
        widths = [widths[1], hi - lo];
        let fx = f(x);
        if (fx < 0.0) == lo_negative {
            (lo, f_lo, true_lo) = (x, fx, fx);
            if side == -1 {
                f_hi *= 0.5;
            }
            side = -1;
        } else {
            (hi, f_hi, true_hi) = (x, fx, fx);
            if side == 1 {
                f_lo *= 0.5;
            }
            side = 1;
        }
    }
    if lo_negative {
        SignChange {
            negative: lo,
            f_negative: true_lo,
            non_negative: hi,
            f_non_negative: true_hi,
        }
    } else {
        SignChange {
            negative: hi,
            f_negative: true_hi,
            non_negative: lo,
            f_non_negative: true_lo,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bisection to adjacent numbers: the reference the finder must reproduce.
    fn bisection(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> (f64, f64) {
        let lo_negative = f(lo) < 0.0;
        loop {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                return (lo, hi);
            }
            if (f(mid) < 0.0) == lo_negative {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    }

    fn check(f: impl Fn(f64) -> f64 + Copy, a: f64, b: f64, root: f64) -> usize {
        let mut calls = 0;
        let r = find_sign_change(
            |x| {
                calls += 1;
                f(x)
            },
            a,
            b,
            f(a),
            f(b),
        );
        assert!(r.f_negative < 0.0 && r.f_non_negative >= 0.0, "{r:?}");
        assert_eq!(f(r.negative), r.f_negative);
        assert_eq!(f(r.non_negative), r.f_non_negative);
        let (lo, hi) = bisection(f, a.min(b), a.max(b));
        let (rlo, rhi) = (
            r.negative.min(r.non_negative),
            r.negative.max(r.non_negative),
        );
        assert_eq!((rlo, rhi), (lo, hi), "same final bracket as bisection");
        assert!(
            (r.nearest() - root).abs() <= 4.0 * f64::EPSILON * root.abs().max(1.0),
            "root {root}: found {r:?}"
        );
        calls
    }

    #[test]
    fn polynomial_roots() {
        // (x − 1)(x − 2)(x + 3) = x³ − 7x + 6
        let p = |x: f64| ((x - 1.0) * (x - 2.0)) * (x + 3.0);
        check(p, 0.0, 1.5, 1.0);
        check(p, 1.5, 3.0, 2.0);
        check(p, -10.0, 0.0, -3.0);
        check(p, 3.0, 1.5, 2.0); // reversed bracket
                                 // x² − 2: √2; a high-order root (x − 0.3)⁵ (slow for regula falsi)
        check(|x| x * x - 2.0, 0.0, 2.0, 2f64.sqrt());
        let calls = check(|x: f64| (x - 0.3).powi(5), 0.0, 1.0, 0.3);
        assert!(calls <= 2 * 64, "{calls} evaluations");
    }

    #[test]
    fn trigonometric_polynomial_roots() {
        // cos τ − ½ on [0, π]: π/3; sin 3τ on [0.5, 1.5]: π/3; sin τ + sin 2τ = sin τ (1 + 2 cos τ)
        // on [1, 3]: 2π/3
        check(
            |t: f64| t.cos() - 0.5,
            0.0,
            std::f64::consts::PI,
            std::f64::consts::FRAC_PI_3,
        );
        check(
            |t: f64| (3.0 * t).sin(),
            0.5,
            1.5,
            std::f64::consts::FRAC_PI_3,
        );
        let two_thirds_pi = 2.0 * std::f64::consts::FRAC_PI_3;
        let calls = check(|t: f64| t.sin() + (2.0 * t).sin(), 1.0, 3.0, two_thirds_pi);
        assert!(
            calls < 20,
            "Illinois converges superlinearly: {calls} evaluations"
        );
        // a root at an end of the bracket: f(a) = 0 is the non-negative class
        let r = find_sign_change(|t: f64| -t.sin(), 0.0, 1.0, 0.0, -(1f64.sin()));
        assert_eq!(r.non_negative, 0.0);
        assert!(r.negative > 0.0 && r.negative < 1e-55, "{r:?}");
    }

    #[test]
    #[should_panic(expected = "do not bracket")]
    fn refuses_a_bracket_without_sign_change() {
        find_sign_change(|x| x * x + 1.0, -1.0, 1.0, 2.0, 2.0);
    }
}
