//! Python bindings of fbgforge (PyO3): the compiled part `fbgforge._fbgforge` of the
//! Python package. Each function takes a design handle ([`design::PyDesign`]) or paths
//! plus the use case's settings, calls one library use case with the GIL released,
//! and returns its result structs as Python objects ([`convert`]: dicts in field
//! order, NaN kept, per-frame results as numpy columns). The Python layer
//! (`python/fbgforge/`) matches names, builds the result objects and documents the
//! API; errors are raised as the exceptions of `fbgforge.errors` ([`errors`]).

mod convert;
mod design;
mod errors;
mod live;
mod reconstructor;
mod spectra;

use convert::{columns, to_py, to_py_words, value};
use design::PyDesign;
use errors::{err, err_named, input, must_exist};
use fbgforge::array::calibrate::CalibrateRequest;
use fbgforge::array::kernel::matrix_from_design;
use fbgforge::array::methods::Method;
use fbgforge::array::reconstruct::Frames;
use fbgforge::logs::{num::DateOrder, ForceReadOptions, LogFormat, LogStyle, ReadOptions};
use fbgforge::model::LoadCase;
use fbgforge::prediction::{FidelityChoice, PredictionRequest, RunError};
use fbgforge::report::verify::ReportFolder;
use fbgforge::verify::analysis::AnalysisOptions;
use fbgforge::verify::VerifyRequest;
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// The finite-element structures of this process's solves: the Python package owns
/// one cache for its process (the library keeps none), so a notebook's repeated
/// predictions and sweeps on one geometry share their structures.
fn fe_cache() -> &'static fbgforge::fem::GeometryCache {
    static CACHE: std::sync::OnceLock<fbgforge::fem::GeometryCache> = std::sync::OnceLock::new();
    CACHE.get_or_init(fbgforge::fem::GeometryCache::default)
}

fn parse_case(py: Python<'_>, case: Option<&str>) -> PyResult<Option<LoadCase>> {
    match case.map(str::trim) {
        None => Ok(None),
        Some("I" | "i" | "1") => Ok(Some(LoadCase::I)),
        Some("II" | "ii" | "2") => Ok(Some(LoadCase::II)),
        Some(other) => Err(input(
            py,
            format!(
                "case `{other}`: expected \"I\" (core on a solid insert) or \"II\" (hollow core)"
            ),
        )),
    }
}

fn parse_fidelity(py: Python<'_>, f: &str) -> PyResult<FidelityChoice> {
    match f {
        "auto" => Ok(FidelityChoice::Auto),
        "closed-form" => Ok(FidelityChoice::ClosedForm),
        "fem" => Ok(FidelityChoice::Fem),
        other => Err(input(
            py,
            format!("fidelity `{other}`: expected \"auto\", \"closed-form\" or \"fem\""),
        )),
    }
}

fn parse_format(py: Python<'_>, f: Option<&str>) -> PyResult<Option<LogFormat>> {
    match f {
        None => Ok(None),
        Some(name) => LogFormat::ALL
            .into_iter()
            .find(|x| x.name() == name)
            .map(Some)
            .ok_or_else(|| {
                input(
                    py,
                    format!(
                        "format `{name}`: expected one of {}",
                        LogFormat::ALL.map(|x| x.name()).join(", ")
                    ),
                )
            }),
    }
}

fn parse_date_order(py: Python<'_>, d: Option<&str>) -> PyResult<Option<DateOrder>> {
    match d {
        None => Ok(None),
        Some("dmy") => Ok(Some(DateOrder::DayMonthYear)),
        Some("mdy") => Ok(Some(DateOrder::MonthDayYear)),
        Some(other) => Err(input(
            py,
            format!("date order `{other}`: expected \"dmy\" or \"mdy\""),
        )),
    }
}

fn read_options(
    py: Python<'_>,
    format: Option<&str>,
    date_order: Option<&str>,
) -> PyResult<ReadOptions> {
    Ok(ReadOptions {
        format: parse_format(py, format)?,
        date_order: parse_date_order(py, date_order)?,
        ..Default::default()
    })
}

