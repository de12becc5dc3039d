//! The simplex elements ([`mshbm::fe::simplex`], docs/theory.md §21: Tri3, Tri6, Tet4,
//! Tet10) against independent references: the exact integrals of monomials over the
//! reference simplex (quadrature rules), eigenfrequencies from scikit-fem
//! (tools/fe-reference/skfem_simplex_reference.py), exact linear fields on distorted and
//! curved meshes (patch tests), the rigid-body modes and the total mass.

use std::path::Path;

use faer::linalg::solvers::Solve;
use faer::Mat;
use mshbm::fe::mesh::{CellKind, Cells};
use mshbm::fe::simplex::{quadratic_mesh, tetrahedron_rule, triangle_rule};
use mshbm::fe::solid::{assemble_plane, assemble_solid, ElasticMaterial, PlaneKind};
use mshbm::fe::structured::{cuboid, mesh_face_weights, rectangle, simplices};
use mshbm::modes::{eigenfrequencies_hz, symmetric_eigen};
use mshbm::sparse::SparseMatrix;

const STEEL: ElasticMaterial = ElasticMaterial {
    young: 2.1e5,
    poisson: 0.3,
    density: 7.85e-9,
};

fn factorial(n: u32) -> f64 {
    (1..=n).map(f64::from).product()
}

/// `∫ ξ^α` over the reference simplex of dimension `d`: `α! / (|α| + d)!`.
fn exact_monomial(alpha: &[u32]) -> f64 {
    let d = alpha.len() as u32;
    alpha.iter().map(|&a| factorial(a)).product::<f64>() / factorial(alpha.iter().sum::<u32>() + d)
}

/// Every rule integrates every monomial up to its degree exactly (to round-off), and is
/// not exact one degree higher for some monomial (so the test can tell degrees apart).
#[test]
fn quadrature_rules_are_exact_to_their_degree() {
    for degree in [2usize, 4] {
        let rule = triangle_rule(degree);
        assert_eq!(rule.len(), if degree == 2 { 3 } else { 6 });
        let mut worst = 0.0f64;
        for a in 0..=degree as u32 {
            for b in 0..=degree as u32 - a {
                let q: f64 = rule
                    .iter()
                    .map(|(x, w)| w * x[0].powi(a as i32) * x[1].powi(b as i32))
                    .sum();
                worst = worst.max((q / exact_monomial(&[a, b]) - 1.0).abs());
            }
        }
        assert!(worst < 1e-14, "triangle degree {degree}: {worst:e}");
        let a = degree as u32 + 1;
        let q: f64 = rule.iter().map(|(x, w)| w * x[0].powi(a as i32)).sum();
        assert!((q / exact_monomial(&[a, 0]) - 1.0).abs() > 1e-6);
    }
    for degree in [2usize, 5] {
        let rule = tetrahedron_rule(degree);
        assert_eq!(rule.len(), if degree == 2 { 4 } else { 14 });
        assert!(rule.iter().all(|(_, w)| *w > 0.0));
        let mut worst = 0.0f64;
        let n = degree as u32;
        for a in 0..=n {
            for b in 0..=n - a {
                for c in 0..=n - a - b {
                    let q: f64 = rule
                        .iter()
                        .map(|(x, w)| {
                            w * x[0].powi(a as i32) * x[1].powi(b as i32) * x[2].powi(c as i32)
                        })
                        .sum();
                    worst = worst.max((q / exact_monomial(&[a, b, c]) - 1.0).abs());
                }
            }
        }
        assert!(worst < 1e-14, "tetrahedron degree {degree}: {worst:e}");
        let a = n + 1;
        let q: f64 = rule.iter().map(|(x, w)| w * x[0].powi(a as i32)).sum();
        assert!((q / exact_monomial(&[a, 0, 0]) - 1.0).abs() > 1e-6);
    }
}

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The linear mesh of the reference file, every cell positively oriented.
fn reference_mesh(r: &serde_json::Value, key: &str, kind: CellKind) -> (Vec<Vec<f64>>, Cells) {
    let nodes: Vec<Vec<f64>> = serde_json::from_value(r[key]["nodes"].clone()).unwrap();
    let cells: Vec<Vec<usize>> = serde_json::from_value(r[key]["cells"].clone()).unwrap();
    let mut connectivity = Vec::new();
    for mut c in cells {
        let e: Vec<Vec<f64>> = c[1..]
            .iter()
            .map(|&p| {
                (0..nodes[p].len())
                    .map(|a| nodes[p][a] - nodes[c[0]][a])
                    .collect()
            })
            .collect();
        let det = if e.len() == 2 {
            e[0][0] * e[1][1] - e[0][1] * e[1][0]
        } else {
            e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
                - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
                + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0])
        };
        if det < 0.0 {
            c.swap(1, 2);
        }
        connectivity.extend(c);
    }
    (nodes, Cells { kind, connectivity })
}

