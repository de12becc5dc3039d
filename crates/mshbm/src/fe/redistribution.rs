//! Mass redistribution (paper Section 3, eqs. 21–22; Khenous, Laborde & Renard 2008;
//! docs/theory.md §4, (T25)–(T32), (T120)): a mass matrix `M_R` with massless contact nodes that
//! stays as close as possible to the consistent mass `M` while keeping the total mass, the
//! first moments (centre of gravity) and the second moments (inertia) — i.e. the kinetic
//! energy of every affine velocity field.
//!
//! The problem is posed on the *scalar* per-node mass matrix of the **unconstrained** mesh
//! (Dirichlet DOFs are removed afterwards; docs/theory.md §4, "Where it is posed", shows
//! why). "As close as possible" is measured in one of two norms ([`RedistributionNorm`]):
//! the paper's Frobenius norm (eq. 22), and a mass-weighted one that changes every entry
//! in proportion to itself. Their KKT conditions give the closed forms (T27) and (T120)
//!
//! `R_ij = M_ij + w_ij (Φ Λ Φᵀ)_ij` on the free pattern `F` (entries of `M` between
//! non-contact nodes), `R_ij = 0` elsewhere, `Φ = [1, x_1, …, x_d]`, `w_ij = 1` or `|M_ij|`,
//!
//! with the symmetric `(d+1)×(d+1)` multiplier `Λ` found from a `p = (d+1)(d+2)/2` linear
//! system. Sparsity and symmetry are kept by construction.
//!
//! Nothing here depends on the element: on simplex meshes (Tet4, Tet10, Tri3, Tri6) every
//! node of a contact face, mid-side nodes included, is made massless the same way (as on
//! Hex20 faces, (T213)), and the
//! moments kept are the continuum's inertia (docs/theory.md §21, (T208)); the quadratic
//! elements' mass has negative entries, which the mass-weighted correction scales with
//! their sign kept ((T209)).

use crate::dense::solve_small;
use crate::error::{Error, Result};
use crate::sparse::SparseMatrix;
use faer::Side;

/// The norm in which the redistributed mass is closest to the consistent one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RedistributionNorm {
    /// `‖R − M‖_F` (paper eq. 22, docs/theory.md (T26)–(T27)): the correction is one
    /// bilinear polynomial of the coordinates added to every free entry.
    Frobenius,
    /// `Σ (R_ij − M_ij)² / |M_ij|` (docs/theory.md (T120)): the correction scales each entry,
    /// `R_ij = M_ij (1 + φ_iᵀ Λ φ_j)`, so it stays in proportion to the local mass; it keeps
    /// a mass positive definite where the Frobenius correction does not (a whole face of a
    /// 3D mesh in contact).
    MassWeighted,
}

impl std::fmt::Display for RedistributionNorm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            RedistributionNorm::Frobenius => "Frobenius",
            RedistributionNorm::MassWeighted => "mass-weighted",
        })
    }
}

/// A redistributed scalar mass and the norm that produced it.
#[derive(Clone, Debug)]
pub struct Redistribution {
    pub mass: SparseMatrix,
    pub norm: RedistributionNorm,
}

/// Redistribute in the paper's Frobenius norm, and where that leaves the mass indefinite on
/// the non-contact nodes, in the mass-weighted norm (docs/theory.md §4, "Choice of norm").
/// Fails when neither is positive definite or the moment conditions cannot be met.
pub fn redistribute_scalar_mass(
    mass: &SparseMatrix,
    coordinates: &[Vec<f64>],
    contact_nodes: &[usize],
) -> Result<Redistribution> {
    match redistribute_scalar_mass_in(
        mass,
        coordinates,
        contact_nodes,
        RedistributionNorm::Frobenius,
    ) {
        Ok(mass) => Ok(Redistribution {
            mass,
            norm: RedistributionNorm::Frobenius,
        }),
        Err(Error::Redistribution(why)) if why.contains(NOT_DEFINITE) => {
            redistribute_scalar_mass_in(
                mass,
                coordinates,
                contact_nodes,
                RedistributionNorm::MassWeighted,
            )
            .map(|mass| Redistribution {
                mass,
                norm: RedistributionNorm::MassWeighted,
            })
        }
        Err(e) => Err(e),
    }
}

