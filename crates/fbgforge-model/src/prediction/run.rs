//! The model's use cases as the front ends call them: [`predict_into`] (every grating
//! of a design by the policy), [`sweep`] (one parameter over a range) and
//! [`paper_figures`] (the paper's parametric figures). Each checks its request once,
//! here, and hands what it found to a sink ([`PredictSink`], [`SweepSink`]): the
//! terminal tables, the JSON, the sweep's chart and CSV and the paper figures' files
//! are implementations in `fbgforge-report`; a caller that wants only the returned
//! value passes `&mut ()`.

use super::{
    check_paper_statements, predict, sweep_predictor_with_band, FidelityChoice, ModelledPrediction,
    PaperStatements, PredictionRequest,
};
use crate::fem::{FemOptions, GeometryCache};
use crate::model::sweep::{
    self, paper_trend, run_paper_figure_with, PaperFigure, SweepParam, SweepResult, TrendVerdict,
    PAPER_FIGURES, PAPER_FORCE_N,
};
use crate::model::LoadCase;
use crate::progress::Progress;
use crate::spec::Design;
use anyhow::Result;

/// Why a use case stopped, so that each front end can say where in its own words: the
/// request's numbers, the request against the design, the model, or the sink.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A number of the request is out of range (no design needed to tell).
    #[error(transparent)]
    Request(anyhow::Error),
    /// The request does not fit the design (e.g. Case I without an insert).
    #[error(transparent)]
    Design(anyhow::Error),
    /// The model failed on the design.
    #[error(transparent)]
    Model(anyhow::Error),
    /// The sink could not take the result (e.g. a file could not be written).
    #[error(transparent)]
    Output(anyhow::Error),
}

impl RunError {
    /// The error itself, whatever stopped the use case.
    pub fn into_inner(self) -> anyhow::Error {
        match self {
            RunError::Request(e)
            | RunError::Design(e)
            | RunError::Model(e)
            | RunError::Output(e) => e,
        }
    }
}

/// "Case I needs a solid insert" when `case` is Case I and the module lists none
/// (`where_` says where the design would list them).
fn check_case_insert(design: &Design, case: Option<LoadCase>, where_: &str) -> Result<()> {
    if case == Some(LoadCase::I) && design.module.as_ref().is_some_and(|m| m.inserts.is_empty()) {
        anyhow::bail!("Case I needs a solid insert, but the design lists none{where_}");
    }
    Ok(())
}

/// `value` must be a finite number (`field`: the request field, `unit`: in words).
fn check_finite(field: &str, value: f64, unit: &str) -> Result<()> {
    anyhow::ensure!(
        value.is_finite(),
        "{field} must be a finite number of {unit}, got {value}"
    );
    Ok(())
}

impl PredictionRequest {
    /// Check the request's numbers (no design needed).
    pub fn check(&self) -> Result<()> {
        check_finite("PredictionRequest.force_n", self.force_n, "newtons")?;
        check_finite("PredictionRequest.delta_t_k", self.delta_t_k, "kelvin")
    }

    /// Check the request against `design`: Case I needs an insert.
    pub(crate) fn check_design(&self, design: &Design) -> Result<()> {
        check_case_insert(design, self.case, " under [[module.inserts]]")
    }

    /// Whether the rows carry their band: asked for, and some row is an FE row (the
    /// closed form runs no FE solve, so it has no band).
    pub fn with_band(&self) -> bool {
        self.band && self.fidelity != FidelityChoice::ClosedForm
    }
}

/// A design's prediction as its sinks see it.
#[derive(Debug, Clone, Copy)]
pub struct Predicted<'a> {
    /// The design.
    pub design: &'a Design,
    /// What was asked.
    pub request: &'a PredictionRequest,
    /// One row per strain grating and configuration, in the policy's order.
    pub rows: &'a [ModelledPrediction],
    /// The paper's Case I statements checked on these rows (`None` when the design
    /// has no Case I row to check them on).
    pub statements: Option<&'a PaperStatements>,
}

/// Where a prediction goes; every method has a no-op default.
pub trait PredictSink {
    /// The rows, once predicted.
    fn predicted(&mut self, _p: &Predicted) -> Result<()> {
        Ok(())
    }
}

impl PredictSink for () {}

