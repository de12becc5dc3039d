//! # mshbm
//!
//! Periodic solutions and nonlinear frequency response diagrams of mechanical systems with
//! unilateral contact, by the Mixed Shooting–Harmonic Balance Method (MS-HBM) of Schreyer &
//! Leine ("Mixed Shooting-HBM: a periodic solution solver for unilaterally constrained
//! systems"). Equation numbers in the docs refer to that paper.
//!
//! The library does all numerics and never prints; the `mshbm` binary is in `mshbm-cli`.

pub mod analytic;
pub mod contact;
pub mod dense;
pub mod error;
pub mod fe;
pub mod frd;
pub mod krylov;
pub mod limits;
pub mod model;
pub mod modes;
pub mod newton;
pub mod ode;
pub mod roots;
pub mod sparse;
pub mod stability;

pub use error::{Error, Result};
pub use model::{MassKind, Model, System};
pub mod continuation;
pub mod harmonic;
pub mod integrate;
pub mod linear;
pub mod method;
pub mod problem;
pub mod request;
pub mod simulation;
pub mod solution;
pub mod solve;
