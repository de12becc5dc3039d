//! Export of a model as a general `kind = "matrices"` model: Matrix Market files for the
//! matrices and load vectors, a node-coordinate file and the TOML that ties them
//! together. Reading the export back gives the same model (to the 17 digits written).
//!
//! [`export_files`] only produces the files' names and contents: where and how they are
//! written (refusing to overwrite, atomically) is the caller's policy, e.g. `mshbm export`.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{Error, Result};
use crate::model::matrix_market::format_matrix;
use crate::model::Model;
use crate::sparse::SparseMatrix;

/// One file of an export: its name (in the export's directory) and its contents.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportedFile {
    pub name: &'static str,
    pub contents: String,
}

/// The name of the model file of an export (the one to load).
pub const EXPORTED_MODEL_FILE: &str = "model.toml";

/// Write `model` into `dir` (created if needed) as the files of [`export_files`]; a file
/// that exists already is an error (nothing is overwritten). Returns the path of the TOML
/// file.
pub fn export_matrices(model: &Model, dir: &Path) -> Result<std::path::PathBuf> {
    let files = export_files(model);
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    for f in &files {
        let p = dir.join(f.name);
        let mut out = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&p)
            .map_err(|e| Error::io(&p, e))?;
        std::io::Write::write_all(&mut out, f.contents.as_bytes()).map_err(|e| Error::io(&p, e))?;
    }
    Ok(dir.join(EXPORTED_MODEL_FILE))
}

/// The files of the export of `model`: `model.toml` (listed last), `mass.mtx`,
/// `stiffness.mtx` (`damping.mtx`), `harmonic_load.mtx`, `constant_load.mtx` and
/// `nodes.txt`.
pub fn export_files(model: &Model) -> Vec<ExportedFile> {
    let mut files = Vec::new();
    let mut write = |name: &'static str, contents: String| {
        files.push(ExportedFile { name, contents });
    };
    let vector = |v: &[f64]| {
        let t: Vec<(usize, usize, f64)> = v
            .iter()
            .enumerate()
            .filter(|(_, x)| **x != 0.0)
            .map(|(i, &x)| (i, 0, x))
            .collect();
        format_matrix(&SparseMatrix::from_triplets(v.len(), 1, &t))
    };
    write("mass.mtx", format_matrix(&model.mass));
    write("stiffness.mtx", format_matrix(&model.stiffness));
    if let Some(c) = &model.damping_matrix {
        write("damping.mtx", format_matrix(c));
    }
    write("harmonic_load.mtx", vector(&model.harmonic_load));
    write("constant_load.mtx", vector(&model.constant_load));
    let mut nodes = String::from("# node coordinates, one node per line\n");
    for c in &model.coordinates {
        let row: Vec<String> = c.iter().map(|x| format!("{x:.17e}")).collect();
        let _ = writeln!(nodes, "{}", row.join(" "));
    }
    write("nodes.txt", nodes);

    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Exported by `mshbm export` from {}",
        model.source.display()
    );
    let _ = writeln!(t, "kind = \"matrices\"");
    let _ = writeln!(t, "name = {:?}", model.name);
    let _ = writeln!(
        t,
        "\n[matrices]\nmass = \"mass.mtx\"\nstiffness = \"stiffness.mtx\""
    );
    if model.damping_matrix.is_some() {
        let _ = writeln!(t, "damping = \"damping.mtx\"");
    }
    let _ = writeln!(
        t,
        "\n[mesh]\ndofs_per_node = {}\ncoordinates = \"nodes.txt\"\ndirichlet = {:?}",
        model.dofs_per_node, model.dirichlet
    );
    for c in &model.contacts {
        let w: Vec<String> = c.w.iter().map(|x| format!("{x:?}")).collect();
        let _ = writeln!(
            t,
            "\n[[contacts]]\ndofs = {:?}\nw = [{}]\ngap = {:?}",
            c.dofs,
            w.join(", "),
            c.gap
        );
        if let Some(fr) = &c.friction {
            let tw: Vec<String> = fr.w.iter().map(|x| format!("{x:?}")).collect();
            let _ = writeln!(
                t,
                "mu = {:?}\ntangent_dofs = {:?}\ntangent_w = [{}]",
                fr.mu,
                fr.dofs,
                tw.join(", ")
            );
            if let Some(second) = &fr.second {
                let w: Vec<String> = second.w.iter().map(|x| format!("{x:?}")).collect();
                let _ = writeln!(
                    t,
                    "tangent2_dofs = {:?}\ntangent2_w = [{}]",
                    second.dofs,
                    w.join(", ")
                );
            }
        }
    }
    for f in &model.frictions {
        let w: Vec<String> = f.w.iter().map(|x| format!("{x:?}")).collect();
        let normal = match f.normal {
            crate::model::FrictionNormal::Force(p) => format!("normal_force = {p:?}"),
            crate::model::FrictionNormal::Contact(c) => format!("contact = {c}"),
        };
        let _ = writeln!(
            t,
            "\n[[frictions]]\ndofs = {:?}\nw = [{}]\nmu = {:?}\n{normal}",
            f.dofs,
            w.join(", "),
            f.mu
        );
    }
    let _ = writeln!(
        t,
        "\n[load]\nharmonic_file = \"harmonic_load.mtx\"\nconstant_file = \"constant_load.mtx\""
    );
    if let Some(a) = &model.acceleration {
        let a: Vec<String> = a.iter().map(|x| format!("{x:?}")).collect();
        let _ = writeln!(t, "acceleration = [{}]", a.join(", "));
    }
    let d = &model.damping;
    let _ = writeln!(
        t,
        "\n[damping]\nalpha = {:?}\nbeta = {:?}\nbeta_linear = {:?}\nbeta_condensed = {:?}",
        d.alpha, d.beta, d.beta_linear, d.beta_condensed
    );
    if let Some(z) = d.first_mode_ratio {
        let _ = writeln!(t, "first_mode_ratio = {z:?}");
    }
    write(EXPORTED_MODEL_FILE, t);
    files
}
