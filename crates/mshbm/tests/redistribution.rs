//! Mass redistribution (paper eqs. 21–22, docs/theory.md §4): moments kept, massless contact
//! nodes, pattern and symmetry kept, positive definite elsewhere — in 1-D, 2-D and 3-D.

use std::path::Path;

use mshbm::fe::redistribution::{
    moments, redistribute_scalar_mass, redistribute_scalar_mass_in, RedistributionNorm,
};
use mshbm::model::bar::BarParameters;
use mshbm::sparse::SparseMatrix;
use mshbm::MassKind;

fn check(mass: &SparseMatrix, coords: &[Vec<f64>], contact: &[usize]) -> SparseMatrix {
    let r = redistribute_scalar_mass(mass, coords, contact)
        .unwrap()
        .mass;
    // moments about the origin: total mass, first and second moments
    let before = moments(mass, coords);
    let after = moments(&r, coords);
    let scale = before.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (a, b) in before.iter().zip(&after) {
        assert!((a - b).abs() <= 1e-12 * scale, "moment {a} vs {b}");
    }
    assert!(
        (before[0] - after[0]).abs() <= 1e-12 * before[0],
        "total mass"
    );
    // contact rows and columns exactly zero
    for &c in contact {
        for j in 0..r.ncols() {
            assert_eq!(r.get(c, j), 0.0);
            assert_eq!(r.get(j, c), 0.0);
        }
    }
    // pattern kept (never grows), symmetry exact
    for (i, j, _) in r.iter() {
        assert!(mass.is_stored(i, j), "new entry ({i}, {j})");
    }
    assert_eq!(r.asymmetry(0.0), None);
    r
}

#[test]
fn bar_redistribution_keeps_moments_and_matches_the_reference_entries() {
    let model = BarParameters::paper().build(Path::new("bar")).unwrap();
    let r = check(&model.mass, &model.coordinates, &[100]);
    // Entries in units of rho A h / 6 from the closed form docs/theory.md (T31).
    let unit = 9e-9 * 0.2 / 6.0;
    for (i, j, expected) in [
        (0, 0, 2.0416),
        (1, 1, 4.0383),
        (50, 50, 3.9791),
        (99, 99, 4.1228),
        (98, 99, 1.1203),
    ] {
        assert!(
            (r.get(i, j) / unit - expected).abs() < 1e-4,
            "R[{i},{j}] = {}",
            r.get(i, j) / unit
        );
    }
    // every interior entry changes: the correction is global
    assert!((r.get(50, 50) / unit - 4.0).abs() > 1e-3);
    // positive definite on the non-contact nodes: Cholesky succeeds (checked inside) and
    // the system builds
    model.system(MassKind::Redistributed).unwrap();
}

/// Bilinear quadrilaterals on a `nx × ny` grid (consistent scalar mass), nodes row-major.
fn quad_mesh(nx: usize, ny: usize) -> (SparseMatrix, Vec<Vec<f64>>) {
    let idx = |i: usize, j: usize| j * (nx + 1) + i;
    let base = [
        [4.0, 2.0, 1.0, 2.0],
        [2.0, 4.0, 2.0, 1.0],
        [1.0, 2.0, 4.0, 2.0],
        [2.0, 1.0, 2.0, 4.0],
    ];
    let mut t = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let nodes = [idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)];
            for a in 0..4 {
                for b in 0..4 {
                    t.push((nodes[a], nodes[b], base[a][b] / 36.0 * 0.5 * 0.25));
                }
            }
        }
    }
    let n = (nx + 1) * (ny + 1);
    let coords = (0..n)
        .map(|k| vec![(k % (nx + 1)) as f64 * 0.5, (k / (nx + 1)) as f64 * 0.25])
        .collect();
    (SparseMatrix::from_triplets(n, n, &t), coords)
}

#[test]
fn two_dimensional_mesh_with_a_contact_edge() {
    let (m, coords) = quad_mesh(8, 6);
    let contact: Vec<usize> = (0..=8).collect(); // bottom edge
    check(&m, &coords, &contact);
}

/// Hexahedral grid, trilinear consistent mass (tensor product of 1-D masses).
fn hex_mesh(nx: usize, ny: usize, nz: usize) -> (SparseMatrix, Vec<Vec<f64>>) {
    let h = 0.3;
    let m1 = |a: usize, b: usize| if a == b { 2.0 / 6.0 * h } else { 1.0 / 6.0 * h };
    let idx = |i: usize, j: usize, k: usize| (k * (ny + 1) + j) * (nx + 1) + i;
    let mut t = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let corners: Vec<(usize, usize, usize)> = (0..8)
                    .map(|c| (c & 1, (c >> 1) & 1, (c >> 2) & 1))
                    .collect();
                for &(a1, a2, a3) in &corners {
                    for &(b1, b2, b3) in &corners {
                        let v = m1(a1, b1) * m1(a2, b2) * m1(a3, b3);
                        t.push((idx(i + a1, j + a2, k + a3), idx(i + b1, j + b2, k + b3), v));
                    }
                }
            }
        }
    }
    let n = (nx + 1) * (ny + 1) * (nz + 1);
    let m = SparseMatrix::from_triplets(n, n, &t);
    let coords: Vec<Vec<f64>> = (0..n)
        .map(|p| {
            let i = p % (nx + 1);
            let j = (p / (nx + 1)) % (ny + 1);
            let k = p / ((nx + 1) * (ny + 1));
            vec![i as f64 * h, j as f64 * h, k as f64 * h]
        })
        .collect();
    (m, coords)
}

