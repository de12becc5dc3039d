//! The 20-node serendipity hexahedron ([`mshbm::fe::solid::hex20_shape`], docs/theory.md
//! (T211)–(T213)) against independent references: the defining properties of its shape
//! functions (Kronecker property, partition of unity, linear reproduction, derivatives
//! against central differences), eigenfrequencies from scikit-fem's ElementHexS2 on a Gmsh
//! mesh (tools/gmsh-meshes/make_hex20_mesh.py; read from the `.msh` and from Gmsh's `.inp`
//! export), the patch test on a distorted mesh, exactly six rigid-body modes, the total
//! mass, the traction shares of its faces and the mass redistribution on a contact face.

mod common;

use std::path::{Path, PathBuf};

use common::assert_redistribution;
use faer::linalg::solvers::Solve;
use faer::Mat;
use mshbm::fe::mesh::{CellKind, Cells};
use mshbm::fe::simplex::quadratic_mesh;
use mshbm::fe::solid::{assemble_solid, hex20_shape, ElasticMaterial};
use mshbm::fe::structured::{cuboid, mesh_face_weights};
use mshbm::model::file::{load_model, parse_model};
use mshbm::modes::{eigenfrequencies_hz, symmetric_eigen};
use mshbm::Model;

const STEEL: ElasticMaterial = ElasticMaterial {
    young: 2.1e5,
    poisson: 0.3,
    density: 7.85e-9,
};

fn data(folder: &str, name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(folder)
        .join(name)
}

/// The reference positions of the 20 nodes in VTK order, written out by hand.
const NODES: [[f64; 3]; 20] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [0.0, -1.0, -1.0],
    [1.0, 0.0, -1.0],
    [0.0, 1.0, -1.0],
    [-1.0, 0.0, -1.0],
    [0.0, -1.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [-1.0, 0.0, 1.0],
    [-1.0, -1.0, 0.0],
    [1.0, -1.0, 0.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
];

/// `N_a(ξ_b) = δ_ab`; at other points `Σ N_a = 1`, `Σ N_a ξ_a = ξ`, `Σ N_a ξ_a ξ_aᵀ`
/// the quadratic `ξ ξᵀ` off the diagonal (the serendipity space holds every quadratic
/// polynomial), and the derivatives equal central differences.
#[test]
fn shape_functions_have_their_defining_properties() {
    for (b, xb) in NODES.iter().enumerate() {
        let (n, _) = hex20_shape(*xb);
        for (a, v) in n.iter().enumerate() {
            let expected = if a == b { 1.0 } else { 0.0 };
            assert!((v - expected).abs() < 1e-15, "N_{a}(node {b}) = {v}");
        }
    }
    for k in 0..20 {
        let xi: [f64; 3] = std::array::from_fn(|i| ((k * 7 + i * 3) as f64 * 0.37).sin());
        let (n, dn) = hex20_shape(xi);
        assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        for i in 0..3 {
            let lin: f64 = n.iter().zip(&NODES).map(|(n, x)| n * x[i]).sum();
            assert!((lin - xi[i]).abs() < 1e-14);
            let j = (i + 1) % 3;
            let quad: f64 = n.iter().zip(&NODES).map(|(n, x)| n * x[i] * x[j]).sum();
            assert!((quad - xi[i] * xi[j]).abs() < 1e-14);
            let h = 1e-6;
            let (mut up, mut down) = (xi, xi);
            up[i] += h;
            down[i] -= h;
            let (nu, nd) = (hex20_shape(up).0, hex20_shape(down).0);
            for a in 0..20 {
                let fd = (nu[a] - nd[a]) / (2.0 * h);
                assert!(
                    (dn[a][i] - fd).abs() < 1e-8,
                    "dN_{a}/dξ_{i}: {} vs {fd}",
                    dn[a][i]
                );
            }
        }
    }
}

fn reference() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(data("gmsh", "hex20_reference.json")).unwrap())
        .unwrap()
}

fn inp_model() -> Model {
    let text = std::fs::read_to_string(data("gmsh", "box_hex20.toml"))
        .unwrap()
        .replace("box_hex20.msh", "box_hex20.inp");
    parse_model(&text, &data("abaqus", "model.toml"), &[]).unwrap()
}

