//! Settings of a frequency response diagram, validated, with documented defaults.

use crate::continuation::arclength::ContinuationOptions;
use crate::error::{OptionError, Result};
use crate::limits::Limits;
use crate::method::SetupObserver;
use crate::model::Model;
use crate::newton::NewtonOptions;

/// Default first arclength step.
pub const DEFAULT_INITIAL_STEP: f64 = 0.01;
/// Default largest arclength step.
pub const DEFAULT_MAX_STEP: f64 = 0.1;
/// Default smallest arclength step.
pub const DEFAULT_MIN_STEP: f64 = 1e-12;
/// Default largest turn of the tangent between two points, degrees.
pub const DEFAULT_MAX_TURN_DEG: f64 = 20.0;
/// Default most points per branch.
pub const DEFAULT_MAX_POINTS: usize = 20_000;

/// What to trace and how finely. Step sizes are in the continuation's scaled arclength
/// (unknowns divided by the model's length scale, frequency as `ln(ω/ω_start)`).
#[derive(Clone, Debug)]
pub struct FrdSettings {
    /// Start frequency (Hz): the branch starts from the contact-free response there.
    pub from_hz: f64,
    /// End frequency (Hz); below `from_hz` for a downward sweep.
    pub to_hz: f64,
    /// First arclength step (default 0.01).
    pub initial_step: f64,
    /// Smallest arclength step (default 1e-12): below it the branch stops and says why.
    /// Grazing contacts turn a branch within very short arcs, so this is small.
    pub min_step: f64,
    /// Largest arclength step (default 0.1).
    pub max_step: f64,
    /// Largest turn of the tangent between two points, degrees (default 20).
    pub max_turn_deg: f64,
    /// Newton of the first point and of every corrector (default: tolerance 1e-10 relative
    /// to the length scale, 50 iterations).
    pub newton: NewtonOptions,
    /// Compute the Floquet multipliers of every point (default `false`), for the methods
    /// that provide them: stable/unstable parts and stability changes.
    pub stability: bool,
    /// The model DOF whose extremes the points report (`None`: the first DOF of the first
    /// contact, or of the first friction element).
    pub response_dof: Option<usize>,
    /// Most points per branch (default 20 000): a safety limit.
    pub max_points: usize,
    /// The memory budget each branch's method is checked against before it allocates
    /// (default: the machine's memory, [`Limits::default`]).
    pub limits: Limits,
    /// Told the phases of each branch's method set-up (progress on large models).
    pub setup_observer: Option<SetupObserver>,
}

impl FrdSettings {
    /// The defaults for a sweep from `from_hz` to `to_hz`.
    pub fn new(from_hz: f64, to_hz: f64) -> Self {
        FrdSettings {
            from_hz,
            to_hz,
            initial_step: DEFAULT_INITIAL_STEP,
            min_step: DEFAULT_MIN_STEP,
            max_step: DEFAULT_MAX_STEP,
            max_turn_deg: DEFAULT_MAX_TURN_DEG,
            newton: NewtonOptions::default(),
            stability: false,
            response_dof: None,
            max_points: DEFAULT_MAX_POINTS,
            limits: Limits::default(),
            setup_observer: None,
        }
    }

    /// Refuse settings that cannot describe a sweep: frequencies in Hz here, the steps, turn,
    /// point limit and Newton settings as the continuation checks them
    /// ([`ContinuationOptions::validate`]).
    pub fn validate(&self) -> Result<()> {
        check_frequencies(self.from_hz, self.to_hz)?;
        self.continuation().validate()
    }

    /// The continuation settings of one branch.
    pub fn continuation(&self) -> ContinuationOptions {
        let two_pi = 2.0 * std::f64::consts::PI;
        let mut options = ContinuationOptions::new(two_pi * self.from_hz, two_pi * self.to_hz);
        options.initial_step = self.initial_step;
        options.max_step = self.max_step;
        options.min_step = self.min_step;
        options.max_turn_deg = self.max_turn_deg;
        options.newton = self.newton.clone();
        options.newton.cancel = self.newton.cancel.or(self.limits.cancel);
        options.max_points = self.max_points;
        options
    }
}

/// The sweep's end frequencies [Hz]: positive, finite and different.
pub fn check_frequencies(from_hz: f64, to_hz: f64) -> std::result::Result<(), OptionError> {
    for (name, v) in [("from_hz", from_hz), ("to_hz", to_hz)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(OptionError::new(
                name,
                format!("⟨{name}⟩ must be a positive number of Hz, got {v}"),
            ));
        }
    }
    if from_hz == to_hz {
        return Err(OptionError::new(
            "to_hz",
            "⟨from_hz⟩ and ⟨to_hz⟩ must differ",
        ));
    }
    Ok(())
}

/// The response DOF of `model` (model numbering): `requested`, or the first DOF of the
/// first contact (else of the first friction element).
pub fn response_dof(
    model: &Model,
    requested: Option<usize>,
) -> std::result::Result<usize, OptionError> {
    let dof = match requested {
        Some(d) => d,
        None => match (model.contacts.first(), model.frictions.first()) {
            (Some(c), _) => c.dofs[0],
            (None, Some(f)) => f.dofs[0],
            (None, None) => {
                return Err(OptionError::new(
                    "dof",
                    "the model has no contact and no friction element: give ⟨dof⟩",
                ))
            }
        },
    };
    if dof >= model.n_dofs() {
        return Err(OptionError::new(
            "dof",
            format!(
                "⟨dof⟩ {dof} out of range: the model has DOFs 0..{}",
                model.n_dofs() - 1
            ),
        ));
    }
    Ok(dof)
}
