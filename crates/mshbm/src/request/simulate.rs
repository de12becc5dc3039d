//! The request of a reference time integration ([`SimulateRequest`]): the scheme, the
//! time grid (steps per period or `dt`, periods or duration) and their defaults, the
//! steady-state criterion, the start, the response DOF; [`SimulatePlan`] is what it
//! means for a model, [`TimeGrid`] the steps it runs.

use super::solve::StartSolution;
use super::{Checked, Choice};
use crate::error::{OptionError, Result};
use crate::integrate::steady_state::{Periodicity, SteadyState, SteadyStateOptions};
use crate::integrate::Scheme;
use crate::limits::Limits;
use crate::model::{Model, System};

/// Default harmonics of a steady state's Fourier coefficients.
pub const DEFAULT_HARMONICS: usize = 10;
/// Default steps per period of a forced run and of a steady state.
pub const FORCED_STEPS_PER_PERIOD: usize = 2000;
/// Default steps per period of a free run.
pub const FREE_STEPS_PER_PERIOD: usize = 8000;
/// Default length of a forced run [periods].
pub const FORCED_PERIODS: f64 = 20.0;
/// Default length of a free run [periods].
pub const FREE_PERIODS: f64 = 2.0;
/// Default period limit of a steady state.
pub const STEADY_STATE_MAX_PERIODS: usize = 1000;

/// The time-stepping scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SchemeKind {
    /// Moreau–Jean on the consistent mass with Newton's impact law.
    Moreau,
    /// Position-level Newmark on the redistributed mass.
    Redistributed,
}

impl Choice for SchemeKind {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("moreau", SchemeKind::Moreau),
        ("redistributed", SchemeKind::Redistributed),
    ];
}

impl Choice for Periodicity {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("response", Periodicity::Response),
        ("state", Periodicity::State),
    ];
}

/// A reference time integration (defaults: [`SimulateRequest::default`]).
#[derive(Clone, Debug)]
pub struct SimulateRequest {
    /// Frequency of the harmonic load [Hz] (required with a load and for a steady state).
    pub frequency: Option<f64>,
    /// Length in periods (default [`FORCED_PERIODS`] or [`FREE_PERIODS`]; a steady state's
    /// limit, default [`STEADY_STATE_MAX_PERIODS`]).
    pub periods: Option<f64>,
    /// Length [s] (instead of `periods`).
    pub duration: Option<f64>,
    /// Steps per period (default [`FORCED_STEPS_PER_PERIOD`] or [`FREE_STEPS_PER_PERIOD`]).
    pub steps_per_period: Option<usize>,
    /// Time step [s] (instead of `steps_per_period`).
    pub dt: Option<f64>,
    /// Scheme (default: redistributed with contacts, moreau without).
    pub scheme: Option<SchemeKind>,
    /// Restitution of Moreau–Jean in [0, 1] (default 0).
    pub restitution: Option<f64>,
    /// θ of Moreau–Jean in [0.5, 1] (default 0.5).
    pub theta: Option<f64>,
    /// Integrate until the response repeats.
    pub steady_state: bool,
    /// What must repeat (default the response).
    pub periodicity: Periodicity,
    /// Repeat tolerance (default [`Periodicity::default_tolerance`]).
    pub tolerance: Option<f64>,
    /// Harmonics of the steady state ([`DEFAULT_HARMONICS`]).
    pub harmonics: usize,
    /// The response DOF (default the first contact's first DOF).
    pub dof: Option<usize>,
    /// A periodic solution to start from.
    pub start_solution: Option<StartSolution>,
}

impl Default for SimulateRequest {
    fn default() -> Self {
        SimulateRequest {
            frequency: None,
            periods: None,
            duration: None,
            steps_per_period: None,
            dt: None,
            scheme: None,
            restitution: None,
            theta: None,
            steady_state: false,
            periodicity: Periodicity::Response,
            tolerance: None,
            harmonics: DEFAULT_HARMONICS,
            dof: None,
            start_solution: None,
        }
    }
}

/// What a request means for a model.
#[derive(Clone, Debug)]
pub struct SimulatePlan {
    /// The frequency [Hz]: given, or the start solution's.
    pub frequency: Option<f64>,
    /// The model has a harmonic load.
    pub forced: bool,
    /// The chosen scheme and its parameters (its mass: [`Scheme::mass_kind`]).
    pub scheme: Scheme,
    /// The response DOF (required for a steady state).
    pub response_dof: Option<usize>,
    /// The steady state's tolerance.
    pub tolerance: f64,
}

