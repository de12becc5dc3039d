//! The `[damping]` section of a model file, shared by every kind (`model::file`,
//! `model::solid`): Rayleigh coefficients or a first-mode ratio.

use serde::Deserialize;

use crate::model::Damping;

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(crate) struct DampingSection {
    #[serde(default)]
    alpha: f64,
    #[serde(default)]
    beta: f64,
    #[serde(default)]
    beta_linear: f64,
    #[serde(default)]
    beta_condensed: f64,
    first_mode_ratio: Option<f64>,
}

impl From<DampingSection> for Damping {
    fn from(d: DampingSection) -> Self {
        Damping {
            alpha: d.alpha,
            beta: d.beta,
            beta_linear: d.beta_linear,
            beta_condensed: d.beta_condensed,
            first_mode_ratio: d.first_mode_ratio,
        }
    }
}
