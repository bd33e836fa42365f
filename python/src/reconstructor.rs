//! Python's `Reconstructor`: the problem stated and the method picked and built
//! once ([`fbgforge::array::reconstruct::prepare`]), then called per frame or per
//! batch. Per-frame calls skip everything a one-shot `reconstruct` repeats (matrix
//! conversion, the default choice's probing, the method's set-up), so a frame
//! costs what it costs inside a batch plus the call.

use crate::convert::{columns, to_py, value};
use crate::errors::{self, input};
use fbgforge::array::methods::{self as array_methods, Method, ReadingSettings};
use fbgforge::array::problem::{default_min_load_g, SensingProblem, Uncertainty};
use fbgforge::array::reconstruct::{prepare, MethodRequest, Setup};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A reconstructor for one sensing matrix: built once, called per frame
/// (`frame`) or per batch (`frames`); the same answers either way.
#[pyclass(module = "fbgforge._fbgforge")]
pub struct Reconstructor {
    setup: Setup,
    /// Rows of the full matrix the method was built on (the gratings kept).
    kept: Vec<usize>,
    gratings: usize,
    cells: usize,
    budget_us: Option<f64>,
}

/// The prior a frame is read with and the method asked for, from the keywords that
/// the one-shot `reconstruct` and the `Reconstructor` share.
pub(crate) fn reading_request(
    py: Python<'_>,
    max_loads: Option<usize>,
    resolution_pm: f64,
    method: Option<&str>,
    penalty: Option<f64>,
    budget_us: f64,
) -> PyResult<(ReadingSettings, MethodRequest)> {
    let prior = ReadingSettings {
        max_loads: max_loads.unwrap_or(array_methods::DEFAULT_MAX_LOADS),
        resolution_pm,
    };
    let request = match method {
        Some(name) => MethodRequest::Named {
            method: Method::from_name(name).map_err(|e| input(py, e.to_string()))?,
            penalty,
        },
        None => MethodRequest::Default { budget_us },
    };
    Ok((prior, request))
}

/// The problem as stated from Python: bounds, uncertainty, common mode, gratings kept.
#[allow(clippy::too_many_arguments)]
pub(crate) fn stated_problem(
    py: Python<'_>,
    matrix: nalgebra::DMatrix<f64>,
    ulimit_g: f64,
    min_load_g: Option<f64>,
    normalise: bool,
    resolution_pm: f64,
    matrix_sd_pct: Option<f64>,
    common_mode: bool,
    significance: Option<f64>,
) -> PyResult<SensingProblem> {
    let (m, n) = matrix.shape();
    let words =
        |e: fbgforge::array::ArrayError| input(py, errors::python_words(&e.to_string(), &[]));
    let mut uncertainty = Uncertainty::paper(m, n, resolution_pm);
    if let Some(pct) = matrix_sd_pct {
        if !(pct.is_finite() && pct >= 0.0) {
            return Err(input(
                py,
                format!("matrix_sd_pct must be a percentage ≥ 0, got {pct}"),
            ));
        }
        uncertainty.matrix_sd_pm_per_g = matrix.map(|v| v.abs() * pct / 100.0);
    }
    let mut p = SensingProblem::new(matrix, ulimit_g, normalise)
        .and_then(|p| p.with_min_load_g(min_load_g.unwrap_or(default_min_load_g(ulimit_g))))
        .and_then(|p| p.with_uncertainty(uncertainty))
        .map_err(words)?;
    if let Some(a) = significance {
        p = p.with_significance(a).map_err(words)?;
    }
    if common_mode {
        p = p.with_common_mode(&vec![1.0; m]).map_err(words)?;
    }
    Ok(p)
}

