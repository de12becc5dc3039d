//! Newton's method over any [`crate::problem::PeriodicProblem`] (and, later, continuation).

pub mod newton;
