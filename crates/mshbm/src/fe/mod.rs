//! Finite elements — bars (paper eq. 45), linear-elastic quadrilaterals and hexahedra with
//! structured meshes (docs/theory.md §15), linear and quadratic triangles and tetrahedra
//! (§21) — and the mass redistribution of the paper (Section 3).

pub mod bar1d;
pub mod mesh;
pub mod redistribution;
pub mod simplex;
pub mod solid;
pub mod structured;
