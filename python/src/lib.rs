//! Python bindings of fbgforge (PyO3): the library's use cases for labs that script
//! their rigs in Python. Each function calls one library use case; results come back
//! as the same JSON documents the command line prints (as dicts) or as numpy arrays;
//! every error is an `fbgforge.FbgforgeError` (a `ValueError`) carrying the command
//! line's message. Heavy work runs with the GIL released.

use fbgforge::array::kernel::matrix_from_design;
use fbgforge::array::methods::{self as array_methods, Method, ReadingPrior};
use fbgforge::array::problem::{default_min_load_g, SensingProblem};
use fbgforge::array::reconstruct::{Frames, MethodRequest, DEFAULT_BUDGET_US};
use fbgforge::logs::{num::DateOrder, ForceColumns, LogFormat, ReadOptions};
use fbgforge::model::LoadCase;
use fbgforge::prediction::{FidelityChoice, PredictionRequest};
use fbgforge::spec::Design;
use fbgforge::verify::analysis::AnalysisOptions;
use fbgforge::verify::VerifyRequest;
use numpy::ndarray::{Array1, Array2};
use numpy::{AllowTypeChange, IntoPyArray, PyArrayLike2, PyArrayLikeDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

pyo3::create_exception!(
    fbgforge,
    FbgforgeError,
    PyValueError,
    "An fbgforge error: the message names the file, line or field and what was expected, as the command line prints it."
);

/// An anyhow error as the CLI prints it (`error: {e:#}` without the `error: `).
fn err(e: anyhow::Error) -> PyErr {
    FbgforgeError::new_err(format!("{e:#}"))
}

fn fail(msg: impl Into<String>) -> PyErr {
    FbgforgeError::new_err(msg.into())
}

/// A serialisable value as Python objects, through the same JSON the CLI prints (so a
/// NaN is `None` in both).
fn to_py<'py, T: serde::Serialize>(py: Python<'py>, v: &T) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| fail(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A loaded, checked design spec.
#[pyclass(name = "Design", module = "fbgforge", frozen)]
struct PyDesign {
    path: PathBuf,
    design: Design,
}

#[pymethods]
impl PyDesign {
    /// The design's name.
    #[getter]
    fn name(&self) -> String {
        self.design.name.clone()
    }

    /// The file it was loaded from.
    #[getter]
    fn path(&self) -> String {
        self.path.display().to_string()
    }

    /// `"module"`, `"array"` or `"module+array"`.
    #[getter]
    fn kind(&self) -> &'static str {
        match (&self.design.module, &self.design.array) {
            (Some(_), Some(_)) => "module+array",
            (Some(_), None) => "module",
            _ => "array",
        }
    }

    /// Grating names, in spec order (module gratings, then array gratings).
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

    /// The spec as a dict (the TOML's fields, defaults filled in).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.design)
    }

    fn __repr__(&self) -> String {
        format!(
            "Design(name={:?}, kind={:?}, path={:?})",
            self.design.name,
            self.kind(),
            self.path.display().to_string()
        )
    }
}

/// A design argument: a `Design` or a path.
fn design_arg(obj: &Bound<'_, PyAny>) -> PyResult<(PathBuf, Design)> {
    if let Ok(d) = obj.cast::<PyDesign>() {
        let d = d.get();
        return Ok((d.path.clone(), d.design.clone()));
    }
    let path = path_arg(obj)?;
    let design = obj
        .py()
        .detach(|| fbgforge::design::load(&path))
        .map_err(|e| err(e.into()))?;
    Ok((path, design))
}

/// A path argument: `str` or `os.PathLike`.
fn path_arg(obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    let os = obj.py().import("os")?;
    let p = os.call_method1("fspath", (obj,))?;
    Ok(PathBuf::from(p.extract::<String>()?))
}

/// Load and check a design spec (TOML).
#[pyfunction]
fn load_design(py: Python<'_>, path: &Bound<'_, PyAny>) -> PyResult<PyDesign> {
    let path = path_arg(path)?;
    let design = py
        .detach(|| fbgforge::design::load(&path))
        .map_err(|e| err(e.into()))?;
    Ok(PyDesign { path, design })
}

