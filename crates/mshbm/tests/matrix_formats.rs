//! `kind = "matrices"` models from the matrix formats of commercial codes: Abaqus
//! `*MATRIX OUTPUT` files ([`mshbm::model::abaqus_matrix`]). The reference is the same
//! model in Matrix Market (`mshbm::model::export`): the matrices are written in the other
//! format by a writer of this test (not the library's), with node labels that are not the
//! model's node numbers, and read back.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use mshbm::method::settings::MethodSettings;
use mshbm::model::export::export_files;
use mshbm::model::file::load_model;
use mshbm::solve::{solve_periodic, SolveSettings};
use mshbm::sparse::SparseMatrix;
use mshbm::Model;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mshbm-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The label Abaqus would give model node `p` in these tests: not `p`, not contiguous.
fn label(p: usize) -> usize {
    1000 + 3 * p
}

/// `a` as Abaqus writes it: `node, dof, node, dof, value`, one triangle (`lower`: row ≥
/// column), in reverse order (the reader must not rely on the order), after a comment.
fn abaqus_text(a: &SparseMatrix, dofs_per_node: usize, lower: bool) -> String {
    let mut s = String::from("** written by tests/matrix_formats.rs\n");
    let mut lines = Vec::new();
    for (i, j, v) in a.iter() {
        if (lower && i < j) || (!lower && i > j) {
            continue;
        }
        let (ni, di) = (label(i / dofs_per_node), i % dofs_per_node + 1);
        let (nj, dj) = (label(j / dofs_per_node), j % dofs_per_node + 1);
        lines.push(format!("{ni},{di}, {nj},{dj}, {v:.17e}"));
    }
    for l in lines.iter().rev() {
        let _ = writeln!(s, "{l}");
    }
    s
}

/// The cantilever on a stop (examples/cantilever_stop) on a coarse mesh, exported to
/// Matrix Market, and the same matrices as Abaqus files with a model file that gives the
/// contacts by node label and DOF; returns both model files.
fn cantilever_in_both_formats(name: &str) -> (Model, PathBuf, PathBuf) {
    let mut original = load_model(
        &examples().join("cantilever_stop/model.toml"),
        &["solid.divisions=[20, 2]".to_string()],
    )
    .unwrap();
    // the assembly is symmetric to round-off; a file holds one triangle, so the reference
    // is exactly symmetric: (A + Aᵀ)/2
    let symmetric = |a: &SparseMatrix| {
        let t: Vec<(usize, usize, f64)> = a
            .iter()
            .flat_map(|(i, j, v)| [(i, j, 0.5 * v), (j, i, 0.5 * v)])
            .collect();
        SparseMatrix::from_triplets(a.nrows(), a.ncols(), &t)
    };
    original.stiffness = symmetric(&original.stiffness);
    original.mass = symmetric(&original.mass);
    assert!(original.stiffness.asymmetry(0.0).is_none());
    let dir = scratch(name);
    let mut exported_toml = String::new();
    for f in export_files(&original) {
        std::fs::write(dir.join(f.name), &f.contents).unwrap();
        if f.name == "model.toml" {
            exported_toml = f.contents;
        }
    }
    let dpn = original.dofs_per_node;
    assert_eq!(dpn, 2);
    std::fs::write(
        dir.join("job_STIF2.mtx"),
        abaqus_text(&original.stiffness, dpn, true),
    )
    .unwrap();
    std::fs::write(
        dir.join("job_MASS2.mtx"),
        abaqus_text(&original.mass, dpn, false),
    )
    .unwrap();
    let mut t = String::from(
        "kind = \"matrices\"\n[matrices]\nstiffness = \"job_STIF2.mtx\"\nmass = \"job_MASS2.mtx\"\n",
    );
    let _ = writeln!(
        t,
        "[mesh]\ncoordinates = \"nodes.txt\"\ndirichlet = {:?}",
        original.dirichlet
    );
    for c in &original.contacts {
        assert!(c.friction.is_none());
        let pairs: Vec<String> = c
            .dofs
            .iter()
            .map(|&d| format!("[{}, {}]", label(d / dpn), d % dpn + 1))
            .collect();
        let w: Vec<String> = c.w.iter().map(|x| format!("{x:?}")).collect();
        let _ = writeln!(
            t,
            "[[contacts]]\nnode_dofs = [{}]\nw = [{}]\ngap = {:?}",
            pairs.join(", "),
            w.join(", "),
            c.gap
        );
    }
    let _ = writeln!(t, "[[node_sets]]\nname = \"tip\"\nlabels = [{}]", label(20));
    let _ = writeln!(
        t,
        "[load]\nharmonic_file = \"harmonic_load.mtx\"\nconstant_file = \"constant_load.mtx\""
    );
    let damping = &exported_toml[exported_toml.find("\n[damping]").unwrap()..];
    t.push_str(damping);
    std::fs::write(dir.join("abaqus.toml"), t).unwrap();
    (original, dir.join("model.toml"), dir.join("abaqus.toml"))
}

