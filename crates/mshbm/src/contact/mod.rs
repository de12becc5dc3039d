//! Contact laws and their solvers.

pub mod lcp;
