//! Gmsh meshes ([`mshbm::model::gmsh`]) and `kind = "mesh"` model files
//! ([`mshbm::model::mesh`]) against the Gmsh API's own account of the same files and
//! scikit-fem's eigenfrequencies on the same nodes (tools/gmsh-meshes/make_test_meshes.py),
//! the mass redistribution on Tet4 and Tet10 contact faces against its defining properties,
//! and clear errors naming the file, the line or the missing group.

mod common;

use std::path::{Path, PathBuf};

use common::assert_redistribution;
use mshbm::fe::mesh::CellKind;
use mshbm::model::file::{load_model, parse_model};
use mshbm::model::gmsh::parse_msh;
use mshbm::modes::eigenfrequencies_hz;
use mshbm::MassKind;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/gmsh")
        .join(name)
}

fn reference() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(data("reference.json")).unwrap()).unwrap()
}

/// Each file's dimension, node and cell counts and, per physical group, the number of
/// nodes and the sum of their coordinates are those the Gmsh API reports.
#[test]
fn meshes_are_read_as_gmsh_reports_them() {
    let r = reference();
    for (name, kind) in [
        ("box_tet10", CellKind::Tet10),
        ("box_tet4", CellKind::Tet4),
        ("plate_tri6", CellKind::Tri6),
    ] {
        let text = std::fs::read_to_string(data(&format!("{name}.msh"))).unwrap();
        let mesh = parse_msh(&text).unwrap();
        let r = &r[name];
        assert_eq!(mesh.cells.kind, kind);
        assert_eq!(mesh.dimension as u64, r["dimension"].as_u64().unwrap());
        assert_eq!(mesh.coordinates.len() as u64, r["nodes"].as_u64().unwrap());
        assert_eq!(mesh.cells.len() as u64, r["cells"].as_u64().unwrap());
        let groups = r["groups"].as_object().unwrap();
        assert_eq!(mesh.groups.len(), groups.len(), "{name}");
        for (group, facts) in groups {
            let nodes = &mesh.groups[group];
            assert_eq!(nodes.len() as u64, facts["nodes"].as_u64().unwrap());
            let sum: Vec<f64> = serde_json::from_value(facts["sum"].clone()).unwrap();
            for (a, s) in sum.iter().enumerate() {
                let ours: f64 = nodes.iter().map(|&p| mesh.coordinates[p][a]).sum();
                assert!(
                    (ours - s).abs() <= 1e-12 * s.abs().max(1.0),
                    "{name} {group} axis {a}: {ours} vs {s}"
                );
            }
        }
    }
}

/// The box in Tet4 and Tet10 cells, loaded as `kind = "mesh"` models with the group "root"
/// clamped: the ten lowest eigenfrequencies agree with scikit-fem's on the same mesh to
/// 1e-8 (for Tet10 this also checks Gmsh's node order of the quadratic tetrahedron).
#[test]
fn box_models_have_scikit_fem_eigenfrequencies() {
    let r = reference();
    for name in ["box_tet4", "box_tet10"] {
        let m = load_model(&data(&format!("{name}.toml")), &[]).unwrap();
        let free: Vec<usize> = (0..m.n_dofs())
            .filter(|i| m.dirichlet.binary_search(i).is_err())
            .collect();
        // the clamped DOFs are those of the nodes at x = 0
        let at_root = (0..m.n_dofs())
            .filter(|&i| m.coordinates[i / 3][0] == 0.0)
            .count();
        assert_eq!(m.dirichlet.len(), at_root);
        let theirs: Vec<f64> = serde_json::from_value(r[name]["frequencies_hz"].clone()).unwrap();
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
        println!("{name}: {ours:?} Hz, largest relative difference {worst:.1e}");
        assert!(worst < 1e-8, "{name}: {ours:?} vs {theirs:?}");
        // the load is the resultant on the top face, spread as a uniform traction
        let fz: f64 = (0..m.n_nodes()).map(|p| m.harmonic_load[3 * p + 2]).sum();
        assert!((fz + 10.0).abs() < 1e-12, "{fz}");
        let moment: f64 = (0..m.n_nodes())
            .map(|p| m.harmonic_load[3 * p + 2] * m.coordinates[p][0])
            .sum();
        assert!(
            (moment + 10.0 * 1.5).abs() < 1e-10,
            "centre of the traction: {moment}"
        );
    }
}