impl<S: PredictSink + ?Sized> PredictSink for &mut S {
    fn predicted(&mut self, p: &Predicted) -> Result<()> {
        (**self).predicted(p)
    }
}

/// Predict every strain grating of `design` with the model policy ([`predict`]), check
/// the paper's Case I statements on the rows, and hand both to `sink`; returns them.
///
/// ```
/// use fbgforge_model::model::LoadCase;
/// use fbgforge_model::prediction::{predict_into, FidelityChoice, PredictionRequest};
///
/// let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
/// let design = fbgforge_core::design::load(&root.join("designs/clip-on-34mm.toml"))?;
/// let request = PredictionRequest {
///     force_n: 10.0,
///     case: Some(LoadCase::II),
///     fidelity: FidelityChoice::ClosedForm,
///     ..PredictionRequest::default()
/// };
/// let (rows, _) = predict_into(&design, &request, &mut ())?;
/// // Case II loads the core in compression: every strain grating shifts blue, and the
/// // shift at 10 N is ten times K.
/// assert!(!rows.is_empty());
/// for r in &rows {
///     let p = &r.detail.prediction;
///     assert!(p.sensitivity_pm_per_n < 0.0);
///     assert!((p.shift_pm - 10.0 * p.sensitivity_pm_per_n).abs() < 1e-9);
/// }
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn predict_into(
    design: &Design,
    request: &PredictionRequest,
    sink: &mut dyn PredictSink,
) -> Result<(Vec<ModelledPrediction>, Option<PaperStatements>), RunError> {
    request.check().map_err(RunError::Request)?;
    request.check_design(design).map_err(RunError::Design)?;
    let rows = predict(design, request).map_err(RunError::Model)?;
    let statements = check_paper_statements(design, &rows);
    sink.predicted(&Predicted {
        design,
        request,
        rows: &rows,
        statements: statements.as_ref(),
    })
    .map_err(RunError::Output)?;
    Ok((rows, statements))
}

/// How a sweep's values are spaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spacing {
    /// Even ratios over a range wider than [`AUTO_LOG_RATIO`] ×, even steps otherwise.
    Auto,
    /// Even ratios between neighbours (a log axis).
    Log,
    /// Even steps (a linear axis), however wide the range.
    Linear,
}

/// A range wider than this factor is swept in log steps under [`Spacing::Auto`].
pub const AUTO_LOG_RATIO: f64 = 20.0;

/// What [`sweep`] computes.
#[derive(Debug, Clone)]
pub struct SweepRequest {
    /// The parameter swept (`model::sweep::find_param`).
    pub param: &'static SweepParam,
    /// First value of the range.
    pub start: f64,
    /// Last value of the range (above the first).
    pub stop: f64,
    /// Number of values, both ends included.
    pub steps: usize,
    /// How the values are spaced.
    pub spacing: Spacing,
    /// These values instead of the range, as given (`start`, `stop`, `steps` and
    /// `spacing` are then not used).
    pub values: Option<Vec<f64>>,
    /// Apex force, N.
    pub force_n: f64,
    /// One loading case only.
    pub case: Option<LoadCase>,
    /// Which model answers at each step.
    pub fidelity: FidelityChoice,
    /// Each step's band (two more FE solves per configuration and step).
    pub band: bool,
    /// Mesh and solver of the FE solves.
    pub fem_options: FemOptions,
    /// The FE structures, kept from step to step (the sweep's own by default).
    pub cache: GeometryCache,
}

/// `steps` values from `from` to `to` with equal ratios between neighbours.
fn log_values(from: f64, to: f64, steps: usize) -> Vec<f64> {
    let r = (to / from).ln();
    (0..steps)
        .map(|i| {
            if i + 1 == steps {
                to
            } else {
                from * (r * i as f64 / (steps - 1) as f64).exp()
            }
        })
        .collect()
}

impl SweepRequest {
    /// The values the sweep takes and whether they are spaced in log, checked (the
    /// force, and the range and steps).
    pub fn values(&self) -> Result<(Vec<f64>, bool)> {
        check_finite("SweepRequest.force_n", self.force_n, "newtons")?;
        if let Some(v) = &self.values {
            return Ok((v.clone(), false));
        }
        let (start, stop, steps) = (self.start, self.stop, self.steps);
        let linear = sweep::sweep_values(self.param, start, stop, steps)?;
        let log = match self.spacing {
            Spacing::Log => true,
            Spacing::Linear => false,
            Spacing::Auto => start > 0.0 && stop / start > AUTO_LOG_RATIO,
        };
        Ok(if log {
            (log_values(start, stop, steps), true)
        } else {
            (linear, false)
        })
    }

