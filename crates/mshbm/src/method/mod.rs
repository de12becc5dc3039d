//! Periodic-solution methods, each an implementor of [`crate::problem::PeriodicProblem`].

pub mod hbm_aft;
pub mod redistributed;
pub mod shooting;