/// The Gmsh Hex20 box clamped at x = 0, read from the `.msh` and from Gmsh's `.inp`
/// export: the ten lowest eigenfrequencies agree with scikit-fem's ElementHexS2 on the same
/// mesh to 1e-8 (which also checks Gmsh's Hex20 node order in both files), and the total
/// mass is scikit-fem's.
#[test]
fn box_eigenfrequencies_equal_scikit_fem() {
    let r = reference();
    let theirs: Vec<f64> = serde_json::from_value(r["frequencies_hz"].clone()).unwrap();
    for (file, m) in [
        (
            "msh",
            load_model(&data("gmsh", "box_hex20.toml"), &[]).unwrap(),
        ),
        ("inp", inp_model()),
    ] {
        assert_eq!(m.cells.as_ref().map(|c| c.kind), Some(CellKind::Hex20));
        assert_eq!(m.n_nodes() as u64, r["nodes"].as_u64().unwrap());
        assert_eq!(m.n_dofs() as u64, r["dofs"].as_u64().unwrap());
        let total: f64 = m.mass.iter().map(|(_, _, v)| v).sum();
        let sum_m = r["sum_m"].as_f64().unwrap();
        assert!((total / sum_m - 1.0).abs() < 1e-12, "{total} vs {sum_m}");
        let free: Vec<usize> = (0..m.n_dofs())
            .filter(|i| m.dirichlet.binary_search(i).is_err())
            .collect();
        let ours = eigenfrequencies_hz(
            &m.mass.submatrix(&free, &free),
            &m.stiffness.submatrix(&free, &free),
            theirs.len(),
        )
        .unwrap();
        let worst = ours
            .iter()
            .zip(&theirs)
            .fold(0.0f64, |w, (a, b)| w.max(((a - b) / b).abs()));
        println!("Hex20 box ({file}): largest relative difference {worst:.1e}");
        assert!(worst < 1e-8, "{file}: {ours:?} vs {theirs:?}");
    }
}

/// The unit cube in 3 × 3 × 3 Hex20 cells with its interior corner nodes moved (the
/// mid-side nodes at the middles of the straight edges): returns (coordinates, cells,
/// boundary nodes).
fn distorted_cube() -> (Vec<Vec<f64>>, Cells, Vec<usize>) {
    let mut mesh = cuboid([1.0, 1.0, 1.0], [3, 3, 3]).unwrap();
    let inside = |p: &[f64]| p.iter().all(|&v| v > 1e-12 && v < 1.0 - 1e-12);
    for (p, xp) in mesh.coordinates.iter_mut().enumerate() {
        if inside(xp) {
            for (a, v) in xp.iter_mut().enumerate() {
                *v += 0.08 / 3.0 * ((p * (a + 3)) as f64 * 0.7).sin();
            }
        }
    }
    let (x, cells) = quadratic_mesh(&mesh.coordinates, &mesh.cells).unwrap();
    assert_eq!(cells.kind, CellKind::Hex20);
    let boundary = (0..x.len()).filter(|&p| !inside(&x[p])).collect();
    (x, cells, boundary)
}

/// Patch test: the boundary displacements of a linear field give that field at every
/// interior node of the distorted mesh.
#[test]
fn patch_test_reproduces_linear_fields() {
    let (x, cells, boundary_nodes) = distorted_cube();
    let field = |p: &[f64]| -> Vec<f64> {
        (0..3)
            .map(|c| {
                1e-3 * (0.3 * c as f64
                    + (0..3)
                        .map(|a| ((a * 3 + c * 5 + 1) % 7) as f64 * 0.4 - 1.0)
                        .zip(p)
                        .map(|(g, v)| g * v)
                        .sum::<f64>())
            })
            .collect()
    };
    let (_, k) = assemble_solid(&x, &cells, &STEEL).unwrap();
    let exact: Vec<f64> = x.iter().flat_map(|p| field(p)).collect();
    let boundary: Vec<usize> = boundary_nodes
        .iter()
        .flat_map(|&p| (0..3).map(move |c| p * 3 + c))
        .collect();
    let interior: Vec<usize> = (0..k.nrows()).filter(|i| !boundary.contains(i)).collect();
    assert!(interior.len() > 100);
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
    println!("Hex20 patch test error {err:.1e}");
    assert!(err < 1e-12, "patch test: error {err:e}");
}

