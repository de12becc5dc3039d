//! Pseudo-arclength continuation over any [`crate::problem::PeriodicProblem`] (Newton is
//! [`crate::newton`]).

pub mod arclength;
