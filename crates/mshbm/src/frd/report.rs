//! What a frequency response diagram reports: its points, folds, stability changes and why
//! each branch stopped (serialised as `mshbm frf --json`).

use serde::Serialize;

use crate::continuation::arclength::StopReason;
use crate::solution::{MethodKind, StateFractions};
use crate::stability::Crossing;

/// One point of a branch: the extremes and first-harmonic amplitude of the response DOF.
#[derive(Clone, Debug, Serialize)]
pub struct FrdPoint {
    pub frequency_hz: f64,
    /// Largest and smallest displacement of the response DOF over the period.
    pub max_qn: f64,
    pub min_qn: f64,
    /// `√(a1² + b1²)` of the response DOF.
    pub amplitude_h1: f64,
    /// `‖R‖_∞` relative to the problem's length scale.
    pub residual_norm: f64,
    /// Corrector iterations spent on the point (0 for a located fold).
    pub newton_iterations: usize,
    /// The point is a located fold (turning point in frequency).
    pub fold: bool,
    /// Stable (all Floquet multipliers inside the unit circle), when computed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable: Option<bool>,
    /// Largest Floquet multiplier modulus, when computed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_multiplier: Option<f64>,
    /// Why the stability is unknown: asked for (`FrdSettings::stability`) and not
    /// computable at this point (e.g. an eigenvalue problem that did not converge);
    /// `stable` and `max_multiplier` are then `None`, and the diagram goes on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stability_unknown: Option<String>,
    /// HBM-AFT: largest penetration `max(−g)` over the contacts and the time samples.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_penetration: Option<f64>,
    /// Contacts with friction: the energy the friction dissipates per period
    /// (docs/theory.md (T180)).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dissipated_energy: Option<f64>,
    /// Contacts with friction: per contact, the fractions of the period stuck, slipping and
    /// open (docs/theory.md (T181)).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub state_fractions: Option<Vec<StateFractions>>,
}

/// A located fold of a branch.
#[derive(Clone, Debug, Serialize)]
pub struct FoldReport {
    pub harmonics: usize,
    /// The branch's label (see [`BranchReport::label`]).
    pub label: String,
    pub frequency_hz: f64,
    pub max_qn: f64,
    pub min_qn: f64,
    pub amplitude_h1: f64,
    /// The branch turns at a kink of a nonsmooth residual rather than at a smooth fold.
    pub at_kink: bool,
}

/// A multiplier crossing the unit circle between two neighbouring points of a branch.
#[derive(Clone, Debug, Serialize)]
pub struct BifurcationReport {
    pub harmonics: usize,
    pub label: String,
    /// "fold" (+1), "period-doubling" (−1) or "neimark-sacker" (complex pair).
    pub kind: Crossing,
    /// Where the largest multiplier modulus passes 1, interpolated linearly in frequency
    /// between the two points (their midpoint when it does not pass 1 between them).
    pub frequency_hz: f64,
    /// Extremes of the response at the later of the two points.
    pub max_qn: f64,
    pub min_qn: f64,
}

/// One traced branch.
#[derive(Clone, Debug, Serialize)]
pub struct BranchReport {
    pub harmonics: usize,
    pub method: MethodKind,
    /// "H = 5", or "HBM-AFT kp = 1.000e7, H = 5" when several methods share a diagram.
    pub label: String,
    /// HBM-AFT: penalty stiffness of the (first) contact.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub penalty: Option<f64>,
    pub points: Vec<FrdPoint>,
    /// "reached … Hz", or why the branch stopped ([`describe_stop`]).
    pub stop: String,
    /// The branch reached the end frequency.
    pub completed: bool,
    /// Points found by stepping in frequency where the arclength step failed (methods
    /// whose policy asks for it): a fold between two of them would be jumped over.
    pub frequency_steps: usize,
    /// Why the branch stopped.
    #[serde(skip)]
    pub stop_reason: StopReason,
}

/// A whole diagram: its branches, and the folds and stability changes of all of them.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrdReport {
    pub branches: Vec<BranchReport>,
    pub folds: Vec<FoldReport>,
    /// Stability changes between neighbouring points (when stability is computed).
    pub bifurcations: Vec<BifurcationReport>,
}

impl FrdReport {
    /// Whether every branch reached its end frequency.
    pub fn completed(&self) -> bool {
        self.branches.iter().all(|b| b.completed)
    }
}

/// Why a branch stopped, in words (`to_hz`: the end frequency it was traced to).
pub fn describe_stop(stop: &StopReason, to_hz: f64) -> String {
    match stop {
        StopReason::ReachedEnd => format!("reached {to_hz} Hz"),
        StopReason::LeftRange => "the branch turned back past the start frequency without reaching the end (it may have retraced itself after a sharp turn)".into(),
        StopReason::MaxPoints => "point limit reached".into(),
        StopReason::StartFailed(why) => format!("no solution at the start frequency: {why}"),
        StopReason::Retraced { omega } => format!(
            "stopped at {:.3} Hz: the branch came back onto a fold it had passed (it retraces itself after a sharp turn it could not resolve)",
            omega / (2.0 * std::f64::consts::PI)
        ),
        StopReason::StepTooSmall { omega, reason } => {
            format!("stopped at {:.3} Hz: {reason}", omega / (2.0 * std::f64::consts::PI))
        }
    }
}

/// A branch's values at one frequency ([`branch_values_at`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BranchValue {
    pub max: f64,
    pub min: f64,
    /// Stability of the nearer neighbouring point, when computed.
    pub stable: Option<bool>,
}

/// The extremes of a branch at `frequency_hz`, linearly interpolated between neighbouring
/// points (folds left out); where the branch passes the frequency several times, the
/// crossing whose min is closest to `near_min`. `None` where the branch does not reach the
/// frequency.
pub fn branch_values_at(
    points: &[FrdPoint],
    frequency_hz: f64,
    near_min: f64,
) -> Option<BranchValue> {
    let pts: Vec<&FrdPoint> = points.iter().filter(|p| !p.fold).collect();
    let mut best: Option<BranchValue> = None;
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let (fa, fb) = (a.frequency_hz, b.frequency_hz);
        if (fa - frequency_hz) * (fb - frequency_hz) > 0.0 || fa == fb {
            continue;
        }
        let t = (frequency_hz - fa) / (fb - fa);
        let v = BranchValue {
            max: a.max_qn + t * (b.max_qn - a.max_qn),
            min: a.min_qn + t * (b.min_qn - a.min_qn),
            stable: if t < 0.5 { a.stable } else { b.stable },
        };
        if best.is_none_or(|m| (v.min - near_min).abs() < (m.min - near_min).abs()) {
            best = Some(v);
        }
    }
    best
}
