//! The method options of `solve` and `frf`, translated as the CLI's `MethodArgs`
//! (crates/mshbm-cli/src/commands/solve.rs) translates `--method`, `--samples`,
//! `--quadrature`, `--mass`, `--penalty`, `--tolerance`, `--max-iterations`, `--dof`,
//! `--stability-modes`, `--receptance`, `--receptance-modes` and `--jacobian`, with the same defaults and checks; the messages name the Python
//! keyword instead of the option.

use mshbm::harmonic::Quadrature;
use mshbm::method::general::GeneralOptions;
use mshbm::method::hbm_aft::{HbmAftOptions, Penalty};
use mshbm::method::redistributed::{
    JacobianForm, ReceptanceChoice, RedistributedOptions, DEFAULT_RECEPTANCE_MODES,
};
use mshbm::method::settings::MethodSettings;
use mshbm::newton::NewtonOptions;
use mshbm::stability::StabilityOptions;
use mshbm::{MassKind, Model};
use pyo3::prelude::*;

use crate::errors::argument;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Redistributed,
    Mshbm,
    HbmAft,
}

/// The method options of one call.
#[derive(Clone, Debug)]
pub struct MethodArgs {
    pub method: Method,
    pub samples: Option<usize>,
    pub quadrature: Option<Quadrature>,
    pub mass: Option<MassKind>,
    pub penalty: Vec<String>,
    pub tolerance: f64,
    pub max_iterations: usize,
    pub dof: Option<usize>,
    pub stability_modes: Option<usize>,
    /// `"auto"`, `"exact"` or `"modal"`.
    pub receptance: String,
    pub receptance_modes: Option<usize>,
    /// `"auto"`, `"dense"` or `"operator"`.
    pub jacobian: JacobianForm,
}

fn one_of<T: Copy>(name: &str, value: &str, choices: &[(&str, T)]) -> PyResult<T> {
    choices
        .iter()
        .find(|(n, _)| *n == value)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let names: Vec<String> = choices.iter().map(|(n, _)| format!("'{n}'")).collect();
            argument(format!(
                "{name}={value:?}: expected one of {}",
                names.join(", ")
            ))
        })
}