/// A use case's error as its Python exception, with the design named before what does
/// not fit it and `failed` (e.g. "cannot predict") before what the model could not do.
fn run_err(py: Python<'_>, e: RunError, design: &str, failed: &str) -> PyErr {
    let e = match e {
        RunError::Request(e) | RunError::Output(e) => e,
        RunError::Design(e) => e.context(format!("design `{design}`")),
        RunError::Model(e) => e.context(format!("design `{design}`: {failed}")),
    };
    err(py, e)
}

/// Predict each grating's K (pm/N): the rows of the model policy.
#[pyfunction]
#[pyo3(signature = (design, force_n, delta_t_k, case, fidelity, band, mesh_level, spectrum))]
#[allow(clippy::too_many_arguments)] // one per keyword of the Python function
fn predict<'py>(
    py: Python<'py>,
    design: &PyDesign,
    force_n: f64,
    delta_t_k: f64,
    case: Option<&str>,
    fidelity: &str,
    band: bool,
    mesh_level: Option<u32>,
    spectrum: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let case = parse_case(py, case)?;
    let choice = parse_fidelity(py, fidelity)?;
    let levels =
        fbgforge::fem::FemOptions::MIN_MESH_LEVEL..=fbgforge::fem::FemOptions::MAX_MESH_LEVEL;
    if let Some(k) = mesh_level.filter(|k| !levels.contains(k)) {
        return Err(input(
            py,
            format!(
                "mesh_level {k}: expected {} to {} (fine), or None (the policy picks per configuration)",
                levels.start(),
                levels.end()
            ),
        ));
    }
    let d = &design.design;
    let request = PredictionRequest {
        force_n,
        delta_t_k,
        case,
        fidelity: choice,
        band,
        design_interval: band,
        spectrum,
        fem_options: fbgforge::fem::FemOptions::mesh_level(
            mesh_level.unwrap_or(fbgforge::fem::FemOptions::DEFAULT_MESH_LEVEL),
        ),
        // As the command line: a level asked for is kept, else the policy refines.
        refine_to_level: match mesh_level {
            Some(_) => None,
            None => Some(fbgforge::fem::FemOptions::AUTO_FINEST_MESH_LEVEL),
        },
        cache: fe_cache().clone(),
        ..Default::default()
    };
    // The rows with the same checks of the paper's statements as the command line's.
    let (rows, statements) = py
        .detach(|| fbgforge::prediction::predict_into(d, &request, &mut ()))
        .map_err(|e| run_err(py, e, &d.name, "cannot predict"))?;
    Ok((convert::to_py_words(py, &rows)?, to_py(py, &statements)?)
        .into_pyobject(py)?
        .into_any())
}

/// Build the printable parts into `out_dir`: the build report and manifest.json.
#[pyfunction]
#[pyo3(signature = (design, out_dir, tolerance_mm, parts))]
fn build<'py>(
    py: Python<'py>,
    design: &PyDesign,
    out_dir: PathBuf,
    tolerance_mm: Option<f64>,
    parts: Option<Vec<String>>,
) -> PyResult<Bound<'py, PyAny>> {
    let d = &design.design;
    let report = py
        .detach(|| {
            let request = fbgforge::geometry::BuildRequest {
                tolerance_mm,
                parts,
            };
            // The same files as the command line's build, previews included.
            let mut previews = fbgforge::report::build::Previews;
            fbgforge::geometry::build_design(d, &out_dir, &request, &mut previews)
        })
        .map_err(|e| err_named(py, e, &[("tolerance", "tolerance_mm")]))?;
    let manifest_path = report.dir.join("manifest.json");
    let manifest = std::fs::read_to_string(&manifest_path).map_err(|e| {
        err(
            py,
            anyhow::Error::new(e).context(format!("cannot read {}", manifest_path.display())),
        )
    })?;
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

/// Read an interrogator log into numpy columns.
#[pyfunction]
#[pyo3(signature = (path, format, date_order))]
fn read_log<'py>(
    py: Python<'py>,
    path: PathBuf,
    format: Option<&str>,
    date_order: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    must_exist(py, &path, "log")?;
    let opts = read_options(py, format, date_order)?;
    let log = py
        .detach(|| fbgforge::logs::read_peak_log(&path, &opts))
        .map_err(|e| err(py, e))?;
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

