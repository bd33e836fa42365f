//! The library's result structs as Python objects, through serde: every struct that
//! derives `Serialize` crosses as dicts, lists, floats and strings in its field order,
//! a NaN staying a float NaN (serde_json would make it `null`); a list of per-frame
//! structs crosses as columns (numpy arrays for numbers and flags). A field the library
//! adds to a result struct reaches Python with no change here.

use ciborium::value::Value;
use numpy::ndarray::Array1;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyList, PyString};

/// The intermediate value of a serialisable result (field order and NaN kept).
pub fn value<T: serde::Serialize + ?Sized>(v: &T) -> PyResult<Value> {
    Value::serialized(v).map_err(|e| {
        pyo3::exceptions::PyRuntimeError::new_err(format!("internal: cannot convert a result: {e}"))
    })
}

/// A serialisable result as Python objects.
pub fn to_py<'py, T: serde::Serialize + ?Sized>(
    py: Python<'py>,
    v: &T,
) -> PyResult<Bound<'py, PyAny>> {
    value_to_py(py, &value(v)?)
}

/// A serialisable result as Python objects, every text in the package's words (the
/// request fields the library names in reasons and warnings as Python parameters,
/// [`crate::errors::py_words`]).
pub fn to_py_words<'py, T: serde::Serialize + ?Sized>(
    py: Python<'py>,
    v: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let mut v = value(v)?;
    in_words(&mut v);
    value_to_py(py, &v)
}

/// Every text of `v` in the package's words.
fn in_words(v: &mut Value) {
    match v {
        Value::Text(s) => *s = crate::errors::py_words(s),
        Value::Tag(_, inner) => in_words(inner),
        Value::Array(items) => items.iter_mut().for_each(in_words),
        Value::Map(entries) => entries.iter_mut().for_each(|(_, x)| in_words(x)),
        _ => {}
    }
}

/// One intermediate value as a Python object.
pub fn value_to_py<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Integer(i) => i128::from(*i).into_pyobject(py)?.into_any(),
        Value::Float(f) => PyFloat::new(py, *f).into_any(),
        Value::Text(s) => PyString::new(py, s).into_any(),
        Value::Bytes(b) => PyBytes::new(py, b).into_any(),
        Value::Tag(_, inner) => value_to_py(py, inner)?,
        Value::Array(items) => {
            let list = PyList::empty(py);
            for x in items {
                list.append(value_to_py(py, x)?)?;
            }
            list.into_any()
        }
        Value::Map(entries) => {
            let dict = PyDict::new(py);
            for (k, x) in entries {
                dict.set_item(value_to_py(py, k)?, value_to_py(py, x)?)?;
            }
            dict.into_any()
        }
        other => {
            return Err(pyo3::exceptions::PyRuntimeError::new_err(format!(
                "internal: a result value of an unknown kind: {other:?}"
            )))
        }
    })
}

/// A number of a column, NaN for a missing one.
fn number(v: &Value) -> Option<f64> {
    match v {
        Value::Float(f) => Some(*f),
        Value::Integer(i) => Some(i128::from(*i) as f64),
        Value::Null => Some(f64::NAN),
        _ => None,
    }
}

/// Records (structs serialised to maps with the same keys) as columns: a dict of
/// numpy float arrays (numbers; NaN where a record has none), numpy bool arrays
/// (flags), or lists (anything else), in the first record's key order. Keys in
/// `skip` are left out.
pub fn columns<'py>(
    py: Python<'py>,
    records: &[Value],
    skip: &[&str],
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let Some(Value::Map(first)) = records.first() else {
        return Ok(out);
    };
    for (key, _) in first {
        let Value::Text(name) = key else { continue };
        if skip.contains(&name.as_str()) {
            continue;
        }
        let cells: Vec<&Value> = records
            .iter()
            .map(|r| match r {
                Value::Map(m) => m
                    .iter()
                    .find(|(k, _)| k == key)
                    .map_or(&Value::Null, |(_, v)| v),
                _ => &Value::Null,
            })
            .collect();
        let col = if cells.iter().all(|c| matches!(c, Value::Bool(_))) {
            Array1::from_iter(cells.iter().map(|c| matches!(c, Value::Bool(true))))
                .into_pyarray(py)
                .into_any()
        } else if let Some(nums) = cells
            .iter()
            .map(|c| number(c))
            .collect::<Option<Vec<f64>>>()
        {
            Array1::from(nums).into_pyarray(py).into_any()
        } else {
            let list = PyList::empty(py);
            for c in cells {
                list.append(value_to_py(py, c)?)?;
            }
            list.into_any()
        };
        out.set_item(name, col)?;
    }
    Ok(out)
}
