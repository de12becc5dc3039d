//! When a simulated response counts as periodic: the two period-to-period measures of
//! [`simulate_to_steady_state`](super::steady_state::simulate_to_steady_state).
//!
//! * [`Periodicity::Response`] (default, docs/theory.md (T97)): the harmonics `0..=H` (the
//!   reported ones) of the displacements of the **reported DOFs** — the response DOF and the
//!   first DOF of each contact — compared with those of the previous period, relative to the
//!   largest displacement magnitude of those DOFs over the two periods,
//!
//!   `δ_p = max_r max_{0≤k≤H} |Δĉ_{r,k}| / S_p`, `|Δĉ_{r,0}| = |Δa_{r,0}|`,
//!   `|Δĉ_{r,k}| = √(Δa_{r,k}² + Δb_{r,k}²)`,
//!   `S_p = max(max_{r,j} |q_r(t_j)| over periods p−1 and p, 10⁻⁶ max_c |g_{0,c}|)`,
//!
//!   and `δ_p = 0` when nothing changed (a response that stays exactly at rest, e.g. without
//!   load). High modes that ring after every contact event but do not move the reported
//!   harmonics do not count.
//! * [`Periodicity::State`] (docs/theory.md (T70)): the whole state of the DOFs with mass
//!   at the end of the period, `max(‖Δq‖∞, ‖Δv‖∞/ω) / A` with `A` the largest displacement
//!   amplitude of the structure — every mode counts, also those no output shows.

use serde::{Deserialize, Serialize};

/// The period-to-period measure that decides whether a simulated response is periodic
/// (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Periodicity {
    /// Harmonics of the displacements of the response DOF and the contact DOFs
    /// (docs/theory.md (T97)).
    #[default]
    Response,
    /// Displacements and velocities of every DOF with mass (docs/theory.md (T70)).
    State,
}

impl Periodicity {
    /// The default tolerance of the measure: `1e-3` for [`Periodicity::Response`] (the
    /// reported harmonics repeat to 0.1 % of the response), `1e-6` for
    /// [`Periodicity::State`].
    pub fn default_tolerance(self) -> f64 {
        match self {
            Periodicity::Response => 1e-3,
            Periodicity::State => 1e-6,
        }
    }

    /// Short name for reports (`"response"`, `"state"`).
    pub fn name(self) -> &'static str {
        match self {
            Periodicity::Response => "response",
            Periodicity::State => "state",
        }
    }
}

/// Fraction of the largest initial gap below which a displacement counts as zero in the
/// scale `S_p` of docs/theory.md (T97).
pub(super) const GAP_FLOOR: f64 = 1e-6;

/// What one period leaves for the comparison with later ones.
#[derive(Clone, Debug)]
pub(super) enum PeriodRecord {
    /// [`Periodicity::State`]: displacements and velocities of the DOFs with mass at the
    /// end of the period (or at the start of the run).
    State { q: Vec<f64>, v: Vec<f64> },
    /// [`Periodicity::Response`]: the DFT coefficients (docs/theory.md (T10)) of each
    /// reported DOF over the period, and the largest displacement magnitude of those DOFs.
    Response {
        coefficients: Vec<Vec<f64>>,
        magnitude: f64,
    },
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
}

/// `d / scale`, with `0` when nothing changed and `∞` when something changed at zero scale.
fn relative(d: f64, scale: f64) -> f64 {
    if d == 0.0 {
        0.0
    } else if scale > 0.0 {
        d / scale
    } else {
        f64::INFINITY
    }
}

/// Largest amplitude of the change of one harmonic between two coefficient vectors
/// `[a0, a1, b1, …, aH, bH]`: `max(|Δa0|, max_k √(Δa_k² + Δb_k²))` (docs/theory.md (T97)).
pub(super) fn harmonic_change(now: &[f64], old: &[f64]) -> f64 {
    let mut d = (now[0] - old[0]).abs();
    for k in 0..(now.len() - 1) / 2 {
        let (i, j) = (2 * k + 1, 2 * k + 2);
        d = d.max((now[i] - old[i]).hypot(now[j] - old[j]));
    }
    d
}

impl PeriodRecord {
    /// The period-to-period change from `old` to `self`: (T97) for response records, (T70)
    /// for state records with `omega` [rad/s] and `amplitude` (the largest displacement
    /// amplitude of the DOFs with mass over the current period). `gap_scale` is the largest
    /// initial gap `max_c |g_{0,c}|`. Records of different kinds never repeat (`∞`).
    pub(super) fn change_from(
        &self,
        old: &PeriodRecord,
        omega: f64,
        amplitude: f64,
        gap_scale: f64,
    ) -> f64 {
        match (self, old) {
            (PeriodRecord::State { q, v }, PeriodRecord::State { q: q0, v: v0 }) => {
                let d = max_abs_diff(q, q0).max(max_abs_diff(v, v0) / omega);
                relative(d, amplitude)
            }
            (
                PeriodRecord::Response {
                    coefficients,
                    magnitude,
                },
                PeriodRecord::Response {
                    coefficients: c0,
                    magnitude: m0,
                },
            ) => {
                let d = coefficients
                    .iter()
                    .zip(c0)
                    .fold(0.0f64, |m, (a, b)| m.max(harmonic_change(a, b)));
                relative(d, magnitude.max(*m0).max(GAP_FLOOR * gap_scale))
            }
            _ => f64::INFINITY,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn harmonic_change_is_the_amplitude_of_the_change_per_harmonic() {
        // Δ = [0.5, (3, 4), (0, −1)]: harmonic 1 changes by amplitude 5
        let old = [1.0, 1.0, 1.0, 2.0, 2.0];
        let now = [1.5, 4.0, 5.0, 2.0, 1.0];
        assert_eq!(harmonic_change(&now, &old), 5.0);
        assert_eq!(harmonic_change(&old, &old), 0.0);
    }

    #[test]
    fn a_response_at_rest_repeats_and_a_change_at_zero_scale_does_not() {
        let rest = PeriodRecord::Response {
            coefficients: vec![vec![0.0; 3]],
            magnitude: 0.0,
        };
        assert_eq!(rest.change_from(&rest, 1.0, 0.0, 0.0), 0.0);
        let moved = PeriodRecord::Response {
            coefficients: vec![vec![0.0, 1e-3, 0.0]],
            magnitude: 1e-3,
        };
        // relative to the larger magnitude of the two periods
        assert_eq!(moved.change_from(&rest, 1.0, 0.0, 0.0), 1.0);
        // the gap floor: 1e-3 against 1e-6 · 2000
        assert_eq!(moved.change_from(&rest, 1.0, 0.0, 2000.0), 0.5);
        let state = PeriodRecord::State {
            q: vec![0.0],
            v: vec![0.0],
        };
        assert_eq!(moved.change_from(&state, 1.0, 1.0, 0.0), f64::INFINITY);
    }
}