fn parse_case(case: Option<&str>) -> PyResult<Option<LoadCase>> {
    match case.map(str::trim) {
        None => Ok(None),
        Some("I" | "i" | "1") => Ok(Some(LoadCase::I)),
        Some("II" | "ii" | "2") => Ok(Some(LoadCase::II)),
        Some(other) => Err(fail(format!(
            "case `{other}`: expected \"I\" (core on a solid insert) or \"II\" (hollow core)"
        ))),
    }
}

fn parse_fidelity(f: &str) -> PyResult<FidelityChoice> {
    match f {
        "auto" => Ok(FidelityChoice::Auto),
        "closed-form" => Ok(FidelityChoice::ClosedForm),
        "fem" => Ok(FidelityChoice::Fem),
        other => Err(fail(format!(
            "fidelity `{other}`: expected \"auto\", \"closed-form\" or \"fem\""
        ))),
    }
}

fn parse_format(f: Option<&str>) -> PyResult<Option<LogFormat>> {
    match f {
        None => Ok(None),
        Some(name) => LogFormat::ALL
            .into_iter()
            .find(|x| x.name() == name)
            .map(Some)
            .ok_or_else(|| {
                fail(format!(
                    "format `{name}`: expected one of {}",
                    LogFormat::ALL.map(|x| x.name()).join(", ")
                ))
            }),
    }
}

fn parse_date_order(d: Option<&str>) -> PyResult<Option<DateOrder>> {
    match d {
        None => Ok(None),
        Some("dmy") => Ok(Some(DateOrder::DayMonthYear)),
        Some("mdy") => Ok(Some(DateOrder::MonthDayYear)),
        Some(other) => Err(fail(format!(
            "date order `{other}`: expected \"dmy\" or \"mdy\""
        ))),
    }
}

/// Predict each grating's sensitivity K (pm/N): the dict `fbgforge predict --json` prints.
#[pyfunction]
#[pyo3(signature = (design, force_n=10.0, delta_t_k=0.0, case=None, fidelity="auto"))]
fn predict<'py>(
    py: Python<'py>,
    design: &Bound<'py, PyAny>,
    force_n: f64,
    delta_t_k: f64,
    case: Option<&str>,
    fidelity: &str,
) -> PyResult<Bound<'py, PyAny>> {
    if !force_n.is_finite() {
        return Err(fail(format!(
            "--force-n must be a finite number of newtons, got {force_n}"
        )));
    }
    if !delta_t_k.is_finite() {
        return Err(fail(format!(
            "--delta-t-k must be a finite number of kelvin, got {delta_t_k}"
        )));
    }
    let (path, d) = design_arg(design)?;
    let case = parse_case(case)?;
    let choice = parse_fidelity(fidelity)?;
    if case == Some(LoadCase::I) && d.module.as_ref().is_some_and(|m| m.inserts.is_empty()) {
        return Err(fail(format!(
            "{}: Case I needs a solid insert, but the design lists none under [[module.inserts]]",
            path.display()
        )));
    }
    let rows = py
        .detach(|| {
            fbgforge::prediction::predict(
                &d,
                &PredictionRequest {
                    force_n,
                    delta_t_k,
                    case,
                    fidelity: choice,
                    band: true,
                    ..Default::default()
                },
            )
        })
        .map_err(|e| err(e.context(format!("{}: cannot predict", path.display()))))?;
    // The document `fbgforge predict --json` prints.
    let doc = serde_json::json!({
        "design": d.name,
        "force_n": force_n,
        "delta_t_k": delta_t_k,
        "fidelity": choice,
        "predictions": rows,
    });
    to_py(py, &doc)
}

/// Build the printable parts (STL, STEP, manifest.json) into `out_dir`; returns the
/// manifest as a dict plus the files written.
#[pyfunction]
#[pyo3(signature = (design, out_dir, tolerance_mm=None, parts=None))]
fn build<'py>(
    py: Python<'py>,
    design: &Bound<'py, PyAny>,
    out_dir: &Bound<'py, PyAny>,
    tolerance_mm: Option<f64>,
    parts: Option<Vec<String>>,
) -> PyResult<Bound<'py, PyAny>> {
    let (_, d) = design_arg(design)?;
    let dir = path_arg(out_dir)?;
    let report = py
        .detach(|| fbgforge::geometry::build_design(&d, &dir, tolerance_mm, parts.as_deref()))
        .map_err(err)?;
    let manifest_path = report.dir.join("manifest.json");
    let manifest = std::fs::read_to_string(&manifest_path)
        .map_err(|e| fail(format!("cannot read {}: {e}", manifest_path.display())))?;
    let out = PyDict::new(py);
    out.set_item("dir", report.dir.display().to_string())?;
    out.set_item(
        "files",
        report
            .files
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>(),
    )?;
    out.set_item(
        "manifest",
        py.import("json")?.call_method1("loads", (manifest,))?,
    )?;
    Ok(out.into_any())
}

