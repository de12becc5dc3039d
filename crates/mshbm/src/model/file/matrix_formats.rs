//! The `[matrices]` of a `kind = "matrices"` model in their file formats: Matrix Market
//! ([`crate::model::matrix_market`]) or Abaqus `*MATRIX OUTPUT` files
//! ([`crate::model::abaqus_matrix`]) or Harwell–Boeing files
//! ([`crate::model::harwell_boeing`]), chosen by `format = "matrix_market" | "abaqus" |
//! "harwell_boeing"`, or, without it, by each file's content: a file starting with `%%` is
//! Matrix Market, one whose first data line has five comma-separated fields is Abaqus, one
//! whose third line starts with a type code such as `RSA` is Harwell–Boeing, any other is
//! read as Matrix Market (whose errors say what it expected). The
//! mass, stiffness and damping are all of one format. Abaqus matrices carry node labels:
//! their [`DofMap`] numbers the nodes by increasing label and is returned, so that contacts
//! and node sets can be given by label.

use std::path::Path;

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::limits::Limits;
use crate::model::abaqus_matrix::{
    assemble, looks_like_abaqus_matrix, parse_abaqus_matrix, DofMap, LabelledMatrix,
};
use crate::model::harwell_boeing::{looks_like_harwell_boeing, parse_harwell_boeing};
use crate::model::input_files::InputFiles;
use crate::model::matrix_market::{declared_dimensions, parse_matrix_with};
use crate::model::MODEL_BYTES_PER_DOF;
use crate::sparse::SparseMatrix;

/// The file format of a model's matrices.
#[derive(Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub(super) enum MatrixFormat {
    MatrixMarket,
    Abaqus,
    HarwellBoeing,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MatricesSection {
    pub mass: String,
    pub stiffness: String,
    pub damping: Option<String>,
    /// The files' format; by content when absent (module docs).
    pub format: Option<MatrixFormat>,
}

/// The matrices of a model, and the DOF map of Abaqus matrices.
pub(super) struct ModelMatrices {
    pub stiffness: SparseMatrix,
    pub mass: SparseMatrix,
    pub damping: Option<SparseMatrix>,
    pub dof_map: Option<DofMap>,
}

/// Check the matrix in `text` (of `file`, field `field` of the model file `path`) declares
/// no more rows and columns than a model of that many DOFs could hold in memory
/// ([`MODEL_BYTES_PER_DOF`]), before it is parsed.
fn check_declared_dofs(
    path: &Path,
    field: &str,
    file: &Path,
    text: &str,
    limits: &Limits,
) -> Result<(usize, usize)> {
    let (rows, cols) = declared_dimensions(text, file)?;
    limits.check_items(
        &format!(
            "{}: field `{field}`: {} declares a {rows}×{cols} matrix; a model of that many DOFs",
            path.display(),
            file.display()
        ),
        rows.max(cols) as u64,
        MODEL_BYTES_PER_DOF,
    )?;
    Ok((rows, cols))
}

/// A Matrix Market matrix, square.
fn read_matrix_market(
    path: &Path,
    field: &str,
    full: &Path,
    text: &str,
    limits: &Limits,
) -> Result<SparseMatrix> {
    let (rows, cols) = check_declared_dofs(path, field, full, text, limits)?;
    if rows != cols {
        return Err(Error::field(
            path,
            field,
            format!("{} is {rows}×{cols}, not square", full.display()),
        ));
    }
    parse_matrix_with(text, full, limits)
}

/// Refuse a matrix that is not symmetric, naming the model file, the field and the file.
fn check_symmetric(path: &Path, field: &str, full: &Path, a: &SparseMatrix) -> Result<()> {
    if let Some((i, j)) = a.asymmetry(1e-10) {
        return Err(Error::field(
            path,
            field,
            format!(
                "{} is not symmetric: entry ({}, {}) = {:e} but ({}, {}) = {:e} (1-based)",
                full.display(),
                i + 1,
                j + 1,
                a.get(i, j),
                j + 1,
                i + 1,
                a.get(j, i)
            ),
        ));
    }
    Ok(())
}