/// Verify a printed part from its logs: the report (and the report folder written).
#[pyfunction]
#[pyo3(signature = (design_path, log, force, case, insert, core, k_tolerance, window_nm,
    clock_offset_s, force_start, max_offset_s, resolution_pm, format, date_order,
    force_time_column, force_force_column, force_scale_to_n, force_date_order, report_dir))]
#[allow(clippy::too_many_arguments)]
fn verify<'py>(
    py: Python<'py>,
    design_path: PathBuf,
    log: PathBuf,
    force: PathBuf,
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
    report_dir: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    must_exist(py, &log, "log")?;
    must_exist(py, &force, "force log")?;
    let mut req = VerifyRequest::new(design_path, log, force);
    req.read = read_options(py, format, date_order)?;
    req.force_read = ForceReadOptions {
        time: force_time_column,
        force: force_force_column,
        scale_to_n: force_scale_to_n,
        date_order: parse_date_order(py, force_date_order)?,
    };
    req.case = parse_case(py, case)?;
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
    let report = py
        .detach(|| -> anyhow::Result<_> {
            let mut folder = report_dir
                .as_deref()
                .map(|dir| ReportFolder::new(dir, errors::py_words))
                .transpose()?;
            Ok(fbgforge::verify::run_with(&req, &mut folder)?.report)
        })
        .map_err(|e| err(py, e))?;
    to_py_words(py, &report)
}

/// The model sensing matrix of an array design.
#[pyfunction]
fn sensing_matrix<'py>(py: Python<'py>, design: &PyDesign) -> PyResult<Bound<'py, PyAny>> {
    let (m, ulimit_g) = matrix_from_design(&design.design).map_err(|e| err(py, e))?;
    matrix_dict(py, &m, Some(ulimit_g))
}

fn matrix_dict<'py>(
    py: Python<'py>,
    m: &fbgforge::array::SensingMatrix,
    ulimit_g: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let a = &m.sensitivity_pm_per_g;
    let arr = Array2::from_shape_fn((a.nrows(), a.ncols()), |(i, j)| a[(i, j)]);
    let out = PyDict::new(py);
    out.set_item("gratings", m.gratings.clone())?;
    out.set_item("cells", m.cells.clone())?;
    out.set_item("sensitivity_pm_per_g", arr.into_pyarray(py))?;
    out.set_item("ulimit_g", ulimit_g)?;
    Ok(out.into_any())
}

/// The library's rule for named shift columns: for each grating, the column index;
/// and the `time_s` column, if any.
#[pyfunction]
fn shift_columns(
    py: Python<'_>,
    names: Vec<String>,
    gratings: Vec<String>,
) -> PyResult<(Option<usize>, Vec<usize>)> {
    fbgforge::array::io::shift_columns(&names, &gratings)
        .map(|c| (c.time, c.gratings))
        .map_err(|e| input(py, format!("shifts: {e}")))
}

/// Names of the reconstruction methods.
#[pyfunction]
fn methods() -> Vec<&'static str> {
    Method::ALL.iter().map(|m| m.name()).collect()
}

/// Reconstruct cell loads (g) from shifts (pm): `y` is frames × gratings, its columns
/// in the order of `gratings` (the matrix's rows). Returns (loads, per-frame columns,
/// set-up).
#[pyfunction]
#[pyo3(signature = (a, gratings, y, method, ulimit_g, min_load_g, penalty, max_loads,
    resolution_pm, budget_us, normalise, common_mode=false, matrix_sd_pct=None,
    keep_all_gratings=false, significance=None))]