/// The end face of the box in contact (a whole face, with the mid-side nodes of the
/// Tet10 faces): every DOF of its nodes massless, total mass and first and second moments
/// kept to 1e-12, positive definite on the rest; the shifts of the lowest
/// eigenfrequencies as `modes` reports them. Likewise the hole of the Tri6 plate.
#[test]
fn redistribution_on_tetrahedral_and_triangular_contact_faces() {
    for name in ["box_tet4", "box_tet10", "plate_tri6"] {
        let m = load_model(&data(&format!("{name}.toml")), &[]).unwrap();
        assert!(!m.contacts.is_empty());
        assert_redistribution(&m, name);
        let shift = m.compare_masses(3).unwrap();
        println!(
            "{name}: {} contact nodes of {}, {} norm: {:?} Hz -> {:?} Hz ({:?})",
            m.contacts.len(),
            m.n_nodes(),
            shift.norm,
            shift.original_hz,
            shift.redistributed_hz,
            shift.relative_error
        );
        assert!(shift.relative_error.iter().all(|e| e.abs() < 0.05));
    }
}

/// The plate with a hole: total mass ρ t times the area of its curved (quadratic) cells,
/// the area found independently by Green's theorem on the boundary edges of the mesh
/// (`½ ∮ x dy − y dx`, Simpson's rule exact on a quadratic edge); and within the
/// quadratic boundary's error of the true geometry's area.
#[test]
fn the_quadratic_plate_has_the_mass_of_its_curved_geometry() {
    let m = load_model(&data("plate_tri6.toml"), &[]).unwrap();
    let total: f64 = m
        .mass
        .iter()
        .filter(|&(i, j, _)| i % 2 == 0 && j % 2 == 0)
        .map(|(_, _, v)| v)
        .sum();
    let measured = total / (7.85e-9 * 2.0);
    let cells = m.cells.as_ref().unwrap();
    let mut edges: std::collections::HashMap<(usize, usize), (usize, usize, usize, usize)> =
        Default::default();
    for c in 0..cells.len() {
        let v = cells.cell(c);
        for (a, b, mid) in [(0, 1, 3), (1, 2, 4), (2, 0, 5)] {
            let key = (v[a].min(v[b]), v[a].max(v[b]));
            edges.entry(key).or_insert((v[a], v[b], v[mid], 0)).3 += 1;
        }
    }
    let x = &m.coordinates;
    let mut green = 0.0;
    for &(a, b, mid, count) in edges.values() {
        if count == 1 {
            // x(s) through a, mid, b at s = 0, ½, 1; ∫ (x y' − y x') ds by Simpson
            let point = |s: f64| -> [f64; 4] {
                let n = [
                    (1.0 - s) * (1.0 - 2.0 * s),
                    s * (2.0 * s - 1.0),
                    4.0 * s * (1.0 - s),
                ];
                let dn = [4.0 * s - 3.0, 4.0 * s - 1.0, 4.0 - 8.0 * s];
                let p = [a, b, mid];
                let f = |w: &[f64; 3], k: usize| (0..3).map(|i| w[i] * x[p[i]][k]).sum::<f64>();
                [f(&n, 0), f(&n, 1), f(&dn, 0), f(&dn, 1)]
            };
            let integrand = |s: f64| {
                let [px, py, dx, dy] = point(s);
                px * dy - py * dx
            };
            green += 0.5 * (integrand(0.0) + 4.0 * integrand(0.5) + integrand(1.0)) / 6.0;
        }
    }
    let true_area = 4.0 - std::f64::consts::PI * 0.25 * 0.25;
    println!("plate area from M {measured}, from its boundary {green}, true {true_area}");
    assert!(
        ((measured - green) / green).abs() < 1e-13,
        "{measured} vs {green}"
    );
    assert!(((measured - true_area) / true_area).abs() < 1e-4);
}

fn parse_mesh_model(text: &str) -> String {
    parse_model(text, &data("inline.toml"), &[])
        .unwrap_err()
        .to_string()
}

const MODEL: &str = r#"
kind = "mesh"
[mesh]
file = "box_tet4.msh"
young = 2.1e5
poisson = 0.3
density = 7.85e-9
clamped = ["root"]
"#;

