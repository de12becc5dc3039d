//! The request of a frequency response diagram ([`FrdRequest`]): the sweep, the numbers of
//! harmonics, the method options, the continuation's steps and what each point reports.

use super::method::{MethodRequest, DEFAULT_HARMONICS};
use super::Checked;
use crate::error::OptionError;
use crate::frd::{
    check_frequencies, FrdSettings, DEFAULT_INITIAL_STEP, DEFAULT_MAX_POINTS, DEFAULT_MAX_STEP,
    DEFAULT_MAX_TURN_DEG, DEFAULT_MIN_STEP,
};
use crate::limits::Limits;
use crate::method::settings::MethodSettings;
use crate::model::Model;

/// A frequency response diagram (defaults: [`FrdRequest::new`]).
#[derive(Clone, Debug)]
pub struct FrdRequest {
    /// Start frequency [Hz].
    pub from_hz: f64,
    /// End frequency [Hz].
    pub to_hz: f64,
    /// Numbers of harmonics, one branch each (default `[DEFAULT_HARMONICS]`).
    pub harmonics: Vec<usize>,
    /// The method options.
    pub method: MethodRequest,
    /// First arclength step.
    pub step: f64,
    /// Largest arclength step.
    pub max_step: f64,
    /// Smallest arclength step.
    pub min_step: f64,
    /// Largest turn of the tangent [degrees].
    pub max_turn: f64,
    /// Floquet multipliers of every point (default `false`).
    pub stability: bool,
    /// With hbm-aft: also trace the redistributed MS-HBM (default `false`).
    pub overlay_mshbm: bool,
    /// Most points per branch.
    pub max_points: usize,
}

impl FrdRequest {
    /// The defaults for a sweep from `from_hz` to `to_hz`.
    pub fn new(from_hz: f64, to_hz: f64) -> Self {
        FrdRequest {
            from_hz,
            to_hz,
            harmonics: vec![DEFAULT_HARMONICS],
            method: MethodRequest::default(),
            step: DEFAULT_INITIAL_STEP,
            max_step: DEFAULT_MAX_STEP,
            min_step: DEFAULT_MIN_STEP,
            max_turn: DEFAULT_MAX_TURN_DEG,
            stability: false,
            overlay_mshbm: false,
            max_points: DEFAULT_MAX_POINTS,
        }
    }

    /// The checks that need no model (the turn and the point limit are the continuation's,
    /// [`crate::continuation::arclength::ContinuationOptions::validate`]), and the methods to trace (one per penalty, the
    /// MS-HBM first with `overlay_mshbm`).
    pub fn methods(&self) -> Checked<Vec<MethodSettings>> {
        check_frequencies(self.from_hz, self.to_hz)?;
        if self.harmonics.is_empty() || self.harmonics.contains(&0) {
            return Err(OptionError::new(
                "harmonics",
                "⟨harmonics⟩ must list numbers of harmonics of at least 1",
            ));
        }
        if !(self.min_step > 0.0 && self.min_step <= self.step && self.step <= self.max_step) {
            return Err(OptionError::new(
                "step",
                "steps must satisfy 0 < ⟨min_step⟩ <= ⟨step⟩ <= ⟨max_step⟩",
            ));
        }
        let h = self.harmonics[0];
        let mut methods = self.method.methods(h)?;
        if self.overlay_mshbm {
            methods.insert(0, self.method.overlay_mshbm()?.single_method(h)?);
        }
        Ok(methods)
    }

    /// The library's settings on `model` (no set-up observer), with `limits`.
    pub fn settings(&self, model: &Model, limits: Limits) -> Checked<FrdSettings> {
        let mut settings = FrdSettings::new(self.from_hz, self.to_hz);
        settings.initial_step = self.step;
        settings.max_step = self.max_step;
        settings.min_step = self.min_step;
        settings.max_turn_deg = self.max_turn;
        settings.newton = self.method.newton()?;
        settings.stability = self.stability;
        settings.response_dof = Some(self.method.response_dof(model)?);
        settings.limits = limits;
        settings.max_points = self.max_points;
        Ok(settings)
    }
}