const NOT_DEFINITE: &str = "not positive definite";

/// Redistribute the scalar (one DOF per node) mass matrix `mass` of a mesh with node
/// `coordinates` (each of dimension 1, 2 or 3) so that the nodes in `contact_nodes` become
/// massless (eq. 21), keeping total mass and first and second moments, closest to `mass`
/// in `norm`. Checks that the result is positive definite on the other nodes.
pub fn redistribute_scalar_mass_in(
    mass: &SparseMatrix,
    coordinates: &[Vec<f64>],
    contact_nodes: &[usize],
    norm: RedistributionNorm,
) -> Result<SparseMatrix> {
    let n = mass.nrows();
    if coordinates.len() != n {
        return Err(Error::Redistribution(format!(
            "{} node coordinates for a {n}-node mass matrix",
            coordinates.len()
        )));
    }
    let dim = coordinates.first().map_or(0, Vec::len);
    if !(1..=3).contains(&dim) || coordinates.iter().any(|c| c.len() != dim) {
        return Err(Error::Redistribution(
            "node coordinates must all have the same dimension, 1, 2 or 3".into(),
        ));
    }
    let mut is_contact = vec![false; n];
    for &c in contact_nodes {
        is_contact[c] = true;
    }
    // contact nodes that already carry no mass (a model built with a massless boundary)
    // need no redistribution
    if mass
        .iter()
        .all(|(i, j, v)| v == 0.0 || (!is_contact[i] && !is_contact[j]))
    {
        return Ok(mass.clone());
    }

    // Centred and scaled affine basis Φ = [1, x'_1, …, x'_d] (invariant result, better conditioning).
    let q = dim + 1;
    let mut centre = vec![0.0; dim];
    for c in coordinates {
        for a in 0..dim {
            centre[a] += c[a] / n as f64;
        }
    }
    let mut length = 0.0f64;
    for c in coordinates {
        for a in 0..dim {
            length = length.max((c[a] - centre[a]).abs());
        }
    }
    let length = if length > 0.0 { length } else { 1.0 };
    let phi: Vec<Vec<f64>> = coordinates
        .iter()
        .map(|c| {
            let mut row = vec![1.0];
            row.extend((0..dim).map(|a| (c[a] - centre[a]) / length));
            row
        })
        .collect();

    // Index pairs (a <= b) of the symmetric multiplier.
    let pairs: Vec<(usize, usize)> = (0..q).flat_map(|a| (a..q).map(move |b| (a, b))).collect();
    let p = pairs.len();
    let basis = |i: usize, j: usize, (a, b): (usize, usize)| -> f64 {
        if a == b {
            phi[i][a] * phi[j][a]
        } else {
            phi[i][a] * phi[j][b] + phi[i][b] * phi[j][a]
        }
    };

    // Targets Φᵀ M Φ, the moments of M0 (M restricted to the free pattern) and the KKT matrix.
    let mut target = vec![0.0; p];
    let mut kept = vec![0.0; p];
    // weight of each entry's correction: 1 (Frobenius, T27) or |m_ij| (mass-weighted, T33)
    let weight = |v: f64| match norm {
        RedistributionNorm::Frobenius => 1.0,
        RedistributionNorm::MassWeighted => v.abs(),
    };
    let mut g = vec![0.0; p * p];
    for (i, j, v) in mass.iter() {
        let free = !is_contact[i] && !is_contact[j];
        for (r, &(c, e)) in pairs.iter().enumerate() {
            let w = phi[i][c] * phi[j][e];
            target[r] += w * v;
            if free {
                kept[r] += w * v;
                for (s, &ab) in pairs.iter().enumerate() {
                    g[r * p + s] += w * weight(v) * basis(i, j, ab);
                }
            }
        }
    }
    let rhs: Vec<f64> = target.iter().zip(&kept).map(|(t, k)| t - k).collect();
    let mu = solve_small(&g, &rhs, 1e-13).ok_or_else(|| {
        Error::Redistribution(
            "the moment conditions cannot be met: too few non-contact nodes, or their coordinates are degenerate (e.g. all on a line in 2-D)".into(),
        )
    })?;

    let mut triplets = Vec::with_capacity(mass.nnz());
    for (i, j, v) in mass.iter() {
        if is_contact[i] || is_contact[j] {
            continue;
        }
        let correction: f64 = pairs
            .iter()
            .zip(&mu)
            .map(|(&ab, m)| m * basis(i, j, ab))
            .sum::<f64>()
            * weight(v);
        triplets.push((i, j, v + correction));
    }
    let redistributed = SparseMatrix::from_triplets(n, n, &triplets);

    // Positive definiteness on the nodes that keep mass.
    let massive: Vec<usize> = (0..n).filter(|&i| !is_contact[i]).collect();
    let block = redistributed.submatrix(&massive, &massive);
    if block.to_faer().sp_cholesky(Side::Lower).is_err() {
        return Err(Error::Redistribution(format!(
            "the redistributed mass ({norm} norm) is {NOT_DEFINITE} on the non-contact nodes; \
             the moment-preserving correction is too strong for this mesh (more element layers behind the contact face, or fewer contact nodes)"
        )));
    }
    Ok(redistributed)
}