impl MethodArgs {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        method: &str,
        samples: Option<usize>,
        quadrature: Option<&str>,
        mass: Option<&str>,
        penalty: Vec<String>,
        tolerance: f64,
        max_iterations: usize,
        dof: Option<usize>,
        stability_modes: Option<usize>,
        receptance: &str,
        receptance_modes: Option<usize>,
        jacobian: &str,
    ) -> PyResult<Self> {
        Ok(MethodArgs {
            method: one_of(
                "method",
                method,
                &[
                    ("redistributed", Method::Redistributed),
                    ("hbm-aft", Method::HbmAft),
                    ("mshbm", Method::Mshbm),
                ],
            )?,
            samples,
            quadrature: quadrature
                .map(|q| {
                    one_of(
                        "quadrature",
                        q,
                        &[
                            ("exact", Quadrature::Exact),
                            ("sampled", Quadrature::Sampled),
                        ],
                    )
                })
                .transpose()?,
            mass: mass
                .map(|m| {
                    one_of(
                        "mass",
                        m,
                        &[
                            ("consistent", MassKind::Consistent),
                            ("redistributed", MassKind::Redistributed),
                        ],
                    )
                })
                .transpose()?,
            penalty,
            tolerance,
            max_iterations,
            dof,
            stability_modes,
            receptance: receptance.to_string(),
            receptance_modes,
            jacobian: one_of(
                "jacobian",
                jacobian,
                &[
                    ("auto", JacobianForm::Auto),
                    ("dense", JacobianForm::Dense),
                    ("operator", JacobianForm::Operator),
                ],
            )?,
        })
    }

    /// The receptance of `receptance` and `receptance_modes` (as the CLI's
    /// `--receptance`, `--receptance-modes`).
    fn receptance_choice(&self) -> PyResult<ReceptanceChoice> {
        let kind = one_of(
            "receptance",
            &self.receptance,
            &[("auto", 0u8), ("exact", 1), ("modal", 2)],
        )?;
        Ok(match (kind, self.receptance_modes) {
            (_, Some(0)) => return Err(argument("receptance_modes must be at least 1")),
            (2, modes) => ReceptanceChoice::Modal {
                modes: modes.unwrap_or(DEFAULT_RECEPTANCE_MODES),
            },
            (_, Some(_)) => return Err(argument("receptance_modes needs receptance='modal'")),
            (0, None) => ReceptanceChoice::Auto,
            _ => ReceptanceChoice::Exact,
        })
    }

    pub fn newton(&self) -> PyResult<NewtonOptions> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(argument(format!(
                "tolerance must be positive, got {}",
                self.tolerance
            )));
        }
        if self.max_iterations == 0 {
            return Err(argument("max_iterations must be at least 1"));
        }
        Ok(NewtonOptions {
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            ..NewtonOptions::default()
        })
    }

    fn penalties(&self) -> PyResult<Vec<Penalty>> {
        if self.penalty.is_empty() {
            return Ok(vec![Penalty::default()]);
        }
        self.penalty.iter().map(|s| parse_penalty(s)).collect()
    }

    /// One method per penalty for hbm-aft, one otherwise (as the CLI).
    pub fn methods(&self, harmonics: usize) -> PyResult<Vec<MethodSettings>> {
        match self.stability_modes {
            Some(0) => return Err(argument("stability_modes must be at least 1")),
            Some(_) if self.method != Method::Redistributed => {
                return Err(argument("stability_modes applies to method='redistributed' only (the method with Floquet multipliers)"))
            }
            _ => {}
        }
        if self.method != Method::Redistributed
            && (self.receptance != "auto" || self.receptance_modes.is_some())
        {
            return Err(argument(
                "receptance and receptance_modes apply to method='redistributed' only",
            ));
        }
        if self.method != Method::Redistributed && self.jacobian != JacobianForm::Auto {
            return Err(argument("jacobian applies to method='redistributed' only"));
        }
        let quadrature = |default| self.quadrature.unwrap_or(default);
        if self.method == Method::HbmAft {
            return Ok(self
                .penalties()?
                .into_iter()
                .map(|penalty| {
                    MethodSettings::HbmAft(HbmAftOptions {
                        harmonics,
                        samples: self.samples,
                        mass: self.mass.unwrap_or(MassKind::Consistent),
                        penalty,
                        tangential_penalty: None,
                        quadrature: quadrature(Quadrature::Sampled),
                    })
                })
                .collect());
        }
        if !self.penalty.is_empty() {
            return Err(argument(
                "penalty applies to method='hbm-aft' only (the MS-HBM treats contact exactly)",
            ));
        }
        if self.mass.is_some() {
            return Err(argument(
                "mass applies to method='hbm-aft' only (the MS-HBM methods fix their mass)",
            ));
        }
        Ok(vec![match self.method {
            Method::Redistributed => MethodSettings::Redistributed {
                options: RedistributedOptions {
                    harmonics,
                    samples: self.samples,
                    quadrature: quadrature(Quadrature::Exact),
                    receptance: self.receptance_choice()?,
                    jacobian: self.jacobian,
                },
                stability: StabilityOptions {
                    modes: self.stability_modes,
                },
            },
            Method::Mshbm => MethodSettings::General(GeneralOptions {
                steps: self.samples,
                ..GeneralOptions::new(harmonics)
            }),
            Method::HbmAft => unreachable!("returned above"),
        }])
    }

    pub fn single_method(&self, harmonics: usize) -> PyResult<MethodSettings> {
        let mut methods = self.methods(harmonics)?;
        if methods.len() > 1 {
            return Err(argument(
                "solve takes one penalty value (frf traces one branch per value)",
            ));
        }
        Ok(methods.remove(0))
    }

    /// The response DOF (model numbering): `dof`, or the first contact's first DOF.
    pub fn response_dof(&self, model: &Model) -> PyResult<usize> {
        let dof = match self.dof {
            Some(d) => d,
            None => match (model.contacts.first(), model.frictions.first()) {
                (Some(c), _) => c.dofs[0],
                (None, Some(f)) => f.dofs[0],
                (None, None) => return Err(argument("the model has no contact: give dof")),
            },
        };
        if dof >= model.n_dofs() {
            return Err(argument(format!(
                "dof {dof} out of range: the model has DOFs 0..{}",
                model.n_dofs() - 1
            )));
        }
        Ok(dof)
    }

    /// `samples` against `harmonics` (NS ≥ 2H+1).
    pub fn check_samples(&self, harmonics: usize) -> PyResult<()> {
        if let Some(ns) = self.samples {
            if ns < 2 * harmonics + 1 {
                return Err(argument(format!(
                    "samples={ns} is too few for {harmonics} harmonics: need at least 2H+1 = {}",
                    2 * harmonics + 1
                )));
            }
        }
        Ok(())
    }
}

/// A penalty: a stiffness (`1e8`) or a multiple of the contact stiffness (`"100x"`).
fn parse_penalty(text: &str) -> PyResult<Penalty> {
    let t = text.trim();
    let (number, relative) = match t.strip_suffix(['x', 'X']) {
        Some(n) => (n.trim(), true),
        None => (t, false),
    };
    let expected = "a positive stiffness [force/length] such as 1e8, or a positive multiple of the contact stiffness such as \"100x\"";
    let v: f64 = number
        .parse()
        .map_err(|_| argument(format!("penalty {text:?}: expected {expected}")))?;
    if !(v.is_finite() && v > 0.0) {
        return Err(argument(format!(
            "penalty must be positive, got {text}: expected {expected}"
        )));
    }
    Ok(if relative {
        Penalty::Relative(v)
    } else {
        Penalty::Stiffness(v)
    })
}
