//! Abaqus input files ([`mshbm::model::abaqus`]) as the meshes of `kind = "mesh"` models:
//! the same mesh exported by Gmsh as `.msh` (tests/data/gmsh) and as `.inp`
//! (tests/data/abaqus, Gmsh's own export, tools/gmsh-meshes/export_inp.py) gives the same
//! nodes, cells, node sets and system; a hand-written file with the keywords Gmsh does not
//! write (GENERATE, sets of sets, node surfaces, continued lines) against hand-counted sets
//! and the analytic mass; errors naming the line and the missing set.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use mshbm::fe::mesh::CellKind;
use mshbm::model::abaqus::parse_inp;
use mshbm::model::file::{load_model, parse_model};
use mshbm::model::gmsh::parse_msh;
use mshbm::model::Model;
use mshbm::sparse::SparseMatrix;

fn data(folder: &str, name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(folder)
        .join(name)
}

fn entries(m: &SparseMatrix) -> BTreeMap<(usize, usize), f64> {
    let mut out = BTreeMap::new();
    for (i, j, v) in m.iter() {
        *out.entry((i, j)).or_insert(0.0) += v;
    }
    out
}

/// Largest entry difference relative to the largest entry (the pattern the same).
fn matrix_difference(a: &SparseMatrix, b: &SparseMatrix) -> f64 {
    let (a, b) = (entries(a), entries(b));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "patterns differ"
    );
    let scale = a.values().fold(0.0f64, |s, v| s.max(v.abs()));
    a.values()
        .zip(b.values())
        .fold(0.0f64, |w, (x, y)| w.max((x - y).abs() / scale))
}

/// The model of tests/data/gmsh/NAME.toml with its mesh read from the `.inp` export.
fn inp_model(name: &str) -> Model {
    let text = std::fs::read_to_string(data("gmsh", &format!("{name}.toml"))).unwrap();
    let text = text.replace(
        &format!("file = \"{name}.msh\""),
        &format!("file = \"{name}.inp\""),
    );
    assert!(text.contains(".inp"));
    parse_model(&text, &data("abaqus", "model.toml"), &[]).unwrap()
}

/// Gmsh's `.msh` and `.inp` exports of one mesh read to the same nodes (tags, coordinates
/// to the 14 digits Gmsh writes in `.inp`), the same cells in the same node order (Tet10
/// and Hex20: Gmsh's own orders in `.msh`, Abaqus's in `.inp`) and the same groups; their
/// models have the same mass and stiffness matrices (to round-off), loads, clamped DOFs,
/// contacts and node sets.
#[test]
fn gmsh_and_abaqus_exports_give_the_same_model() {
    for (name, kind) in [
        ("box_tet10", CellKind::Tet10),
        ("box_tet4", CellKind::Tet4),
        ("plate_tri6", CellKind::Tri6),
        ("box_hex20", CellKind::Hex20),
    ] {
        let msh =
            parse_msh(&std::fs::read_to_string(data("gmsh", &format!("{name}.msh"))).unwrap())
                .unwrap();
        let inp =
            parse_inp(&std::fs::read_to_string(data("abaqus", &format!("{name}.inp"))).unwrap())
                .unwrap();
        assert_eq!(inp.cells.kind, kind);
        assert_eq!(inp.dimension, msh.dimension);
        assert_eq!(inp.node_tags, msh.node_tags, "{name}");
        assert_eq!(inp.cells, msh.cells, "{name}");
        let worst = msh
            .coordinates
            .iter()
            .flatten()
            .zip(inp.coordinates.iter().flatten())
            .fold(0.0f64, |w, (a, b)| w.max((a - b).abs()));
        assert!(worst < 1e-13, "{name}: coordinates differ by {worst:e}");
        for (group, nodes) in &msh.groups {
            assert_eq!(inp.groups.get(group), Some(nodes), "{name}: group {group}");
        }

        let a = load_model(&data("gmsh", &format!("{name}.toml")), &[]).unwrap();
        let b = inp_model(name);
        let dm = matrix_difference(&a.mass, &b.mass);
        let dk = matrix_difference(&a.stiffness, &b.stiffness);
        println!("{name}: mass {dm:.1e}, stiffness {dk:.1e}");
        assert!(dm < 1e-12 && dk < 1e-12, "{name}: {dm:e} {dk:e}");
        assert_eq!(a.dirichlet, b.dirichlet);
        let dl = a
            .harmonic_load
            .iter()
            .zip(&b.harmonic_load)
            .fold(0.0f64, |w, (x, y)| w.max((x - y).abs()));
        assert!(dl < 1e-12, "{name}: loads differ by {dl:e}");
        assert_eq!(a.contacts.len(), b.contacts.len());
        for (x, y) in a.contacts.iter().zip(&b.contacts) {
            assert_eq!(x.dofs, y.dofs);
        }
        for (set, nodes) in &a.node_sets {
            assert_eq!(b.node_sets.get(set), Some(nodes), "{name}: set {set}");
        }
    }
}

