//! Small built-in finite elements and the mass redistribution of the paper (Section 3).

pub mod bar1d;
pub mod mesh;
pub mod redistribution;