#[allow(clippy::too_many_arguments)]
fn reconstruct<'py>(
    py: Python<'py>,
    a: PyReadonlyArray2<'py, f64>,
    gratings: Vec<String>,
    y: PyReadonlyArray2<'py, f64>,
    method: Option<&str>,
    ulimit_g: f64,
    min_load_g: Option<f64>,
    penalty: Option<f64>,
    max_loads: Option<usize>,
    resolution_pm: f64,
    budget_us: f64,
    normalise: bool,
    common_mode: bool,
    matrix_sd_pct: Option<f64>,
    keep_all_gratings: bool,
    significance: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    if penalty.is_some() && method.is_none() {
        return Err(input(
            py,
            "penalty is a setting of a named method: give method= as well (the default choice tunes its own)",
        ));
    }
    let av = a.as_array();
    let (m, n) = av.dim();
    if gratings.len() != m {
        return Err(input(
            py,
            format!(
                "{} grating names for a sensing matrix of {m} rows",
                gratings.len()
            ),
        ));
    }
    let matrix = nalgebra::DMatrix::from_fn(m, n, |i, j| av[(i, j)]);
    let yv = y.as_array();
    if yv.ncols() != m {
        return Err(input(
            py,
            format!(
                "a frame holds {} shifts but the sensing matrix has {m} gratings",
                yv.ncols()
            ),
        ));
    }
    let frames: Vec<Vec<f64>> = yv.outer_iter().map(|r| r.to_vec()).collect();
    for (f, row) in frames.iter().enumerate() {
        if let Some(g) = row.iter().position(|v| !v.is_finite()) {
            return Err(input(
                py,
                format!(
                    "shifts of frame {f}, grating `{}`: {} is not a finite shift in pm",
                    gratings[g], row[g]
                ),
            ));
        }
    }
    let problem = reconstructor::stated_problem(
        py,
        matrix,
        ulimit_g,
        min_load_g,
        normalise,
        resolution_pm,
        matrix_sd_pct,
        common_mode,
        significance,
    )?
    .with_diagnosis(!keep_all_gratings);
    let (prior, request) =
        reconstructor::reading_request(py, max_loads, resolution_pm, method, penalty, budget_us)?;
    let done = py
        .detach(|| {
            fbgforge::array::reconstruct(
                &problem,
                Frames {
                    gratings: &gratings,
                    shifts_pm: &frames,
                },
                &prior,
                &request,
                &fbgforge::progress::Quiet,
            )
        })
        .map_err(|e| input(py, errors::python_words(&e.to_string(), &[])))?;
    let results = &done.frames;
    let loads = Array2::from_shape_fn((results.len(), n), |(i, j)| results[i].loads_g[j]);
    // Every per-frame field but the loads, as columns (new fields come along).
    let records = results.iter().map(value).collect::<PyResult<Vec<_>>>()?;
    let per_frame = columns(py, &records, &["loads_g"])?;
    let setup = PyDict::new(py);
    setup.set_item("method", done.setup.method.name())?;
    setup.set_item("reason", &done.setup.reason)?;
    setup.set_item("penalty", done.setup.penalty())?;
    setup.set_item("max_loads", prior.max_loads)?;
    setup.set_item("resolution_pm", prior.resolution_pm)?;
    setup.set_item("setup_ms", done.setup.setup_ms)?;
    setup.set_item("time_per_frame_us", done.time_per_frame_us)?;
    setup.set_item("threads", done.threads)?;
    setup.set_item("choice", to_py(py, &done.setup.choice)?)?;
    // Issue 24: the gratings left out as dead or stuck, and the flag counts.
    setup.set_item("suspect_gratings", to_py(py, &done.suspect_gratings)?)?;
    setup.set_item("flag_counts", to_py(py, &done.flag_counts)?)?;
    Ok((loads.into_pyarray(py), per_frame, setup)
        .into_pyobject(py)?
        .into_any())
}

