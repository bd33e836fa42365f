//! Parametric sweeps: one spec parameter over a range, the predicted shift of every
//! grating and configuration at a force (the paper's Figs. 8–11).
//!
//! Parameters are named in the field's words (`e1_mpa`, `cap_wall_mm`, ...). Each
//! step edits a copy of the design, re-validates it and re-derives the profile, so a
//! swept dimension moves the prediction exactly as it would move the printed solid.

use super::{predict_with, GratingPrediction, LoadCase, PredictOptions};
use crate::progress::{Progress, Quiet};
use crate::spec::{Design, SpecError};
use serde::Serialize;

/// A sweepable parameter: its names, unit and how it edits a design.
pub struct SweepParam {
    /// Canonical name.
    pub name: &'static str,
    /// Other accepted names.
    pub aliases: &'static [&'static str],
    /// What it is, with unit (axis label).
    pub label: &'static str,
    /// True for a modulus (must stay strictly positive).
    pub is_modulus: bool,
    apply: fn(&mut Design, f64),
}

impl std::fmt::Debug for SweepParam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SweepParam")
            .field("name", &self.name)
            .field("label", &self.label)
            .finish_non_exhaustive()
    }
}

fn set_core_moduli(d: &mut Design, v: f64) {
    let keys: Vec<String> = d
        .module
        .iter()
        .flat_map(|m| m.cores.iter().map(|c| c.material.clone()))
        .collect();
    for k in keys {
        if let Some(mat) = d.materials.get_mut(&k) {
            mat.youngs_modulus_mpa = v;
        }
    }
}
fn set_insert_moduli(d: &mut Design, v: f64) {
    let keys: Vec<String> = d
        .module
        .iter()
        .flat_map(|m| m.inserts.iter().map(|c| c.material.clone()))
        .collect();
    for k in keys {
        if let Some(mat) = d.materials.get_mut(&k) {
            mat.youngs_modulus_mpa = v;
        }
    }
}
/// Set a material property of every material the chosen parts use.
fn set_materials(d: &mut Design, keys: Vec<String>, f: impl Fn(&mut crate::spec::Material)) {
    for k in keys {
        if let Some(mat) = d.materials.get_mut(&k) {
            f(mat);
        }
    }
}
fn core_keys(d: &Design) -> Vec<String> {
    d.module
        .iter()
        .flat_map(|m| m.cores.iter().map(|c| c.material.clone()))
        .collect()
}
fn insert_keys(d: &Design) -> Vec<String> {
    d.module
        .iter()
        .flat_map(|m| m.inserts.iter().map(|c| c.material.clone()))
        .collect()
}
fn cap_keys(d: &Design) -> Vec<String> {
    d.module.iter().map(|m| m.cap_material.clone()).collect()
}
fn set_cap_modulus(d: &mut Design, v: f64) {
    if let Some(k) = d.module.as_ref().map(|m| m.cap_material.clone()) {
        if let Some(mat) = d.materials.get_mut(&k) {
            mat.youngs_modulus_mpa = v;
        }
    }
}
fn with_module(d: &mut Design, f: impl FnOnce(&mut crate::spec::Module)) {
    if let Some(m) = d.module.as_mut() {
        f(m)
    }
}