/// A missing group, a missing file, a field that does not apply: the message names the
/// model file, the field and the group (with the known ones).
#[test]
fn bad_model_files_are_refused_naming_the_field_and_group() {
    let e = parse_mesh_model(&MODEL.replace(r#"["root"]"#, r#"["roots"]"#));
    assert!(
        e.contains("inline.toml") && e.contains("mesh.clamped[0]") && e.contains("\"roots\""),
        "{e}"
    );
    assert!(
        e.contains("root") && e.contains("tip") && e.contains("body"),
        "{e}"
    );
    let e = parse_mesh_model(&format!(
        "{MODEL}[[interfaces]]\nname = \"x\"\nkind = \"obstacle\"\nset = \"nowhere\"\nnormal = [1.0, 0.0, 0.0]\ngap = 0.1\n"
    ));
    assert!(
        e.contains("interfaces[0].set") && e.contains("nowhere"),
        "{e}"
    );
    let e = parse_mesh_model(&MODEL.replace("box_tet4.msh", "absent.msh"));
    assert!(e.contains("mesh.file") && e.contains("absent.msh"), "{e}");
    let e = parse_mesh_model(&MODEL.replace("clamped", "thickness = 1.0\nclamped"));
    assert!(e.contains("mesh.thickness"), "{e}");
    let e = parse_mesh_model(&MODEL.replace("box_tet4.msh", "../gmsh/box_tet4.msh"));
    assert!(e.contains("outside"), "{e}");
}

/// Errors in the mesh file name the line; binary files and other versions are refused
/// with what to do instead.
#[test]
fn bad_mesh_files_are_refused_naming_the_line() {
    let good = std::fs::read_to_string(data("box_tet4.msh")).unwrap();
    let line_of = |needle: &str| good.lines().position(|l| l == needle).unwrap() + 1;
    let cases: Vec<(String, String)> = vec![
        (good.replacen("4.1 0 8", "4.1 1 8", 1), "binary".into()),
        (good.replacen("4.1 0 8", "2.2 0 8", 1), "MSH version".into()),
        (
            good.replacen("$EndNodes", "$EndNode", 1),
            format!("line {}", line_of("$EndNodes")),
        ),
        (
            good.replacen("$Elements", "$Elementz", 1),
            "ends inside Elementz".into(),
        ),
        (
            good.replacen("$EndElements\n", "", 1),
            "ends inside Elements".into(),
        ),
        ("hello".into(), "line 1".into()),
        (String::new(), "no $MeshFormat".into()),
    ];
    for (text, expected) in cases {
        let e = parse_msh(&text).unwrap_err().to_string();
        assert!(e.contains(&expected), "{expected:?} not in {e:?}");
    }
    // a cell's node missing from $Nodes
    let mut lines: Vec<String> = good.lines().map(String::from).collect();
    let start = lines.iter().position(|l| l == "$Elements").unwrap();
    let tet = (start..lines.len())
        .find(|&i| lines[i].split_whitespace().count() == 5 && lines[i - 1].starts_with("3 "))
        .unwrap();
    lines[tet] = "1000 1 2 3 999999".into();
    let e = parse_msh(&lines.join("\n")).unwrap_err().to_string();
    assert!(e.contains("999999") && e.contains("line"), "{e}");
}

/// A mesh model gives the system the methods work on (Dirichlet DOFs removed,
/// redistributed mass) and keeps its cells for the VTK output.
#[test]
fn mesh_models_give_systems() {
    let m = load_model(&data("box_tet10.toml"), &[]).unwrap();
    let system = m.system(MassKind::Redistributed).unwrap();
    assert_eq!(system.n_dofs(), m.n_dofs() - m.dirichlet.len());
    assert!(m.cells.as_ref().is_some_and(|c| c.kind == CellKind::Tet10));
}

/// The bracket example (examples/bracket_gmsh, 10-node tetrahedra from Gmsh): 285 contact
/// nodes on its stop face, redistributed in the mass-weighted norm, and the lowest
/// eigenfrequency its README shows.
#[test]
fn the_bracket_example_redistributes_its_stop_face() {
    let m = load_model(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/bracket_gmsh/model.toml"),
        &[],
    )
    .unwrap();
    assert_eq!((m.contacts.len(), m.n_dofs()), (285, 20457));
    // the full property check (tests/common's assert_redistribution) takes minutes on
    // 20457 DOFs and is made on the small boxes above; here the eigenfrequencies, whose
    // solve needs the redistributed mass positive definite on the other DOFs
    let shift = m.compare_masses(1).unwrap();
    assert_eq!(
        shift.norm,
        mshbm::fe::redistribution::RedistributionNorm::MassWeighted
    );
    for (ours, readme) in [
        (shift.original_hz[0], 1244.674),
        (shift.redistributed_hz[0], 1246.325),
    ] {
        assert!((ours - readme).abs() < 1e-3, "{ours} vs {readme}");
    }
}

/// The binary twins of the test meshes (written by Gmsh itself from the ASCII files,
/// tools/gmsh-meshes/make_binary_meshes.py) are read as the same mesh and give the same
/// model, matrices and contacts included.
#[test]
fn binary_meshes_give_the_systems_of_their_ascii_twins() {
    use mshbm::model::gmsh::parse_msh_bytes;
    let scratch = std::env::temp_dir().join(format!("mshbm-binary-msh-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).unwrap();
    for name in ["box_tet10", "plate_tri6", "box_hex20"] {
        let ascii = std::fs::read(data(&format!("{name}.msh"))).unwrap();
        let binary = std::fs::read(data(&format!("{name}_binary.msh"))).unwrap();
        assert!(binary.contains(&0u8), "{name}: the twin is binary");
        let a = parse_msh(std::str::from_utf8(&ascii).unwrap()).unwrap();
        let b = parse_msh_bytes(&binary).unwrap();
        assert_eq!(b.dimension, a.dimension, "{name}");
        assert_eq!(b.node_tags, a.node_tags, "{name}");
        assert_eq!(b.coordinates, a.coordinates, "{name}");
        assert_eq!(b.cells, a.cells, "{name}");
        assert_eq!(b.groups, a.groups, "{name}");
        // the same model: the model file with the binary mesh
        let toml = std::fs::read_to_string(data(&format!("{name}.toml"))).unwrap();
        std::fs::write(scratch.join(format!("{name}_binary.msh")), &binary).unwrap();
        let twin = toml.replace(&format!("{name}.msh"), &format!("{name}_binary.msh"));
        assert_ne!(twin, toml);
        std::fs::write(scratch.join("twin.toml"), twin).unwrap();
        let ma = load_model(&data(&format!("{name}.toml")), &[]).unwrap();
        let mb = load_model(&scratch.join("twin.toml"), &[]).unwrap();
        assert!(mb.stiffness == ma.stiffness, "{name}: stiffness");
        assert!(mb.mass == ma.mass, "{name}: mass");
        assert_eq!(mb.harmonic_load, ma.harmonic_load, "{name}");
        assert_eq!(mb.dirichlet, ma.dirichlet, "{name}");
        let contacts = |m: &mshbm::Model| -> Vec<(Vec<usize>, Vec<f64>, f64)> {
            m.contacts
                .iter()
                .map(|c| (c.dofs.clone(), c.w.clone(), c.gap))
                .collect()
        };
        assert_eq!(contacts(&mb), contacts(&ma), "{name}");
        // cut anywhere, the binary file is refused with the byte offset, never a panic
        for cut in (0..binary.len()).step_by(97) {
            let e = parse_msh_bytes(&binary[..cut]);
            assert!(e.is_err(), "{name} cut at {cut}");
        }
        let mut big = binary.clone();
        big[20] = 2; // the byte-order check
        let e = parse_msh_bytes(&big).unwrap_err().to_string();
        assert!(e.contains("byte 20") && e.contains("byte-order"), "{e}");
    }
    let _ = std::fs::remove_dir_all(&scratch);
}

/// Binary files in either byte order and with a 4- or 8-byte `size_t`, written by a
/// Python writer of their own (tools/gmsh-meshes/make_binary_seeds.py), are the
/// one-tetrahedron mesh of their ASCII twin.
#[test]
fn binary_meshes_in_either_byte_order_and_size() {
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_corpus");
    let ascii = std::fs::read_to_string(corpus.join("meshes/tiny_tet.msh")).unwrap();
    let a = parse_msh(&ascii).unwrap();
    for name in ["le8", "be8", "le4"] {
        let bytes =
            std::fs::read(corpus.join(format!("meshes_binary/tiny_tet_{name}.msh"))).unwrap();
        let b = mshbm::model::gmsh::parse_msh_bytes(&bytes).unwrap();
        assert_eq!(b.coordinates, a.coordinates, "{name}");
        assert_eq!(b.node_tags, a.node_tags, "{name}");
        assert_eq!(b.cells, a.cells, "{name}");
        assert_eq!(b.groups, a.groups, "{name}");
    }
}