/// Read an interrogator log (ENLIGHT Peaks or Sensors, I-MON, CSV) into numpy columns.
#[pyfunction]
#[pyo3(signature = (path, format=None, date_order=None))]
fn read_log<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
    format: Option<&str>,
    date_order: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    let path = path_arg(path)?;
    let opts = ReadOptions {
        format: parse_format(format)?,
        date_order: parse_date_order(date_order)?,
    };
    let log = py
        .detach(|| fbgforge::logs::read_peak_log(&path, &opts))
        .map_err(err)?;
    let rows = log.rows();
    let mut peak_row = Vec::with_capacity(log.peaks_nm.len());
    let mut peak_time = Vec::with_capacity(log.peaks_nm.len());
    for i in 0..rows {
        for _ in log.row_start[i]..log.row_start[i + 1] {
            peak_row.push(i as i64);
            peak_time.push(log.time_s[i]);
        }
    }
    let out = PyDict::new(py);
    out.set_item("source", log.source.display().to_string())?;
    out.set_item("format", log.format.name())?;
    out.set_item("clock", to_py(py, &log.clock)?)?;
    out.set_item("channels", log.channels)?;
    out.set_item("column_names", log.column_names.clone())?;
    out.set_item("rows", rows)?;
    out.set_item("time_s", Array1::from(log.time_s.clone()).into_pyarray(py))?;
    out.set_item(
        "row_start",
        Array1::from_iter(log.row_start.iter().map(|&v| v as i64)).into_pyarray(py),
    )?;
    out.set_item(
        "line_of_row",
        Array1::from(log.line_of_row.clone()).into_pyarray(py),
    )?;
    // One row per peak: `pandas.DataFrame(log["peaks"])` is the long table.
    let peaks = PyDict::new(py);
    peaks.set_item("row", Array1::from(peak_row).into_pyarray(py))?;
    peaks.set_item("time_s", Array1::from(peak_time).into_pyarray(py))?;
    peaks.set_item(
        "channel",
        Array1::from(log.peak_channel.clone()).into_pyarray(py),
    )?;
    peaks.set_item(
        "wavelength_nm",
        Array1::from(log.peaks_nm.clone()).into_pyarray(py),
    )?;
    out.set_item("peaks", peaks)?;
    out.set_item("warnings", to_py(py, &log.warnings.counts)?)?;
    Ok(out.into_any())
}

/// Verify a printed part from its logs: the dict `fbgforge verify --json` prints.
#[pyfunction]
#[pyo3(signature = (design, log, force, *, case=None, insert=None, core=None,
    k_tolerance=0.08, window_nm=None, clock_offset_s=None, force_start=None,
    max_offset_s=60.0, resolution_pm=None, format=None, date_order=None,
    force_time_column=None, force_force_column=None, force_scale_to_n=None,
    force_date_order=None, report_dir=None))]