/// Every parameter `sweep` accepts.
pub const PARAMS: &[SweepParam] = &[
    SweepParam {
        name: "e1_mpa",
        aliases: &["core_modulus_mpa"],
        label: "E1, core modulus (MPa)",
        is_modulus: true,
        apply: set_core_moduli,
    },
    SweepParam {
        name: "e2_mpa",
        aliases: &["cap_modulus_mpa"],
        label: "E2, cap modulus (MPa)",
        is_modulus: true,
        apply: set_cap_modulus,
    },
    SweepParam {
        name: "es_mpa",
        aliases: &["insert_modulus_mpa"],
        label: "Es, insert modulus (MPa)",
        is_modulus: true,
        apply: set_insert_moduli,
    },
    SweepParam {
        name: "outer_diameter_mm",
        aliases: &[],
        label: "outer diameter (mm)",
        is_modulus: false,
        apply: |d, v| with_module(d, |m| m.outer_diameter_mm = v),
    },
    SweepParam {
        name: "overall_height_mm",
        aliases: &[],
        label: "overall height (mm)",
        is_modulus: false,
        apply: |d, v| with_module(d, |m| m.overall_height_mm = v),
    },
    SweepParam {
        name: "dome_height_mm",
        aliases: &[],
        label: "dome height (mm)",
        is_modulus: false,
        apply: |d, v| with_module(d, |m| m.dome_height_mm = v),
    },
    SweepParam {
        name: "cap_wall_mm",
        aliases: &[],
        label: "cap wall (mm)",
        is_modulus: false,
        apply: |d, v| with_module(d, |m| m.cap_wall_mm = v),
    },
    SweepParam {
        name: "core_wall_mm",
        aliases: &[],
        label: "core wall (mm)",
        is_modulus: false,
        apply: |d, v| with_module(d, |m| m.core_wall_mm = v),
    },
    SweepParam {
        name: "apex_flat_diameter_mm",
        aliases: &[],
        label: "apex flat diameter (mm)",
        is_modulus: false,
        apply: |d, v| with_module(d, |m| m.apex_flat_diameter_mm = v),
    },
    SweepParam {
        name: "pillar_width_mm",
        aliases: &[],
        label: "pillar width (mm)",
        is_modulus: false,
        apply: |d, v| with_module(d, |m| m.pillars.width_mm = v),
    },
    SweepParam {
        name: "pillar_height_mm",
        aliases: &[],
        label: "pillar height (mm)",
        is_modulus: false,
        apply: |d, v| with_module(d, |m| m.pillars.height_mm = v),
    },
    SweepParam {
        name: "nu1",
        aliases: &["core_poisson_ratio"],
        label: "ν1, core Poisson's ratio",
        is_modulus: false,
        apply: |d, v| set_materials(d, core_keys(d), |m| m.poisson_ratio = v),
    },
    SweepParam {
        name: "nu2",
        aliases: &["cap_poisson_ratio"],
        label: "ν2, cap Poisson's ratio",
        is_modulus: false,
        apply: |d, v| set_materials(d, cap_keys(d), |m| m.poisson_ratio = v),
    },
    SweepParam {
        name: "nus",
        aliases: &["insert_poisson_ratio"],
        label: "νs, insert Poisson's ratio",
        is_modulus: false,
        apply: |d, v| set_materials(d, insert_keys(d), |m| m.poisson_ratio = v),
    },
    SweepParam {
        name: "grating_center_height_mm",
        aliases: &[],
        label: "grating centre height (mm)",
        is_modulus: false,
        apply: |d, v| {
            with_module(d, |m| {
                for g in m
                    .gratings
                    .iter_mut()
                    .filter(|g| g.center_height_mm.is_some())
                {
                    g.center_height_mm = Some(v);
                }
            })
        },
    },
];

/// Names accepted by [`find_param`], canonical first, aliases in brackets.
pub fn param_names() -> Vec<String> {
    PARAMS
        .iter()
        .map(|p| {
            if p.aliases.is_empty() {
                p.name.to_string()
            } else {
                format!("{} ({})", p.name, p.aliases.join(", "))
            }
        })
        .collect()
}

/// Errors of a sweep.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SweepError {
    /// Unknown parameter name.
    #[error("unknown sweep parameter `{0}`; known parameters: {known}", known = param_names().join(", "))]
    UnknownParam(String),
    /// Empty, reversed or non-finite range, or too few steps.
    #[error("bad range: {0}")]
    BadRange(String),
    /// Nothing to sweep: no strain grating, or Case I without an insert.
    #[error("nothing to sweep: {0}")]
    Nothing(String),
    /// A swept value makes the design invalid.
    #[error("at {param} = {value}: {reason}")]
    InvalidDesign {
        /// Parameter.
        param: String,
        /// Value.
        value: f64,
        /// Why the design is invalid.
        reason: SpecError,
    },
    /// The model rejected the design.
    #[error("at {param} = {value}: {reason}")]
    Model {
        /// Parameter.
        param: String,
        /// Value.
        value: f64,
        /// Model error.
        reason: super::ModelError,
    },
    /// Another predictor (the finite-element model) failed.
    #[error("at {param} = {value}: {reason}")]
    Predictor {
        /// Parameter.
        param: String,
        /// Value.
        value: f64,
        /// What the predictor reported, with its context.
        reason: String,
    },
}

