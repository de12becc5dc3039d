//! `NativeModel`: a model read from a TOML file (with `--set`-style overrides) or built
//! from arrays, by the library's own loading and validation.

use std::path::{Path, PathBuf};

use mshbm::limits::Limits;
use mshbm::model::{Contact, Damping, LoadOptions};
use mshbm::sparse::SparseMatrix;
use mshbm::Model;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::array;
use crate::errors::{argument, to_py, IntoPy};

/// Where a model came from: what re-creates it (pickling is done in Python from these).
#[derive(Clone, Debug)]
pub enum Source {
    /// A model file: its path, its text as read, the overrides.
    Toml {
        path: PathBuf,
        text: String,
        overrides: Vec<String>,
    },
    /// Arrays given by the caller.
    Arrays,
}

/// A validated model (see the module docs).
#[pyclass(module = "mshbm._native", frozen)]
pub struct NativeModel {
    pub model: Model,
    pub source: Source,
    /// The memory budget (`max_memory_gib`) of the model and of every computation on it,
    /// as `--max-memory` of the CLI.
    pub limits: Limits,
    pub allow_outside_paths: bool,
}

/// `max_memory_gib` as the CLI's `--max-memory`.
fn limits(max_memory_gib: Option<f64>) -> PyResult<Limits> {
    match max_memory_gib {
        None => Ok(Limits::default()),
        Some(g) if g.is_finite() && g > 0.0 => Ok(Limits::default().with_memory_gib(g)),
        Some(g) => Err(argument(format!(
            "max_memory_gib: expected a positive number of GiB, got {g}"
        ))),
    }
}

/// The source path of models built from arrays, as error messages name it.
const ARRAYS: &str = "<arrays>";

fn field_error(field: &str, message: String) -> PyErr {
    to_py(mshbm::Error::field(Path::new(ARRAYS), field, message))
}

/// A CSC matrix from scipy's arrays (shape, data, indices, indptr), checked.
fn csc(
    field: &str,
    (shape, data, indices, indptr): (
        (usize, usize),
        PyReadonlyArray1<'_, f64>,
        PyReadonlyArray1<'_, i64>,
        PyReadonlyArray1<'_, i64>,
    ),
    limits: &Limits,
) -> PyResult<SparseMatrix> {
    let (nrows, ncols) = shape;
    let data = data.as_slice()?;
    let indices = indices.as_slice()?;
    let indptr = indptr.as_slice()?;
    if indptr.len() != ncols + 1 || indptr.first() != Some(&0) {
        return Err(field_error(
            field,
            format!(
                "malformed CSC arrays: indptr has {} entries for {ncols} columns",
                indptr.len()
            ),
        ));
    }
    if indptr.windows(2).any(|w| w[1] < w[0])
        || indptr[ncols] as usize != data.len()
        || indices.len() != data.len()
    {
        return Err(field_error(
            field,
            "malformed CSC arrays: indptr is not non-decreasing up to the number of entries".into(),
        ));
    }
    limits
        .check_memory(field, SparseMatrix::assembly_bytes(ncols, data.len()))
        .py_err()?;
    let mut triplets = Vec::with_capacity(data.len());
    for j in 0..ncols {
        for k in indptr[j] as usize..indptr[j + 1] as usize {
            let i = indices[k];
            if i < 0 || i as usize >= nrows {
                return Err(field_error(
                    field,
                    format!("row index {i} out of range of the {nrows}×{ncols} matrix"),
                ));
            }
            if !data[k].is_finite() {
                return Err(field_error(
                    field,
                    format!("entry ({i}, {j}) is not a finite number: {}", data[k]),
                ));
            }
            triplets.push((i as usize, j, data[k]));
        }
    }
    SparseMatrix::try_from_triplets(nrows, ncols, &triplets)
        .map_err(|e| field_error(field, e.to_string()))
}

type CscArgs<'py> = (
    (usize, usize),
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, i64>,
    PyReadonlyArray1<'py, i64>,
);

/// COO arrays of a matrix: (shape, rows, cols, values).
fn coo(py: Python<'_>, a: &SparseMatrix) -> PyResult<Py<PyAny>> {
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    for (i, j, v) in a.iter() {
        rows.push(i as i64);
        cols.push(j as i64);
        vals.push(v);
    }
    let t = (
        (a.nrows(), a.ncols()),
        PyArray1::from_vec(py, rows),
        PyArray1::from_vec(py, cols),
        PyArray1::from_vec(py, vals),
    );
    Ok(t.into_pyobject(py)?.into_any().unbind())
}