/// The free distorted mesh has exactly six zero-energy modes (the rigid-body modes, whose
/// strain energy is zero) and the next eigenvalue clearly positive; M carries ρ·1 per
/// component (the distortion keeps the cube's volume) and couples no components.
#[test]
fn free_mesh_has_exactly_the_rigid_body_modes() {
    let (x, cells, _) = distorted_cube();
    let (m, k) = assemble_solid(&x, &cells, &STEEL).unwrap();
    let (values, _) = symmetric_eigen(&k.to_dense()).unwrap();
    let top = values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let zeros = values.iter().filter(|v| v.abs() < 1e-10 * top).count();
    assert_eq!(zeros, 6, "{:?}", &values[..7]);
    // the rigid-body motions: K r = 0 for the translations and rotations
    for r in 0..6 {
        let v: Vec<f64> = x
            .iter()
            .flat_map(|p| {
                let mut u = [0.0; 3];
                if r < 3 {
                    u[r] = 1.0;
                } else {
                    let (i, j) = ((r + 1) % 3, (r + 2) % 3);
                    u[i] = -p[j];
                    u[j] = p[i];
                }
                u
            })
            .collect();
        let mut kv = vec![0.0; v.len()];
        for (i, j, a) in k.iter() {
            kv[i] += a * v[j];
        }
        let energy: f64 = kv.iter().zip(&v).map(|(a, b)| a * b).sum();
        let worst = kv.iter().fold(0.0f64, |w, a| w.max(a.abs()));
        assert!(
            worst < 1e-9 * top && energy.abs() < 1e-9 * top,
            "mode {r}: {worst:e}"
        );
    }
    for c in 0..3 {
        let comp: f64 = m
            .iter()
            .filter(|&(i, j, _)| i % 3 == c && j % 3 == c)
            .map(|(_, _, v)| v)
            .sum();
        assert!(
            (comp / STEEL.density - 1.0).abs() < 1e-12,
            "component {c}: {comp}"
        );
    }
    assert!(m.iter().all(|(i, j, v)| i % 3 == j % 3 || v == 0.0));
}

/// A uniform traction on the end face of a Hex20 block: −1/12 of a cell face at each
/// corner node, 1/3 at each mid-side node (T212), summing to the face; the weights' first
/// moment is the face's centroid.
#[test]
fn face_weights_of_serendipity_faces() {
    let mesh = cuboid([2.0, 1.0, 0.5], [2, 2, 1]).unwrap();
    let (x, cells) = quadratic_mesh(&mesh.coordinates, &mesh.cells).unwrap();
    let face: Vec<usize> = (0..x.len()).filter(|&p| x[p][0] == 2.0).collect();
    let w = mesh_face_weights(&x, &cells, &face).unwrap();
    assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-14);
    // two cell faces of 0.5 × 0.5: a corner shared by both gets −2/12 · ½, one on its own
    // −1/12 · ½; a mid-side node 1/3 · ½ (or twice on the shared edge)
    for (&p, w) in face.iter().zip(&w) {
        let corner = p < mesh.coordinates.len();
        let shared = (x[p][1] - 0.5).abs() < 1e-12;
        let cells_at = if shared { 2.0 } else { 1.0 };
        let share = if corner { -1.0 / 12.0 } else { 1.0 / 3.0 };
        assert!(
            (w - cells_at * share * 0.5).abs() < 1e-15,
            "node {p} at {:?}: {w}",
            x[p]
        );
    }
    for (a, centre) in [(1, 0.5), (2, 0.25)] {
        let c: f64 = face.iter().zip(&w).map(|(&p, w)| w * x[p][a]).sum();
        assert!((c - centre).abs() < 1e-14, "axis {a}: {c}");
    }
}

/// The end face of the Hex20 box in contact (its corner and mid-side nodes): every DOF of
/// its nodes massless, total mass and first and second moments kept to 1e-12, positive
/// definite on the rest (tests/common); the eigenfrequency shifts `modes` reports.
#[test]
fn redistribution_on_hex20_contact_faces() {
    let m = load_model(&data("gmsh", "box_hex20.toml"), &[]).unwrap();
    // the tip face x = 3: 4 × 3 corners and 3 × 3 + 4 × 2 mid-side nodes
    assert_eq!(m.contacts.len(), 12 + 17);
    assert_redistribution(&m, "box_hex20");
    let shift = m.compare_masses(3).unwrap();
    println!(
        "box_hex20: {} contact nodes of {}, {:?} norm: {:?} Hz -> {:?} Hz ({:?})",
        m.contacts.len(),
        m.n_nodes(),
        shift.norm,
        shift.original_hz,
        shift.redistributed_hz,
        shift.relative_error
    );
    assert!(shift.relative_error.iter().all(|e| e.abs() < 0.05));
}