/// One grating's answer at a sweep step from a model other than the closed form.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    /// The prediction.
    pub prediction: GratingPrediction,
    /// The band of K (pm/N, low and high), when the model gives one.
    pub band_pm_per_n: Option<[f64; 2]>,
    /// The bounding readings behind the band (pm/N: pillars bonded, cylinders sliding
    /// with the domes on the apex patch), when the model gives them.
    pub readings_pm_per_n: Option<[f64; 2]>,
}

/// Where a step's predictions come from when not from the closed form: any model of
/// the same design (the model policy, `crate::prediction`), returning every grating's
/// prediction with its band and readings when the model gives them, or a message.
/// Keeps `model` free of a dependency on `fem`.
pub type Predictor<'a> = dyn Fn(&Design, &PredictOptions) -> Result<Vec<SweepPoint>, String> + 'a;

/// Look a parameter up by name or alias (case-insensitive).
pub fn find_param(name: &str) -> Result<&'static SweepParam, SweepError> {
    let n = name.to_ascii_lowercase();
    PARAMS
        .iter()
        .find(|p| p.name == n || p.aliases.contains(&n.as_str()))
        .ok_or_else(|| SweepError::UnknownParam(name.to_string()))
}

/// A copy of `design` with `param` set to `value`, validated. The contact reading
/// follows the swept geometry by the family rule (`spec::ContactRatios`): a contact
/// length the design gives in mm is first restated as its ratio to its feature.
pub fn with_param(design: &Design, param: &SweepParam, value: f64) -> Result<Design, SweepError> {
    let mut d = design.clone();
    if let Some(m) = d.module.as_mut() {
        m.restate_contact_relative();
    }
    (param.apply)(&mut d, value);
    d.validate().map_err(|reason| SweepError::InvalidDesign {
        param: param.name.to_string(),
        value,
        reason,
    })?;
    Ok(d)
}

/// Largest number of sweep values (a typo such as `--steps 1000000000` must not hang).
pub(crate) const MAX_STEPS: usize = 100_000;

/// Evenly spaced values from `from` to `to` inclusive, checked.
pub fn sweep_values(
    param: &SweepParam,
    from: f64,
    to: f64,
    steps: usize,
) -> Result<Vec<f64>, SweepError> {
    if !from.is_finite() || !to.is_finite() {
        return Err(SweepError::BadRange(format!(
            "SweepRequest.start {from} and SweepRequest.stop {to} must be finite numbers"
        )));
    }
    if to <= from {
        return Err(SweepError::BadRange(format!(
            "SweepRequest.start {from} must be smaller than SweepRequest.stop {to} (an empty or reversed range)"
        )));
    }
    if !(2..=MAX_STEPS).contains(&steps) {
        return Err(SweepError::BadRange(format!(
            "SweepRequest.steps must be between 2 and {MAX_STEPS}, got {steps}"
        )));
    }
    if param.is_modulus && from <= 0.0 {
        return Err(SweepError::BadRange(format!(
            "{} is a modulus: the range must stay above 0 MPa, got SweepRequest.start {from}",
            param.name
        )));
    }
    if from <= 0.0 {
        return Err(SweepError::BadRange(format!(
            "{} must stay above 0 (a length or ratio), got SweepRequest.start {from}",
            param.name
        )));
    }
    Ok((0..steps)
        .map(|i| from + (to - from) * i as f64 / (steps - 1) as f64)
        .collect())
}

