//! Closed-form reference solutions of the continuum (docs/theory.md (T90) and (T93)): the
//! references of the time integrators and of the models that carry them.
//!
//! * [`DroppedBarSolution`] — the elastic bar dropped under gravity onto a rigid support
//!   (the paper's Figs. 3–5; Doyen, Ern & Piperno 2011): gap and contact force of the lower
//!   end, exactly periodic when `κ = v0 c/(g L)` is an integer.
//! * [`BouncingBarSolution`] — a bar clamped at one end, its other end lifted off a stop
//!   and released (no gravity): period `3L/c`.
//!
//! Both are solutions of the continuum (wave equation with Signorini at one end), derived
//! by d'Alembert's method; they are what the finite-element models converge to as the mesh
//! and the time step are refined.

use crate::error::{Error, Result};

/// The elastic bar dropped under gravity (docs/theory.md §12, (T88)–(T92)).
///
/// Bar of length `L`, wave speed `c = sqrt(E/ρ)`, mass per unit length `ρA`; released at
/// rest, undeformed, with its lower end at height `h0` above a rigid support. Time `t` is
/// measured from the release. With `v0 = sqrt(2 g h0)` (impact speed), `t1 = v0/g` (fall),
/// `T0 = 2L/c` (contact), `tf = 2 v0/g` (flight between the two contacts), the motion is
/// exactly periodic with period `T = 2 t1 + 2 T0 + tf = 4 (κ+1) L/c` iff
/// `κ = tf/T0 = v0 c/(g L)` is an integer (docs/theory.md (T89)); [`DroppedBarSolution::new`]
/// requires an integer `κ ≥ 3`.
#[derive(Clone, Debug, PartialEq)]
pub struct DroppedBarSolution {
    length: f64,
    wave_speed: f64,
    gravity: f64,
    height: f64,
    mass_per_length: f64,
}

