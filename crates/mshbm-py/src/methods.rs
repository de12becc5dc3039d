//! The method options of `solve` and `frf`: Python keywords → the library's
//! [`MethodRequest`] (its defaults, checks and messages, shared with the CLI's
//! `MethodArgs`); the choices by name through [`mshbm::request::choose`].

use mshbm::request::{choose, Choice, MethodRequest};
use pyo3::prelude::*;

use crate::errors::Spelled;

/// The method keywords of one call, as given.
pub struct MethodKeywords<'a> {
    pub method: Option<&'a str>,
    pub samples: Option<usize>,
    pub quadrature: Option<&'a str>,
    pub mass: Option<&'a str>,
    pub penalty: Vec<String>,
    pub tangential_penalty: Option<String>,
    pub tolerance: Option<f64>,
    pub max_iterations: Option<usize>,
    pub dof: Option<usize>,
    pub stability_modes: Option<usize>,
    pub receptance: Option<&'a str>,
    pub receptance_modes: Option<usize>,
    pub jacobian: Option<&'a str>,
}

impl MethodKeywords<'_> {
    /// The library's request of these keywords.
    pub fn request(self) -> PyResult<MethodRequest> {
        let defaults = MethodRequest::default();
        Ok(MethodRequest {
            method: chosen("method", self.method, defaults.method)?,
            samples: self.samples,
            quadrature: self
                .quadrature
                .map(|q| choose("quadrature", q))
                .transpose()
                .spelled()?,
            mass: self.mass.map(|m| choose("mass", m)).transpose().spelled()?,
            penalty: self.penalty,
            tangential_penalty: self.tangential_penalty,
            tolerance: self.tolerance.unwrap_or(defaults.tolerance),
            max_iterations: self.max_iterations.unwrap_or(defaults.max_iterations),
            dof: self.dof,
            stability_modes: self.stability_modes,
            receptance: chosen("receptance", self.receptance, defaults.receptance)?,
            receptance_modes: self.receptance_modes,
            jacobian: chosen("jacobian", self.jacobian, defaults.jacobian)?,
        })
    }
}

/// The value named `text` of `option`, or `default` (the library's) when not given.
pub fn chosen<T: Choice>(option: &'static str, text: Option<&str>, default: T) -> PyResult<T> {
    text.map_or(Ok(default), |t| choose(option, t).spelled())
}