    /// Check the request against `design`: Case I needs an insert.
    pub(crate) fn check_design(&self, design: &Design) -> Result<()> {
        check_case_insert(design, self.case, "")
    }
}

/// A finished sweep as its sinks see it.
#[derive(Debug, Clone, Copy)]
pub struct Swept<'a> {
    /// The design swept.
    pub design: &'a Design,
    /// What was asked.
    pub request: &'a SweepRequest,
    /// Whether the values are spaced in log (a log x axis).
    pub log: bool,
    /// Every series.
    pub result: &'a SweepResult,
}

/// One curve of a paper figure judged against the paper's stated trend.
#[derive(Debug, Clone, PartialEq)]
pub struct Trend {
    /// The model behind the curve, in words.
    pub model: String,
    /// The verdict.
    pub verdict: TrendVerdict,
}

/// One of the paper's figures, swept.
#[derive(Debug, Clone, Copy)]
pub struct FigureSwept<'a> {
    /// The figure.
    pub figure: &'a PaperFigure,
    /// What was asked.
    pub request: &'a PaperFiguresRequest,
    /// Its series.
    pub result: &'a SweepResult,
    /// Which of the paper's trends its curves reproduce: the nominal, and the bounding
    /// readings when the band was computed.
    pub trends: &'a [Trend],
}

/// Where a sweep (or the paper's figures) goes; every method has a no-op default.
pub trait SweepSink {
    /// A sweep, once done.
    fn swept(&mut self, _s: &Swept) -> Result<()> {
        Ok(())
    }
    /// Before the first paper figure.
    fn figures_begin(&mut self, _r: &PaperFiguresRequest) -> Result<()> {
        Ok(())
    }
    /// Each paper figure, once swept.
    fn figure(&mut self, _f: &FigureSwept) -> Result<()> {
        Ok(())
    }
    /// After the last paper figure, with every figure's trends in order.
    fn figures_end(&mut self, _design: &Design, _r: &PaperFiguresRequest) -> Result<()> {
        Ok(())
    }
}

impl SweepSink for () {}

impl<S: SweepSink + ?Sized> SweepSink for &mut S {
    fn swept(&mut self, s: &Swept) -> Result<()> {
        (**self).swept(s)
    }
    fn figures_begin(&mut self, r: &PaperFiguresRequest) -> Result<()> {
        (**self).figures_begin(r)
    }
    fn figure(&mut self, f: &FigureSwept) -> Result<()> {
        (**self).figure(f)
    }
    fn figures_end(&mut self, design: &Design, r: &PaperFiguresRequest) -> Result<()> {
        (**self).figures_end(design, r)
    }
}

/// Sweep one parameter of `design` as `request` says, each step answered by the model
/// the request picks, and hand the series to `sink`; `progress` hears one step per
/// value.
///
/// ```
/// use fbgforge_model::model::{sweep::find_param, LoadCase};
/// use fbgforge_model::prediction::{sweep, FidelityChoice, Spacing, SweepRequest};
///
/// let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
/// let design = fbgforge_core::design::load(&root.join("designs/clip-on-34mm.toml"))?;
/// let request = SweepRequest {
///     param: find_param("e1_mpa")?,
///     start: 1.0,
///     stop: 100.0,
///     steps: 3,
///     spacing: Spacing::Auto,
///     values: None,
///     force_n: 50.0,
///     case: Some(LoadCase::II),
///     fidelity: FidelityChoice::ClosedForm,
///     band: false,
///     fem_options: Default::default(),
///     cache: Default::default(),
/// };
/// // A range of 100× is spaced in log: 1, 10, 100 MPa.
/// assert_eq!(request.values()?.1, true);
/// let r = sweep(&design, &request, &fbgforge_core::progress::Quiet, &mut ())
///     .map_err(|e| e.into_inner())?;
/// // Case II: |Δλ| falls as the core stiffens (more of the force goes through it).
/// for s in &r.series {
///     assert_eq!(s.x.len(), 3);
///     assert!(s.shift_pm.windows(2).all(|w| w[1].abs() < w[0].abs()));
/// }
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn sweep(
    design: &Design,
    request: &SweepRequest,
    progress: &dyn Progress,
    sink: &mut dyn SweepSink,
) -> Result<SweepResult, RunError> {
    let (values, log) = request.values().map_err(RunError::Request)?;
    request.check_design(design).map_err(RunError::Design)?;
    let predictor = sweep_predictor_with_band(
        request.fidelity,
        request.case,
        request.fem_options,
        request.band,
        request.cache.clone(),
    );
    let result = sweep::run_with(
        design,
        request.param,
        &values,
        request.force_n,
        request.case,
        predictor.as_deref(),
        progress,
    )
    .map_err(|e| RunError::Model(e.into()))?;
    sink.swept(&Swept {
        design,
        request,
        log,
        result: &result,
    })
    .map_err(RunError::Output)?;
    Ok(result)
}