/// Two unit cubes of C3D8 elements side by side along x (nodes 1–12, labels with a gap),
/// with the keywords Gmsh does not write.
const TWO_CUBES: &str = "\
*HEADING
two cubes
** a comment
*Node, nset=ALLN
 1, 0., 0., 0.
 2, 1., 0., 0.
 3, 2., 0., 0.
 4, 0., 1., 0.
 5, 1., 1., 0.
 6, 2., 1., 0.
 11, 0., 0., 1.
 12, 1., 0., 1.
 13, 2., 0., 1.
 14, 0., 1., 1.
 15, 1., 1., 1.
 16, 2., 1., 1.
*ELEMENT, TYPE=c3d8, ELSET=Cubes
 7, 1, 2, 5, 4,
    11, 12, 15, 14
 8, 2, 3, 6, 5, 12, 13, 16, 15
*Nset, nset=Left, generate
 1, 11, 10
*NSET, NSET=left
 4, 14
*Nset, nset=RIGHT_BOTTOM, generate
 3, 6, 3
*Nset, nset=Right
 right_bottom, 13, 16
*Elset, elset=second, generate
 8, 8
*Nset, nset=middle, elset=SECOND
*Surface, name=contact, type=NODE
 Right, 1.0
 2
*MATERIAL, NAME=steel
*ELASTIC
 210000., 0.3
";

