//! The design handle: a loaded, checked `fbgforge::spec::Design` held in Rust, made
//! from a file, TOML text or a dict (every way goes through `design::parse`, so the
//! same checks and messages apply), turned back into a dict or TOML, and compared.
//! The Python class `fbgforge.Design` wraps it (with the path it came from).

use crate::convert::to_py;
use crate::errors::{self, spec_err};
use fbgforge::spec::{Design, SpecError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::path::PathBuf;

/// The shipped designs, compiled in: (name, TOML text).
pub const SHIPPED: &[(&str, &str)] = &[
    (
        "clip-on-10mm",
        include_str!("../../designs/clip-on-10mm.toml"),
    ),
    (
        "clip-on-16mm",
        include_str!("../../designs/clip-on-16mm.toml"),
    ),
    (
        "clip-on-22mm",
        include_str!("../../designs/clip-on-22mm.toml"),
    ),
    (
        "clip-on-34mm",
        include_str!("../../designs/clip-on-34mm.toml"),
    ),
    (
        "tactile-array-60x80",
        include_str!("../../designs/tactile-array-60x80.toml"),
    ),
];

/// A loaded, checked design (private: `fbgforge.Design` is the public face).
#[pyclass(name = "_Design", module = "fbgforge._fbgforge", frozen)]
pub struct PyDesign {
    pub design: Design,
}

/// Parse TOML text into a checked design; `origin` names it in errors.
fn parse(py: Python<'_>, text: &str, origin: Option<PathBuf>) -> PyResult<Design> {
    fbgforge::design::parse(text).map_err(|mut e| {
        e.file = origin;
        spec_err(py, e, None)
    })
}

/// A Python value of a design dict as TOML (None values are left out, as an absent
/// optional field); `at` is the key path, for messages.
fn toml_value(py: Python<'_>, obj: &Bound<'_, PyAny>, at: &str) -> PyResult<Option<toml::Value>> {
    if obj.is_none() {
        return Ok(None);
    }
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(Some(toml::Value::Boolean(b.is_true())));
    }
    if obj.is_instance_of::<PyInt>() {
        return Ok(Some(toml::Value::Integer(obj.extract()?)));
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(Some(toml::Value::Float(obj.extract()?)));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Some(toml::Value::String(s.to_string())));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, v) in d.iter() {
            let Ok(key) = k.extract::<String>() else {
                return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                    "design dict: key {k} under `{at}` is not a string"
                )));
            };
            let path = if at.is_empty() {
                key.clone()
            } else {
                format!("{at}.{key}")
            };
            if let Some(x) = toml_value(py, &v, &path)? {
                t.insert(key, x);
            }
        }
        return Ok(Some(toml::Value::Table(t)));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (i, v) in obj.try_iter()?.enumerate() {
            let path = format!("{at}[{i}]");
            match toml_value(py, &v?, &path)? {
                Some(x) => items.push(x),
                None => {
                    return Err(errors::input(
                        py,
                        format!("design dict: `{path}` is None; a list holds values only"),
                    ))
                }
            }
        }
        return Ok(Some(toml::Value::Array(items)));
    }
    // numpy scalars and other numbers.
    if let Ok(v) = obj
        .call_method0("__float__")
        .and_then(|f| f.extract::<f64>())
    {
        return Ok(Some(toml::Value::Float(v)));
    }
    Err(pyo3::exceptions::PyTypeError::new_err(format!(
        "design dict: `{at}` is a {}; expected a number, string, bool, list or dict",
        obj.get_type().name()?
    )))
}

#[pymethods]
impl PyDesign {
    /// Load a design file.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        errors::must_exist(py, &path, "design")?;
        let design = py
            .detach(|| fbgforge::design::load(&path))
            .map_err(|e| spec_err(py, e, None))?;
        Ok(PyDesign { design })
    }

    /// A design from TOML text.
    #[staticmethod]
    fn from_toml(py: Python<'_>, text: &str) -> PyResult<Self> {
        Ok(PyDesign {
            design: parse(py, text, None)?,
        })
    }

    /// A design from a dict of the TOML's tables and fields.
    #[staticmethod]
    fn from_value(py: Python<'_>, value: &Bound<'_, PyAny>) -> PyResult<Self> {
        if value.cast::<PyDict>().is_err() {
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "Design.from_dict takes a dict, got a {}",
                value.get_type().name()?
            )));
        }
        let Some(toml::Value::Table(t)) = toml_value(py, value, "")? else {
            unreachable!("a dict is a table")
        };
        let text =
            toml::to_string(&t).map_err(|e| errors::input(py, format!("design dict: {e}")))?;
        fbgforge::design::parse(&text)
            .map(|design| PyDesign { design })
            .map_err(|e| {
                // Line numbers would point into text the caller never saw.
                let message = match e.message.split_once(": ") {
                    Some((line, rest)) if line.starts_with("line ") => rest.to_string(),
                    _ => e.message.clone(),
                };
                spec_err(py, SpecError { message, ..e }, None)
            })
    }

    /// A shipped design by name.
    #[staticmethod]
    fn shipped(py: Python<'_>, name: &str) -> PyResult<Self> {
        let name = name.trim_end_matches(".toml");
        match SHIPPED.iter().find(|(n, _)| *n == name) {
            Some((n, text)) => Ok(PyDesign {
                design: parse(py, text, Some(PathBuf::from(format!("designs/{n}.toml"))))?,
            }),
            None => Err(errors::input(
                py,
                format!(
                    "no shipped design `{name}`; the shipped designs: {}",
                    SHIPPED
                        .iter()
                        .map(|(n, _)| *n)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )),
        }
    }

    /// Names of the shipped designs.
    #[staticmethod]
    fn shipped_names() -> Vec<&'static str> {
        SHIPPED.iter().map(|(n, _)| *n).collect()
    }

    #[getter]
    fn name(&self) -> String {
        self.design.name.clone()
    }

    #[getter]
    fn kind(&self) -> &'static str {
        match (&self.design.module, &self.design.array) {
            (Some(_), Some(_)) => "module+array",
            (Some(_), None) => "module",
            _ => "array",
        }
    }

    /// Grating names in spec order (module gratings, then array gratings).
    #[getter]
    fn gratings(&self) -> Vec<String> {
        let mut v: Vec<String> = Vec::new();
        if let Some(m) = &self.design.module {
            v.extend(m.gratings.iter().map(|g| g.name.clone()));
        }
        if let Some(a) = &self.design.array {
            v.extend(a.gratings.iter().map(|g| g.name.clone()));
        }
        v
    }

    /// Cell labels of the array (`A`, `B`, … row-major from −x, −y), empty for a module.
    #[getter]
    fn cells(&self) -> Vec<String> {
        self.design.array.as_ref().map_or_else(Vec::new, |a| {
            (0..(a.cells_x * a.cells_y) as usize)
                .map(fbgforge::profile::cell_label)
                .collect()
        })
    }

    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.design)
    }

    fn to_toml(&self) -> String {
        self.design.to_toml()
    }

    /// Whether two handles hold the same spec.
    fn same(&self, other: &PyDesign) -> bool {
        self.design == other.design
    }
}