/// Sweep one parameter: the predicted shift and K of every series at each value.
#[pyfunction]
#[pyo3(signature = (design, param, values, start, stop, steps, spacing, force_n, case, fidelity, band))]
#[allow(clippy::too_many_arguments)]
fn sweep<'py>(
    py: Python<'py>,
    design: &PyDesign,
    param: &str,
    values: Option<Vec<f64>>,
    start: Option<f64>,
    stop: Option<f64>,
    steps: usize,
    spacing: &str,
    force_n: f64,
    case: Option<&str>,
    fidelity: &str,
    band: bool,
) -> PyResult<Bound<'py, PyAny>> {
    use fbgforge::model::sweep;
    let p = sweep::find_param(param).map_err(|e| input(py, e.to_string()))?;
    let values = match (values, start, stop) {
        (Some(v), None, None) => {
            if v.is_empty() {
                return Err(input(py, "values is empty: give at least one value"));
            }
            if let Some((i, x)) = v
                .iter()
                .enumerate()
                .find(|(_, x)| !(x.is_finite() && **x > 0.0))
            {
                return Err(input(
                    py,
                    format!(
                        "values[{i}] = {x}: {} must be a finite number above 0",
                        p.name
                    ),
                ));
            }
            v
        }
        (None, Some(a), Some(b)) => {
            let linear = sweep::sweep_values(p, a, b, steps)
                .map_err(|e| input(py, errors::py_words(&e.to_string())))?;
            match spacing {
                "linear" => linear,
                "log" => (0..steps)
                    .map(|i| a * (b / a).powf(i as f64 / (steps - 1) as f64))
                    .collect(),
                other => {
                    return Err(input(
                        py,
                        format!("spacing `{other}`: expected \"linear\" or \"log\""),
                    ))
                }
            }
        }
        _ => {
            return Err(input(
                py,
                format!(
                    "give either values= or both start= and stop= for a sweep of {}",
                    p.name
                ),
            ))
        }
    };
    let case = parse_case(py, case)?;
    let d = &design.design;
    let choice = parse_fidelity(py, fidelity)?;
    let request = fbgforge::prediction::SweepRequest {
        param: p,
        start: values.first().copied().unwrap_or(f64::NAN),
        stop: values.last().copied().unwrap_or(f64::NAN),
        steps: values.len(),
        spacing: fbgforge::prediction::Spacing::Linear,
        values: Some(values),
        force_n,
        case,
        fidelity: choice,
        band,
        fem_options: fbgforge::fem::FemOptions::default(),
        cache: fe_cache().clone(),
    };
    let r = py
        .detach(|| fbgforge::prediction::sweep(d, &request, &fbgforge::progress::Quiet, &mut ()))
        .map_err(|e| run_err(py, e, &d.name, "sweep failed"))?;
    to_py(py, &r)
}

/// Optimise a module design: the outcome, the optimised design, where it was written.
#[pyfunction]
#[pyo3(signature = (design_path, objective, vary, bounds, max_force_n, max_strain_microstrain,
    min_clearance_mm, cores, inserts, materials, measured, solver, starts, max_iters,
    swarm_iters, seed, landscape, out, report_dir))]
#[allow(clippy::too_many_arguments)]
fn optimize<'py>(
    py: Python<'py>,
    design_path: PathBuf,
    objective: &str,
    vary: &str,
    bounds: Option<&str>,
    max_force_n: f64,
    max_strain_microstrain: f64,
    min_clearance_mm: Option<f64>,
    cores: Option<Vec<String>>,
    inserts: Option<Vec<String>>,
    materials: Option<PathBuf>,
    measured: Option<PathBuf>,
    solver: &str,
    starts: usize,
    max_iters: u64,
    swarm_iters: u64,
    seed: u64,
    landscape: Option<&str>,
    out: Option<PathBuf>,
    report_dir: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    use fbgforge::optimize::module::{parse_bounds, ModuleSettings, Objective, Variable};
    use fbgforge::optimize::run::{run_module, ModuleRequest};
    use fbgforge::solvers::SolverKind;
    let e = |e: anyhow::Error| err(py, e);
    if let Some(p) = &materials {
        must_exist(py, p, "materials")?;
    }
    if let Some(p) = &measured {
        must_exist(py, p, "measured")?;
    }
    let mut settings = ModuleSettings {
        objective: Objective::parse(objective).map_err(e)?,
        max_force_n,
        max_grating_strain: max_strain_microstrain * 1e-6,
        min_fit_clearance_mm: min_clearance_mm,
        vary: Variable::parse_list(vary).map_err(e)?,
        bounds: bounds
            .map(parse_bounds)
            .transpose()
            .map_err(e)?
            .unwrap_or_default(),
        cores,
        inserts,
        solvers: SolverKind::parse(solver).map_err(e)?,
        extra_starts: starts,
        seed,
        ..ModuleSettings::default()
    };
    settings.run.max_iters = max_iters;
    settings.run.swarm_iters = swarm_iters;
    let req = ModuleRequest {
        design: design_path,
        materials,
        settings,
        measured,
        landscape: landscape.map(Variable::parse_list).transpose().map_err(e)?,
        out,
        report_dir,
        words: errors::py_words,
    };
    let mut folder = fbgforge::report::optimize::ModuleReportFolder::new(errors::py_words);
    let run = py
        .detach(|| run_module(&req, &fbgforge::progress::Quiet, &mut folder))
        .map_err(|x| err(py, x))?;
    optimised(
        py,
        &run.outcome,
        &run.outcome.design,
        &run.design_path,
        &run.report_dir,
    )
}