/// The steps of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeGrid {
    /// Time step [s].
    pub dt: f64,
    /// Steps of a run that is not a steady state.
    pub steps: u64,
    /// Steps per period of a steady state (0 otherwise).
    pub steps_per_period: usize,
    /// Period limit of a steady state.
    pub max_periods: usize,
    /// The load's angular frequency the integrator applies (forced runs and steady
    /// states).
    pub load_omega: Option<f64>,
}

impl TimeGrid {
    /// Steps the run may take at the most (a steady state: every period of its limit).
    pub fn total_steps(&self) -> u64 {
        if self.steps_per_period > 0 {
            (self.max_periods as u64).saturating_mul(self.steps_per_period as u64)
        } else {
            self.steps
        }
    }
}

fn positive(option: &'static str, what: &str, v: f64) -> Checked<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(OptionError::new(
            option,
            format!("{what} must be a positive number, got {v}"),
        ))
    }
}

impl SimulatePlan {
    /// The angular frequency [rad/s] of `frequency` (a start solution's state is built at
    /// it).
    pub fn omega(&self) -> Option<f64> {
        self.frequency.map(|f| 2.0 * std::f64::consts::PI * f)
    }
}

impl SimulateRequest {
    /// The checks that need no model.
    pub fn validate(&self) -> Checked<()> {
        if let Some(f) = self.frequency {
            positive("frequency", "⟨frequency⟩ [Hz]", f)?;
        }
        if let Some(p) = self.periods {
            positive("periods", "⟨periods⟩", p)?;
        }
        if let Some(d) = self.duration {
            positive("duration", "⟨duration⟩ [s]", d)?;
        }
        if let Some(dt) = self.dt {
            positive("dt", "⟨dt⟩ [s]", dt)?;
        }
        if self.periods.is_some() && self.duration.is_some() {
            return Err(OptionError::new(
                "duration",
                "give ⟨periods⟩ or ⟨duration⟩, not both",
            ));
        }
        if self.steps_per_period.is_some() && self.dt.is_some() {
            return Err(OptionError::new(
                "dt",
                "give ⟨steps_per_period⟩ or ⟨dt⟩, not both",
            ));
        }
        if self.steps_per_period == Some(0) {
            return Err(OptionError::new(
                "steps_per_period",
                "⟨steps_per_period⟩ must be at least 1",
            ));
        }
        if let Some(e) = self.restitution {
            if !(e.is_finite() && (0.0..=1.0).contains(&e)) {
                return Err(OptionError::new(
                    "restitution",
                    format!("⟨restitution⟩ must lie in [0, 1], got {e}"),
                ));
            }
        }
        if let Some(t) = self.theta {
            if !(t.is_finite() && (0.5..=1.0).contains(&t)) {
                return Err(OptionError::new(
                    "theta",
                    format!("⟨theta⟩ must lie in [0.5, 1] (theta < 0.5 is unstable), got {t}"),
                ));
            }
        }
        if let Some(t) = self.tolerance {
            positive("tolerance", "⟨tolerance⟩", t)?;
        }
        if self.harmonics == 0 {
            return Err(OptionError::new(
                "harmonics",
                "⟨harmonics⟩ must be at least 1",
            ));
        }
        if self.steady_state {
            if self.duration.is_some() {
                return Err(OptionError::new(
                    "duration",
                    "⟨steady_state⟩ runs whole periods: give ⟨periods⟩ (the period limit), not ⟨duration⟩",
                ));
            }
            if self.dt.is_some() {
                return Err(OptionError::new(
                    "dt",
                    "⟨steady_state⟩ needs a whole number of steps per period: give ⟨steps_per_period⟩, not ⟨dt⟩",
                ));
            }
            if let Some(p) = self.periods {
                if p.fract() != 0.0 {
                    return Err(OptionError::new(
                        "periods",
                        format!("⟨periods⟩ must be a whole number with ⟨steady_state⟩, got {p}"),
                    ));
                }
                if self.periodicity == Periodicity::Response && p < 2.0 {
                    return Err(OptionError::new(
                        "periods",
                        format!("⟨periods⟩ must be at least 2 with ⟨steady_state⟩ and ⟨periodicity=response⟩ (it compares whole periods), got {p}"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// What the request means for `model`: the frequency, the scheme, the response DOF.
    pub fn plan(&self, model: &Model) -> Checked<SimulatePlan> {
        self.validate()?;
        let forced = model.harmonic_load.iter().any(|&f| f != 0.0);
        let frequency = match (&self.start_solution, self.frequency) {
            (Some(start), Some(f)) => {
                let theirs = start.solution.frequency_hz;
                if ((f - theirs) / f).abs() > 1e-9 {
                    return Err(OptionError::new(
                        "frequency",
                        format!(
                            "⟨frequency⟩ {f} Hz differs from the frequency of {} ({theirs} Hz)",
                            start.source
                        ),
                    ));
                }
                Some(f)
            }
            (Some(start), None) => Some(positive(
                "start_solution",
                &format!("the frequency of {} [Hz]", start.source),
                start.solution.frequency_hz,
            )?),
            (None, f) => f,
        };
        if forced && frequency.is_none() {
            return Err(OptionError::new(
                "frequency",
                "the model has a harmonic load: give its ⟨frequency⟩ [Hz]",
            ));
        }
        if self.steady_state && frequency.is_none() {
            return Err(OptionError::new(
                "frequency",
                "⟨steady_state⟩ needs ⟨frequency⟩ [Hz]: the period of the steady state (also without load)",
            ));
        }
        let kind = self.scheme.unwrap_or(if model.contacts.is_empty() {
            SchemeKind::Moreau
        } else {
            SchemeKind::Redistributed
        });
        let scheme = match kind {
            SchemeKind::Moreau => Scheme::moreau_jean(self.theta, self.restitution),
            SchemeKind::Redistributed => {
                if self.restitution.is_some() || self.theta.is_some() {
                    return Err(OptionError::new(
                        "scheme",
                        "⟨restitution⟩ and ⟨theta⟩ belong to ⟨scheme=moreau⟩; the redistributed scheme has no impact law",
                    ));
                }
                Scheme::PositionNewmark
            }
        };
        let response_dof = match self.dof {
            Some(d) if d >= model.n_dofs() => {
                return Err(OptionError::new(
                    "dof",
                    format!(
                        "⟨dof⟩ {d} out of range: the model has DOFs 0..{}",
                        model.n_dofs() - 1
                    ),
                ))
            }
            Some(d) => Some(d),
            None => model.contacts.first().map(|c| c.dofs[0]),
        };
        if self.steady_state && response_dof.is_none() {
            return Err(OptionError::new(
                "dof",
                "the model has no contact: give ⟨dof⟩",
            ));
        }
        Ok(SimulatePlan {
            frequency,
            forced,
            scheme,
            response_dof,
            tolerance: self
                .tolerance
                .unwrap_or_else(|| self.periodicity.default_tolerance()),
        })
    }

    /// The steps of the run, with `period` the reference period of the system
    /// ([`crate::simulation::reference_period`]).
    pub fn grid(&self, plan: &SimulatePlan, period: Option<f64>) -> Checked<TimeGrid> {
        // a steady state is sampled like a forced response, also without load
        let periodic = plan.forced || self.steady_state;
        let default_steps = if periodic {
            FORCED_STEPS_PER_PERIOD
        } else {
            FREE_STEPS_PER_PERIOD
        };
        let dt = match (self.dt, period) {
            (Some(dt), _) => dt,
            (None, Some(t)) => t / self.steps_per_period.unwrap_or(default_steps) as f64,
            (None, None) => {
                return Err(OptionError::new(
                    "dt",
                    "no reference period for this model (free structure): give ⟨dt⟩ [s] and ⟨duration⟩ [s]",
                ))
            }
        };
        let steps = match (self.duration, self.periods, period) {
            (Some(d), _, _) => (d / dt).round(),
            (None, Some(p), Some(t)) => (p * t / dt).round(),
            (None, None, Some(t)) => ((if plan.forced {
                FORCED_PERIODS
            } else {
                FREE_PERIODS
            }) * t
                / dt)
                .round(),
            (None, _, None) => {
                return Err(OptionError::new(
                    "duration",
                    "no reference period for this model: give ⟨duration⟩ [s]",
                ))
            }
        };
        if !(1.0..1e12).contains(&steps) {
            return Err(OptionError::new(
                "duration",
                format!("the run would have {steps} steps of dt = {dt:e} s"),
            ));
        }
        Ok(TimeGrid {
            dt,
            steps: steps as u64,
            steps_per_period: if self.steady_state {
                self.steps_per_period.unwrap_or(default_steps)
            } else {
                0
            },
            max_periods: self
                .periods
                .map_or(STEADY_STATE_MAX_PERIODS, |p| p as usize),
            load_omega: plan.omega().filter(|_| periodic),
        })
    }

    /// The steady state's options (`None` for a run of a given length), its one period of
    /// signals checked against `limits` before the run.
    pub fn steady_state_options(
        &self,
        plan: &SimulatePlan,
        grid: &TimeGrid,
        system: &System,
        limits: &Limits,
    ) -> Result<Option<SteadyStateOptions>> {
        if !self.steady_state {
            return Ok(None);
        }
        // the steady state keeps one period of the contact and nonlinear DOFs' signals
        // (and the reported solution's series)
        let per_step = (4 * system.contacts.len() + system.nonlinear_dofs.len() + 2) as u64 * 16;
        limits.check_memory(
            &format!(
                "{} steps per period (the steady state's period of signals)",
                grid.steps_per_period
            ),
            (grid.steps_per_period as u64).checked_mul(per_step),
        )?;
        Ok(Some(SteadyStateOptions {
            steps_per_period: grid.steps_per_period,
            max_periods: grid.max_periods,
            tolerance: plan.tolerance,
            harmonics: self.harmonics,
            response_dof: plan
                .response_dof
                .ok_or_else(|| OptionError::new("dof", "the model has no contact: give ⟨dof⟩"))?,
            periodicity: self.periodicity,
        }))
    }
}

/// Why a steady state is not one (`None` when it became periodic): the sentence every
/// front end reports, naming the `periodicity` option (rendered like an [`OptionError`]:
/// the option it points at is `periods`, the limit to raise).
pub fn not_periodic(s: &SteadyState) -> Option<OptionError> {
    (!s.periodic).then(|| {
        OptionError::new(
            "periods",
            format!(
                "the response did not become periodic within {} periods: period-to-period scatter {:.2e} >= tolerance {:.1e} (⟨periodicity={}⟩)",
                s.periods_simulated,
                s.period_scatter,
                s.tolerance,
                s.periodicity.name()
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::bar::BarParameters;

    fn bar() -> Model {
        BarParameters::paper()
            .build(std::path::Path::new("bar"))
            .expect("the paper's bar")
    }

    #[test]
    fn the_time_grid_takes_its_defaults_from_the_kind_of_run() {
        let model = bar();
        let forced = SimulateRequest {
            frequency: Some(1000.0),
            ..SimulateRequest::default()
        };
        let plan = forced.plan(&model).unwrap();
        assert!(plan.forced);
        assert_eq!(plan.scheme, Scheme::PositionNewmark);
        let grid = forced.grid(&plan, Some(1e-3)).unwrap();
        assert_eq!(grid.dt, 1e-3 / FORCED_STEPS_PER_PERIOD as f64);
        assert_eq!(
            grid.steps,
            (FORCED_PERIODS as u64) * FORCED_STEPS_PER_PERIOD as u64
        );
        assert_eq!(grid.steps_per_period, 0);
        // a free run of the same period: finer steps, fewer periods, no load
        let free_plan = SimulatePlan {
            forced: false,
            ..plan.clone()
        };
        let grid = SimulateRequest::default()
            .grid(&free_plan, Some(1e-3))
            .unwrap();
        assert_eq!(grid.dt, 1e-3 / FREE_STEPS_PER_PERIOD as f64);
        assert_eq!(
            grid.steps,
            (FREE_PERIODS as u64) * FREE_STEPS_PER_PERIOD as u64
        );
        assert_eq!(grid.load_omega, None);
        // a steady state: whole periods, the period limit by default
        let steady = SimulateRequest {
            steady_state: true,
            ..forced.clone()
        };
        let grid = steady
            .grid(&steady.plan(&model).unwrap(), Some(1e-3))
            .unwrap();
        assert_eq!(grid.steps_per_period, FORCED_STEPS_PER_PERIOD);
        assert_eq!(grid.max_periods, STEADY_STATE_MAX_PERIODS);
    }

    #[test]
    fn bad_combinations_name_the_option() {
        let model = bar();
        let cases = [
            (
                SimulateRequest {
                    theta: Some(0.7),
                    frequency: Some(1000.0),
                    ..SimulateRequest::default()
                },
                "scheme",
            ),
            (SimulateRequest::default(), "frequency"),
            (
                SimulateRequest {
                    frequency: Some(1000.0),
                    steady_state: true,
                    periods: Some(2.5),
                    ..SimulateRequest::default()
                },
                "periods",
            ),
            (
                SimulateRequest {
                    frequency: Some(1000.0),
                    dof: Some(10_000),
                    ..SimulateRequest::default()
                },
                "dof",
            ),
        ];
        for (request, option) in cases {
            let e = request.plan(&model).unwrap_err();
            assert_eq!(e.option, option, "{e}");
        }
    }
}