#[pymethods]
impl NativeModel {
    /// Read a model file with overrides (`["contact.gap=0.1", …]`), as `mshbm … MODEL
    /// --set …` does.
    #[staticmethod]
    #[pyo3(signature = (path, overrides=Vec::new(), max_memory_gib=None, allow_outside_paths=false))]
    fn from_toml(
        py: Python<'_>,
        path: PathBuf,
        overrides: Vec<String>,
        max_memory_gib: Option<f64>,
        allow_outside_paths: bool,
    ) -> PyResult<Self> {
        let limits = limits(max_memory_gib)?;
        let options = LoadOptions {
            limits,
            allow_outside_paths,
        };
        py.detach(|| {
            // the steps of `load_model_with`, keeping the text for pickling
            let text = mshbm::limits::read_model_file(&path, &options.limits)?;
            let mut model =
                mshbm::model::file::parse_model_with(&text, &path, &overrides, &options)?;
            let canonical = path
                .canonicalize()
                .map_err(|e| mshbm::Error::io(&path, e))?;
            model.input_files.insert(0, canonical);
            Ok(NativeModel {
                model,
                source: Source::Toml {
                    path: path.clone(),
                    text,
                    overrides: overrides.clone(),
                },
                limits,
                allow_outside_paths,
            })
        })
        .py_err()
    }

    /// Parse model-file text (as read from `path`, which locates the files it refers to
    /// and names errors), with overrides: how a pickled model is re-created.
    #[staticmethod]
    #[pyo3(signature = (text, path, overrides=Vec::new(), max_memory_gib=None, allow_outside_paths=false))]
    fn from_toml_text(
        py: Python<'_>,
        text: String,
        path: PathBuf,
        overrides: Vec<String>,
        max_memory_gib: Option<f64>,
        allow_outside_paths: bool,
    ) -> PyResult<Self> {
        let limits = limits(max_memory_gib)?;
        let options = LoadOptions {
            limits,
            allow_outside_paths,
        };
        py.detach(|| {
            let model = mshbm::model::file::parse_model_with(&text, &path, &overrides, &options)?;
            Ok(NativeModel {
                model,
                source: Source::Toml {
                    path: path.clone(),
                    text: text.clone(),
                    overrides: overrides.clone(),
                },
                limits,
                allow_outside_paths,
            })
        })
        .py_err()
    }