/// One curve of a sweep: a grating in a configuration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepSeries {
    /// Grating name.
    pub grating: String,
    /// Loading case.
    pub case: LoadCase,
    /// Insert (Case I).
    pub insert: Option<String>,
    /// Swept values.
    pub x: Vec<f64>,
    /// Predicted shift at the force, pm.
    pub shift_pm: Vec<f64>,
    /// Sensitivity, pm/N.
    pub sensitivity_pm_per_n: Vec<f64>,
    /// Band of K at each value, pm/N (low, high); empty when the model gives none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub band_pm_per_n: Vec<[f64; 2]>,
    /// The bounding readings at each value, pm/N (pillars bonded, cylinders sliding);
    /// empty when the model gives none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub readings_pm_per_n: Vec<[f64; 2]>,
}

impl SweepSeries {
    /// Legend label, e.g. `lambda_11 · Case I · blue`.
    pub fn label(&self) -> String {
        match &self.insert {
            Some(i) => format!("{} · Case {} · {}", self.grating, self.case, i),
            None => format!("{} · Case {}", self.grating, self.case),
        }
    }
}

/// A finished sweep.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepResult {
    /// Parameter name.
    pub param: String,
    /// Axis label with unit.
    pub label: String,
    /// Force, N.
    pub force_n: f64,
    /// One series per grating and configuration.
    pub series: Vec<SweepSeries>,
}

/// Sweep `param` over `values` at `force_n` with the closed form; `case` keeps only
/// one loading case. `progress` hears one stage of one step per value.
pub fn run(
    design: &Design,
    param: &SweepParam,
    values: &[f64],
    force_n: f64,
    case: Option<LoadCase>,
    progress: &dyn Progress,
) -> Result<SweepResult, SweepError> {
    run_with(design, param, values, force_n, case, None, progress)
}

/// [`run`] with another model answering at each step (`None`: the closed form).
pub fn run_with(
    design: &Design,
    param: &SweepParam,
    values: &[f64],
    force_n: f64,
    case: Option<LoadCase>,
    predictor: Option<&Predictor>,
    progress: &dyn Progress,
) -> Result<SweepResult, SweepError> {
    let mut series: Vec<SweepSeries> = Vec::new();
    progress.begin(param.name, values.len() as u64);
    let opts = PredictOptions {
        force_n,
        delta_t_k: 0.0,
    };
    for &v in values {
        let d = with_param(design, param, v)?;
        let preds: Vec<SweepPoint> = match predictor {
            None => predict_with(&d, &opts)
                .map_err(|reason| SweepError::Model {
                    param: param.name.to_string(),
                    value: v,
                    reason,
                })?
                .into_iter()
                .map(|d| SweepPoint {
                    prediction: d.prediction,
                    band_pm_per_n: None,
                    readings_pm_per_n: None,
                })
                .collect(),
            Some(f) => f(&d, &opts).map_err(|reason| SweepError::Predictor {
                param: param.name.to_string(),
                value: v,
                reason,
            })?,
        };
        for SweepPoint {
            prediction: p,
            band_pm_per_n: band,
            readings_pm_per_n: readings,
        } in preds
            .into_iter()
            .filter(|q| case.is_none_or(|c| c == q.prediction.case))
        {
            let s = match series
                .iter_mut()
                .find(|s| s.grating == p.grating && s.case == p.case && s.insert == p.insert)
            {
                Some(s) => s,
                None => {
                    series.push(SweepSeries {
                        grating: p.grating.clone(),
                        case: p.case,
                        insert: p.insert.clone(),
                        x: Vec::new(),
                        shift_pm: Vec::new(),
                        sensitivity_pm_per_n: Vec::new(),
                        band_pm_per_n: Vec::new(),
                        readings_pm_per_n: Vec::new(),
                    });
                    series.last_mut().expect("just pushed")
                }
            };
            s.x.push(v);
            s.shift_pm.push(p.shift_pm);
            s.sensitivity_pm_per_n.push(p.sensitivity_pm_per_n);
            if let Some(b) = band {
                s.band_pm_per_n.push(b);
            }
            if let Some(r) = readings {
                s.readings_pm_per_n.push(r);
            }
        }
        progress.advance(1);
    }
    progress.end();
    if series.is_empty() {
        return Err(SweepError::Nothing(match case {
            Some(LoadCase::I) => {
                "Case I needs a solid insert and a strain grating; the design lacks one".into()
            }
            _ => "the design has no strain grating to predict".into(),
        }));
    }
    Ok(SweepResult {
        param: param.name.to_string(),
        label: param.label.to_string(),
        force_n,
        series,
    })
}