#[allow(clippy::too_many_arguments)]
fn verify<'py>(
    py: Python<'py>,
    design: &Bound<'py, PyAny>,
    log: &Bound<'py, PyAny>,
    force: &Bound<'py, PyAny>,
    case: Option<&str>,
    insert: Option<String>,
    core: Option<String>,
    k_tolerance: f64,
    window_nm: Option<f64>,
    clock_offset_s: Option<f64>,
    force_start: Option<String>,
    max_offset_s: f64,
    resolution_pm: Option<f64>,
    format: Option<&str>,
    date_order: Option<&str>,
    force_time_column: Option<String>,
    force_force_column: Option<String>,
    force_scale_to_n: Option<f64>,
    force_date_order: Option<&str>,
    report_dir: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let design_path = match design.cast::<PyDesign>() {
        Ok(d) => d.get().path.clone(),
        Err(_) => path_arg(design)?,
    };
    let mut req = VerifyRequest::new(design_path, path_arg(log)?, path_arg(force)?);
    req.read = ReadOptions {
        format: parse_format(format)?,
        date_order: parse_date_order(date_order)?,
    };
    req.force_columns = ForceColumns {
        time: force_time_column,
        force: force_force_column,
        scale_to_n: force_scale_to_n,
        date_order: parse_date_order(force_date_order)?,
    };
    req.case = parse_case(case)?;
    req.insert = insert;
    req.analysis = AnalysisOptions {
        core,
        window_half_width_nm: window_nm,
        clock_offset_s,
        max_clock_offset_s: max_offset_s,
        resolution_pm,
    };
    req.k_tolerance = k_tolerance;
    req.force_start = force_start;
    let report_dir = report_dir.map(path_arg).transpose()?;
    let report = py
        .detach(|| -> anyhow::Result<_> {
            let outcome = fbgforge::verify::run(&req)?;
            if let Some(dir) = &report_dir {
                fbgforge::verify::report::write_report(dir, &outcome.report, &outcome.series)?;
            }
            Ok(outcome.report)
        })
        .map_err(err)?;
    to_py(py, &report)
}

/// The model sensing matrix of an array design: gratings, cells, A (pm/g), ulimit (g).
#[pyfunction]
fn sensing_matrix<'py>(py: Python<'py>, design: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let (_, d) = design_arg(design)?;
    let (m, ulimit_g) = matrix_from_design(&d).map_err(err)?;
    let a = &m.sensitivity_pm_per_g;
    let arr = Array2::from_shape_fn((a.nrows(), a.ncols()), |(i, j)| a[(i, j)]);
    let out = PyDict::new(py);
    out.set_item("gratings", m.gratings.clone())?;
    out.set_item("cells", m.cells.clone())?;
    out.set_item("sensitivity_pm_per_g", arr.into_pyarray(py))?;
    out.set_item("ulimit_g", ulimit_g)?;
    Ok(out.into_any())
}

/// Names of the reconstruction methods, and the one used when none is named for a
/// matrix `A` (when given).
#[pyfunction]
fn methods() -> Vec<&'static str> {
    Method::ALL.iter().map(|m| m.name()).collect()
}

/// Reconstruct cell loads x (g) from grating shifts y (pm) with y = A x: `A` is
/// gratings × cells (pm/g), `Y` one frame (1-D) or frames × gratings. Frames run in
/// parallel with the GIL released. Returns loads (frames × cells, or 1-D for one
/// frame), and with `return_info` also a dict of per-frame `converged`, `residual_pm`,
/// `certified`, `chi2` and `flags` (a list of flag words per frame, empty when the
/// frame can be trusted), the `suspect_gratings` left out (names `fbg<row>`), and
/// the `method` and `penalty` used.
#[pyfunction]
#[pyo3(signature = (a, y, method=None, *, ulimit_g=250.0, min_load_g=None, penalty=None,
    max_loads=None, resolution_pm=0.5, normalise=true, return_info=false))]
