//! The method options shared by `solve` and `frf` ([`MethodRequest`]): which method, its
//! samples, quadrature, mass, penalties, receptance and Jacobian, Newton's tolerance and
//! iteration limit, the response DOF; the combinations that make no sense are refused.

use super::Checked;
use crate::error::OptionError;
use crate::frd::response_dof;
use crate::harmonic::Quadrature;
use crate::method::general::GeneralOptions;
use crate::method::hbm_aft::{HbmAftOptions, Penalty};
use crate::method::redistributed::{
    JacobianForm, ReceptanceChoice, RedistributedOptions, DEFAULT_RECEPTANCE_MODES,
};
use crate::method::settings::MethodSettings;
use crate::model::{MassKind, Model};
use crate::newton::NewtonOptions;
use crate::solution::MethodKind;
use crate::stability::StabilityOptions;

/// Default Newton tolerance (max-norm of the residual relative to the length scale).
pub const DEFAULT_TOLERANCE: f64 = 1e-10;
/// Default Newton iteration limit per solution.
pub const DEFAULT_MAX_ITERATIONS: usize = 50;
/// Default number of harmonics of `solve` and `frf`.
pub const DEFAULT_HARMONICS: usize = 5;

/// How the receptance at the contacts is computed (redistributed MS-HBM), before the
/// number of modes is known.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReceptanceKind {
    /// [`ReceptanceChoice::Auto`].
    #[default]
    Auto,
    /// [`ReceptanceChoice::Exact`].
    Exact,
    /// [`ReceptanceChoice::Modal`].
    Modal,
}

/// A value chosen by name (`"redistributed"`, `"exact"`, …): the names every front end
/// accepts.
pub trait Choice: Sized + Copy + 'static {
    /// The names and their values, in the order an error lists them.
    const NAMES: &'static [(&'static str, Self)];
}

impl Choice for MethodKind {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("redistributed", MethodKind::Redistributed),
        ("hbm-aft", MethodKind::HbmAft),
        ("mshbm", MethodKind::General),
    ];
}

impl Choice for Quadrature {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("exact", Quadrature::Exact),
        ("sampled", Quadrature::Sampled),
    ];
}

impl Choice for MassKind {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("consistent", MassKind::Consistent),
        ("redistributed", MassKind::Redistributed),
    ];
}

impl Choice for ReceptanceKind {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("auto", ReceptanceKind::Auto),
        ("exact", ReceptanceKind::Exact),
        ("modal", ReceptanceKind::Modal),
    ];
}

impl Choice for JacobianForm {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("auto", JacobianForm::Auto),
        ("dense", JacobianForm::Dense),
        ("operator", JacobianForm::Operator),
    ];
}

/// The value of `option` named `text`, or an error listing the names.
pub fn choose<T: Choice>(option: &'static str, text: &str) -> Checked<T> {
    T::NAMES
        .iter()
        .find(|(name, _)| *name == text)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let names: Vec<String> = T::NAMES.iter().map(|(n, _)| format!("'{n}'")).collect();
            OptionError::new(
                option,
                format!("⟨{option}={text}⟩: expected one of {}", names.join(", ")),
            )
        })
}

/// A penalty of `option` (`penalty`, `tangential_penalty`): a stiffness (`1e8`) or a
/// multiple of the contact stiffness (`100x`).
pub fn parse_penalty(option: &'static str, text: &str) -> Checked<Penalty> {
    let t = text.trim();
    let (number, relative) = match t.strip_suffix(['x', 'X']) {
        Some(n) => (n.trim(), true),
        None => (t, false),
    };
    let expected = "a positive stiffness [force/length] such as 1e8, or a positive multiple of the contact stiffness such as 100x";
    let v: f64 = number.parse().map_err(|_| {
        OptionError::new(option, format!("⟨{option}⟩ {text:?}: expected {expected}"))
    })?;
    if !(v.is_finite() && v > 0.0) {
        return Err(OptionError::new(
            option,
            format!("⟨{option}⟩ must be positive, got {text}: expected {expected}"),
        ));
    }
    Ok(if relative {
        Penalty::Relative(v)
    } else {
        Penalty::Stiffness(v)
    })
}