/// One figure of the paper's parametric analysis (Figs. 9 and 11): which modulus is
/// swept, over which range, with which fixed values, in which case.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperFigure {
    /// File stem, e.g. `fig9a_case1_e1`.
    pub id: &'static str,
    /// Title.
    pub title: &'static str,
    /// Loading case.
    pub case: LoadCase,
    /// Swept parameter name.
    pub param: &'static str,
    /// Range swept, MPa (the paper's axes are lost: our reading, see docs/model.md).
    pub range_mpa: (f64, f64),
    /// Fixed E1, MPa (None when swept).
    pub e1_mpa: Option<f64>,
    /// Fixed E2, MPa (None when swept).
    pub e2_mpa: Option<f64>,
    /// Fixed Es, MPa (None when swept or Case II).
    pub es_mpa: Option<f64>,
    /// Where the paper says the curve levels off, MPa.
    pub knee_mpa: f64,
    /// Smallest share of the whole change of |Δλ| that must happen below the knee
    /// (our reading of "falls sharply up to the knee, then levels off", docs/model.md §7).
    pub min_share_below_knee: f64,
}

/// Force of the paper's parametric figures, N.
pub(crate) const PAPER_FORCE_N: f64 = 50.0;

/// The five parametric figures of the paper (Fig. 9a–c: Case I; Fig. 11a–b: Case II).
pub const PAPER_FIGURES: &[PaperFigure] = &[
    PaperFigure {
        id: "fig9a_case1_e1",
        title: "Case I: shift at 50 N vs E1 (E2 = 44 MPa, Es = 44 MPa)",
        case: LoadCase::I,
        param: "e1_mpa",
        range_mpa: (1.0, 1000.0),
        e1_mpa: None,
        e2_mpa: Some(44.0),
        es_mpa: Some(44.0),
        knee_mpa: 800.0,
        min_share_below_knee: 0.9,
    },
    PaperFigure {
        id: "fig9b_case1_e2",
        title: "Case I: shift at 50 N vs E2 (E1 = 1.4 MPa, Es = 44 MPa)",
        case: LoadCase::I,
        param: "e2_mpa",
        range_mpa: (0.5, 50.0),
        e1_mpa: Some(1.4),
        e2_mpa: None,
        es_mpa: Some(44.0),
        knee_mpa: 5.0,
        min_share_below_knee: 0.6,
    },
    PaperFigure {
        id: "fig9c_case1_es",
        title: "Case I: shift at 50 N vs Es (E1 = 1.4 MPa, E2 = 44 MPa)",
        case: LoadCase::I,
        param: "es_mpa",
        range_mpa: (10.0, 2000.0),
        e1_mpa: Some(1.4),
        e2_mpa: Some(44.0),
        es_mpa: None,
        knee_mpa: 500.0,
        min_share_below_knee: 0.75,
    },
    PaperFigure {
        id: "fig11a_case2_e1",
        title: "Case II: shift at 50 N vs E1 (E2 = 44 MPa)",
        case: LoadCase::II,
        param: "e1_mpa",
        range_mpa: (1.0, 1000.0),
        e1_mpa: None,
        e2_mpa: Some(44.0),
        es_mpa: None,
        knee_mpa: 700.0,
        min_share_below_knee: 0.9,
    },
    PaperFigure {
        id: "fig11b_case2_e2",
        title: "Case II: shift at 50 N vs E2 (E1 = 1.4 MPa)",
        case: LoadCase::II,
        param: "e2_mpa",
        range_mpa: (0.5, 50.0),
        e1_mpa: Some(1.4),
        e2_mpa: None,
        es_mpa: None,
        knee_mpa: 5.0,
        min_share_below_knee: 0.6,
    },
];