/// The ten lowest eigenfrequencies of the clamped triangle and tetrahedron meshes (linear
/// and quadratic, plane stress, plane strain and 3D) agree with scikit-fem to 1e-8, and so
/// do the traces of K and M and the total mass.
#[test]
fn eigenfrequencies_equal_scikit_fem() {
    let text = std::fs::read_to_string(data("skfem_simplex_reference.json")).unwrap();
    let reference: serde_json::Value = serde_json::from_str(&text).unwrap();
    let (x2, tri3) = reference_mesh(&reference, "triangles", CellKind::Tri3);
    let (x3, tet4) = reference_mesh(&reference, "tetrahedra", CellKind::Tet4);
    let (x2q, tri6) = quadratic_mesh(&x2, &tri3).unwrap();
    let (x3q, tet10) = quadratic_mesh(&x3, &tet4).unwrap();
    let plane = |x: &[Vec<f64>], c: &Cells, kind| assemble_plane(x, c, &STEEL, 1.0, kind).unwrap();
    let cases = [
        (
            "tri3_plane_stress",
            plane(&x2, &tri3, PlaneKind::Stress),
            &x2,
        ),
        (
            "tri3_plane_strain",
            plane(&x2, &tri3, PlaneKind::Strain),
            &x2,
        ),
        (
            "tri6_plane_stress",
            plane(&x2q, &tri6, PlaneKind::Stress),
            &x2q,
        ),
        (
            "tri6_plane_strain",
            plane(&x2q, &tri6, PlaneKind::Strain),
            &x2q,
        ),
        ("tet4", assemble_solid(&x3, &tet4, &STEEL).unwrap(), &x3),
        ("tet10", assemble_solid(&x3q, &tet10, &STEEL).unwrap(), &x3q),
    ];
    for (name, (m, k), x) in cases {
        let r = &reference[name];
        let d = x[0].len();
        assert_eq!(k.nrows() as u64, r["dofs"].as_u64().unwrap(), "{name}");
        let close = |ours: f64, key: &str| {
            let theirs = r[key].as_f64().unwrap();
            assert!(
                ((ours - theirs) / theirs).abs() < 1e-8,
                "{name} {key}: {ours} vs {theirs}"
            );
        };
        close((0..k.nrows()).map(|i| k.get(i, i)).sum(), "trace_k");
        close((0..m.nrows()).map(|i| m.get(i, i)).sum(), "trace_m");
        close(m.iter().map(|(_, _, v)| v).sum(), "sum_m");
        let theirs: Vec<f64> = serde_json::from_value(r["frequencies_hz"].clone()).unwrap();
        let free: Vec<usize> = (0..k.nrows()).filter(|&i| x[i / d][0] != 0.0).collect();
        let ours = eigenfrequencies_hz(
            &m.submatrix(&free, &free),
            &k.submatrix(&free, &free),
            theirs.len(),
        )
        .unwrap();
        let worst = ours
            .iter()
            .zip(&theirs)
            .fold(0.0f64, |w, (a, b)| w.max(((a - b) / b).abs()));
        println!("{name}: largest relative difference {worst:.1e}");
        assert!(worst < 1e-8, "{name}: {ours:?} vs {theirs:?}");
    }
}

