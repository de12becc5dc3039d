//! The scalar root finder of the library: a sign change of a continuous function bracketed
//! in `[a, b]` is narrowed to two adjacent floating-point numbers (the switching times of
//! the exact quadratures, paper eqs. 33–35, and the extrema of the gaps between them).
//!
//! Bisection, with the classes `f < 0` and `f ≥ 0` (an exact zero is in the non-negative
//! class), until the midpoint of the bracket is one of its ends. Its result is the sign
//! change that the computed `f` has, to the last bit, whatever the conditioning of the root,
//! and it is reproducible: the exact quadratures' switching times are the ones they had with
//! their own bisection. (An Illinois regula falsi needs fewer evaluations, ~10 instead of
//! ~50, but where round-off makes the computed `f` change sign more than once within a few
//! ulps it lands on another of those changes: tried here, it moved the converged MS-HBM
//! solutions at round-off level, ~1e-13 of their scale and more for single samples next to
//! a switch; the evaluations are a negligible part of a residual.)

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
    let (mut negative, mut f_negative, mut non_negative, mut f_non_negative) = if fa < 0.0 {
        (a, fa, b, fb)
    } else {
        (b, fb, a, fa)
    };
    for _ in 0..200 {
        let mid = 0.5 * (negative + non_negative);
        let (lo, hi) = (negative.min(non_negative), negative.max(non_negative));
        if mid <= lo || mid >= hi {
            break;
        }
        let f_mid = f(mid);
        if f_mid < 0.0 {
            (negative, f_negative) = (mid, f_mid);
        } else {
            (non_negative, f_non_negative) = (mid, f_mid);
        }
    }
    SignChange {
        negative,
        f_negative,
        non_negative,
        f_non_negative,
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
        assert!(calls <= 64, "{calls} evaluations");
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
        assert!(calls <= 60, "{calls} evaluations");
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