/// Read the mass, stiffness and damping of `section`; `dofs_per_node` is the model file's
/// `mesh.dofs_per_node` when given (Abaqus: the DOFs per node of the map).
pub(super) fn read_model_matrices(
    inputs: &mut InputFiles,
    path: &Path,
    section: &MatricesSection,
    dofs_per_node: Option<usize>,
) -> Result<ModelMatrices> {
    let mut files = vec![
        ("matrices.stiffness", &section.stiffness),
        ("matrices.mass", &section.mass),
    ];
    if let Some(c) = &section.damping {
        files.push(("matrices.damping", c));
    }
    let mut texts = Vec::with_capacity(files.len());
    for &(field, name) in &files {
        let (full, text) = inputs.read(field, name)?;
        let format = section.format.unwrap_or_else(|| {
            if text.trim_start().starts_with("%%") {
                MatrixFormat::MatrixMarket
            } else if looks_like_abaqus_matrix(&text) {
                MatrixFormat::Abaqus
            } else if looks_like_harwell_boeing(&text) {
                MatrixFormat::HarwellBoeing
            } else {
                MatrixFormat::MatrixMarket
            }
        });
        texts.push((field, full, text, format));
    }
    let first = texts[0].3;
    if let Some((field, full, _, f)) = texts.iter().find(|t| t.3 != first) {
        return Err(Error::field(
            path,
            *field,
            format!(
                "{} is in {f:?} format, the stiffness in {first:?} format: give all the matrices in one format",
                full.display()
            ),
        ));
    }
    let limits = *inputs.limits();
    let mut matrices = Vec::with_capacity(texts.len());
    let dof_map = match first {
        MatrixFormat::MatrixMarket => {
            for (field, full, text, _) in &texts {
                let a = read_matrix_market(path, field, full, text, &limits)?;
                check_symmetric(path, field, full, &a)?;
                matrices.push(a);
            }
            None
        }
        MatrixFormat::HarwellBoeing => {
            for (field, full, text, _) in &texts {
                let a = parse_harwell_boeing(text, full, &limits)?;
                if a.nrows() != a.ncols() {
                    return Err(Error::field(
                        path,
                        *field,
                        format!(
                            "{} is {}×{}, not square",
                            full.display(),
                            a.nrows(),
                            a.ncols()
                        ),
                    ));
                }
                limits.check_items(
                    &format!(
                        "{}: field `{field}`: {} is {2}×{2}; a model of that many DOFs",
                        path.display(),
                        full.display(),
                        a.nrows()
                    ),
                    a.nrows() as u64,
                    MODEL_BYTES_PER_DOF,
                )?;
                check_symmetric(path, field, full, &a)?;
                matrices.push(a);
            }
            None
        }
        MatrixFormat::Abaqus => {
            let labelled: Vec<LabelledMatrix> = texts
                .iter()
                .map(|(_, full, text, _)| parse_abaqus_matrix(text, full, &limits))
                .collect::<Result<_>>()?;
            let named: Vec<(&Path, &LabelledMatrix)> = texts
                .iter()
                .zip(&labelled)
                .map(|(t, m)| (t.1.as_path(), m))
                .collect();
            let map = DofMap::new(&named, dofs_per_node)?;
            limits.check_items(
                &format!(
                    "{}: field `matrices.stiffness`: {} nodes of {} DOFs; a model of that many DOFs",
                    path.display(),
                    map.labels.len(),
                    map.dofs_per_node
                ),
                map.dofs() as u64,
                MODEL_BYTES_PER_DOF,
            )?;
            for ((field, full, _, _), m) in texts.iter().zip(&labelled) {
                let a = assemble(m, &map, full)?;
                check_symmetric(path, field, full, &a)?;
                matrices.push(a);
            }
            Some(map)
        }
    };
    let mut matrices = matrices.into_iter();
    let stiffness = matrices.next().expect("the stiffness is read");
    let mass = matrices.next().expect("the mass is read");
    let damping = matrices.next();
    for (k, a) in std::iter::once(&mass).chain(damping.iter()).enumerate() {
        if a.nrows() != stiffness.nrows() {
            let (field, name) = files[k + 1];
            return Err(Error::field(
                path,
                field,
                format!(
                    "{name} is {0}×{0}, the stiffness matrix is {1}×{1}",
                    a.nrows(),
                    stiffness.nrows()
                ),
            ));
        }
    }
    Ok(ModelMatrices {
        stiffness,
        mass,
        damping,
        dof_map,
    })
}