/// The four simplex meshes of a distorted structured mesh: Tri3 and Tri6 of a rectangle,
/// Tet4 and Tet10 of a box; the interior nodes moved (in the quadratic meshes the mid-side
/// nodes too, so that the cells are curved). Returns (coordinates, cells, boundary nodes).
fn distorted_meshes() -> Vec<(Vec<Vec<f64>>, Cells, Vec<usize>)> {
    let mut out = Vec::new();
    let rect = simplices(&rectangle([2.0, 1.0], [4, 4], None).unwrap()).unwrap();
    let boxed = simplices(&cuboid([1.0, 1.0, 1.0], [3, 3, 3]).unwrap()).unwrap();
    for (mesh, h) in [(rect, 0.25), (boxed, 1.0 / 3.0)] {
        let linear = (mesh.coordinates.clone(), mesh.cells.clone());
        let quadratic = quadratic_mesh(&mesh.coordinates, &mesh.cells).unwrap();
        for (mut x, cells) in [linear, quadratic] {
            let d = x[0].len();
            let extent: Vec<f64> = (0..d)
                .map(|a| x.iter().fold(0.0f64, |m, p| m.max(p[a])))
                .collect();
            let on_boundary =
                |p: &[f64]| (0..d).any(|a| p[a].abs() < 1e-12 || (p[a] - extent[a]).abs() < 1e-12);
            let boundary: Vec<usize> = (0..x.len()).filter(|&p| on_boundary(&x[p])).collect();
            for (p, xp) in x.iter_mut().enumerate() {
                if !on_boundary(xp) {
                    for (a, v) in xp.iter_mut().enumerate() {
                        *v += 0.08 * h * ((p * (a + 3)) as f64 * 0.7).sin();
                    }
                }
            }
            out.push((x, cells, boundary));
        }
    }
    out
}

fn assemble(x: &[Vec<f64>], cells: &Cells) -> (SparseMatrix, SparseMatrix) {
    if cells.kind.dimension() == 2 {
        assemble_plane(x, cells, &STEEL, 1.0, PlaneKind::Strain).unwrap()
    } else {
        assemble_solid(x, cells, &STEEL).unwrap()
    }
}

/// Patch test: on distorted (and, quadratic, curved) meshes the boundary displacements of
/// a linear field give that field at every interior node (K u = 0 there), for every
/// simplex element.
#[test]
fn patch_tests_reproduce_linear_fields() {
    for (x, cells, boundary_nodes) in distorted_meshes() {
        let d = x[0].len();
        let field = |p: &[f64]| -> Vec<f64> {
            (0..d)
                .map(|c| {
                    1e-3 * (0.3 * c as f64
                        + (0..d)
                            .map(|a| ((a * 3 + c * 5 + 1) % 7) as f64 * 0.4 - 1.0)
                            .zip(p)
                            .map(|(g, v)| g * v)
                            .sum::<f64>())
                })
                .collect()
        };
        let (_, k) = assemble(&x, &cells);
        let exact: Vec<f64> = x.iter().flat_map(|p| field(p)).collect();
        let boundary: Vec<usize> = boundary_nodes
            .iter()
            .flat_map(|&p| (0..d).map(move |c| p * d + c))
            .collect();
        let interior: Vec<usize> = (0..k.nrows()).filter(|i| !boundary.contains(i)).collect();
        assert!(!interior.is_empty());
        let kd = k.to_dense();
        let kii = Mat::<f64>::from_fn(interior.len(), interior.len(), |a, b| {
            kd[(interior[a], interior[b])]
        });
        let rhs = Mat::<f64>::from_fn(interior.len(), 1, |a, _| {
            -boundary
                .iter()
                .map(|&j| kd[(interior[a], j)] * exact[j])
                .sum::<f64>()
        });
        let u = kii.partial_piv_lu().solve(&rhs);
        let err =
            (0..interior.len()).fold(0.0f64, |e, a| e.max((u[(a, 0)] - exact[interior[a]]).abs()));
        println!("{:?}: patch test error {err:.1e}", cells.kind);
        assert!(err < 1e-12, "{:?} patch test: error {err:e}", cells.kind);
    }
}