/// An optimisation for Python: its outcome as a dict, the written design, and where
/// the design file and the report went.
fn optimised<'py, T: serde::Serialize>(
    py: Python<'py>,
    outcome: &T,
    design: &fbgforge::spec::Design,
    design_path: &std::path::Path,
    report_dir: &std::path::Path,
) -> PyResult<Bound<'py, PyAny>> {
    let doc = PyDict::new(py);
    doc.set_item("outcome", convert::to_py_words(py, outcome)?)?;
    doc.set_item(
        "design",
        PyDesign {
            design: design.clone(),
        },
    )?;
    doc.set_item("design_path", design_path.display().to_string())?;
    doc.set_item("report_dir", report_dir.display().to_string())?;
    Ok(doc.into_any())
}

/// Optimise grating placement in a flat array.
#[pyfunction]
#[pyo3(signature = (design_path, objective, method, vary_fibers, solver, max_iters,
    agreement_samples, out, report_dir))]
#[allow(clippy::too_many_arguments)]
fn place<'py>(
    py: Python<'py>,
    design_path: PathBuf,
    objective: &str,
    method: &str,
    vary_fibers: bool,
    solver: &str,
    max_iters: u64,
    agreement_samples: usize,
    out: Option<PathBuf>,
    report_dir: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    use fbgforge::optimize::place::{PlaceObjective, PlaceSettings};
    use fbgforge::optimize::run::{run_placement, PlaceRequest};
    use fbgforge::solvers::SolverKind;
    let e = |e: anyhow::Error| err(py, e);
    let mut settings = PlaceSettings {
        objective: PlaceObjective::parse(objective).map_err(e)?,
        method: Method::from_name(method).map_err(|x| input(py, x.to_string()))?,
        vary_fibers,
        solvers: SolverKind::parse(solver).map_err(e)?,
        agreement_samples,
        ..PlaceSettings::default()
    };
    settings.run.max_iters = max_iters;
    settings.run.swarm_iters = max_iters;
    let req = PlaceRequest {
        design: design_path,
        settings,
        out,
        report_dir,
    };
    let mut folder = fbgforge::report::place::PlaceReportFolder::new(errors::py_words);
    let run = py
        .detach(|| run_placement(&req, &fbgforge::progress::Quiet, &mut folder))
        .map_err(|x| err(py, x))?;
    optimised(
        py,
        &run.outcome,
        &run.outcome.design,
        &run.design_path,
        &run.report_dir,
    )
}