#[test]
fn abaqus_matrices_give_the_matrix_market_model() {
    let (original, mm, abq) = cantilever_in_both_formats("abaqus-same");
    let a = load_model(&mm, &[]).unwrap();
    let b = load_model(&abq, &[]).unwrap();
    assert!(a.stiffness == original.stiffness);
    assert!(b.stiffness == a.stiffness, "the stiffness differs");
    assert!(b.mass == a.mass, "the mass differs");
    assert_eq!(b.dofs_per_node, 2);
    assert_eq!(b.coordinates, a.coordinates);
    assert_eq!(b.dirichlet, a.dirichlet);
    let dofs = |m: &Model| -> Vec<(Vec<usize>, Vec<f64>, f64)> {
        m.contacts
            .iter()
            .map(|c| (c.dofs.clone(), c.w.clone(), c.gap))
            .collect()
    };
    assert!(!a.contacts.is_empty());
    assert_eq!(dofs(&b), dofs(&a));
    // the label of model node 20 (the tip's lower corner on the 21 × 3 grid)
    assert_eq!(b.node_sets["tip"], vec![20]);
    // outputs name the nodes by the labels the files gave them
    let labels: Vec<u64> = (0..b.n_nodes()).map(|p| label(p) as u64).collect();
    assert_eq!(b.node_labels.as_deref(), Some(&labels[..]));
    assert_eq!(b.node_label(20), 1060);
    assert_eq!(
        a.node_labels, None,
        "Matrix Market matrices carry no labels"
    );
    assert_eq!(a.node_label(20), 20);

    // the frequency response through the contact resonance, point by point
    let method = MethodSettings::redistributed(5);
    let settings = SolveSettings {
        stability: false,
        ..SolveSettings::default()
    };
    let mut active = 0;
    for f in [600.0, 800.0, 850.0, 1000.0] {
        let sa = solve_periodic(&a, &method, f, &settings).unwrap();
        let sb = solve_periodic(&b, &method, f, &settings).unwrap();
        assert!(sa.outcome.converged && sb.outcome.converged, "{f} Hz");
        let (xa, xb) = (
            sa.solution.unknowns.as_ref().unwrap(),
            sb.solution.unknowns.as_ref().unwrap(),
        );
        let scale = xa.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let diff = xa
            .iter()
            .zip(xb)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(diff <= 1e-12 * scale, "{f} Hz: {diff:e} of {scale:e}");
        if sa
            .solution
            .contacts
            .iter()
            .any(|c| c.force.iter().any(|&p| p > 0.0))
        {
            active += 1;
        }
    }
    assert!(active > 0, "no point of the response touches the stop");
}

#[test]
fn bad_abaqus_inputs_are_refused_naming_file_line_and_field() {
    let (_, _, abq) = cantilever_in_both_formats("abaqus-bad");
    let dir = abq.parent().unwrap();
    let toml = std::fs::read_to_string(&abq).unwrap();
    let err = |toml: &str| {
        std::fs::write(dir.join("bad.toml"), toml).unwrap();
        load_model(&dir.join("bad.toml"), &[])
            .unwrap_err()
            .to_string()
    };
    // a node label the matrices do not have
    let first = toml.find("node_dofs = [[").unwrap() + "node_dofs = [[".len();
    let e = err(&format!(
        "{}7, 1{}",
        &toml[..first],
        &toml[first + toml[first..].find(']').unwrap()..]
    ));
    assert!(
        e.contains("contacts[0].node_dofs") && e.contains("node 7, DOF 1"),
        "{e}"
    );
    // both `dofs` and `node_dofs`
    let e = err(&toml.replacen("node_dofs =", "dofs = [1]\nnode_dofs =", 1));
    assert!(e.contains("not both"), "{e}");
    // node_dofs on Matrix Market matrices
    let e = err(&toml
        .replace("job_STIF2.mtx", "stiffness.mtx")
        .replace("job_MASS2.mtx", "mass.mtx"));
    assert!(
        e.contains("contacts[0].node_dofs") && e.contains("Abaqus"),
        "{e}"
    );
    // mixed formats
    let e = err(&toml.replace("job_MASS2.mtx", "mass.mtx"));
    assert!(
        e.contains("matrices.mass") && e.contains("one format"),
        "{e}"
    );
    // a DOF number out of range in the file
    let k = std::fs::read_to_string(dir.join("job_STIF2.mtx")).unwrap();
    let bad = k.replacen(",1, ", ",9, ", 1);
    std::fs::write(dir.join("job_STIF2.mtx"), bad).unwrap();
    let e = err(&toml);
    assert!(
        e.contains("job_STIF2.mtx, line ") && e.contains("DOF): \"9\" is not a DOF number 1 to 6"),
        "{e}"
    );
    // a DOF a node lacks: dofs_per_node 3 for a 2D model
    std::fs::write(dir.join("job_STIF2.mtx"), &k).unwrap();
    let e = err(&toml.replace("[mesh]", "[mesh]\ndofs_per_node = 3"));
    assert!(e.contains("DOF 3 appears in none"), "{e}");
    let _ = std::fs::remove_dir_all(dir);
}