/// A free mesh of each simplex has exactly the rigid-body modes as zero-stiffness modes
/// (3 in 2D, 6 in 3D; their strain energy is zero) and the next eigenvalue is clearly
/// positive; M carries ρ·volume per component and couples no components.
#[test]
fn free_meshes_have_exactly_the_rigid_body_modes() {
    for (x, cells, _) in distorted_meshes() {
        let d = x[0].len();
        let (m, k) = assemble(&x, &cells);
        let (values, _) = symmetric_eigen(&k.to_dense()).unwrap();
        let top = values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let zeros = values.iter().filter(|v| v.abs() < 1e-10 * top).count();
        let rigid = if d == 2 { 3 } else { 6 };
        assert_eq!(zeros, rigid, "{:?}: {:?}", cells.kind, &values[..rigid + 1]);
        // the structured domains keep their volume under the interior distortion
        let volume = if d == 2 { 2.0 } else { 1.0 };
        for c in 0..d {
            let comp: f64 = m
                .iter()
                .filter(|&(i, j, _)| i % d == c && j % d == c)
                .map(|(_, _, v)| v)
                .sum();
            assert!(
                (comp / (STEEL.density * volume) - 1.0).abs() < 1e-12,
                "{:?} component {c}: {comp}",
                cells.kind
            );
        }
        assert!(m.iter().all(|(i, j, v)| i % d == j % d || v == 0.0));
    }
}

/// An inverted cell is refused with a message naming it, never a panic; a cell of the
/// wrong dimension too.
#[test]
fn inverted_and_misplaced_cells_are_refused() {
    let x = vec![
        vec![0.0, 0.0, 0.0],
        vec![1.0, 0.0, 0.0],
        vec![0.0, 1.0, 0.0],
        vec![0.0, 0.0, 1.0],
    ];
    let inverted = Cells {
        kind: CellKind::Tet4,
        connectivity: vec![0, 2, 1, 3],
    };
    let e = assemble_solid(&x, &inverted, &STEEL)
        .unwrap_err()
        .to_string();
    assert!(e.contains("cell 0") && e.contains("inverted"), "{e}");
    let tri = Cells {
        kind: CellKind::Tri3,
        connectivity: vec![0, 1, 2],
    };
    let e = assemble_solid(&x, &tri, &STEEL).unwrap_err().to_string();
    assert!(e.contains("Tri3"), "{e}");
}

/// A uniform traction on a face of quadratic simplices: the vertices of a Tet10 face get
/// nothing, its mid-side nodes a third of the face each (T206); Tri6 edges 1 : 4 : 1.
#[test]
fn face_weights_of_quadratic_faces() {
    let mesh = simplices(&cuboid([2.0, 1.0, 1.0], [2, 1, 1]).unwrap()).unwrap();
    let (x, cells) = quadratic_mesh(&mesh.coordinates, &mesh.cells).unwrap();
    let face: Vec<usize> = (0..x.len()).filter(|&p| x[p][0] == 2.0).collect();
    let w = mesh_face_weights(&x, &cells, &face).unwrap();
    assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-14);
    for (&p, w) in face.iter().zip(&w) {
        let vertex = p < mesh.coordinates.len();
        if vertex {
            assert_eq!(*w, 0.0);
        } else {
            assert!(*w > 0.0);
        }
    }
    // the first moment of the weights is the face's centroid (a uniform traction)
    for a in [1, 2] {
        let c: f64 = face.iter().zip(&w).map(|(&p, w)| w * x[p][a]).sum();
        assert!((c - 0.5).abs() < 1e-14, "axis {a}: {c}");
    }
    let rect = simplices(&rectangle([1.0, 1.0], [1, 1], None).unwrap()).unwrap();
    let (x, cells) = quadratic_mesh(&rect.coordinates, &rect.cells).unwrap();
    let edge: Vec<usize> = (0..x.len()).filter(|&p| x[p][1] == 0.0).collect();
    let w = mesh_face_weights(&x, &cells, &edge).unwrap();
    let mut sorted: Vec<(f64, f64)> = edge.iter().map(|&p| x[p][0]).zip(w).collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let shares: Vec<f64> = sorted.iter().map(|s| s.1).collect();
    for (a, b) in shares.iter().zip([1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0]) {
        assert!((a - b).abs() < 1e-15, "{shares:?}");
    }
}