impl DroppedBarSolution {
    /// `length` L, `wave_speed` c, `gravity` g (> 0, pointing down), drop `height` h0 of the
    /// lower end, `mass_per_length` ρA. Fails unless all are positive and `κ = v0 c/(g L)`
    /// is an integer ≥ 3 (to within 1e-9 relative).
    pub fn new(
        length: f64,
        wave_speed: f64,
        gravity: f64,
        height: f64,
        mass_per_length: f64,
    ) -> Result<Self> {
        for (name, v) in [
            ("length", length),
            ("wave_speed", wave_speed),
            ("gravity", gravity),
            ("height", height),
            ("mass_per_length", mass_per_length),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::argument(name, format!("must be positive, got {v}")));
            }
        }
        let s = DroppedBarSolution {
            length,
            wave_speed,
            gravity,
            height,
            mass_per_length,
        };
        let kappa = s.kappa();
        if (kappa - kappa.round()).abs() > 1e-9 * kappa || kappa.round() < 3.0 {
            return Err(Error::argument(
                "height",
                format!(
                    "the closed-form dropped-bar solution needs an integer kappa = v0 c/(g L) >= 3 \
                     (h0 = kappa^2 g L^2/(2 c^2)); h0 = {height} gives kappa = {kappa}"
                ),
            ));
        }
        Ok(s)
    }

    /// Drop height `h0 = κ² g L²/(2 c²)` for an integer `κ` (docs/theory.md (T89)).
    pub fn height_for_kappa(kappa: f64, length: f64, wave_speed: f64, gravity: f64) -> f64 {
        kappa * kappa * gravity * length * length / (2.0 * wave_speed * wave_speed)
    }

    pub fn length(&self) -> f64 {
        self.length
    }

    pub fn wave_speed(&self) -> f64 {
        self.wave_speed
    }

    pub fn gravity(&self) -> f64 {
        self.gravity
    }

    pub fn height(&self) -> f64 {
        self.height
    }

    /// Total mass `m = ρ A L`.
    pub fn mass(&self) -> f64 {
        self.mass_per_length * self.length
    }

    /// Impedance `Z = ρ A c`.
    pub fn impedance(&self) -> f64 {
        self.mass_per_length * self.wave_speed
    }

    /// Impact speed `v0 = sqrt(2 g h0)`.
    pub fn impact_speed(&self) -> f64 {
        (2.0 * self.gravity * self.height).sqrt()
    }

    /// Fall time `t1 = v0/g`.
    pub fn fall_time(&self) -> f64 {
        self.impact_speed() / self.gravity
    }

    /// Duration of each contact `T0 = 2L/c`.
    pub fn contact_duration(&self) -> f64 {
        2.0 * self.length / self.wave_speed
    }

    /// Flight time between the two contacts of a period, `tf = 2 v0/g`.
    pub fn flight_time(&self) -> f64 {
        2.0 * self.impact_speed() / self.gravity
    }

    /// `κ = tf/T0 = v0 c/(g L)`.
    pub fn kappa(&self) -> f64 {
        self.impact_speed() * self.wave_speed / (self.gravity * self.length)
    }

    /// Period `T = 2 t1 + 2 T0 + tf = 4 (κ+1) L/c`.
    pub fn period(&self) -> f64 {
        2.0 * self.fall_time() + 2.0 * self.contact_duration() + self.flight_time()
    }

    /// Start times of the two contacts within a period: `t1` and `tD = t1 + T0 + tf`.
    pub fn contact_starts(&self) -> [f64; 2] {
        let t1 = self.fall_time();
        [t1, t1 + self.contact_duration() + self.flight_time()]
    }

    /// Impulse of the support per contact, `2 m v0 + m g T0` (momentum balance).
    pub fn contact_impulse(&self) -> f64 {
        self.mass() * (2.0 * self.impact_speed() + self.gravity * self.contact_duration())
    }

    /// Total energy `m g h0` (datum: bar undeformed, resting on the support), constant.
    pub fn energy(&self) -> f64 {
        self.mass() * self.gravity * self.height
    }

    /// Gap of the lower end (height above the support) and upward contact force at time `t`
    /// from the release (docs/theory.md (T90), phases A–E, repeated with period `T`).
    pub fn state(&self, t: f64) -> (f64, f64) {
        let g = self.gravity;
        let v0 = self.impact_speed();
        let t1 = self.fall_time();
        let t0 = self.contact_duration();
        let tf = self.flight_time();
        let z = self.impedance();
        let t = t.rem_euclid(self.period());
        let td = t1 + t0 + tf;
        if t < t1 {
            // A: free fall
            (self.height - 0.5 * g * t * t, 0.0)
        } else if t < t1 + t0 {
            // B: first contact
            (0.0, z * (v0 + g * (t - t1)))
        } else if t < td {
            // C: flight with the bar vibrating ("scallops" of period T0)
            let tau = t - t1 - t0;
            let s = tau.rem_euclid(t0);
            (0.5 * g * tau * (tf - tau) - g * s * (t0 - s), 0.0)
        } else if t < td + t0 {
            // D: second contact
            (0.0, z * (v0 + g * (td + t0 - t)))
        } else {
            // E: rise back to the release height
            let r = t - td - t0;
            (v0 * r - 0.5 * g * r * r, 0.0)
        }
    }

    /// Gap of the lower end at time `t`.
    pub fn gap(&self, t: f64) -> f64 {
        self.state(t).0
    }

    /// Upward contact force of the support at time `t`.
    pub fn contact_force(&self, t: f64) -> f64 {
        self.state(t).1
    }
}

/// A bar clamped at one end whose other end is lifted by `a` off a stop and released at
/// rest, without gravity (docs/theory.md (T93); the GetFEM 1-D dynamic-contact benchmark).
///
/// Initial displacement linear from `0` at the clamp to `a` (away from the stop) at the
/// contact end. The motion is periodic with period `3L/c` in three phases of length `L/c`:
/// free (`gap = a (1 − c t/L)`), in contact (`gap = 0`, force `E A a/L`), free
/// (`gap = a (c t/L − 2)`). Energy `E A a²/(2L)` is conserved.
#[derive(Clone, Debug, PartialEq)]
pub struct BouncingBarSolution {
    length: f64,
    wave_speed: f64,
    lift: f64,
    axial_stiffness: f64,
}

