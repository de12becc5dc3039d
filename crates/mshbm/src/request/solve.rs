//! The request of one periodic solution ([`SolveRequest`]): frequency, harmonics, the
//! method options, stability, and where Newton starts.

use super::method::{MethodRequest, DEFAULT_HARMONICS};
use super::Checked;
use crate::error::OptionError;
use crate::limits::Limits;
use crate::method::settings::MethodSettings;
use crate::model::Model;
use crate::solution::PeriodicSolution;
use crate::solve::{SolveSettings, SolveStart};

/// Where Newton starts when no solution or sweep is given.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StartKind {
    /// [`SolveStart::Auto`].
    #[default]
    Auto,
    /// [`SolveStart::Linear`].
    Linear,
}

impl super::Choice for StartKind {
    const NAMES: &'static [(&'static str, Self)] =
        &[("auto", StartKind::Auto), ("linear", StartKind::Linear)];
}

/// A solution to start from, and what the user calls it (a file's path, `start`): the
/// front end reads it, the request checks it.
#[derive(Clone, Debug)]
pub struct StartSolution {
    /// How messages name it (the CLI: the file; Python: the argument).
    pub source: String,
    /// The solution.
    pub solution: PeriodicSolution,
}

/// One periodic solution at one frequency (defaults: [`SolveRequest::new`]).
#[derive(Clone, Debug)]
pub struct SolveRequest {
    /// Excitation frequency [Hz].
    pub frequency: f64,
    /// Harmonics H ([`DEFAULT_HARMONICS`]).
    pub harmonics: usize,
    /// The method options.
    pub method: MethodRequest,
    /// Compute the Floquet multipliers (default `true`).
    pub stability: bool,
    /// Where Newton starts without a start solution or sweep (default auto).
    pub start: StartKind,
    /// A solution to start from.
    pub start_solution: Option<StartSolution>,
    /// Trace the branch from this frequency [Hz] and report every solution at `frequency`.
    pub sweep_from: Option<f64>,
    /// End of the sweep [Hz] (default 1.5 × `frequency`, or `frequency` / 1.5 when the
    /// sweep starts above it).
    pub sweep_to: Option<f64>,
}

impl SolveRequest {
    /// The defaults at `frequency` [Hz].
    pub fn new(frequency: f64) -> Self {
        SolveRequest {
            frequency,
            harmonics: DEFAULT_HARMONICS,
            method: MethodRequest::default(),
            stability: true,
            start: StartKind::Auto,
            start_solution: None,
            sweep_from: None,
            sweep_to: None,
        }
    }

    /// The checks that need no model, and the method to run.
    pub fn method(&self) -> Checked<MethodSettings> {
        let f = self.frequency;
        if !(f.is_finite() && f > 0.0) {
            return Err(OptionError::new(
                "frequency",
                format!("⟨frequency⟩ must be a positive number of Hz, got {f}"),
            ));
        }
        if self.harmonics == 0 {
            return Err(OptionError::new(
                "harmonics",
                "⟨harmonics⟩ must be at least 1",
            ));
        }
        self.method.check_samples(self.harmonics)?;
        self.method.single_method(self.harmonics)
    }

    /// The library's settings on `model` (observers unset), with `limits`.
    pub fn settings(&self, model: &Model, limits: Limits) -> Checked<SolveSettings> {
        let method = self.method()?;
        Ok(SolveSettings {
            newton: self.method.newton()?,
            stability: self.stability,
            response_dof: Some(self.method.response_dof(model)?),
            limits,
            start: self.solve_start(model, &method)?,
            ..SolveSettings::default()
        })
    }

    /// Where Newton starts.
    fn solve_start(&self, model: &Model, method: &MethodSettings) -> Checked<SolveStart> {
        if let Some(start) = &self.start_solution {
            if self.sweep_from.is_some() {
                return Err(OptionError::new(
                    "sweep_from",
                    "give either ⟨start_solution⟩ or ⟨sweep_from⟩, not both",
                ));
            }
            let (source, s) = (&start.source, &start.solution);
            let error = |message: String| OptionError::new("start_solution", message);
            if let Some(why) = s.unusable_start(model, method.kind()) {
                return Err(error(format!(
                    "{source}: cannot start from this solution: {why}"
                )));
            }
            let Some(x) = &s.unknowns else {
                return Err(error(format!("{source}: the solution has no `unknowns` (written by an older mshbm, or not by solve); solve it again")));
            };
            // another H: the same signals with harmonics added (zero) or dropped
            let Some(x) = crate::harmonic::with_harmonics(x, s.harmonics, self.harmonics) else {
                return Err(error(format!(
                    "{source}: its {} unknowns are not a whole number of {}-harmonic signals",
                    x.len(),
                    s.harmonics
                )));
            };
            return Ok(SolveStart::Unknowns(x));
        }
        if let Some(from) = self.sweep_from {
            if !(from.is_finite() && from > 0.0) {
                return Err(OptionError::new(
                    "sweep_from",
                    format!("⟨sweep_from⟩ must be a positive number of Hz, got {from}"),
                ));
            }
            let f = self.frequency;
            let to = self
                .sweep_to
                .unwrap_or(if from < f { 1.5 * f } else { f / 1.5 });
            if !(to.is_finite() && to > 0.0) {
                return Err(OptionError::new(
                    "sweep_to",
                    format!("⟨sweep_to⟩ must be a positive number of Hz, got {to}"),
                ));
            }
            if !((from < f && f <= to) || (to <= f && f < from)) {
                return Err(OptionError::new(
                    "frequency",
                    format!("⟨frequency⟩ {f} Hz must lie between ⟨sweep_from⟩ {from} Hz (excluded) and ⟨sweep_to⟩ {to} Hz"),
                ));
            }
            return Ok(SolveStart::Sweep {
                from_hz: from,
                to_hz: to,
            });
        }
        if self.sweep_to.is_some() {
            return Err(OptionError::new(
                "sweep_to",
                "⟨sweep_to⟩ needs ⟨sweep_from⟩",
            ));
        }
        Ok(match self.start {
            StartKind::Auto => SolveStart::Auto,
            StartKind::Linear => SolveStart::Linear,
        })
    }
}
