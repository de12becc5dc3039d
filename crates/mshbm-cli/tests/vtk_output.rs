//! `solve --vtk`: the deformed mesh over one period for ParaView, read back with `vtkio`
//! (the reader, not the writer's code): the mesh, the displacement at the contact nodes
//! against the solution's own series, zero displacement on the clamp, the `.pvd` collection,
//! and the output checks.

mod common;

use std::path::PathBuf;

use common::{assert_success, mshbm, one_error_line, stdout_json};
use vtkio::model::{Attribute, CellType, DataSet, Piece, VertexNumbers, Vtk};

fn cantilever() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/cantilever_stop/model.toml")
        .display()
        .to_string()
}

/// Points, cells with their types, and the point data `field` of a `.vtu`.
fn read_field(
    path: &std::path::Path,
    field: &str,
) -> (Vec<f64>, Vec<u64>, Vec<CellType>, Vec<f64>) {
    let vtk = Vtk::import(path).unwrap();
    let DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
        panic!("not an unstructured grid")
    };
    let Piece::Inline(piece) = pieces.into_iter().next().unwrap() else {
        panic!("not inline")
    };
    let points = piece.points.cast_into::<f64>().unwrap();
    let VertexNumbers::XML { connectivity, .. } = piece.cells.cell_verts else {
        panic!("not XML cells")
    };
    let displacement = piece
        .data
        .point
        .into_iter()
        .find_map(|a| match a {
            Attribute::DataArray(d) if d.name == field => d.data.cast_into::<f64>(),
            _ => None,
        })
        .unwrap_or_else(|| panic!("no point data {field:?}"));
    (points, connectivity, piece.cells.types, displacement)
}

fn read(path: &std::path::Path) -> (Vec<f64>, Vec<u64>, Vec<CellType>, Vec<f64>) {
    read_field(path, "displacement")
}

#[test]
fn the_deformed_mesh_over_one_period() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("vtk");
    let model = cantilever();
    let out = mshbm(&[
        "solve",
        &model,
        "--frequency",
        "600",
        "--harmonics",
        "3",
        "--no-stability",
        "--json",
        "--vtk",
        out_dir.to_str().unwrap(),
        "--vtk-samples",
        "4",
    ]);
    assert_success(&out);
    let v = stdout_json(&out);
    let pvd = std::fs::read_to_string(out_dir.join("solution.pvd")).unwrap();
    let times: Vec<f64> = pvd
        .lines()
        .filter_map(|l| l.split("timestep=\"").nth(1))
        .map(|t| t.split('"').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(times.len(), 4);
    assert!((times[1] - 1.0 / 600.0 / 4.0).abs() < 1e-15);
    for k in 0..4 {
        assert!(pvd.contains(&format!("file=\"solution_{k:04}.vtu\"")));
    }
    let (points, connectivity, types, u) = read(&out_dir.join("solution_0000.vtu"));
    assert_eq!(points.len(), 729 * 3);
    assert_eq!(types.len(), 640);
    assert!(types.iter().all(|t| *t == CellType::Quad));
    assert_eq!(connectivity.len(), 640 * 4);
    assert_eq!(u.len(), 729 * 3);
    // at t = 0 every contact DOF moves as the solution's series says at its first sample
    for c in v["contacts"].as_array().unwrap() {
        let dof = c["dof"].as_u64().unwrap() as usize;
        let (node, comp) = (dof / 2, dof % 2);
        let want = c["displacement"][0].as_f64().unwrap();
        assert!(
            (u[3 * node + comp] - want).abs() < 1e-12 * want.abs().max(1e-3),
            "DOF {dof}: {} vs {want}",
            u[3 * node + comp]
        );
    }
    // the clamped face x = 0 does not move; the third component is zero in 2D
    for p in 0..729 {
        if points[3 * p] == 0.0 {
            assert_eq!((u[3 * p], u[3 * p + 1]), (0.0, 0.0));
        }
        assert_eq!(u[3 * p + 2], 0.0);
    }
    // a quarter period later the field has moved
    let (_, _, _, u1) = read(&out_dir.join("solution_0001.vtu"));
    assert!(u.iter().zip(&u1).any(|(a, b)| (a - b).abs() > 1e-6));
    // two outputs may not be one file
    let clash = mshbm(&[
        "solve",
        &model,
        "--frequency",
        "600",
        "--vtk",
        dir.path().to_str().unwrap(),
        "--output",
        dir.path().join("solution.pvd").to_str().unwrap(),
    ]);
    let err = one_error_line(&clash);
    assert!(err.contains("solution.pvd"), "{err}");
}