/// Write a synthetic log set (module pulses, or an array calibration run).
#[pyfunction]
#[pyo3(signature = (design, out_dir, format, settings, style))]
fn synth_log<'py>(
    py: Python<'py>,
    design: &PyDesign,
    out_dir: PathBuf,
    format: &str,
    settings: &Bound<'py, PyDict>,
    style: &Bound<'py, PyDict>,
) -> PyResult<Bound<'py, PyAny>> {
    use fbgforge::synth::files::{write_synth_log, SynthLogRequest, SynthRun};
    use fbgforge::synth::module_log::{train, PulseShape, SynthConfig, TrainSettings};
    let get = |k: &str| -> PyResult<Bound<'py, PyAny>> {
        settings
            .get_item(k)?
            .ok_or_else(|| pyo3::exceptions::PyKeyError::new_err(k.to_string()))
    };
    let f = |k: &str| -> PyResult<f64> { get(k)?.extract() };
    let format = parse_format(py, Some(format))?.expect("a format was named");
    let style = LogStyle {
        decimal_comma: style
            .get_item("decimal_comma")?
            .map_or(Ok(false), |v| v.extract())?,
        bom: style.get_item("bom")?.map_or(Ok(false), |v| v.extract())?,
        metadata_lines: style
            .get_item("metadata_lines")?
            .map_or(Ok(45), |v| v.extract())?,
        twelve_hour: style
            .get_item("twelve_hour")?
            .map_or(Ok(false), |v| v.extract())?,
        ..Default::default()
    };
    let schedule: Option<PathBuf> = get("schedule")?.extract()?;
    let seed: u64 = get("seed")?.extract()?;
    let run = match schedule {
        Some(schedule) => {
            must_exist(py, &schedule, "schedule")?;
            SynthRun::ArrayCalibration {
                schedule,
                sample_rate_hz: f("rate_hz")?,
                noise_pm: f("noise_pm")?,
                drift_pm_per_s: f("drift_pm_per_s")?,
                seed,
            }
        }
        None => {
            let pulse_s = f("pulse_s")?;
            let rest_s = f("rest_s")?;
            let ramp_s = f("ramp_s")?;
            let shape = match get("shape")?.extract::<String>()?.as_str() {
                "haversine" => PulseShape::Haversine,
                "trapezoid" => PulseShape::Trapezoid { ramp_s },
                "staircase" => PulseShape::Staircase {
                    steps: get("steps")?.extract()?,
                    ramp_s,
                },
                "sine" => PulseShape::Sine {
                    cycles: get("cycles")?.extract()?,
                },
                other => {
                    return Err(input(
                        py,
                        format!("shape `{other}`: expected \"haversine\", \"trapezoid\", \"staircase\" or \"sine\""),
                    ))
                }
            };
            let core: Option<String> = get("core")?.extract()?;
            let grating_sensitivity_pm_per_n = if get("from_model")?.extract::<bool>()? {
                let case = match get("case")?.extract::<Option<String>>()?.as_deref() {
                    None => None,
                    Some("I" | "i" | "1") => Some(fbgforge::model::LoadCase::I),
                    Some("II" | "ii" | "2") => Some(fbgforge::model::LoadCase::II),
                    Some(other) => {
                        return Err(input(
                            py,
                            format!("case `{other}`: expected \"I\" or \"II\""),
                        ))
                    }
                };
                let source = fbgforge::synth::from_model::ModelSource {
                    core: core.clone(),
                    case,
                    insert: get("insert")?.extract()?,
                };
                let d = &design.design;
                py.detach(|| fbgforge::synth::from_model::model_sensitivities(d, &source))
                    .map_err(|e| err(py, e))?
            } else {
                Vec::new()
            };
            let mut peaks_n: Vec<f64> = get("pulses_n")?.extract()?;
            if !grating_sensitivity_pm_per_n.is_empty()
                && peaks_n == [10.0, 20.0, 30.0, 40.0, 50.0, 25.0]
            {
                // The default protocol scaled so that the model's shifts stay in their
                // windows, as `synth-log --from-model` does.
                let top = fbgforge::synth::from_model::largest_force_n(
                    &design.design,
                    &grating_sensitivity_pm_per_n,
                );
                peaks_n.iter_mut().for_each(|p| *p = *p / 50.0 * top);
            }
            let (pulses, duration_s) = train(&TrainSettings {
                peaks_n,
                pulse_s,
                rest_s,
                lead_s: 5.0,
                shape,
            })
            .map_err(|e| err(py, e))?;
            SynthRun::Module(SynthConfig {
                core,
                grating_sensitivity_pm_per_n,
                sensitivity_pm_per_n: f("k_pm_per_n")?,
                sample_rate_hz: f("rate_hz")?,
                force_rate_hz: f("force_rate_hz")?,
                pulses,
                duration_s,
                tau_s: f("tau_s")?,
                instant_fraction: f("instant_fraction")?,
                transport_delay_s: f("delay_s")?,
                force_start_s: f("force_start_s")?,
                noise_pm: f("noise_pm")?,
                force_noise_n: f("force_noise_n")?,
                drift_pm_per_s: f("drift_pm_per_s")?,
                temperature_ramp_k_per_s: f("temperature_ramp_k_per_s")?,
                dropout_fraction: f("dropout")?,
                seed,
                ..Default::default()
            })
        }
    };
    let req = SynthLogRequest {
        format,
        out_dir,
        style,
        run,
    };
    let d = &design.design;
    let files = py
        .detach(|| write_synth_log(d, &req))
        .map_err(|e| err(py, e))?;
    to_py(py, &files)
}