/// The method options of one `solve` or `frf` (defaults: [`MethodRequest::default`]).
#[derive(Clone, Debug, PartialEq)]
pub struct MethodRequest {
    /// The method (default the redistributed MS-HBM); `TimeIntegration` is refused.
    pub method: MethodKind,
    /// Samples per period NS (general MS-HBM: time steps); default the method's own.
    pub samples: Option<usize>,
    /// Quadrature (default exact for the redistributed MS-HBM, sampled for hbm-aft).
    pub quadrature: Option<Quadrature>,
    /// Mass of hbm-aft (default consistent); refused for the MS-HBM methods.
    pub mass: Option<MassKind>,
    /// Penalties of hbm-aft as typed ([`parse_penalty`]); empty: the default `100x`.
    pub penalty: Vec<String>,
    /// Tangential penalty of hbm-aft on contacts with friction (default: the normal one).
    pub tangential_penalty: Option<String>,
    /// Newton tolerance ([`DEFAULT_TOLERANCE`]).
    pub tolerance: f64,
    /// Newton iteration limit ([`DEFAULT_MAX_ITERATIONS`]).
    pub max_iterations: usize,
    /// The response DOF (default the first contact's first DOF).
    pub dof: Option<usize>,
    /// Modes of the Floquet analysis (redistributed MS-HBM).
    pub stability_modes: Option<usize>,
    /// The receptance (redistributed MS-HBM).
    pub receptance: ReceptanceKind,
    /// Modes of the modal receptance (default [`DEFAULT_RECEPTANCE_MODES`]).
    pub receptance_modes: Option<usize>,
    /// Newton's linear systems (redistributed MS-HBM).
    pub jacobian: JacobianForm,
}

impl Default for MethodRequest {
    fn default() -> Self {
        MethodRequest {
            method: MethodKind::Redistributed,
            samples: None,
            quadrature: None,
            mass: None,
            penalty: Vec::new(),
            tangential_penalty: None,
            tolerance: DEFAULT_TOLERANCE,
            max_iterations: DEFAULT_MAX_ITERATIONS,
            dof: None,
            stability_modes: None,
            receptance: ReceptanceKind::Auto,
            receptance_modes: None,
            jacobian: JacobianForm::Auto,
        }
    }
}

