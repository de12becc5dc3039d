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
//! a switch.) Where the slope is known (the trigonometric polynomials of the redistributed
//! MS-HBM's quadrature, located at every residual evaluation),
//! [`find_sign_change_with_slope`] gets to the same kind of final bracket by
//! safeguarded Newton in ~10 evaluations; its results differ from bisection's at round-off
//! level.

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
    let mut bracket = Bracket::checked("find_sign_change", a, b, fa, fb);
    for _ in 0..200 {
        let Some(mid) = bracket.midpoint() else {
            break;
        };
        bracket.update(mid, f(mid));
    }
    bracket.sign_change()
}

/// [`find_sign_change`] for a smooth `f` whose slope is known: `f_and_slope(x)` gives
/// `(f(x), f'(x))`. Safeguarded Newton (a step that would leave the bracket, or a bracket
/// that has not halved over two steps, bisects instead) until a step is a few ulps; then
/// the other end of the bracket is brought next to the last point by doubling steps from
/// it, and bisection finishes on adjacent floating-point numbers. The final bracket is a
/// sign change of the computed `f`, as bisection's is, in ~10 evaluations instead of ~50
/// near a simple root. (Where round-off makes the computed `f` change sign more than once
/// within a few ulps it may be another of those changes than bisection's: the results
/// move at round-off level.)
///
/// # Panics
/// If `fa` and `fb` are both negative or both non-negative.
pub fn find_sign_change_with_slope(
    mut f_and_slope: impl FnMut(f64) -> (f64, f64),
    a: f64,
    b: f64,
    fa: f64,
    fb: f64,
) -> SignChange {
    let mut bracket = Bracket::checked("find_sign_change_with_slope", a, b, fa, fb);
    // 1. Newton from the evaluated point of smallest |f|, while it stays in the bracket and
    // halves |f|; bisection otherwise
    let mut latest: Option<(f64, f64, f64)> = None;
    let mut best: Option<(f64, f64, f64)> = None;
    let mut newton_allowed = true;
    for _ in 0..100 {
        let Some(mid) = bracket.midpoint() else {
            return bracket.sign_change();
        };
        let newton = best.filter(|_| newton_allowed).and_then(|(x, fx, dfx)| {
            let step = x - fx / dfx;
            (dfx != 0.0 && bracket.strictly_inside(step)).then_some(step)
        });
        let x = newton.unwrap_or(mid);
        let (fx, dfx) = f_and_slope(x);
        bracket.update(x, fx);
        latest = Some((x, fx, dfx));
        newton_allowed = best.is_none_or(|(_, fb, _)| fx.abs() <= 0.5 * fb.abs());
        if best.is_none_or(|(_, fb, _)| fx.abs() < fb.abs()) {
            best = Some((x, fx, dfx));
        }
        // the next Newton step would move by a few ulps: x is the root to round-off
        if dfx != 0.0 && (fx / dfx).abs() <= 4.0 * f64::EPSILON * x.abs().max(f64::MIN_POSITIVE) {
            break;
        }
    }
    // 2. the other end next to the latest point: steps of 1, 2, 4, … ulps towards it
    if let Some((x, fx, _)) = latest {
        let other = if fx < 0.0 {
            bracket.non_negative
        } else {
            bracket.negative
        };
        let direction = (other - x).signum();
        let mut step = f64::EPSILON * x.abs().max(f64::MIN_POSITIVE);
        for _ in 0..64 {
            let probe = x + direction * step;
            if !bracket.strictly_inside(probe) {
                break;
            }
            let (fp, _) = f_and_slope(probe);
            bracket.update(probe, fp);
            if (fp < 0.0) != (fx < 0.0) {
                break;
            }
            step *= 2.0;
        }
    }
    // 3. bisection to adjacent numbers
    while let Some(mid) = bracket.midpoint() {
        let (fm, _) = f_and_slope(mid);
        bracket.update(mid, fm);
    }
    bracket.sign_change()
}

/// A bracket `f(negative) < 0 ≤ f(non_negative)`.
struct Bracket {
    negative: f64,
    f_negative: f64,
    non_negative: f64,
    f_non_negative: f64,
}