/// Calibrate an array from a loading run: the measured matrix with its scatter, faults,
/// Table 2 of every staircase, additivity, the verdicts against the prediction, and
/// optionally the sheet fit; charts beside `out` when `charts`.
#[pyfunction]
#[pyo3(signature = (design, log, schedule, format, date_order, window_nm, out, resolution_pm, model_tolerance, fit_sheet, charts))]
#[allow(clippy::too_many_arguments)]
fn calibrate_array<'py>(
    py: Python<'py>,
    design: &PyDesign,
    log: PathBuf,
    schedule: PathBuf,
    format: Option<&str>,
    date_order: Option<&str>,
    window_nm: Option<f64>,
    out: Option<PathBuf>,
    resolution_pm: Option<f64>,
    model_tolerance: Option<f64>,
    fit_sheet: bool,
    charts: bool,
) -> PyResult<Bound<'py, PyAny>> {
    must_exist(py, &log, "log")?;
    must_exist(py, &schedule, "schedule")?;
    let req = CalibrateRequest {
        design_file: None,
        log,
        schedule,
        read: read_options(py, format, date_order)?,
        window_half_width_nm: window_nm,
        resolution_pm,
        model_tolerance,
        out: out.clone(),
        fit_sheet,
    };
    let d = &design.design;
    let o = py
        .detach(|| match (&out, charts) {
            (Some(o), true) => {
                let mut c = fbgforge::report::calibrate::Charts::beside(o);
                fbgforge::array::calibrate::run(d, &req, &mut c).map(|x| (x, c.written))
            }
            _ => fbgforge::array::calibrate::run(d, &req, &mut ()).map(|x| (x, Vec::new())),
        })
        .map_err(|e| err(py, e))?;
    let (outcome, written) = o;
    let doc = to_py_words(py, &outcome)?.cast_into::<PyDict>()?;
    let ulimit = d.array.as_ref().map(|a| a.ulimit_g);
    let m = matrix_dict(py, &outcome.calibration.matrix(), ulimit)?;
    let sd = matrix_dict(py, &outcome.calibration.matrix_sd(), ulimit)?;
    doc.set_item("sensitivity_pm_per_g", m.get_item("sensitivity_pm_per_g")?)?;
    doc.set_item("sd_pm_per_g", sd.get_item("sensitivity_pm_per_g")?)?;
    doc.set_item("ulimit_g", ulimit)?;
    doc.set_item("charts", written)?;
    Ok(doc.into_any())
}

/// The compiled part of the `fbgforge` package.
#[pymodule]
fn _fbgforge(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<PyDesign>()?;
    m.add_class::<live::LiveStream>()?;
    m.add_class::<reconstructor::Reconstructor>()?;
    m.add_function(wrap_pyfunction!(predict, m)?)?;
    m.add_function(wrap_pyfunction!(build, m)?)?;
    m.add_function(wrap_pyfunction!(read_log, m)?)?;
    m.add_function(wrap_pyfunction!(verify, m)?)?;
    m.add_function(wrap_pyfunction!(sensing_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(shift_columns, m)?)?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    m.add_function(wrap_pyfunction!(reconstruct, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(optimize, m)?)?;
    m.add_function(wrap_pyfunction!(place, m)?)?;
    m.add_function(wrap_pyfunction!(synth_log, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate_array, m)?)?;
    m.add_function(wrap_pyfunction!(live::live_stream, m)?)?;
    m.add_function(wrap_pyfunction!(spectra::read_spectra, m)?)?;
    m.add_function(wrap_pyfunction!(spectra::find_peaks, m)?)?;
    m.add_function(wrap_pyfunction!(spectra::grating_spectrum, m)?)?;
    Ok(())
}