#[allow(clippy::too_many_arguments)]
fn reconstruct<'py>(
    py: Python<'py>,
    a: PyArrayLike2<'py, f64, AllowTypeChange>,
    y: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    method: Option<&str>,
    ulimit_g: f64,
    min_load_g: Option<f64>,
    penalty: Option<f64>,
    max_loads: Option<usize>,
    resolution_pm: f64,
    normalise: bool,
    return_info: bool,
) -> PyResult<Bound<'py, PyAny>> {
    if penalty.is_some() && method.is_none() {
        return Err(fail(
            "penalty is a setting of a named method: give method= as well (the default choice tunes its own)".to_string(),
        ));
    }
    let av = a.as_array();
    let (m, n) = av.dim();
    let matrix = nalgebra::DMatrix::from_fn(m, n, |i, j| av[(i, j)]);
    let one_frame = y.ndim() == 1;
    let yv = y.as_array();
    let frames: Vec<Vec<f64>> = match yv.ndim() {
        1 => vec![yv.iter().copied().collect()],
        2 => yv
            .outer_iter()
            .map(|r| r.iter().copied().collect())
            .collect(),
        k => {
            return Err(fail(format!(
                "Y has {k} dimensions; expected one frame (gratings,) or frames × gratings"
            )))
        }
    };
    for (f, row) in frames.iter().enumerate() {
        if row.len() != m {
            return Err(fail(format!(
                "a frame holds {} shifts but the sensing matrix has {m} gratings (Y must be frames × gratings; A is gratings × cells)",
                row.len()
            )));
        }
        if let Some(g) = row.iter().position(|v| !v.is_finite()) {
            return Err(fail(format!(
                "Y[{f}, {g}] is {}; expected a finite shift in pm",
                row[g]
            )));
        }
    }
    let problem = SensingProblem::new(matrix, ulimit_g, normalise)
        .and_then(|p| p.with_min_load_g(min_load_g.unwrap_or(default_min_load_g(ulimit_g))))
        .map_err(|e| fail(e.to_string()))?;
    let max_loads = max_loads.unwrap_or(array_methods::DEFAULT_MAX_LOADS);
    if max_loads == 0 {
        return Err(fail("max_loads must be at least 1".to_string()));
    }
    let prior = ReadingPrior {
        max_loads,
        resolution_pm,
    };
    let request = match method {
        Some(name) => MethodRequest::Named {
            method: Method::from_name(name).map_err(|e| fail(e.to_string()))?,
            penalty,
        },
        None => MethodRequest::Default {
            budget_us: DEFAULT_BUDGET_US,
        },
    };
    // A numpy matrix has no grating names: its rows are numbered as a matrix CSV
    // without header is.
    let gratings: Vec<String> = (1..=m).map(|i| format!("fbg{i}")).collect();
    let done = py
        .detach(|| {
            let frames = Frames {
                gratings: &gratings,
                shifts_pm: &frames,
            };
            fbgforge::array::reconstruct(
                &problem,
                frames,
                &prior,
                &request,
                &fbgforge::progress::Quiet,
            )
        })
        .map_err(|e| fail(e.to_string()))?;
    let results = &done.frames;
    let loads = Array2::from_shape_fn((results.len(), n), |(i, j)| results[i].loads_g[j]);
    let loads: Bound<'py, PyAny> = if one_frame {
        loads.row(0).to_owned().into_pyarray(py).into_any()
    } else {
        loads.into_pyarray(py).into_any()
    };
    if !return_info {
        return Ok(loads);
    }
    let info = PyDict::new(py);
    info.set_item("method", done.setup.method.name())?;
    info.set_item("reason", &done.setup.reason)?;
    info.set_item("max_loads", prior.max_loads)?;
    info.set_item("penalty", done.setup.penalty())?;
    info.set_item(
        "converged",
        Array1::from_iter(results.iter().map(|r| r.converged)).into_pyarray(py),
    )?;
    info.set_item(
        "residual_pm",
        Array1::from_iter(results.iter().map(|r| r.residual_pm)).into_pyarray(py),
    )?;
    // Issue 24: the per-frame trust the CLI and live carry.
    info.set_item(
        "certified",
        Array1::from_iter(results.iter().map(|r| r.certified)).into_pyarray(py),
    )?;
    info.set_item(
        "chi2",
        Array1::from_iter(results.iter().map(|r| r.chi2)).into_pyarray(py),
    )?;
    let flags: Vec<Vec<&str>> = results.iter().map(|r| r.flags.words()).collect();
    info.set_item("flags", flags)?;
    let suspects: Vec<&str> = done
        .suspect_gratings
        .iter()
        .map(|g| g.name.as_str())
        .collect();
    info.set_item("suspect_gratings", suspects)?;
    Ok((loads, info).into_pyobject(py)?.into_any())
}

/// The compiled part of the `fbgforge` package.
#[pymodule]
fn _fbgforge(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("FbgforgeError", m.py().get_type::<FbgforgeError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<PyDesign>()?;
    m.add_function(wrap_pyfunction!(load_design, m)?)?;
    m.add_function(wrap_pyfunction!(predict, m)?)?;
    m.add_function(wrap_pyfunction!(build, m)?)?;
    m.add_function(wrap_pyfunction!(read_log, m)?)?;
    m.add_function(wrap_pyfunction!(verify, m)?)?;
    m.add_function(wrap_pyfunction!(sensing_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    m.add_function(wrap_pyfunction!(reconstruct, m)?)?;
    Ok(())
}