impl Bracket {
    /// The bracket of `caller`'s sign change; panics (naming `caller`) when `fa`, `fb` do
    /// not have opposite signs.
    fn checked(caller: &str, a: f64, b: f64, fa: f64, fb: f64) -> Self {
        assert!(
            (fa < 0.0) != (fb < 0.0),
            "{caller}: f({a}) = {fa} and f({b}) = {fb} do not bracket a sign change"
        );
        let (negative, f_negative, non_negative, f_non_negative) = if fa < 0.0 {
            (a, fa, b, fb)
        } else {
            (b, fb, a, fa)
        };
        Bracket {
            negative,
            f_negative,
            non_negative,
            f_non_negative,
        }
    }

    fn ends(&self) -> (f64, f64) {
        (
            self.negative.min(self.non_negative),
            self.negative.max(self.non_negative),
        )
    }

    /// The midpoint, `None` when the ends are adjacent numbers.
    fn midpoint(&self) -> Option<f64> {
        let (lo, hi) = self.ends();
        let mid = 0.5 * (lo + hi);
        (mid > lo && mid < hi).then_some(mid)
    }

    fn strictly_inside(&self, x: f64) -> bool {
        let (lo, hi) = self.ends();
        x > lo && x < hi
    }

    fn update(&mut self, x: f64, fx: f64) {
        if fx < 0.0 {
            (self.negative, self.f_negative) = (x, fx);
        } else {
            (self.non_negative, self.f_non_negative) = (x, fx);
        }
    }

    fn sign_change(&self) -> SignChange {
        SignChange {
            negative: self.negative,
            f_negative: self.f_negative,
            non_negative: self.non_negative,
            f_non_negative: self.f_non_negative,
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

    /// The Newton finder ends on adjacent numbers with a sign change, at the root to the
    /// precision of `f`, in far fewer evaluations than bisection.
    fn check_with_slope(
        f: impl Fn(f64) -> f64 + Copy,
        df: impl Fn(f64) -> f64 + Copy,
        a: f64,
        b: f64,
        root: f64,
    ) -> usize {
        let mut calls = 0;
        let r = find_sign_change_with_slope(
            |x| {
                calls += 1;
                (f(x), df(x))
            },
            a,
            b,
            f(a),
            f(b),
        );
        assert!(r.f_negative < 0.0 && r.f_non_negative >= 0.0, "{r:?}");
        assert_eq!(f(r.negative), r.f_negative);
        assert_eq!(f(r.non_negative), r.f_non_negative);
        let (lo, hi) = (
            r.negative.min(r.non_negative),
            r.negative.max(r.non_negative),
        );
        assert!(
            0.5 * (lo + hi) == lo || 0.5 * (lo + hi) == hi,
            "adjacent: {r:?}"
        );
        assert!(
            (r.nearest() - root).abs() <= 4.0 * f64::EPSILON * root.abs().max(1.0),
            "root {root}: found {r:?}"
        );
        calls
    }

    #[test]
    fn newton_finds_the_sign_change_in_few_evaluations() {
        let p = |x: f64| ((x - 1.0) * (x - 2.0)) * (x + 3.0);
        let dp = |x: f64| 3.0 * x * x - 7.0;
        let calls = [
            check_with_slope(p, dp, 0.0, 1.5, 1.0),
            check_with_slope(p, dp, 1.5, 3.0, 2.0),
            check_with_slope(p, dp, -10.0, 0.0, -3.0),
            // a trigonometric polynomial as the quadratures meet them
            check_with_slope(
                |t: f64| 0.3 + (t - 0.2).cos() - 0.1 * (3.0 * t).sin(),
                |t: f64| -(t - 0.2).sin() - 0.3 * (3.0 * t).cos(),
                2.0,
                3.5,
                {
                    let f = |t: f64| 0.3 + (t - 0.2).cos() - 0.1 * (3.0 * t).sin();
                    let r = find_sign_change(f, 2.0, 3.5, f(2.0), f(3.5));
                    r.nearest()
                },
            ),
        ];
        assert!(calls.iter().all(|&c| c <= 20), "evaluations {calls:?}");
        // a double root's neighbourhood (slope vanishing at the root) still ends bracketed
        let q = |x: f64| (x - 1.0).powi(3);
        check_with_slope(q, |x: f64| 3.0 * (x - 1.0).powi(2), 0.0, 1.7, 1.0);
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
