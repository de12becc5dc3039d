//! Newton's method and pseudo-arclength continuation over any
//! [`crate::problem::PeriodicProblem`].

pub mod arclength;
pub mod newton;
