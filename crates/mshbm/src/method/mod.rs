//! Periodic-solution methods, each an implementor of [`crate::problem::PeriodicProblem`].

pub mod redistributed;