#[pymethods]
impl Reconstructor {
    /// Build the reconstructor: `a` gratings × cells (pm/g), `keep` the indices of
    /// the gratings to use (None: all), the rest as `reconstruct`.
    #[new]
    #[pyo3(signature = (a, method, ulimit_g, min_load_g, penalty, max_loads, resolution_pm,
        budget_us, normalise, common_mode, matrix_sd_pct, keep, significance))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        a: PyReadonlyArray2<'_, f64>,
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
        keep: Option<Vec<usize>>,
        significance: Option<f64>,
    ) -> PyResult<Self> {
        if penalty.is_some() && method.is_none() {
            return Err(input(
                py,
                "penalty is a setting of a named method: give method= as well (the default choice tunes its own)",
            ));
        }
        let av = a.as_array();
        let (m, n) = av.dim();
        let matrix = nalgebra::DMatrix::from_fn(m, n, |i, j| av[(i, j)]);
        let full = stated_problem(
            py,
            matrix,
            ulimit_g,
            min_load_g,
            normalise,
            resolution_pm,
            matrix_sd_pct,
            common_mode,
            significance,
        )?;
        let kept: Vec<usize> = keep.unwrap_or_else(|| (0..m).collect());
        if kept.is_empty() || kept.iter().any(|&i| i >= m) {
            return Err(input(
                py,
                format!("keep must name gratings 0 to {} (at least one)", m - 1),
            ));
        }
        let dropped: Vec<usize> = (0..m).filter(|i| !kept.contains(i)).collect();
        let words =
            |e: fbgforge::array::ArrayError| input(py, errors::python_words(&e.to_string(), &[]));
        let problem = if dropped.is_empty() {
            full
        } else {
            full.without_gratings(&dropped).map_err(words)?
        };
        let (prior, request) =
            reading_request(py, max_loads, resolution_pm, method, penalty, budget_us)?;
        let setup = py
            .detach(|| prepare(&problem, &prior, &request, None))
            .map_err(words)?;
        Ok(Reconstructor {
            setup,
            kept,
            gratings: m,
            cells: n,
            budget_us: method.is_none().then_some(budget_us),
        })
    }

    /// One frame (gratings, matrix order, pm): (loads_g, flags, residual_pm, certified).
    fn frame<'py>(
        &self,
        py: Python<'py>,
        y: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<(Bound<'py, PyAny>, Vec<&'static str>, f64, bool)> {
        let y = y.as_slice().map_err(|e| input(py, e.to_string()))?;
        if y.len() != self.gratings {
            return Err(input(
                py,
                format!(
                    "a frame holds {} shifts but the sensing matrix has {} gratings",
                    y.len(),
                    self.gratings
                ),
            ));
        }
        let rows: Vec<f64> = self.kept.iter().map(|&i| y[i]).collect();
        let r = self.setup.reconstruct(&rows);
        let loads = Array1::from(r.loads_g).into_pyarray(py).into_any();
        Ok((loads, r.flags.words(), r.residual_pm, r.certified))
    }

    /// Frames × gratings (matrix order, pm): (loads frames × cells, per-frame columns).
    fn frames<'py>(
        &self,
        py: Python<'py>,
        y: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let yv = y.as_array();
        if yv.ncols() != self.gratings {
            return Err(input(
                py,
                format!(
                    "a frame holds {} shifts but the sensing matrix has {} gratings",
                    yv.ncols(),
                    self.gratings
                ),
            ));
        }
        let frames: Vec<Vec<f64>> = yv
            .outer_iter()
            .map(|r| self.kept.iter().map(|&i| r[i]).collect())
            .collect();
        let results = py.detach(|| {
            self.setup
                .reconstruct_frames(&frames, &fbgforge::progress::Quiet)
        });
        let n = self.cells;
        let loads = Array2::from_shape_fn((results.len(), n), |(i, j)| results[i].loads_g[j]);
        let records = results.iter().map(value).collect::<PyResult<Vec<_>>>()?;
        let per_frame = columns(py, &records, &["loads_g"])?;
        Ok((loads.into_pyarray(py).into_any(), per_frame.into_any()))
    }

    /// The method, why, its penalty, the default choice's candidates and the budget.
    fn setup<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("method", self.setup.method.name())?;
        d.set_item("reason", &self.setup.reason)?;
        d.set_item("penalty", self.setup.penalty())?;
        d.set_item("max_loads", self.setup.prior.max_loads)?;
        d.set_item("resolution_pm", self.setup.prior.resolution_pm)?;
        d.set_item("setup_ms", self.setup.setup_ms)?;
        d.set_item("budget_us", self.budget_us)?;
        d.set_item("kept", self.kept.clone())?;
        d.set_item("choice", to_py(py, &self.setup.choice)?)?;
        Ok(d)
    }
}