impl BouncingBarSolution {
    /// `length` L, `wave_speed` c, initial `lift` a of the contact end (> 0), axial
    /// stiffness `E A`.
    pub fn new(length: f64, wave_speed: f64, lift: f64, axial_stiffness: f64) -> Result<Self> {
        for (name, v) in [
            ("length", length),
            ("wave_speed", wave_speed),
            ("lift", lift),
            ("axial_stiffness", axial_stiffness),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::argument(name, format!("must be positive, got {v}")));
            }
        }
        Ok(BouncingBarSolution {
            length,
            wave_speed,
            lift,
            axial_stiffness,
        })
    }

    /// Period `3L/c`.
    pub fn period(&self) -> f64 {
        3.0 * self.length / self.wave_speed
    }

    /// Contact closes at `L/c` and opens at `2L/c` (within each period).
    pub fn contact_interval(&self) -> (f64, f64) {
        let t = self.length / self.wave_speed;
        (t, 2.0 * t)
    }

    /// Gap of the contact end (its distance from the stop) at time `t` from the release.
    pub fn gap(&self, t: f64) -> f64 {
        let s = t.rem_euclid(self.period()) * self.wave_speed / self.length;
        if s < 1.0 {
            self.lift * (1.0 - s)
        } else if s < 2.0 {
            0.0
        } else {
            self.lift * (s - 2.0)
        }
    }

    /// Contact force at time `t`: `E A a/L` while in contact, zero otherwise.
    pub fn contact_force(&self, t: f64) -> f64 {
        let s = t.rem_euclid(self.period()) * self.wave_speed / self.length;
        if (1.0..2.0).contains(&s) {
            self.axial_stiffness * self.lift / self.length
        } else {
            0.0
        }
    }

    /// Total (elastic) energy `E A a²/(2L)`.
    pub fn energy(&self) -> f64 {
        0.5 * self.axial_stiffness * self.lift * self.lift / self.length
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nondimensional(kappa: f64) -> DroppedBarSolution {
        let h0 = DroppedBarSolution::height_for_kappa(kappa, 1.0, 1.0, 1.0);
        DroppedBarSolution::new(1.0, 1.0, 1.0, h0, 1.0).unwrap()
    }

    #[test]
    fn derived_quantities_of_methods_2_5() {
        let s = nondimensional(3.0);
        assert!((s.height() - 4.5).abs() < 1e-12);
        assert!((s.period() - 16.0).abs() < 1e-12);
        assert!((s.contact_duration() - 2.0).abs() < 1e-12);
        assert!((s.kappa() - 3.0).abs() < 1e-12);
        // period formula 4 (κ+1) L/c for other κ and units
        let h0 = DroppedBarSolution::height_for_kappa(5.0, 20.0, 4.8e6, 9810.0);
        let s = DroppedBarSolution::new(20.0, 4.8e6, 9810.0, h0, 9e-9).unwrap();
        assert!((s.period() / (4.0 * 6.0 * 20.0 / 4.8e6) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn rejects_non_integer_kappa() {
        assert!(DroppedBarSolution::new(1.0, 1.0, 1.0, 5.0, 1.0).is_err());
        let h0 = DroppedBarSolution::height_for_kappa(2.0, 1.0, 1.0, 1.0);
        assert!(DroppedBarSolution::new(1.0, 1.0, 1.0, h0, 1.0).is_err());
        assert!(DroppedBarSolution::new(1.0, -1.0, 1.0, 4.5, 1.0).is_err());
    }

    /// The gap is continuous (including across the phase boundaries and the period),
    /// non-negative, and zero exactly while the force is positive.
    #[test]
    fn gap_is_continuous_and_complementary() {
        for kappa in [3.0, 4.0, 7.0] {
            let s = nondimensional(kappa);
            let t = s.period();
            let n = 200_000;
            let dt = t / n as f64;
            let mut prev = s.gap(0.0);
            let slope_bound = s.impact_speed() + 2.0 * s.gravity() * s.contact_duration();
            for k in 1..=n {
                let (g, f) = s.state(k as f64 * dt);
                assert!(g >= -1e-12, "kappa {kappa}: gap {g} at step {k}");
                assert!(f >= 0.0 && g * f == 0.0);
                assert!(
                    (g - prev).abs() <= slope_bound * dt * 1.001,
                    "kappa {kappa}: jump {} at t = {}",
                    g - prev,
                    k as f64 * dt
                );
                prev = g;
            }
            assert!((s.gap(t) - s.height()).abs() < 1e-12);
        }
    }

    /// Impulse of each contact (trapezoidal integral of the force) equals the momentum
    /// change `2 m v0 + m g T0`; the force has the bottom-stress values of docs/theory.md (T91)–(T92).
    #[test]
    fn contact_impulse_is_the_momentum_change() {
        let h0 = DroppedBarSolution::height_for_kappa(4.0, 2.0, 3.0, 0.5);
        let s = DroppedBarSolution::new(2.0, 3.0, 0.5, h0, 1.7).unwrap();
        for start in s.contact_starts() {
            let n = 100_000;
            let t0 = s.contact_duration();
            let h = t0 / n as f64;
            let mut impulse = 0.0;
            for k in 0..n {
                let ta = start + k as f64 * h;
                impulse += 0.5
                    * h
                    * (s.contact_force(ta + 1e-12 * t0) + s.contact_force(ta + h - 1e-12 * t0));
            }
            assert!(
                (impulse / s.contact_impulse() - 1.0).abs() < 1e-8,
                "{impulse} vs {}",
                s.contact_impulse()
            );
        }
        // force at the start of the first contact = Z v0 (bottom stress E v0/c)
        let [t1, _] = s.contact_starts();
        assert!((s.contact_force(t1) - s.impedance() * s.impact_speed()).abs() < 1e-12);
    }

    /// Phase C agrees with the field solution of docs/theory.md (T92) evaluated at the lower end,
    /// `u(0, τ) = ū0 + v0 τ − g τ²/2 + η(c τ)` with `ū0 + η(s) = (2g/c²)(s²/2 − L s)` on
    /// `[0, 2L]` (η even and 2L-periodic); the mean acceleration of the end over `T0` is `−g`.
    #[test]
    fn flight_phase_matches_the_field_solution() {
        let h0 = DroppedBarSolution::height_for_kappa(3.0, 1.5, 2.0, 0.8);
        let s = DroppedBarSolution::new(1.5, 2.0, 0.8, h0, 1.0).unwrap();
        let (l, c, g, v0) = (1.5, 2.0, 0.8, s.impact_speed());
        let t0 = s.contact_duration();
        let lift_off = s.fall_time() + t0;
        for k in 0..=1000 {
            let tau = s.flight_time() * k as f64 / 1000.0;
            let sigma = (c * tau).rem_euclid(2.0 * l);
            let field = v0 * tau - 0.5 * g * tau * tau
                + 2.0 * g / (c * c) * (0.5 * sigma * sigma - l * sigma);
            let gap = s.gap(lift_off + tau * (1.0 - 1e-15));
            assert!((gap - field).abs() < 1e-12, "tau {tau}: {gap} vs {field}");
        }
        let v = |tau: f64| (s.gap(lift_off + tau + 1e-7) - s.gap(lift_off + tau - 1e-7)) / 2e-7;
        let dv = v(1.5 * t0) - v(0.5 * t0);
        assert!((dv / t0 + g).abs() < 1e-6, "{dv}");
    }

    #[test]
    fn bouncing_bar_phases() {
        let b = BouncingBarSolution::new(20.0, 5.0, 0.1, 3.0).unwrap();
        assert!((b.period() - 12.0).abs() < 1e-12);
        assert!((b.gap(0.0) - 0.1).abs() < 1e-15);
        assert!(b.gap(4.5) == 0.0 && b.contact_force(4.5) > 0.0);
        assert!((b.gap(10.0) - 0.1 * 0.5).abs() < 1e-15);
        assert!((b.gap(12.0) - 0.1).abs() < 1e-12);
        assert!((b.contact_force(5.0) - 3.0 * 0.1 / 20.0).abs() < 1e-15);
        assert_eq!(b.contact_force(9.0), 0.0);
        assert!(BouncingBarSolution::new(1.0, 1.0, 0.0, 1.0).is_err());
    }
}