impl MethodRequest {
    /// Newton's options (tolerance and iteration limit checked).
    pub fn newton(&self) -> Checked<NewtonOptions> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(OptionError::new(
                "tolerance",
                format!("⟨tolerance⟩ must be positive, got {}", self.tolerance),
            ));
        }
        if self.max_iterations == 0 {
            return Err(OptionError::new(
                "max_iterations",
                "⟨max_iterations⟩ must be at least 1",
            ));
        }
        Ok(NewtonOptions {
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            ..NewtonOptions::default()
        })
    }

    /// `samples` against `harmonics`: NS ≥ 2H+1.
    pub fn check_samples(&self, harmonics: usize) -> Checked<()> {
        match self.samples {
            Some(ns) if ns < 2 * harmonics + 1 => Err(OptionError::new(
                "samples",
                format!(
                    "⟨samples⟩ {ns} is too few for {harmonics} harmonics: need at least 2H+1 = {}",
                    2 * harmonics + 1
                ),
            )),
            _ => Ok(()),
        }
    }

    /// The receptance of `receptance` and `receptance_modes`.
    fn receptance_choice(&self) -> Checked<ReceptanceChoice> {
        Ok(match (self.receptance, self.receptance_modes) {
            (_, Some(0)) => {
                return Err(OptionError::new(
                    "receptance_modes",
                    "⟨receptance_modes⟩ must be at least 1",
                ))
            }
            (ReceptanceKind::Modal, modes) => ReceptanceChoice::Modal {
                modes: modes.unwrap_or(DEFAULT_RECEPTANCE_MODES),
            },
            (_, Some(_)) => {
                return Err(OptionError::new(
                    "receptance_modes",
                    "⟨receptance_modes⟩ needs ⟨receptance=modal⟩",
                ))
            }
            (ReceptanceKind::Auto, None) => ReceptanceChoice::Auto,
            (ReceptanceKind::Exact, None) => ReceptanceChoice::Exact,
        })
    }

    /// The penalties of `penalty` (checked), or the default `100x`.
    pub fn penalties(&self) -> Checked<Vec<Penalty>> {
        if self.penalty.is_empty() {
            return Ok(vec![Penalty::default()]);
        }
        self.penalty
            .iter()
            .map(|s| parse_penalty("penalty", s))
            .collect()
    }

    /// The methods to run for `harmonics`, from the combination of options (checked): one
    /// per `penalty` value for hbm-aft, one otherwise.
    pub fn methods(&self, harmonics: usize) -> Checked<Vec<MethodSettings>> {
        let redistributed = self.method == MethodKind::Redistributed;
        if self.method == MethodKind::TimeIntegration {
            return Err(OptionError::new(
                "method",
                "⟨method=time-integration⟩ is not a periodic-solution method",
            ));
        }
        match self.stability_modes {
            Some(0) => {
                return Err(OptionError::new(
                    "stability_modes",
                    "⟨stability_modes⟩ must be at least 1",
                ))
            }
            Some(_) if !redistributed => return Err(OptionError::new(
                "stability_modes",
                "⟨stability_modes⟩ applies to ⟨method=redistributed⟩ only (the method with Floquet multipliers)",
            )),
            _ => {}
        }
        if !redistributed
            && (self.receptance != ReceptanceKind::Auto || self.receptance_modes.is_some())
        {
            return Err(OptionError::new(
                "receptance",
                "⟨receptance⟩ and ⟨receptance_modes⟩ apply to ⟨method=redistributed⟩ only",
            ));
        }
        if !redistributed && self.jacobian != JacobianForm::Auto {
            return Err(OptionError::new(
                "jacobian",
                "⟨jacobian⟩ applies to ⟨method=redistributed⟩ only",
            ));
        }
        let quadrature = |default| self.quadrature.unwrap_or(default);
        let tangential_penalty = match &self.tangential_penalty {
            Some(_) if self.method != MethodKind::HbmAft => return Err(OptionError::new(
                "tangential_penalty",
                "⟨tangential_penalty⟩ applies to ⟨method=hbm-aft⟩ only (the MS-HBM treats friction exactly)",
            )),
            Some(text) => Some(parse_penalty("tangential_penalty", text)?),
            None => None,
        };
        if self.method == MethodKind::HbmAft {
            return Ok(self
                .penalties()?
                .into_iter()
                .map(|penalty| {
                    MethodSettings::HbmAft(HbmAftOptions {
                        harmonics,
                        samples: self.samples,
                        mass: self.mass.unwrap_or(MassKind::Consistent),
                        penalty,
                        tangential_penalty,
                        quadrature: quadrature(Quadrature::Sampled),
                    })
                })
                .collect());
        }
        if !self.penalty.is_empty() {
            return Err(OptionError::new(
                "penalty",
                "⟨penalty⟩ applies to ⟨method=hbm-aft⟩ only (the MS-HBM treats contact exactly)",
            ));
        }
        if self.mass.is_some() {
            return Err(OptionError::new(
                "mass",
                "⟨mass⟩ applies to ⟨method=hbm-aft⟩ only (the MS-HBM methods fix their mass)",
            ));
        }
        Ok(vec![if redistributed {
            MethodSettings::Redistributed {
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
            }
        } else {
            MethodSettings::General(GeneralOptions {
                steps: self.samples,
                ..GeneralOptions::new(harmonics)
            })
        }])
    }

    /// The one method to run for `harmonics` (hbm-aft: with one `penalty` value).
    pub fn single_method(&self, harmonics: usize) -> Checked<MethodSettings> {
        let mut methods = self.methods(harmonics)?;
        if methods.len() > 1 {
            return Err(OptionError::new(
                "penalty",
                "solve takes one ⟨penalty⟩ value (frf traces one branch per value)",
            ));
        }
        Ok(methods.remove(0))
    }

    /// The same options for the redistributed MS-HBM drawn over hbm-aft (`frf`'s
    /// `overlay_mshbm`): the penalties and the mass dropped.
    pub fn overlay_mshbm(&self) -> Checked<MethodRequest> {
        if self.method != MethodKind::HbmAft {
            return Err(OptionError::new(
                "overlay_mshbm",
                "⟨overlay_mshbm⟩ overlays the MS-HBM on ⟨method=hbm-aft⟩; give ⟨method=hbm-aft⟩",
            ));
        }
        Ok(MethodRequest {
            method: MethodKind::Redistributed,
            penalty: Vec::new(),
            tangential_penalty: None,
            mass: None,
            ..self.clone()
        })
    }

    /// The response DOF (model numbering): `dof`, or the first contact's first DOF.
    pub fn response_dof(&self, model: &Model) -> Checked<usize> {
        response_dof(model, self.dof)
    }

    /// Samples per period the chosen method will use (for output-size checks).
    pub fn samples_for(&self, harmonics: usize) -> usize {
        self.samples.unwrap_or_else(|| match self.method {
            MethodKind::General => crate::method::general::default_steps(harmonics),
            _ => crate::method::default_samples(harmonics),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_combinations_are_checked_with_the_options_named() {
        let hbm = MethodRequest {
            method: MethodKind::HbmAft,
            penalty: vec!["1e8".into(), "100x".into()],
            ..MethodRequest::default()
        };
        assert_eq!(hbm.methods(3).unwrap().len(), 2);
        let e = hbm.single_method(3).unwrap_err();
        assert_eq!(e.option, "penalty");
        let bad = MethodRequest {
            receptance_modes: Some(5),
            ..MethodRequest::default()
        };
        let e = bad.methods(3).unwrap_err();
        assert_eq!(e.to_string(), "receptance_modes needs receptance = modal");
        let e = parse_penalty("tangential_penalty", "-3x").unwrap_err();
        assert!(e
            .to_string()
            .starts_with("tangential_penalty must be positive, got -3x"));
        assert_eq!(
            parse_penalty("penalty", " 100X ").unwrap(),
            Penalty::Relative(100.0)
        );
        let e = choose::<JacobianForm>("jacobian", "lu").unwrap_err();
        assert_eq!(
            e.to_string(),
            "jacobian = lu: expected one of 'auto', 'dense', 'operator'"
        );
        assert_eq!(
            MethodRequest::default().overlay_mshbm().unwrap_err().option,
            "overlay_mshbm"
        );
    }
}
