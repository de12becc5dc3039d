//! Results to Python: any serializable result of the library becomes dicts and lists, in
//! which every list of numbers becomes a numpy array (float64, or int64 for integer
//! lists, 2-D for lists of equal-length number lists such as the Floquet multipliers).
//! The arrays take over the vectors built here without another copy.

use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde_json::Value;

use crate::errors::MshbmError;

/// A serializable value as Python objects (see the module docs).
pub fn to_python<T: serde::Serialize + ?Sized>(py: Python<'_>, value: &T) -> PyResult<Py<PyAny>> {
    let v = serde_json::to_value(value)
        .map_err(|e| MshbmError::new_err(format!("cannot convert the result: {e}")))?;
    value_to_py(py, &v)
}

fn numbers(items: &[Value]) -> Option<Vec<f64>> {
    if !items.iter().any(Value::is_number) {
        return None;
    }
    // NaN and infinities serialize as null: they come back as NaN
    items
        .iter()
        .map(|v| match v {
            Value::Number(n) => n.as_f64(),
            Value::Null => Some(f64::NAN),
            _ => None,
        })
        .collect()
}

fn integers(items: &[Value]) -> Option<Vec<i64>> {
    items
        .iter()
        .map(|v| match v {
            Value::Number(n) if !n.is_f64() => n.as_i64(),
            _ => None,
        })
        .collect()
}

pub fn value_to_py(py: Python<'_>, v: &Value) -> PyResult<Py<PyAny>> {
    Ok(match v {
        Value::Null => py.None(),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any().unbind(),
        Value::Number(n) => match (n.is_f64(), n.as_i64()) {
            (false, Some(i)) => i.into_pyobject(py)?.into_any().unbind(),
            _ => n
                .as_f64()
                .unwrap_or(f64::NAN)
                .into_pyobject(py)?
                .into_any()
                .unbind(),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any().unbind(),
        Value::Array(items) if items.is_empty() => PyList::empty(py).into_any().unbind(),
        Value::Array(items) => {
            if let Some(ints) = integers(items) {
                return Ok(PyArray1::from_vec(py, ints).into_any().unbind());
            }
            if let Some(xs) = numbers(items) {
                return Ok(PyArray1::from_vec(py, xs).into_any().unbind());
            }
            if let Some(rows) = matrix(items) {
                return Ok(PyArray2::from_vec2(py, &rows)?.into_any().unbind());
            }
            let list = PyList::empty(py);
            for item in items {
                list.append(value_to_py(py, item)?)?;
            }
            list.into_any().unbind()
        }
        Value::Object(map) => {
            let d = PyDict::new(py);
            for (k, item) in map {
                d.set_item(k, value_to_py(py, item)?)?;
            }
            d.into_any().unbind()
        }
    })
}

/// A list of equal-length number lists (e.g. `[[re, im], …]`) as rows.
fn matrix(items: &[Value]) -> Option<Vec<Vec<f64>>> {
    let rows: Option<Vec<Vec<f64>>> = items
        .iter()
        .map(|v| match v {
            Value::Array(r) if !r.is_empty() => numbers(r),
            _ => None,
        })
        .collect();
    let rows = rows?;
    let width = rows.first()?.len();
    rows.iter().all(|r| r.len() == width).then_some(rows)
}

/// A float64 numpy array that takes over `v`.
pub fn array(py: Python<'_>, v: Vec<f64>) -> Py<PyAny> {
    PyArray1::from_vec(py, v).into_any().unbind()
}