/// The design with a paper figure's fixed moduli applied (the swept one untouched).
/// With Es fixed every insert gets the same modulus, so only the first is kept.
pub(crate) fn paper_figure_design(
    design: &Design,
    fig: &PaperFigure,
) -> Result<Design, SweepError> {
    let mut d = design.clone();
    if let Some(v) = fig.e1_mpa {
        set_core_moduli(&mut d, v);
    }
    if let Some(v) = fig.e2_mpa {
        set_cap_modulus(&mut d, v);
    }
    if let Some(v) = fig.es_mpa {
        set_insert_moduli(&mut d, v);
    }
    let insert_label = match fig.es_mpa {
        Some(v) => format!("Es = {v} MPa"),
        None => "swept insert".to_string(),
    };
    if let Some(m) = d.module.as_mut() {
        m.inserts.truncate(1);
        if let Some(i) = m.inserts.first_mut() {
            i.name = insert_label;
        }
    }
    d.validate().map_err(|reason| SweepError::InvalidDesign {
        param: fig.param.to_string(),
        value: f64::NAN,
        reason,
    })?;
    Ok(d)
}

/// Run one paper figure with `steps` values.
pub fn run_paper_figure(
    design: &Design,
    fig: &PaperFigure,
    steps: usize,
) -> Result<SweepResult, SweepError> {
    run_paper_figure_with(design, fig, steps, None, &Quiet)
}

/// [`run_paper_figure`] with another model answering (`None`: the closed form);
/// `progress` hears one stage of one step per value.
pub fn run_paper_figure_with(
    design: &Design,
    fig: &PaperFigure,
    steps: usize,
    predictor: Option<&Predictor>,
    progress: &dyn Progress,
) -> Result<SweepResult, SweepError> {
    let d = paper_figure_design(design, fig)?;
    let param = find_param(fig.param)?;
    let values = sweep_values(param, fig.range_mpa.0, fig.range_mpa.1, steps)?;
    run_with(
        &d,
        param,
        &values,
        PAPER_FORCE_N,
        Some(fig.case),
        predictor,
        progress,
    )
}

/// Whether one curve reproduces a paper figure's stated trend (docs/model.md §7): the
/// figure's sign (Case I red, Case II blue) at every value, |Δλ| strictly falling, its
/// mean slope below the paper's knee at least ten times its mean slope above, and at
/// least the figure's share of the change below the knee.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrendVerdict {
    /// Whether every part holds.
    pub reproduced: bool,
    /// The first part that fails, or the numbers when all hold.
    pub detail: String,
}

