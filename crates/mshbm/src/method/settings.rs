//! Typed settings of the three periodic-solution methods, and the one place where a method is
//! built from them into a [`PeriodicProblem`]. The CLI, the tests, the benchmarks and
//! `mshbm paper` all build their methods here, so they run the same algorithm by
//! construction (the continuation policy comes with the problem,
//! [`PeriodicProblem::continuation_policy`]).

use super::general::{GeneralMsHbm, GeneralOptions};
use super::hbm_aft::{HbmAft, HbmAftOptions, Penalty};
use super::redistributed::{RedistributedMsHbm, RedistributedOptions};
use super::SetupObserver;
use crate::error::{Error, Result};
use crate::limits::Limits;
use crate::model::{MassKind, Model};
use crate::problem::PeriodicProblem;
use crate::solution::MethodKind;
use crate::stability::StabilityOptions;

/// A method with its options.
#[derive(Clone, Debug)]
pub enum MethodSettings {
    /// The redistributed MS-HBM, with the settings of its Floquet analysis.
    Redistributed {
        options: RedistributedOptions,
        stability: StabilityOptions,
    },
    /// The general MS-HBM.
    General(GeneralOptions),
    /// The HBM-AFT baseline with penalty contact.
    HbmAft(HbmAftOptions),
}

/// A method built for one model.
pub struct BuiltMethod {
    pub problem: Box<dyn PeriodicProblem>,
    /// For people: "MS-HBM", "general MS-HBM" or "HBM-AFT kp = 1.050e8".
    pub label: String,
    /// HBM-AFT: the penalty stiffness of the (first) contact.
    pub penalty: Option<f64>,
}

impl MethodSettings {
    /// The mass the method solves with: the redistributed MS-HBM's redistributed mass, the
    /// general MS-HBM's consistent one, HBM-AFT's choice. The whole structure's response
    /// to a solution ([`crate::simulation::field_harmonics`]) is that of this mass.
    pub fn mass_kind(&self) -> MassKind {
        match self {
            MethodSettings::Redistributed { .. } => MassKind::Redistributed,
            MethodSettings::HbmAft(o) => o.mass,
            MethodSettings::General(_) => MassKind::Consistent,
        }
    }

    /// The redistributed MS-HBM with `harmonics`, default samples, exact quadrature and
    /// the default stability basis.
    pub fn redistributed(harmonics: usize) -> Self {
        MethodSettings::Redistributed {
            options: RedistributedOptions::new(harmonics),
            stability: StabilityOptions::default(),
        }
    }

    pub fn kind(&self) -> MethodKind {
        match self {
            MethodSettings::Redistributed { .. } => MethodKind::Redistributed,
            MethodSettings::General(_) => MethodKind::General,
            MethodSettings::HbmAft(_) => MethodKind::HbmAft,
        }
    }

    /// Number of harmonics `H`.
    pub fn harmonics(&self) -> usize {
        match self {
            MethodSettings::Redistributed { options, .. } => options.harmonics,
            MethodSettings::General(o) => o.harmonics,
            MethodSettings::HbmAft(o) => o.harmonics,
        }
    }

    /// The same settings with `harmonics` harmonics (a frequency response diagram traces one
    /// branch per `H`).
    pub fn with_harmonics(&self, harmonics: usize) -> Self {
        let mut s = self.clone();
        match &mut s {
            MethodSettings::Redistributed { options, .. } => options.harmonics = harmonics,
            MethodSettings::General(o) => o.harmonics = harmonics,
            MethodSettings::HbmAft(o) => o.harmonics = harmonics,
        }
        s
    }

    /// The penalty law (HBM-AFT only).
    pub fn penalty(&self) -> Option<Penalty> {
        match self {
            MethodSettings::HbmAft(o) => Some(o.penalty),
            _ => None,
        }
    }

    /// Check the settings that do not need the model (each method's constructor checks
    /// the rest: resolution, frequency-independent model requirements).
    pub fn validate(&self) -> Result<()> {
        let h = self.harmonics();
        if h == 0 {
            return Err(Error::argument("harmonics", "must be at least 1"));
        }
        match self {
            MethodSettings::Redistributed { stability, .. } if stability.modes == Some(0) => {
                Err(Error::argument(
                    "stability modes",
                    "the reduced basis needs at least one fixed-interface mode",
                ))
            }
            MethodSettings::HbmAft(o) => match o.penalty {
                Penalty::Stiffness(v) | Penalty::Relative(v) if !(v.is_finite() && v > 0.0) => Err(
                    Error::argument("penalty", format!("must be positive, got {v}")),
                ),
                _ => Ok(()),
            },
            _ => Ok(()),
        }
    }

    /// Build the method for `model` within the default [`Limits`] (the machine's memory).
    pub fn build(&self, model: &Model) -> Result<BuiltMethod> {
        self.build_within(model, &Limits::default())
    }

    /// Build the method for `model`, refusing with [`Error::ResourceLimit`] before
    /// allocating when its memory estimate ([`super::memory`]) exceeds `limits`.
    pub fn build_within(&self, model: &Model, limits: &Limits) -> Result<BuiltMethod> {
        self.build_observed(model, limits, None)
    }

    /// [`MethodSettings::build_within`], telling `observer` the phases of the set-up
    /// (those of the redistributed MS-HBM; the other methods report nothing yet).
    pub fn build_observed(
        &self,
        model: &Model,
        limits: &Limits,
        observer: Option<&SetupObserver>,
    ) -> Result<BuiltMethod> {
        self.validate()?;
        limits.cancel.check()?;
        let built = match self {
            MethodSettings::Redistributed { options, stability } => {
                let mut problem =
                    RedistributedMsHbm::within_observed(model, options, limits, observer)?;
                problem.set_stability_options(*stability)?;
                BuiltMethod {
                    problem: Box::new(problem),
                    label: "MS-HBM".into(),
                    penalty: None,
                }
            }
            MethodSettings::General(options) => BuiltMethod {
                problem: Box::new(GeneralMsHbm::within(model, options, limits)?),
                label: "general MS-HBM".into(),
                penalty: None,
            },
            MethodSettings::HbmAft(options) => {
                let problem = HbmAft::within(model, options, limits)?;
                let kp = problem.penalties()[0];
                BuiltMethod {
                    label: format!("HBM-AFT kp = {kp:.3e}"),
                    penalty: Some(kp),
                    problem: Box::new(problem),
                }
            }
        };
        limits.cancel.check()?;
        Ok(built)
    }
}