fn bottom_face(nx: usize, ny: usize) -> Vec<usize> {
    (0..(nx + 1) * (ny + 1)).collect()
}

#[test]
fn three_dimensional_mesh_with_a_contact_face() {
    let (m, coords) = hex_mesh(3, 3, 8);
    check(&m, &coords, &bottom_face(3, 3));
}

/// A whole face of a flat 3D mesh in contact (a third of its nodes): the paper's Frobenius
/// correction (T27) makes the rest indefinite; the mass-weighted one (T120) keeps it definite,
/// keeps the moments, and is the weighted-norm minimiser — checked by its optimality
/// condition: `(R_ij − M_ij) / M_ij` on the free entries is a bilinear polynomial
/// `φ_iᵀ Λ φ_j` of the node coordinates (a least-squares fit of the 10 basis functions
/// leaves a round-off residual), which with the moment constraints characterises the
/// unique minimiser of this convex problem.
#[test]
fn a_whole_contact_face_is_redistributed_in_the_mass_weighted_norm() {
    let (m, coords) = hex_mesh(6, 6, 2);
    let face = bottom_face(6, 6);
    let err = redistribute_scalar_mass_in(&m, &coords, &face, RedistributionNorm::Frobenius)
        .unwrap_err()
        .to_string();
    assert!(err.contains("not positive definite"), "{err}");
    let auto = redistribute_scalar_mass(&m, &coords, &face).unwrap();
    assert_eq!(auto.norm, RedistributionNorm::MassWeighted);
    let r = check(&m, &coords, &face);
    // every free entry of the pattern is kept (none cancels)
    let free = m
        .iter()
        .filter(|&(i, j, _)| i > face.len() - 1 && j > face.len() - 1)
        .count();
    assert_eq!(r.iter().filter(|&(_, _, v)| v != 0.0).count(), free);

    // optimality: the relative change lies in span{φ_i φ_jᵀ + φ_j φ_iᵀ}
    let phi = |i: usize, a: usize| if a == 0 { 1.0 } else { coords[i][a - 1] };
    let pairs: Vec<(usize, usize)> = (0..4).flat_map(|a| (a..4).map(move |b| (a, b))).collect();
    let mut rows = Vec::new();
    let mut rhs = Vec::new();
    for (i, j, v) in r.iter() {
        rows.extend(pairs.iter().map(|&(a, b)| {
            if a == b {
                phi(i, a) * phi(j, a)
            } else {
                phi(i, a) * phi(j, b) + phi(i, b) * phi(j, a)
            }
        }));
        rhs.push(v / m.get(i, j) - 1.0);
    }
    let a = faer::Mat::from_fn(rhs.len(), pairs.len(), |k, c| rows[k * pairs.len() + c]);
    let b = faer::Mat::from_fn(rhs.len(), 1, |k, _| rhs[k]);
    let x = faer::linalg::solvers::SolveLstsq::solve_lstsq(&a.qr(), &b);
    let residual = (&a * &x - &b).norm_max();
    let size = b.norm_max();
    assert!(size > 1e-2, "the correction is not small: {size}");
    assert!(residual < 1e-12 * size.max(1.0), "residual {residual:e}");
}

#[test]
fn too_coarse_a_mesh_is_reported_as_not_positive_definite() {
    // a quarter of the nodes on the contact face, three layers: neither correction keeps
    // the mass definite, which must be reported, not returned
    let (m, coords) = hex_mesh(4, 3, 3);
    let err = redistribute_scalar_mass(&m, &coords, &bottom_face(4, 3))
        .unwrap_err()
        .to_string();
    assert!(err.contains("not positive definite"), "{err}");
}

#[test]
fn degenerate_free_set_is_a_clear_error() {
    // two-element bar with both non-clamped nodes in contact: only one node keeps mass,
    // so the three moment conditions cannot be met
    let (m, coords) = (
        mshbm::fe::bar1d::assemble(2, 1.0, 1.0, 1.0, 1.0).unwrap().0,
        mshbm::fe::bar1d::node_coordinates(2, 1.0),
    );
    let err = redistribute_scalar_mass(&m, &coords, &[1, 2])
        .unwrap_err()
        .to_string();
    assert!(err.contains("mass redistribution"), "{err}");
}