/// Judge one curve (x ascending, Δλ in pm) against `fig`'s stated trend.
pub(crate) fn paper_trend(fig: &PaperFigure, x: &[f64], shift_pm: &[f64]) -> TrendVerdict {
    let fail = |detail: String| TrendVerdict {
        reproduced: false,
        detail,
    };
    let n = x.len().min(shift_pm.len());
    if n < 3 || x[0] >= fig.knee_mpa || x[n - 1] <= fig.knee_mpa {
        return fail(format!(
            "the curve ({n} points) does not straddle the paper's knee at {} MPa",
            fig.knee_mpa
        ));
    }
    let (x, y) = (&x[..n], &shift_pm[..n]);
    let red = fig.case == LoadCase::I;
    if let Some(i) = (0..n).find(|&i| if red { y[i] <= 0.0 } else { y[i] >= 0.0 }) {
        return fail(format!(
            "Δλ = {:+.1} pm at {} MPa: a {} shift where the paper's Case {} is {}",
            y[i],
            x[i],
            if y[i] > 0.0 { "red" } else { "blue" },
            fig.case,
            if red { "red" } else { "blue" }
        ));
    }
    if let Some(i) = (1..n).find(|&i| y[i].abs() >= y[i - 1].abs()) {
        return fail(format!(
            "|Δλ| rises from {:.1} pm at {} MPa to {:.1} pm at {} MPa; the paper's falls",
            y[i - 1].abs(),
            x[i - 1],
            y[i].abs(),
            x[i]
        ));
    }
    let at = |v: f64| {
        let i = x
            .windows(2)
            .position(|w| w[0] <= v && v <= w[1])
            .unwrap_or(0);
        y[i] + (y[i + 1] - y[i]) * (v - x[i]) / (x[i + 1] - x[i])
    };
    let k = fig.knee_mpa;
    let yk = at(k);
    let below = (y[0] - yk).abs() / (k - x[0]);
    let above = (yk - y[n - 1]).abs() / (x[n - 1] - k);
    let ratio = below / above;
    let share = (y[0].abs() - yk.abs()) / (y[0].abs() - y[n - 1].abs());
    if ratio < 10.0 {
        return fail(format!(
            "mean slope below {k} MPa only {ratio:.1}× the slope above it (10× expected)"
        ));
    }
    if share < fig.min_share_below_knee {
        return fail(format!(
            "{:.0} % of the change below {k} MPa ({:.0} % expected)",
            100.0 * share,
            100.0 * fig.min_share_below_knee
        ));
    }
    TrendVerdict {
        reproduced: true,
        detail: format!(
            "|Δλ| {:.0} → {:.0} pm, falling; slope ratio {ratio:.0} at {k} MPa, {:.0} % of the change below it",
            y[0].abs(),
            y[n - 1].abs(),
            100.0 * share
        ),
    }
}

#[cfg(test)]
mod trend_tests {
    use super::*;

    fn fig(id: &str) -> &'static PaperFigure {
        PAPER_FIGURES.iter().find(|f| f.id == id).unwrap()
    }

    #[test]
    fn a_curve_that_levels_off_at_the_knee_reproduces_and_others_do_not() {
        let f = fig("fig9c_case1_es");
        // Δλ = 100 + 1000 exp(−Es/100): falls, almost all of it below 500 MPa.
        let x: Vec<f64> = (0..50).map(|i| 10.0 + 1990.0 * i as f64 / 49.0).collect();
        let good: Vec<f64> = x
            .iter()
            .map(|e| 100.0 + 1000.0 * (-e / 100.0).exp())
            .collect();
        assert!(paper_trend(f, &x, &good).reproduced);
        // A straight falling line: no knee.
        let line: Vec<f64> = x.iter().map(|e| 3000.0 - e).collect();
        let v = paper_trend(f, &x, &line);
        assert!(!v.reproduced && v.detail.contains("slope"), "{}", v.detail);
        // Rising: the Fig. 9b under the default model.
        let rising: Vec<f64> = x.iter().map(|e| 100.0 + e).collect();
        let v = paper_trend(f, &x, &rising);
        assert!(!v.reproduced && v.detail.contains("rises"), "{}", v.detail);
        // Turning blue: the Fig. 9a.
        let blue: Vec<f64> = x.iter().map(|e| 500.0 - e).collect();
        let v = paper_trend(f, &x, &blue);
        assert!(!v.reproduced && v.detail.contains("blue"), "{}", v.detail);
        // Case II must be blue.
        let v = paper_trend(fig("fig11a_case2_e1"), &x, &good);
        assert!(!v.reproduced && v.detail.contains("red"), "{}", v.detail);
    }

    #[test]
    fn the_closed_form_reproduces_all_five_figures() {
        let d =
            crate::design::parse(include_str!("../../../../designs/clip-on-34mm.toml")).unwrap();
        for f in PAPER_FIGURES {
            let r = run_paper_figure(&d, f, 201).unwrap();
            let s = &r.series[0];
            let v = paper_trend(f, &s.x, &s.shift_pm);
            assert!(v.reproduced, "{}: {}", f.id, v.detail);
        }
    }
}