/// What [`paper_figures`] computes.
#[derive(Debug, Clone)]
pub struct PaperFiguresRequest {
    /// Values per figure (at least 2).
    pub steps: usize,
    /// Which model answers at each step.
    pub fidelity: FidelityChoice,
    /// Each step's band and its bounding readings.
    pub band: bool,
    /// Mesh and solver of the FE solves.
    pub fem_options: FemOptions,
    /// The FE structures, kept from figure to figure.
    pub cache: GeometryCache,
}

/// The model of a figure's nominal curve, in words.
fn nominal_label(f: FidelityChoice, case: LoadCase) -> &'static str {
    match (f, case) {
        (FidelityChoice::ClosedForm, _) => "closed form",
        (FidelityChoice::Fem, _) => "FE, design contact",
        (FidelityChoice::Auto, LoadCase::I) => "policy: FE, design contact (default)",
        (FidelityChoice::Auto, LoadCase::II) => "policy: closed form",
    }
}

/// Which of the paper's trends the first series of a figure reproduces: its nominal
/// curve, and the bounding readings when the band was computed.
fn figure_trends(fig: &PaperFigure, fidelity: FidelityChoice, r: &SweepResult) -> Vec<Trend> {
    let first = &r.series[0];
    let mut curves: Vec<(String, Vec<f64>)> = vec![(
        nominal_label(fidelity, fig.case).to_string(),
        first.shift_pm.clone(),
    )];
    if first.readings_pm_per_n.len() == first.x.len() {
        for (k, name) in [
            (0, "FE, pillars bonded (band's reading)"),
            (
                1,
                "FE, cylinders sliding, domes on the apex patch (band's reading)",
            ),
        ] {
            curves.push((
                name.to_string(),
                first
                    .readings_pm_per_n
                    .iter()
                    .map(|r| r[k] * PAPER_FORCE_N)
                    .collect(),
            ));
        }
    }
    curves
        .into_iter()
        .map(|(model, y)| Trend {
            verdict: paper_trend(fig, &first.x, &y),
            model,
        })
        .collect()
}

/// Sweep every parametric figure of the paper (Figs. 9a–c, 11a–b) on `design` and hand
/// each, with the trends its curves reproduce, to `sink`; `progress` hears each
/// figure's steps.
pub fn paper_figures(
    design: &Design,
    request: &PaperFiguresRequest,
    progress: &dyn Progress,
    sink: &mut dyn SweepSink,
) -> Result<(), RunError> {
    sink.figures_begin(request).map_err(RunError::Output)?;
    let steps = request.steps.max(2);
    for fig in PAPER_FIGURES {
        let predictor = sweep_predictor_with_band(
            request.fidelity,
            Some(fig.case),
            request.fem_options,
            request.band,
            request.cache.clone(),
        );
        let r = run_paper_figure_with(design, fig, steps, predictor.as_deref(), progress).map_err(
            |e| RunError::Model(anyhow::Error::new(e).context(format!("paper figure {}", fig.id))),
        )?;
        let trends = figure_trends(fig, request.fidelity, &r);
        sink.figure(&FigureSwept {
            figure: fig,
            request,
            result: &r,
            trends: &trends,
        })
        .map_err(RunError::Output)?;
    }
    sink.figures_end(design, request).map_err(RunError::Output)
}