/// `modes --vtk`: each mode shape, read back, has the eigenfrequency the `.pvd` gives as its
/// Rayleigh quotient with the model's own K and M (an independent check of the shape), is
/// scaled to a largest displacement of 1, and vanishes on the clamp.
#[test]
fn mode_shapes_for_paraview() {
    let dir = tempfile::tempdir().unwrap();
    let model = cantilever();
    let out = mshbm(&[
        "modes",
        &model,
        "--count",
        "2",
        "--vtk",
        dir.path().to_str().unwrap(),
    ]);
    assert_success(&out);
    let pvd = std::fs::read_to_string(dir.path().join("mode.pvd")).unwrap();
    let hz: Vec<f64> = pvd
        .lines()
        .filter_map(|l| l.split("timestep=\"").nth(1))
        .map(|t| t.split('"').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(hz.len(), 2);
    let m = mshbm::model::file::load_model(std::path::Path::new(&model), &[]).unwrap();
    for (k, f) in hz.iter().enumerate() {
        let (_, _, _, u) = read_field(&dir.path().join(format!("mode_{k:04}.vtu")), "mode_shape");
        let phi: Vec<f64> = (0..m.n_dofs()).map(|d| u[3 * (d / 2) + d % 2]).collect();
        let largest = phi.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!((largest - 1.0).abs() < 1e-12);
        assert!(m.dirichlet.iter().all(|&d| phi[d] == 0.0));
        let omega2 = m.stiffness.quadratic_form(&phi) / m.mass.quadratic_form(&phi);
        let rayleigh = omega2.sqrt() / (2.0 * std::f64::consts::PI);
        assert!(
            (rayleigh / f - 1.0).abs() < 1e-8,
            "mode {k}: {rayleigh} vs {f} Hz"
        );
    }
}

/// `modes --vtk` on a Gmsh mesh of 10-node tetrahedra (`kind = "mesh"`): the cells are
/// written as VTK quadratic tetrahedra on the model's nodes, read back by `vtkio`.
#[test]
fn quadratic_tetrahedra_are_written_as_vtk_quadratic_tetrahedra() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("modes");
    let model = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../mshbm/tests/data/gmsh/box_tet10.toml")
        .display()
        .to_string();
    let out = mshbm(&[
        "modes",
        &model,
        "--count",
        "2",
        "--vtk",
        out_dir.to_str().unwrap(),
    ]);
    assert_success(&out);
    let (points, connectivity, types, shape) =
        read_field(&out_dir.join("mode_0000.vtu"), "mode_shape");
    // tests/data/gmsh/reference.json: 420 nodes, 189 cells
    assert_eq!(points.len(), 3 * 420);
    assert_eq!(types.len(), 189);
    assert!(types.iter().all(|t| *t == CellType::QuadraticTetra));
    assert_eq!(connectivity.len(), 10 * 189);
    assert!(connectivity.iter().all(|&p| p < 420));
    assert_eq!(shape.len(), 3 * 420);
}

/// Node tag → coordinates of the `$Nodes` section of an ASCII MSH 4.1 file, read here
/// from the format's definition (blocks of tags followed by their coordinates).
fn msh_nodes(path: &std::path::Path) -> std::collections::BTreeMap<u64, [f64; 3]> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().skip_while(|l| l.trim() != "$Nodes").skip(1);
    let numbers =
        |l: &str| -> Vec<f64> { l.split_whitespace().map(|f| f.parse().unwrap()).collect() };
    let head = numbers(lines.next().unwrap());
    let mut nodes = std::collections::BTreeMap::new();
    for _ in 0..head[0] as usize {
        let block = numbers(lines.next().unwrap());
        let count = block[3] as usize;
        let tags: Vec<u64> = (0..count)
            .map(|_| lines.next().unwrap().trim().parse().unwrap())
            .collect();
        for t in tags {
            let x = numbers(lines.next().unwrap());
            nodes.insert(t, [x[0], x[1], x[2]]);
        }
    }
    assert_eq!(nodes.len(), head[1] as usize);
    nodes
}

/// A model read from a Gmsh file names its nodes by their Gmsh tags in the outputs: the
/// `nodes` column of `--contacts-csv` holds tags whose coordinates in the `.msh` file lie
/// on the contact face (x = 3) — every node of that face once — and the VTK point data
/// `node_label` gives each point's tag, whose `.msh` coordinates are the point's.
#[test]
fn outputs_name_the_nodes_of_a_gmsh_mesh_by_their_tags() {
    let dir = tempfile::tempdir().unwrap();
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../mshbm/tests/data/gmsh");
    let model = data.join("box_tet10.toml").display().to_string();
    let csv = dir.path().join("contacts.csv");
    let out_dir = dir.path().join("vtk");
    let out = mshbm(&[
        "solve",
        &model,
        "--frequency",
        "2000",
        "--harmonics",
        "1",
        "--quadrature",
        "sampled",
        "--no-stability",
        "--contacts-csv",
        csv.to_str().unwrap(),
        "--vtk",
        out_dir.to_str().unwrap(),
        "--vtk-samples",
        "2",
    ]);
    assert_success(&out);
    let msh = msh_nodes(&data.join("box_tet10.msh"));
    let face: std::collections::BTreeSet<u64> = msh
        .iter()
        .filter(|(_, x)| (x[0] - 3.0).abs() < 1e-9)
        .map(|(&t, _)| t)
        .collect();
    assert!(face.len() > 10);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut header = text.lines().next().unwrap().split(',');
    assert_eq!(header.nth(2), Some("nodes"));
    let named: std::collections::BTreeSet<u64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    assert_eq!(
        named, face,
        "contact nodes by tag vs the face x = 3 of the .msh file"
    );

    let (points, _, _, labels) = read_field(&out_dir.join("solution_0000.vtu"), "node_label");
    assert_eq!(labels.len(), msh.len());
    for (p, &t) in labels.iter().enumerate() {
        let x = msh[&(t as u64)];
        for a in 0..3 {
            assert!(
                (points[3 * p + a] - x[a]).abs() < 1e-12,
                "point {p}, tag {t}"
            );
        }
    }
}
