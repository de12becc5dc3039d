//! The requests of the commands: every option of `solve`, `frf` and `simulate` with its
//! default, its validation and its error text, built once for every front end. The CLI and
//! the Python package fill a request from their own syntax (arguments, keywords) and turn
//! its errors ([`OptionError`], options named without any front end's syntax) into their
//! own spelling; neither checks, defaults or computes an option itself.
//!
//! - [`MethodRequest`]: the method options shared by `solve` and `frf` → the
//!   [`MethodSettings`](crate::method::settings::MethodSettings) to run, Newton's options,
//!   the response DOF;
//! - [`SolveRequest`]: one periodic solution → [`SolveSettings`](crate::solve::SolveSettings);
//! - [`FrdRequest`]: a frequency response diagram →
//!   [`FrdSettings`](crate::frd::FrdSettings) and its methods;
//! - [`SimulateRequest`]: a reference time integration → its scheme, time grid and
//!   steady-state options ([`SimulatePlan`]).

pub mod frd;
pub mod method;
pub mod simulate;
pub mod solve;

pub use crate::error::{OptionError, PlainSpelling, Spelling};
pub use frd::FrdRequest;
pub use method::{choose, parse_penalty, Choice, MethodRequest, ReceptanceKind};
pub use simulate::{SchemeKind, SimulatePlan, SimulateRequest, TimeGrid};
pub use solve::{SolveRequest, StartKind, StartSolution};

/// The result of a request's checks.
pub type Checked<T> = std::result::Result<T, OptionError>;