/// The hand-written file: the cells in Abaqus (= VTK) order with nodes numbered by
/// increasing label, the sets as counted by hand (a set defined twice gathers both, names
/// case-insensitive, GENERATE with a step, a set of sets, the nodes of an element set, a
/// node surface), and the total mass ρ·2 of the two unit cubes.
#[test]
fn a_hand_written_file_with_generated_sets_and_a_node_surface() {
    let m = parse_inp(TWO_CUBES).unwrap();
    assert_eq!(
        (m.dimension, m.cells.kind, m.cells.len()),
        (3, CellKind::Hex8, 2)
    );
    assert_eq!(m.node_tags, [1, 2, 3, 4, 5, 6, 11, 12, 13, 14, 15, 16]);
    assert_eq!(m.cells.cell(0), [0, 1, 4, 3, 6, 7, 10, 9]);
    assert_eq!(m.cells.cell(1), [1, 2, 5, 4, 7, 8, 11, 10]);
    let expected: [(&str, &[usize]); 7] = [
        ("ALLN", &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]),
        ("Cubes", &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]),
        ("Left", &[0, 3, 6, 9]),
        ("RIGHT_BOTTOM", &[2, 5]),
        ("Right", &[2, 5, 8, 11]),
        ("middle", &[1, 2, 4, 5, 7, 8, 10, 11]),
        ("contact", &[1, 2, 5, 8, 11]),
    ];
    for (name, nodes) in expected {
        assert_eq!(m.groups.get(name).map(Vec::as_slice), Some(nodes), "{name}");
    }
    assert!(m.groups.contains_key("second"));
    assert_eq!(m.groups.len(), 8);

    let dir = std::env::temp_dir().join(format!("mshbm-abaqus-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("cubes.inp"), TWO_CUBES).unwrap();
    let model = "kind = \"mesh\"\n[mesh]\nfile = \"cubes.inp\"\nyoung = 2.1e5\npoisson = 0.3\n\
                 density = 7.85e-9\nclamped = [\"Left\"]\n[[interfaces]]\nname = \"stop\"\n\
                 kind = \"obstacle\"\nset = \"contact\"\nnormal = [-1.0, 0.0, 0.0]\ngap = 0.01\n";
    let m = parse_model(model, &dir.join("model.toml"), &[]).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let total: f64 = m
        .mass
        .iter()
        .filter(|&(i, j, _)| i % 3 == 0 && j % 3 == 0)
        .map(|(_, _, v)| v)
        .sum();
    assert!((total - 2.0 * 7.85e-9).abs() < 1e-12 * 7.85e-9, "{total}");
    assert_eq!(m.dirichlet.len(), 12);
    // clamped nodes (left) in contact: none; the surface's 5 nodes minus none
    assert_eq!(m.contacts.len(), 5);
}

/// Bad files: an error naming the line and what is wrong or missing, never a panic; a set
/// the model file names but the mesh lacks: the model file, the field and the set.
#[test]
fn errors_name_the_line_and_the_missing_set() {
    let cases: Vec<(String, &str)> = vec![
        (
            TWO_CUBES.replace(" right_bottom, 13, 16", " bottom, 13, 16"),
            "line 28: node set \"bottom\" is not defined",
        ),
        (
            TWO_CUBES.replace("TYPE=c3d8", "TYPE=C3D8R"),
            "line 17: element type \"C3D8R\" is not read",
        ),
        (
            TWO_CUBES.replace(" 1, 11, 10", " 1, 7, 1"),
            "line 22: node 7 is not defined",
        ),
        (
            TWO_CUBES.replace(" 1, 11, 10", " 1, 4000000000, 1"),
            "line 22: GENERATE 1 to 4000000000",
        ),
        (
            TWO_CUBES.replace(" 4, 14", " 4, 14x"),
            "line 24: node \"14x\"",
        ),
        (
            TWO_CUBES.replace(
                " 8, 2, 3, 6, 5, 12, 13, 16, 15",
                " 8, 2, 3, 6, 5, 12, 13, 16",
            ),
            "line 20: expected an element label and 8 node labels, found 8",
        ),
        (
            TWO_CUBES.replace(" 2, 1., 0., 0.", " 2, 1., nan, 0."),
            "line 6: coordinate",
        ),
        (
            TWO_CUBES.replace("type=NODE", "type=ELEMENT"),
            "line 32: *SURFACE of TYPE=ELEMENT",
        ),
        (
            TWO_CUBES.replace("*HEADING", "*Part, name=P"),
            "line 1: *PART is not read",
        ),
        (
            TWO_CUBES.replace("nset=middle, elset=SECOND", "nset=middle, elset=third"),
            "element set \"third\" is not defined",
        ),
        (
            TWO_CUBES
                .replace(" 16, 2., 1., 1.\n", "")
                .replace(" right_bottom, 13, 16", " right_bottom, 13"),
            "line 19: node 16 of this element is not defined",
        ),
        (
            TWO_CUBES.replace(" 13, 2., 0., 1.", " 2, 2., 0., 1."),
            "node 2 defined twice",
        ),
        ("*NODE\n 1, 0., 0.\n".into(), "no 2D or 3D elements"),
        (String::new(), "no 2D or 3D elements"),
    ];
    for (text, expected) in cases {
        let e =
            parse_inp(&text).map_or_else(|e| e.to_string(), |_| format!("{expected}: accepted"));
        assert!(
            e.contains(expected) && !e.ends_with("accepted"),
            "{expected:?} not in {e:?}"
        );
    }
    // the model file names a set the mesh lacks
    let path = data("abaqus", "box_tet4.toml");
    let text = std::fs::read_to_string(data("gmsh", "box_tet4.toml"))
        .unwrap()
        .replace("box_tet4.msh", "box_tet4.inp")
        .replace("clamped = [\"root\"]", "clamped = [\"clamp\"]");
    let e = parse_model(&text, &path, &[]).unwrap_err().to_string();
    assert!(
        e.contains("box_tet4.toml") && e.contains("mesh.clamped") && e.contains("\"clamp\""),
        "{e}"
    );
}