/// `examples/bar_matrices` copied to a scratch directory with the Harwell–Boeing fixtures
/// of `tests/data/matrix_formats` (written by SciPy, `tools/matrix-formats`); returns the
/// directory.
fn bar_with_harwell_boeing(name: &str) -> PathBuf {
    let dir = scratch(name);
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/matrix_formats");
    for from in [examples().join("bar_matrices"), data] {
        for e in std::fs::read_dir(from).unwrap() {
            let p = e.unwrap().path();
            std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
        }
    }
    let toml = std::fs::read_to_string(dir.join("model.toml")).unwrap();
    let hb = toml
        .replace("\"mass.mtx\"", "\"bar_mass.rsa\"")
        .replace("\"stiffness.mtx\"", "\"bar_stiffness.rua\"");
    assert_ne!(hb, toml);
    std::fs::write(dir.join("hb.toml"), hb).unwrap();
    dir
}

#[test]
fn harwell_boeing_files_written_by_scipy_give_the_matrix_market_model() {
    let dir = bar_with_harwell_boeing("hb-same");
    let a = load_model(&dir.join("model.toml"), &[]).unwrap();
    let b = load_model(&dir.join("hb.toml"), &[]).unwrap();
    // SciPy writes 17 significant digits: the matrices are the same numbers
    assert!(b.stiffness == a.stiffness, "the stiffness (RUA) differs");
    assert!(b.mass == a.mass, "the mass (RSA, lower triangle) differs");
    assert_eq!(a.mass.nrows(), 101);
    // the format named instead of recognised
    let named = std::fs::read_to_string(dir.join("hb.toml"))
        .unwrap()
        .replace("[matrices]", "[matrices]\nformat = \"harwell_boeing\"");
    std::fs::write(dir.join("named.toml"), named).unwrap();
    let c = load_model(&dir.join("named.toml"), &[]).unwrap();
    assert!(c.stiffness == a.stiffness && c.mass == a.mass);
    // a periodic solution with contact (the paper's bar at 30 kHz) is the same
    let method = MethodSettings::redistributed(5);
    let settings = SolveSettings {
        stability: false,
        ..SolveSettings::default()
    };
    let sa = solve_periodic(&a, &method, 30000.0, &settings).unwrap();
    let sb = solve_periodic(&b, &method, 30000.0, &settings).unwrap();
    assert!(sa.outcome.converged && sb.outcome.converged);
    assert_eq!(sa.solution.unknowns, sb.solution.unknowns);
    assert!(sa.solution.contacts[0].force.iter().any(|&p| p > 0.0));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_harwell_boeing_files_are_refused_naming_file_line_and_field() {
    let dir = bar_with_harwell_boeing("hb-bad");
    let rsa = std::fs::read_to_string(dir.join("bar_mass.rsa")).unwrap();
    let err = |text: &str| {
        std::fs::write(dir.join("bar_mass.rsa"), text).unwrap();
        load_model(&dir.join("hb.toml"), &[])
            .unwrap_err()
            .to_string()
    };
    // a value that is not a number, on the first line of values (line 5 + 6 + 11 = 22)
    let mut lines: Vec<String> = rsa.lines().map(String::from).collect();
    lines[21].replace_range(3..6, "x.y");
    let e = err(&lines.join("\n"));
    assert!(
        e.contains("bar_mass.rsa, line 22") && e.contains("value"),
        "{e}"
    );
    // a complex matrix
    let e = err(&rsa.replacen("RSA", "CSA", 1));
    assert!(e.contains("line 3") && e.contains("complex"), "{e}");
    // a mass in another format than the stiffness
    std::fs::write(dir.join("bar_mass.rsa"), &rsa).unwrap();
    let toml = std::fs::read_to_string(dir.join("hb.toml")).unwrap();
    std::fs::write(
        dir.join("mixed.toml"),
        toml.replace("\"bar_mass.rsa\"", "\"mass.mtx\""),
    )
    .unwrap();
    let e = load_model(&dir.join("mixed.toml"), &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("matrices.mass") && e.contains("one format"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