    /// A model from arrays (the fields of a `kind = "matrices"` model file), validated by
    /// the library. Matrices are scipy CSC arrays `(shape, data, indices, indptr)`.
    #[staticmethod]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (*, mass, stiffness, coordinates, dofs_per_node, dirichlet, contacts,
        harmonic_load, constant_load, damping_matrix=None, alpha=0.0, beta=0.0,
        beta_linear=0.0, beta_condensed=0.0, first_mode_ratio=None, name=None,
        acceleration=None, max_memory_gib=None))]
    fn from_arrays(
        mass: CscArgs<'_>,
        stiffness: CscArgs<'_>,
        coordinates: PyReadonlyArray2<'_, f64>,
        dofs_per_node: usize,
        dirichlet: Vec<usize>,
        contacts: Vec<(Vec<usize>, Vec<f64>, f64)>,
        harmonic_load: PyReadonlyArray1<'_, f64>,
        constant_load: PyReadonlyArray1<'_, f64>,
        damping_matrix: Option<CscArgs<'_>>,
        alpha: f64,
        beta: f64,
        beta_linear: f64,
        beta_condensed: f64,
        first_mode_ratio: Option<f64>,
        name: Option<String>,
        acceleration: Option<Vec<f64>>,
        max_memory_gib: Option<f64>,
    ) -> PyResult<Self> {
        let limits = limits(max_memory_gib)?;
        let stiffness = csc("matrices.stiffness", stiffness, &limits)?;
        let mass = csc("matrices.mass", mass, &limits)?;
        let damping_matrix = damping_matrix
            .map(|c| csc("matrices.damping", c, &limits))
            .transpose()?;
        let coordinates: Vec<Vec<f64>> = coordinates
            .as_array()
            .rows()
            .into_iter()
            .map(|r| r.to_vec())
            .collect();
        let model = Model {
            stiffness_file: None,
            source: PathBuf::from(ARRAYS),
            input_files: Vec::new(),
            name: name.unwrap_or_else(|| "model from arrays".into()),
            mass,
            stiffness,
            damping_matrix,
            coordinates,
            dofs_per_node,
            cells: None,
            node_sets: Default::default(),
            node_labels: None,
            dirichlet,
            contacts: contacts
                .into_iter()
                .map(|(dofs, w, gap)| Contact {
                    dofs,
                    w,
                    gap,
                    friction: None,
                })
                .collect(),
            interfaces: Vec::new(),
            frictions: Vec::new(),
            harmonic_load: harmonic_load.as_slice()?.to_vec(),
            constant_load: constant_load.as_slice()?.to_vec(),
            acceleration,
            damping: Damping {
                alpha,
                beta,
                beta_linear,
                beta_condensed,
                first_mode_ratio,
            },
        };
        model.validate().py_err()?;
        Ok(NativeModel {
            model,
            source: Source::Arrays,
            limits,
            allow_outside_paths: false,
        })
    }

    /// The model's name.
    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }

    /// Number of DOFs (Dirichlet DOFs included).
    #[getter]
    fn n_dofs(&self) -> usize {
        self.model.n_dofs()
    }

    /// The model file's path, or `<arrays>`.
    #[getter]
    fn source(&self) -> String {
        self.model.source.display().to_string()
    }

    /// For pickling: `("toml", text, path, overrides)` or `("arrays",)`.
    fn recipe(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        Ok(match &self.source {
            Source::Toml {
                path,
                text,
                overrides,
            } => ("toml", text.clone(), path.clone(), overrides.clone())
                .into_pyobject(py)?
                .into_any()
                .unbind(),
            Source::Arrays => ("arrays",).into_pyobject(py)?.into_any().unbind(),
        })
    }

    /// The model's arrays: the consistent mass, stiffness and damping matrices as COO
    /// `(shape, rows, cols, values)`, coordinates, Dirichlet DOFs, contacts, loads and
    /// damping — the fields `from_arrays` takes.
    fn arrays<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let m = &self.model;
        let d = PyDict::new(py);
        d.set_item("mass", coo(py, &m.mass)?)?;
        d.set_item("stiffness", coo(py, &m.stiffness)?)?;
        d.set_item(
            "damping_matrix",
            match &m.damping_matrix {
                Some(c) => coo(py, c)?,
                None => py.None(),
            },
        )?;
        let dim = m.coordinates.first().map_or(0, Vec::len);
        let flat: Vec<f64> = m.coordinates.iter().flatten().copied().collect();
        d.set_item(
            "coordinates",
            PyArray1::from_vec(py, flat).reshape([m.coordinates.len(), dim])?,
        )?;
        d.set_item("dofs_per_node", m.dofs_per_node)?;
        d.set_item("dirichlet", m.dirichlet.clone())?;
        let contacts = PyList::empty(py);
        for c in &m.contacts {
            contacts.append((c.dofs.clone(), c.w.clone(), c.gap))?;
        }
        d.set_item("contacts", contacts)?;
        d.set_item("harmonic_load", array(py, m.harmonic_load.clone()))?;
        d.set_item("constant_load", array(py, m.constant_load.clone()))?;
        d.set_item("alpha", m.damping.alpha)?;
        d.set_item("beta", m.damping.beta)?;
        d.set_item("beta_linear", m.damping.beta_linear)?;
        d.set_item("beta_condensed", m.damping.beta_condensed)?;
        d.set_item("first_mode_ratio", m.damping.first_mode_ratio)?;
        d.set_item("name", m.name.clone())?;
        d.set_item("acceleration", m.acceleration.clone())?;
        if !m.frictions.is_empty() || !m.interfaces.is_empty() {
            d.set_item(
                "note",
                "friction elements and interface groups are not part of the arrays",
            )?;
        }
        Ok(d)
    }

    /// The DOFs of the contacts, one list per contact.
    #[getter]
    fn contact_dofs(&self) -> Vec<Vec<usize>> {
        self.model.contacts.iter().map(|c| c.dofs.clone()).collect()
    }
}