/// Moments `Φᵀ M Φ` (total mass, first and second moments about the origin) of a scalar
/// mass matrix, as the `(d+1)×(d+1)` matrix in row-major order.
pub fn moments(mass: &SparseMatrix, coordinates: &[Vec<f64>]) -> Vec<f64> {
    let dim = coordinates.first().map_or(0, Vec::len);
    let q = dim + 1;
    let phi = |i: usize, a: usize| if a == 0 { 1.0 } else { coordinates[i][a - 1] };
    let mut out = vec![0.0; q * q];
    for (i, j, v) in mass.iter() {
        for a in 0..q {
            for b in 0..q {
                out[a * q + b] += phi(i, a) * v * phi(j, b);
            }
        }
    }
    out
}

/// Extract the scalar per-node mass matrix `m` from a DOF-level mass `M = m ⊗ I_d` (DOF
/// `node * dofs_per_node + component`). Fails when `M` is not of that form (e.g. rotational
/// DOFs, or coupling between components), which the redistribution does not cover.
pub fn scalar_mass(
    mass: &SparseMatrix,
    dofs_per_node: usize,
) -> std::result::Result<SparseMatrix, String> {
    let d = dofs_per_node;
    if d == 1 {
        return Ok(mass.clone());
    }
    let n = mass.nrows() / d;
    let tol = 1e-12 * mass.max_abs();
    let mut t = Vec::new();
    for (i, j, v) in mass.iter() {
        let (ni, ci, nj, cj) = (i / d, i % d, j / d, j % d);
        if ci != cj {
            if v.abs() > tol {
                return Err(format!("entry ({i}, {j}) couples components {ci} and {cj}"));
            }
            continue;
        }
        if ci == 0 {
            t.push((ni, nj, v));
        } else if (v - mass.get(ni * d, nj * d)).abs() > tol {
            return Err(format!(
                "entry ({i}, {j}) differs from the first component's entry ({}, {})",
                ni * d,
                nj * d
            ));
        }
    }
    Ok(SparseMatrix::from_triplets(n, n, &t))
}

/// `m ⊗ I_d`: the DOF-level matrix of a scalar per-node matrix.
pub fn expand_to_dofs(scalar: &SparseMatrix, dofs_per_node: usize) -> SparseMatrix {
    let d = dofs_per_node;
    let t: Vec<(usize, usize, f64)> = scalar
        .iter()
        .flat_map(|(i, j, v)| (0..d).map(move |c| (i * d + c, j * d + c, v)))
        .collect();
    SparseMatrix::from_triplets(scalar.nrows() * d, scalar.ncols() * d, &t)
}
