//! Module optimisation: for each discrete choice of core material and insert (or a
//! hollow core), search the continuous design variables (outer diameter, wall
//! thicknesses, dome height, overall height) for the largest Q (or sensitivity) that
//! meets every constraint.
//!
//! The problem ([`ModuleProblem`], a [`BoxProblem`]) is separate from the method
//! ([`SolverKind`]). Bounds are a feasible parameterisation (the solvers work in the
//! box); the other constraints enter the cost as an exact (L1) penalty, and the problem
//! itself remembers the best *feasible* design it has evaluated, so the answer always
//! satisfies every constraint and, since the starting design is evaluated first, never
//! has a lower objective than the start.
//!
//! Derived dimensions follow the variables by fixed rules (documented in
//! docs/optimize.md): the overall height, pillars, holes and grating heights scale with
//! the diameter, floored at what the printer can make.

use super::materials::{MaterialLibrary, MaterialRole};
use super::quality::{
    design_quality, Calibration, MeasuredPrototype, QualityBreakdown, QualitySettings,
};
use crate::fem::FemOptions;
use crate::model::{GratingPrediction, LoadCase};
use crate::prediction::{Anchored, FidelityChoice};
use crate::profile::ModuleProfile;
use crate::progress::Progress;
use crate::solvers::{multi_start, start_points, BoxProblem, Run, RunSettings, SolverKind};
use crate::spec::{Core, Design, GratingRole, Insert, Module};
use rayon::prelude::*;
use serde::Serialize;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A function that predicts every grating of a design at a force.
pub type PredictFn =
    Arc<dyn Fn(&Design, f64) -> anyhow::Result<Vec<GratingPrediction>> + Send + Sync>;

/// Anchored policies already built, keyed by the TOML of the design they were anchored
/// on (one FE solve per configuration saved when a problem is set up again).
pub type AnchorCache = Arc<Mutex<Vec<(String, Arc<Anchored>)>>>;

/// The model the optimiser asks.
#[derive(Clone)]
pub enum Predictor {
    /// The model policy ([`crate::prediction`]), as [`Anchored`] on each problem's
    /// start design: equal to `fbgforge predict` there; the final answer is anchored
    /// on itself, so the optimiser reports the policy's own K for the design it writes.
    Policy {
        /// Which model the policy uses.
        fidelity: FidelityChoice,
        /// Anchors built so far.
        cache: AnchorCache,
    },
    /// Any function (synthetic models in tests).
    Function(PredictFn),
}

impl Predictor {
    /// A predictor from a plain function.
    pub fn function(
        f: impl Fn(&Design, f64) -> anyhow::Result<Vec<GratingPrediction>> + Send + Sync + 'static,
    ) -> Self {
        Predictor::Function(Arc::new(f))
    }

    /// The model anchored on `design`, and its name.
    fn anchored_on(&self, design: &Design) -> anyhow::Result<(PredictFn, String)> {
        match self {
            Predictor::Function(f) => Ok((f.clone(), "custom predictor".into())),
            Predictor::Policy { fidelity, cache } => {
                let key = design.to_toml();
                let found = cache
                    .lock()
                    .expect("anchor cache")
                    .iter()
                    .find(|(k, _)| k == &key)
                    .map(|(_, a)| a.clone());
                let a = match found {
                    Some(a) => a,
                    None => {
                        let a = Arc::new(
                            Anchored::new(design, *fidelity, &FemOptions::default()).map_err(
                                |e| e.context("anchoring the model policy on the start design"),
                            )?,
                        );
                        cache.lock().expect("anchor cache").push((key, a.clone()));
                        a
                    }
                };
                let name = a.description().to_string();
                Ok((Arc::new(move |d: &Design, f: f64| a.predict(d, f)), name))
            }
        }
    }
}

/// The opto-mechanical model policy as a [`Predictor`].
pub fn model_predictor() -> Predictor {
    Predictor::Policy {
        fidelity: FidelityChoice::Auto,
        cache: Arc::new(Mutex::new(Vec::new())),
    }
}

/// What to maximise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Objective {
    /// Q = |K|·R²/Δt_max of the worst strain grating, pm/(N·s).
    Q,
    /// |K| of the worst strain grating, pm/N.
    Sensitivity,
}

impl Objective {
    /// Parse `q` or `sensitivity`.
    pub fn parse(s: &str) -> anyhow::Result<Self> {
        match s {
            "q" => Ok(Objective::Q),
            "sensitivity" => Ok(Objective::Sensitivity),
            _ => anyhow::bail!("unknown objective `{s}`; expected q or sensitivity"),
        }
    }

    /// Unit of the objective value.
    pub fn unit(self) -> &'static str {
        match self {
            Objective::Q => "pm/(N·s)",
            Objective::Sensitivity => "pm/N",
        }
    }
}

/// A continuous design variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Hash)]
#[serde(rename_all = "snake_case")]
pub enum Variable {
    /// `module.outer_diameter_mm`.
    OuterDiameterMm,
    /// `module.cap_wall_mm`.
    CapWallMm,
    /// `module.core_wall_mm`.
    CoreWallMm,
    /// `module.dome_height_mm` / outer radius (1 = hemisphere).
    DomeHeightRatio,
    /// `module.overall_height_mm` (otherwise it scales with the diameter).
    OverallHeightMm,
}

impl Variable {
    /// Every variable.
    pub const ALL: [Variable; 5] = [
        Variable::OuterDiameterMm,
        Variable::CapWallMm,
        Variable::CoreWallMm,
        Variable::DomeHeightRatio,
        Variable::OverallHeightMm,
    ];
    /// Varied when the user does not say.
    pub const DEFAULT: [Variable; 4] = [
        Variable::OuterDiameterMm,
        Variable::CapWallMm,
        Variable::CoreWallMm,
        Variable::DomeHeightRatio,
    ];

    /// Name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Variable::OuterDiameterMm => "outer_diameter_mm",
            Variable::CapWallMm => "cap_wall_mm",
            Variable::CoreWallMm => "core_wall_mm",
            Variable::DomeHeightRatio => "dome_height_ratio",
            Variable::OverallHeightMm => "overall_height_mm",
        }
    }

    /// Parse a comma-separated list, naming an unknown entry and the known ones.
    pub fn parse_list(s: &str) -> anyhow::Result<Vec<Variable>> {
        let mut out = Vec::new();
        for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            let v = Variable::ALL
                .iter()
                .copied()
                .find(|v| v.name() == name)
                .ok_or_else(|| {
                    let known: Vec<&str> = Variable::ALL.iter().map(|v| v.name()).collect();
                    anyhow::anyhow!(
                        "unknown variable `{name}` in --vary; known: {}",
                        known.join(", ")
                    )
                })?;
            if out.contains(&v) {
                anyhow::bail!("variable `{name}` is listed twice in --vary");
            }
            out.push(v);
        }
        anyhow::ensure!(!out.is_empty(), "--vary lists no variable");
        Ok(out)
    }

    /// The variable's value in a module.
    pub fn value(self, m: &Module) -> f64 {
        match self {
            Variable::OuterDiameterMm => m.outer_diameter_mm,
            Variable::CapWallMm => m.cap_wall_mm,
            Variable::CoreWallMm => m.core_wall_mm,
            Variable::DomeHeightRatio => m.dome_height_mm / (m.outer_diameter_mm / 2.0),
            Variable::OverallHeightMm => m.overall_height_mm,
        }
    }

    /// Default search range given the start module and the printer's minimum wall.
    /// The diameter spans the paper's scripted 10–22 mm, widened to hold the start.
    pub fn default_bounds(self, m: &Module, min_wall_mm: f64) -> (f64, f64) {
        let v = self.value(m);
        match self {
            Variable::OuterDiameterMm => (v.min(10.0), v.max(22.0)),
            Variable::CapWallMm | Variable::CoreWallMm => (min_wall_mm, v.max(3.0)),
            Variable::DomeHeightRatio => (v.min(0.3), 1.0),
            Variable::OverallHeightMm => (0.6 * v, 1.4 * v),
        }
    }
}

/// Parse `name=lo:hi` bound overrides.
pub fn parse_bounds(s: &str) -> anyhow::Result<Vec<(Variable, f64, f64)>> {
    let mut out = Vec::new();
    for item in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        let (name, range) = item.split_once('=').ok_or_else(|| {
            anyhow::anyhow!("bound `{item}`: expected NAME=LO:HI, e.g. outer_diameter_mm=10:22")
        })?;
        let v = Variable::parse_list(name)?[0];
        let (lo, hi) = range
            .split_once(':')
            .ok_or_else(|| anyhow::anyhow!("bound `{item}`: expected NAME=LO:HI"))?;
        let num = |t: &str| -> anyhow::Result<f64> {
            let x: f64 = t
                .trim()
                .parse()
                .map_err(|_| anyhow::anyhow!("bound `{item}`: `{t}` is not a number"))?;
            anyhow::ensure!(x.is_finite(), "bound `{item}`: `{t}` is not finite");
            Ok(x)
        };
        out.push((v, num(lo)?, num(hi)?));
    }
    Ok(out)
}

/// Everything the module optimisation needs besides the design.
#[derive(Debug, Clone, Serialize)]
pub struct ModuleSettings {
    /// What to maximise.
    pub objective: Objective,
    /// The user's largest force, N: strain and window constraints are checked there.
    pub max_force_n: f64,
    /// Largest allowed |axial strain| of a grating at the largest force.
    pub max_grating_strain: f64,
    /// Smallest printable fit clearance, mm (default: the printer's resolution).
    pub min_fit_clearance_mm: Option<f64>,
    /// Temperature excursion each window must also hold, ± K.
    pub temperature_span_k: f64,
    /// Gap kept between neighbouring gratings' ranges, nm.
    pub guard_band_nm: f64,
    /// Interrogator band, nm (SM125: 1510–1590 nm).
    pub band_nm: (f64, f64),
    /// Variables searched.
    pub vary: Vec<Variable>,
    /// User bounds replacing the defaults.
    pub bounds: Vec<(Variable, f64, f64)>,
    /// Core materials tried (None: the design's plus the library's for this printer).
    pub cores: Option<Vec<String>>,
    /// Insert materials tried; `none` is the hollow core (None: the design's plus the
    /// library's, plus hollow).
    pub inserts: Option<Vec<String>>,
    /// Q model settings.
    pub quality: QualitySettings,
    /// Solvers compared.
    pub solvers: Vec<SolverKind>,
    /// Random starts besides the design's own point.
    pub extra_starts: usize,
    /// Budget of each run.
    pub run: RunSettings,
    /// Seed for the starts and the swarms.
    pub seed: u64,
}

impl Default for ModuleSettings {
    fn default() -> Self {
        ModuleSettings {
            objective: Objective::Q,
            max_force_n: 20.0,
            max_grating_strain: 3e-3,
            min_fit_clearance_mm: None,
            temperature_span_k: 10.0,
            guard_band_nm: 0.2,
            band_nm: (1510.0, 1590.0),
            vary: Variable::DEFAULT.to_vec(),
            bounds: Vec::new(),
            cores: None,
            inserts: None,
            quality: QualitySettings::default(),
            solvers: SolverKind::BOTH.to_vec(),
            extra_starts: 2,
            run: RunSettings::default(),
            seed: 2024,
        }
    }
}

/// One discrete choice: core material and insert material (None = hollow, Case II).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Choice {
    /// Core material key.
    pub core_material: String,
    /// Insert material key, or None for a hollow core.
    pub insert_material: Option<String>,
}

impl std::fmt::Display for Choice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "core {} + {}",
            self.core_material,
            self.insert_material.as_deref().unwrap_or("hollow")
        )
    }
}

/// One constraint's value at a design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConstraintValue {
    /// Constraint name (stable, used in errors).
    pub name: String,
    /// What it requires, in words with units.
    pub requirement: String,
    /// Normalised violation, 0 when met.
    pub violation: f64,
    /// The measured value, in words with units.
    pub detail: String,
}

/// A design evaluated: objective, Q breakdown and constraints.
#[derive(Debug, Clone, Serialize)]
pub struct Evaluation {
    /// Variable values, in `ModuleProblem::variables` order.
    pub x: Vec<f64>,
    /// Objective value (worst strain grating), or 0 when the model failed.
    pub objective: f64,
    /// Q breakdown per strain grating.
    pub gratings: Vec<QualityBreakdown>,
    /// Every constraint.
    pub constraints: Vec<ConstraintValue>,
}

impl Evaluation {
    /// Sum of normalised violations.
    pub fn total_violation(&self) -> f64 {
        self.constraints.iter().map(|c| c.violation).sum()
    }
    /// How far from feasible, for ranking infeasible designs: designs whose geometry,
    /// spec or model fails rank behind designs that only break a physics constraint
    /// (strain, wavelength window), since only the latter were checked in full.
    pub fn infeasibility_rank(&self) -> (u8, f64) {
        let geometric = self
            .constraints
            .iter()
            .any(|c| c.violation > 0.0 && !PHYSICS_CONSTRAINTS.contains(&c.name.as_str()));
        (u8::from(geometric), self.total_violation())
    }

    /// True when every constraint is met.
    pub fn feasible(&self) -> bool {
        self.constraints.iter().all(|c| c.violation <= 0.0)
    }
}

/// Weight of the tie-break toward the start design (see [`ModuleProblem::merit`]).
pub const TIE_WEIGHT: f64 = 1e-3;

/// Constraints checked on the model's prediction (only once the geometry is valid).
pub const PHYSICS_CONSTRAINTS: [&str; 2] = ["grating_strain", "wavelength_window"];

/// A linear correction of the anchored estimate around `center`: per grating row
/// (grating, case, insert), the relative slope of the policy's K against it along each
/// variable.
#[derive(Debug, Clone)]
struct Correction {
    center: Vec<f64>,
    rows: Vec<(RowKey, Vec<f64>)>,
}

/// A prediction row's identity: grating, case, insert.
type RowKey = (String, LoadCase, Option<String>);

impl Correction {
    fn apply(&self, x: &[f64], preds: &mut [GratingPrediction]) {
        for p in preds.iter_mut() {
            let Some((_, s)) = self
                .rows
                .iter()
                .find(|(k, _)| k.0 == p.grating && k.1 == p.case && k.2 == p.insert)
            else {
                continue;
            };
            let f: f64 = 1.0
                + s.iter()
                    .zip(x.iter().zip(&self.center))
                    .map(|(s, (x, c))| s * (x - c))
                    .sum::<f64>();
            // A linear factor is trusted near its centre only; keep it positive.
            let f = f.clamp(0.2, 5.0);
            p.sensitivity_pm_per_n *= f;
            p.shift_pm *= f;
            p.strain *= f;
        }
    }
}

/// The problem for one discrete choice.
#[derive(Clone)]
pub struct ModuleProblem {
    /// The choice.
    pub choice: Choice,
    /// Variables searched.
    pub variables: Vec<Variable>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    base: Design,
    template: Design,
    core_name: String,
    insert_name: Option<String>,
    lib: MaterialLibrary,
    settings: ModuleSettings,
    calibration: Calibration,
    predictor: Predictor,
    model: PredictFn,
    model_description: String,
    correction: Option<Correction>,
    windows_nm: Vec<(String, f64, f64)>,
    scale: f64,
    x0: Vec<f64>,
}

fn module_of(d: &Design) -> anyhow::Result<&Module> {
    d.module
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("design `{}` has no [module] section to optimise", d.name))
}

fn push(
    cons: &mut Vec<ConstraintValue>,
    name: &str,
    requirement: String,
    violation: f64,
    detail: String,
) {
    cons.push(ConstraintValue {
        name: name.into(),
        requirement,
        violation: violation.max(0.0),
        detail,
    })
}

/// Wavelength windows: each grating owns the band between the midpoints to its
/// neighbours, less half the guard band on each side; the outer gratings reach the
/// interrogator's band edges.
pub fn wavelength_windows(
    m: &Module,
    guard_nm: f64,
    band_nm: (f64, f64),
) -> Vec<(String, f64, f64)> {
    let mut g: Vec<(String, f64)> = m
        .gratings
        .iter()
        .map(|g| (g.name.clone(), g.bragg_wavelength_nm))
        .collect();
    g.sort_by(|a, b| a.1.total_cmp(&b.1));
    (0..g.len())
        .map(|i| {
            let lo = if i == 0 {
                band_nm.0
            } else {
                0.5 * (g[i - 1].1 + g[i].1) + guard_nm / 2.0
            };
            let hi = if i + 1 == g.len() {
                band_nm.1
            } else {
                0.5 * (g[i].1 + g[i + 1].1) - guard_nm / 2.0
            };
            (g[i].0.clone(), lo, hi)
        })
        .collect()
}

impl ModuleProblem {
    /// Set up the problem for `choice` from the start design.
    pub fn new(
        base: &Design,
        choice: Choice,
        lib: &MaterialLibrary,
        settings: &ModuleSettings,
        calibration: Calibration,
        predictor: Predictor,
    ) -> anyhow::Result<Self> {
        let m = module_of(base)?;
        let core0 = m
            .cores
            .first()
            .ok_or_else(|| anyhow::anyhow!("the design lists no core"))?;
        let mut t = base.clone();
        let tm = t.module.as_mut().expect("checked above");
        for key in std::iter::once(&choice.core_material).chain(choice.insert_material.iter()) {
            if !t.materials.contains_key(key) {
                let lm = lib.materials.get(key).ok_or_else(|| {
                    anyhow::anyhow!(
                        "unknown material `{key}`: neither the design nor the material library has it (library: {})",
                        lib.materials.keys().cloned().collect::<Vec<_>>().join(", ")
                    )
                })?;
                t.materials.insert(key.clone(), lm.to_spec_material());
            }
        }
        tm.cores = vec![Core {
            name: core0.name.clone(),
            material: choice.core_material.clone(),
        }];
        let insert_name = choice.insert_material.clone();
        tm.inserts = insert_name
            .iter()
            .map(|k| Insert {
                name: k.clone(),
                material: k.clone(),
            })
            .collect();
        tm.gratings.retain(|g| {
            g.role == GratingRole::TemperatureReference
                || g.core.as_deref() == Some(core0.name.as_str())
        });
        if !tm.gratings.iter().any(|g| g.role == GratingRole::Strain) {
            anyhow::bail!(
                "core `{}` carries no strain grating: nothing to optimise",
                core0.name
            );
        }
        // Keep only the materials the new design uses, so the written TOML is tidy.
        let used: Vec<String> = std::iter::once(tm.cap_material.clone())
            .chain(tm.cores.iter().map(|c| c.material.clone()))
            .chain(tm.inserts.iter().map(|i| i.material.clone()))
            .collect();
        let windows_nm = wavelength_windows(tm, settings.guard_band_nm, settings.band_nm);
        t.materials.retain(|k, _| used.contains(k));

        let min_wall = base.printer.min_wall_mm;
        let mut lo = Vec::new();
        let mut hi = Vec::new();
        for &v in &settings.vary {
            let (mut l, mut h) = v.default_bounds(m, min_wall);
            if let Some(&(_, ul, uh)) = settings.bounds.iter().find(|b| b.0 == v) {
                l = ul;
                h = uh;
            }
            if l >= h || l.is_nan() || h.is_nan() {
                anyhow::bail!(
                    "contradictory bounds for `{}`: lower {l} is not below upper {h}",
                    v.name()
                );
            }
            if matches!(v, Variable::CapWallMm | Variable::CoreWallMm) && h < min_wall {
                anyhow::bail!(
                    "bounds for `{}` ({l}..{h} mm) lie below the printer's minimum wall {min_wall} mm: constraint `printer_min_wall` cannot be met",
                    v.name()
                );
            }
            if matches!(v, Variable::CapWallMm | Variable::CoreWallMm) {
                l = l.max(min_wall);
            }
            if v == Variable::DomeHeightRatio {
                anyhow::ensure!(
                    l > 0.0 && h <= 1.0,
                    "bounds for `dome_height_ratio` must lie in (0, 1], got {l}..{h}"
                );
            }
            anyhow::ensure!(
                l > 0.0,
                "bounds for `{}` must be positive, got {l}..{h}",
                v.name()
            );
            lo.push(l);
            hi.push(h);
        }
        for (v, _, _) in &settings.bounds {
            if !settings.vary.contains(v) {
                anyhow::bail!(
                    "a bound is given for `{}`, which is not in --vary",
                    v.name()
                );
            }
        }
        let mut p = ModuleProblem {
            core_name: core0.name.clone(),
            insert_name,
            choice,
            variables: settings.vary.clone(),
            lo,
            hi,
            base: base.clone(),
            template: t,
            lib: lib.clone(),
            settings: settings.clone(),
            calibration,
            predictor: predictor.clone(),
            model: Arc::new(|_: &Design, _: f64| anyhow::bail!("the model is not anchored yet")),
            model_description: String::new(),
            correction: None,
            windows_nm,
            scale: 1.0,
            x0: Vec::new(),
        };
        p.x0 = p.start_point();
        (p.model, p.model_description) = predictor.anchored_on(&p.design_at(&p.x0))?;
        Ok(p)
    }

    /// The same problem with the model anchored on the design at `x` (the policy's
    /// own K there).
    pub fn anchored_at(&self, x: &[f64]) -> anyhow::Result<Self> {
        let mut p = self.clone();
        (p.model, p.model_description) = self.predictor.anchored_on(&self.design_at(x))?;
        p.correction = None;
        Ok(p)
    }

    /// The model anchored at `x` with a first-order correction: the ratio of the
    /// policy's K to the anchored estimate is measured a step along each variable (one
    /// anchoring each) and applied as a linear factor, so the estimate has the
    /// policy's value and slope at `x` (what a trust region needs to converge).
    pub fn corrected_at(&self, x: &[f64]) -> anyhow::Result<Self> {
        let mut p = self.anchored_at(x)?;
        if matches!(self.predictor, Predictor::Function(_)) {
            return Ok(p);
        }
        let at = |q: &ModuleProblem, x: &[f64]| -> anyhow::Result<Vec<GratingPrediction>> {
            (q.model)(&q.design_at(x), 1.0)
        };
        let base = at(&p, x)?;
        let mut slopes: Vec<Vec<f64>> = vec![vec![0.0; x.len()]; base.len()];
        for v in 0..x.len() {
            let span = self.hi[v] - self.lo[v];
            let mut h = 0.02 * span;
            if x[v] + h > self.hi[v] {
                h = -h;
            }
            let mut xs = x.to_vec();
            xs[v] += h;
            let estimate = at(&p, &xs)?;
            let exact = at(&p.anchored_at(&xs)?, &xs)?;
            for (i, (e, t)) in estimate.iter().zip(&exact).enumerate() {
                if e.sensitivity_pm_per_n != 0.0 {
                    slopes[i][v] = (t.sensitivity_pm_per_n / e.sensitivity_pm_per_n - 1.0) / h;
                }
            }
        }
        p.correction = Some(Correction {
            center: x.to_vec(),
            rows: base
                .iter()
                .map(|b| (b.grating.clone(), b.case, b.insert.clone()))
                .zip(slopes)
                .collect(),
        });
        Ok(p)
    }

    /// The same problem searched in the box `lo`..`hi` (a trust region).
    pub fn within(&self, lo: Vec<f64>, hi: Vec<f64>) -> Self {
        let mut p = self.clone();
        p.lo = lo;
        p.hi = hi;
        p
    }

    /// The model that scores candidates, in words.
    pub fn model_description(&self) -> &str {
        &self.model_description
    }

    /// The start point: the start design's own values, clamped into the box.
    pub fn start_point(&self) -> Vec<f64> {
        let m = self.base.module.as_ref().expect("checked in new");
        self.variables
            .iter()
            .zip(self.lo.iter().zip(&self.hi))
            .map(|(v, (&l, &h))| v.value(m).clamp(l, h))
            .collect()
    }

    /// Use `scale` to normalise the objective in the cost (typically the start's value).
    pub fn set_scale(&mut self, scale: f64) {
        self.scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            1.0
        };
    }

    /// Build the candidate design at `x` by the derivation rules.
    pub fn design_at(&self, x: &[f64]) -> Design {
        let b = self.base.module.as_ref().expect("checked in new");
        let get = |v: Variable| self.variables.iter().position(|&w| w == v).map(|i| x[i]);
        let mut d = self.template.clone();
        let min_wall = d.printer.min_wall_mm;
        let fit = self.min_fit_clearance_mm();
        let m = d.module.as_mut().expect("template has a module");
        let dia = get(Variable::OuterDiameterMm).unwrap_or(b.outer_diameter_mm);
        let s = dia / b.outer_diameter_mm;
        let r = dia / 2.0;
        m.outer_diameter_mm = dia;
        m.overall_height_mm = get(Variable::OverallHeightMm).unwrap_or(b.overall_height_mm * s);
        let ratio = get(Variable::DomeHeightRatio)
            .unwrap_or(b.dome_height_mm / (b.outer_diameter_mm / 2.0));
        m.dome_height_mm = ratio * r;
        m.cap_wall_mm = get(Variable::CapWallMm).unwrap_or((b.cap_wall_mm * s).max(min_wall));
        m.core_wall_mm = get(Variable::CoreWallMm).unwrap_or((b.core_wall_mm * s).max(min_wall));
        m.cap_core_clearance_mm = b.cap_core_clearance_mm.max(fit);
        m.core_insert_clearance_mm = b.core_insert_clearance_mm.max(fit);
        // Small features scale with the module but never below what prints and what a
        // coated fiber (250 µm) passes through.
        let p = &mut m.pillars;
        let bp = &b.pillars;
        p.fiber_hole_diameter_mm = (bp.fiber_hole_diameter_mm * s)
            .max(0.4)
            .min(bp.fiber_hole_diameter_mm.max(0.4));
        p.groove_depth_mm = (bp.groove_depth_mm * s).max(0.1);
        // EPS keeps the floors strictly inside the spec's limits despite rounding.
        const EPS: f64 = 1e-3;
        p.groove_width_mm =
            (bp.groove_width_mm * s).max(2.0 * m.cap_core_clearance_mm + min_wall + EPS);
        p.width_mm = (bp.width_mm * s).max(p.groove_width_mm + 2.0 * min_wall + EPS);
        p.height_mm = (bp.height_mm * s)
            .max(p.groove_depth_mm + p.fiber_hole_diameter_mm + 2.0 * min_wall + EPS);
        m.top_hole_diameter_mm = (b.top_hole_diameter_mm * s).max(0.4);
        // The contact reading's lengths scale with the module too (the clip with the cap
        // wall by default, the domes' contact zone with the diameter).
        if let Some(r) = b.contact.dome_contact_radius_mm {
            m.contact.dome_contact_radius_mm = Some(r * s);
        }
        if let Some(h) = b.contact.clip_height_mm {
            m.contact.clip_height_mm = Some(h * m.cap_wall_mm / b.cap_wall_mm);
        }
        m.apex_flat_diameter_mm = (b.apex_flat_diameter_mm * s).max(2.0 * d.printer.resolution_mm);
        // Gratings keep their relative height, inside the cylindrical section.
        let prof = ModuleProfile::from_module_unchecked(m);
        let hs = m.overall_height_mm / b.overall_height_mm;
        for g in m.gratings.iter_mut() {
            if let Some(z) = g.center_height_mm {
                let lo = g.length_mm / 2.0;
                let hi = (prof.pillar_top_mm - g.length_mm / 2.0).max(lo);
                g.center_height_mm = Some((z * hs).clamp(lo, hi));
            }
        }
        d
    }

    fn min_fit_clearance_mm(&self) -> f64 {
        self.settings
            .min_fit_clearance_mm
            .unwrap_or(self.base.printer.resolution_mm)
    }

    /// Evaluate the design at `x`: every constraint and the objective.
    pub fn evaluate(&self, x: &[f64]) -> Evaluation {
        let d = self.design_at(x);
        self.evaluate_design(x, &d)
    }

    /// Evaluate a built candidate design.
    pub fn evaluate_design(&self, x: &[f64], d: &Design) -> Evaluation {
        let m = d.module.as_ref().expect("candidate has a module");
        let min_wall = d.printer.min_wall_mm;
        let mut cons = Vec::new();
        let thinnest = m.cap_wall_mm.min(m.core_wall_mm);
        push(
            &mut cons,
            "printer_min_wall",
            format!("cap and core walls ≥ {min_wall} mm"),
            (min_wall - thinnest) / min_wall,
            format!("thinnest wall {thinnest:.3} mm"),
        );
        let fit = self.min_fit_clearance_mm();
        let tight = m.cap_core_clearance_mm.min(m.core_insert_clearance_mm);
        push(
            &mut cons,
            "fit_clearance",
            format!("fit clearances ≥ {fit} mm"),
            (fit - tight) / fit,
            format!("tightest clearance {tight:.3} mm"),
        );
        // The spec's rules on the derived profile, each with how far it is broken:
        // the same rules `design::load` enforces, as penalties.
        for v in crate::design::profile_violations(m, min_wall) {
            push(&mut cons, v.rule, v.requirement, v.excess, v.detail);
        }
        // Everything the spec itself checks (a design that fails here would not load).
        let spec_violation = cons.iter().all(|c| c.violation <= 0.0);
        if spec_violation {
            if let Err(e) = d.validate() {
                push(
                    &mut cons,
                    "spec_validation",
                    "the design validates".into(),
                    1.0,
                    e.to_string(),
                );
            }
        }
        let mut objective = 0.0;
        let mut gratings = Vec::new();
        if cons.iter().all(|c| c.violation <= 0.0) {
            let preds = (self.model)(d, self.settings.max_force_n).map(|mut preds| {
                if let Some(c) = &self.correction {
                    c.apply(x, &mut preds);
                }
                preds
            });
            match preds {
                Err(e) => push(
                    &mut cons,
                    "model",
                    "the model predicts the design".into(),
                    1.0,
                    format!("{e:#}"),
                ),
                Ok(preds) => {
                    match design_quality(
                        d,
                        &preds,
                        &self.lib,
                        &self.core_name,
                        self.insert_name.as_deref(),
                        &self.settings.quality,
                        &self.calibration,
                    ) {
                        Err(e) => push(
                            &mut cons,
                            "model",
                            "the model predicts the design".into(),
                            1.0,
                            format!("{e:#}"),
                        ),
                        Ok(q) if q.is_empty() => push(
                            &mut cons,
                            "model",
                            "the model predicts the design".into(),
                            1.0,
                            "no strain grating predicted".into(),
                        ),
                        Ok(q) => {
                            objective = q
                                .iter()
                                .map(|g| match self.settings.objective {
                                    Objective::Q => g.quality_pm_per_n_s,
                                    Objective::Sensitivity => g.sensitivity_pm_per_n.abs(),
                                })
                                .fold(f64::INFINITY, f64::min);
                            if !objective.is_finite() {
                                objective = 0.0;
                            }
                            self.physics_constraints(d, &preds, &mut cons);
                            gratings = q;
                        }
                    }
                }
            }
        }
        Evaluation {
            x: x.to_vec(),
            objective,
            gratings,
            constraints: cons,
        }
    }

    fn physics_constraints(
        &self,
        d: &Design,
        preds: &[GratingPrediction],
        cons: &mut Vec<ConstraintValue>,
    ) {
        let m = d.module.as_ref().expect("candidate has a module");
        let case_preds: Vec<&GratingPrediction> = preds
            .iter()
            .filter(|p| {
                p.core == self.core_name && p.insert.as_deref() == self.insert_name.as_deref()
            })
            .collect();
        let f = self.settings.max_force_n;
        let lim = self.settings.max_grating_strain;
        let worst = case_preds
            .iter()
            .map(|p| (p.strain.abs(), p.grating.as_str()))
            .fold((0.0, ""), |a, b| if b.0 > a.0 { b } else { a });
        push(
            cons,
            "grating_strain",
            format!("|grating strain| at {f} N ≤ {:.0} µε", lim * 1e6),
            (worst.0 - lim) / lim,
            format!("{:.0} µε at grating `{}`", worst.0 * 1e6, worst.1),
        );
        let mut excess_nm: f64 = 0.0;
        let mut detail = String::from("every grating inside its window");
        for (name, lo, hi) in &self.windows_nm {
            let Some(g) = m.gratings.iter().find(|g| &g.name == name) else {
                continue;
            };
            let shift_nm = case_preds
                .iter()
                .find(|p| &p.grating == name)
                .map(|p| p.sensitivity_pm_per_n * f * 1e-3)
                .unwrap_or(0.0);
            let thermal_nm = d
                .fiber
                .temperature_sensitivity_pm_per_k(g.bragg_wavelength_nm)
                * self.settings.temperature_span_k
                * 1e-3;
            let low = g.bragg_wavelength_nm + shift_nm.min(0.0) - thermal_nm;
            let high = g.bragg_wavelength_nm + shift_nm.max(0.0) + thermal_nm;
            let e = (lo - low).max(high - hi).max(0.0);
            if e > excess_nm {
                excess_nm = e;
                detail = format!(
                    "grating `{name}` spans {low:.3}–{high:.3} nm, its window is {lo:.3}–{hi:.3} nm"
                );
            }
        }
        push(
            cons,
            "wavelength_window",
            format!(
                "each grating's range at {f} N ± {} K inside its window (guard {} nm)",
                self.settings.temperature_span_k, self.settings.guard_band_nm
            ),
            excess_nm,
            detail,
        );
    }

    /// Penalised cost of an evaluation: −objective/scale when feasible; otherwise
    /// 1 + 10 × violation, plus 100 when the geometry itself fails. Feasible designs
    /// cost below 0 and infeasible ones above 1, and the problem keeps the best feasible
    /// design separately, so the penalty only has to steer the search.
    fn penalised(&self, e: &Evaluation) -> f64 {
        let (geometric, v) = e.infeasibility_rank();
        if v > 0.0 {
            1.0 + 10.0 * v + 100.0 * f64::from(geometric)
        } else {
            -self.merit(e)
        }
    }

    /// What the search maximises among feasible designs: the objective over the scale,
    /// less `TIE_WEIGHT` × the squared distance from the start in box units. Designs
    /// within ~0.1 % of each other tie, and a tie goes to the design closest to the
    /// start: when a constraint caps the objective (the grating strain usually does),
    /// a whole family of designs reaches the cap and the least change is the one to
    /// print.
    pub fn merit(&self, e: &Evaluation) -> f64 {
        let d2: f64 =
            e.x.iter()
                .zip(&self.x0)
                .zip(self.lo.iter().zip(&self.hi))
                .map(|((x, s), (l, h))| ((x - s) / (h - l)).powi(2))
                .sum();
        e.objective / self.scale - TIE_WEIGHT * d2
    }

    /// Bounds of the search box.
    pub fn box_bounds(&self) -> (Vec<f64>, Vec<f64>) {
        (self.lo.clone(), self.hi.clone())
    }

    /// Of the runs' best points (argmin's state), the feasible one of highest merit.
    pub fn best_feasible<'e>(&self, evals: &'e [Evaluation]) -> Option<&'e Evaluation> {
        evals
            .iter()
            .filter(|e| e.feasible())
            .max_by(|a, b| self.merit(a).total_cmp(&self.merit(b)))
    }

    /// Of the runs' best points, the one that violates the constraints least.
    pub fn least_violating<'e>(&self, evals: &'e [Evaluation]) -> Option<&'e Evaluation> {
        evals.iter().filter(|e| !e.feasible()).min_by(|a, b| {
            let (a, b) = (a.infeasibility_rank(), b.infeasibility_rank());
            a.0.cmp(&b.0).then(a.1.total_cmp(&b.1))
        })
    }
}

impl BoxProblem for ModuleProblem {
    fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
        self.box_bounds()
    }

    fn cost(&self, x: &[f64]) -> f64 {
        self.penalised(&self.evaluate(x))
    }
}

/// Summary of one run for the report.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// Solver.
    pub solver: SolverKind,
    /// Start index.
    pub start: usize,
    /// Iterations.
    pub iterations: u64,
    /// Cost evaluations.
    pub evaluations: u64,
    /// Wall time, s.
    pub time_s: f64,
    /// Objective at the run's best point (0 if infeasible).
    pub objective: f64,
    /// Whether the run's best point is feasible.
    pub feasible: bool,
    /// Termination reason.
    pub termination: String,
    /// Best penalised cost after each iteration.
    pub history: Vec<f64>,
}

/// Outcome of one discrete choice.
#[derive(Debug, Clone, Serialize)]
pub struct ChoiceResult {
    /// The choice.
    pub choice: Choice,
    /// Best feasible evaluation, if any.
    pub best: Option<Evaluation>,
    /// When nothing was feasible: the least violating evaluation.
    pub least_violating: Option<Evaluation>,
    /// Every run.
    pub runs: Vec<RunSummary>,
}

/// Outcome of a module optimisation.
#[derive(Debug, Clone, Serialize)]
pub struct ModuleOutcome {
    /// Objective.
    pub objective: Objective,
    /// Unit of the objective.
    pub objective_unit: &'static str,
    /// Variables, in the order of every `x`.
    pub variables: Vec<Variable>,
    /// Search bounds.
    pub lower_bounds: Vec<f64>,
    /// Search bounds.
    pub upper_bounds: Vec<f64>,
    /// The start design's choice and evaluation.
    pub start_choice: Choice,
    /// The start design evaluated (its objective is the bar to beat).
    pub start: Evaluation,
    /// The model that scored the answer, in words (the policy anchored on it).
    pub model: String,
    /// Index of the winning choice in `choices`.
    pub best_choice: usize,
    /// Every choice.
    pub choices: Vec<ChoiceResult>,
    /// The optimised design.
    #[serde(skip)]
    pub design: Design,
    /// Wall time of the whole optimisation, s.
    pub time_s: f64,
    /// Calibration used for the Q model.
    pub calibration: Calibration,
}

/// The discrete choices: cores × (inserts + hollow).
pub fn choices(
    base: &Design,
    lib: &MaterialLibrary,
    settings: &ModuleSettings,
) -> anyhow::Result<Vec<Choice>> {
    let m = module_of(base)?;
    let proc_ = base.printer.process;
    let cores: Vec<String> = match &settings.cores {
        Some(c) => c.clone(),
        None => {
            let mut c: Vec<String> = m.cores.iter().map(|c| c.material.clone()).collect();
            c.extend(lib.for_role(MaterialRole::Core, proc_));
            c
        }
    };
    let inserts: Vec<Option<String>> = match &settings.inserts {
        Some(i) => i
            .iter()
            .map(|s| if s == "none" { None } else { Some(s.clone()) })
            .collect(),
        None => {
            let mut i: Vec<Option<String>> =
                m.inserts.iter().map(|i| Some(i.material.clone())).collect();
            i.extend(
                lib.for_role(MaterialRole::Insert, proc_)
                    .into_iter()
                    .map(Some),
            );
            i.push(None);
            i
        }
    };
    anyhow::ensure!(
        !cores.is_empty(),
        "no core material to try: the list is empty"
    );
    anyhow::ensure!(
        !inserts.is_empty(),
        "no insert to try: the list is empty (use `none` for a hollow core)"
    );
    let mut out: Vec<Choice> = Vec::new();
    for c in &cores {
        for i in &inserts {
            let ch = Choice {
                core_material: c.clone(),
                insert_material: i.clone(),
            };
            if !out.contains(&ch) {
                out.push(ch);
            }
        }
    }
    Ok(out)
}

/// The start design's own choice: its first core's material and its first insert (or
/// hollow when it lists none).
pub fn start_choice(base: &Design) -> anyhow::Result<Choice> {
    let m = module_of(base)?;
    Ok(Choice {
        core_material: m
            .cores
            .first()
            .ok_or_else(|| anyhow::anyhow!("the design lists no core"))?
            .material
            .clone(),
        insert_material: m.inserts.first().map(|i| i.material.clone()),
    })
}

/// Check the settings an optimisation cannot run without.
fn check_settings(lib: &MaterialLibrary, settings: &ModuleSettings) -> anyhow::Result<()> {
    anyhow::ensure!(!lib.materials.is_empty(), "the material library is empty");
    anyhow::ensure!(
        settings.max_force_n.is_finite() && settings.max_force_n > 0.0,
        "--max-force-n must be a positive number of newtons, got {}",
        settings.max_force_n
    );
    anyhow::ensure!(
        settings.max_grating_strain.is_finite() && settings.max_grating_strain > 0.0,
        "the grating strain limit must be positive, got {}",
        settings.max_grating_strain
    );
    anyhow::ensure!(!settings.solvers.is_empty(), "no solver selected");
    Ok(())
}

/// What every choice's problem is built from.
struct ProblemInputs<'a> {
    base: &'a Design,
    lib: &'a MaterialLibrary,
    settings: &'a ModuleSettings,
    predictor: Predictor,
    /// Calibration of the Q model (identity unless a prototype was measured).
    cal: Calibration,
}

impl ProblemInputs<'_> {
    /// The problem of one discrete choice.
    fn problem(&self, choice: Choice) -> anyhow::Result<ModuleProblem> {
        ModuleProblem::new(
            self.base,
            choice,
            self.lib,
            self.settings,
            self.cal,
            self.predictor.clone(),
        )
    }

    /// Evaluate the start design, and calibrate the Q model on it when a verifier JSON
    /// of this design is given.
    fn evaluate_start(
        &mut self,
        start_ch: &Choice,
        measured: Option<&MeasuredPrototype>,
    ) -> anyhow::Result<Evaluation> {
        let probe = self.problem(start_ch.clone())?;
        let x0 = probe.start_point();
        let start = probe.evaluate(&x0);
        let (Some(meas), false) = (measured, start.gratings.is_empty()) else {
            return Ok(start);
        };
        // The lag is the same for every grating of a core; stiffening differs a little,
        // so the verifier's mean R² is matched against the mean model value.
        let n = start.gratings.len() as f64;
        let lin = start
            .gratings
            .iter()
            .map(|g| g.r_squared_linearity)
            .sum::<f64>()
            / n;
        let quality = &self.settings.quality;
        self.cal = meas.calibrate(start.gratings[0].lag_s, lin, quality);
        Ok(self.problem(start_ch.clone())?.evaluate(&x0))
    }

    /// Search one choice from several starts with every solver; keep its best feasible
    /// point (or the least violating one) and a summary of each run.
    fn optimise_choice(&self, ci: usize, ch: &Choice, scale: f64) -> anyhow::Result<ChoiceResult> {
        let settings = self.settings;
        let mut p = self.problem(ch.clone())?;
        p.set_scale(scale);
        let (lo, hi) = p.box_bounds();
        let seed = settings.seed ^ ci as u64;
        let starts = start_points(&p.start_point(), &lo, &hi, settings.extra_starts, seed);
        let seed = settings.seed.wrapping_add(ci as u64);
        let runs: Vec<Run> = multi_start(&p, &settings.solvers, &starts, seed, &settings.run)?;
        // The best point of each run comes from argmin's state; the start point
        // is a candidate too (every Nelder–Mead run starts there).
        let evals: Vec<Evaluation> = std::iter::once(p.evaluate(&p.start_point()))
            .chain(runs.iter().map(|r| p.evaluate(&r.best_x)))
            .collect();
        let summaries = runs
            .into_iter()
            .zip(&evals[1..])
            .map(|(r, e)| RunSummary {
                solver: r.solver,
                start: r.start,
                iterations: r.iterations,
                evaluations: r.evaluations,
                time_s: r.time_s,
                objective: if e.feasible() { e.objective } else { 0.0 },
                feasible: e.feasible(),
                termination: r.termination,
                history: r.history,
            })
            .collect();
        let best = p.best_feasible(&evals).cloned();
        let least = if best.is_none() {
            p.least_violating(&evals).cloned()
        } else {
            None
        };
        Ok(ChoiceResult {
            choice: ch.clone(),
            best,
            least_violating: least,
            runs: summaries,
        })
    }

    /// Refine the answer on the policy: try the choices of `order` (the best by
    /// estimated merit, `bi`, first) until one holds under the policy's own prediction.
    fn policy_refined(
        &self,
        choices: &[ChoiceResult],
        order: &[usize],
        bi: usize,
    ) -> anyhow::Result<(usize, ModuleProblem, Evaluation)> {
        let mut why = Vec::new();
        for &i in order
            .iter()
            .filter(|&&i| i == bi)
            .chain(order.iter().filter(|&&i| i != bi))
        {
            let p = self.problem(choices[i].choice.clone())?;
            let found = choices[i]
                .best
                .clone()
                .unwrap_or_else(|| p.evaluate(&p.start_point()));
            match policy_answer(p, found, self.settings) {
                Ok((p, e)) => return Ok((i, p, e)),
                Err(e) => why.push(format!("{}: {e:#}", choices[i].choice)),
            }
        }
        anyhow::bail!(
            "infeasible under the model policy's own prediction: {}",
            why.join("; ")
        )
    }
}

/// The feasible choices in the order the policy tries them: by estimated merit (at
/// most four), then the start's own choice. Every choice shares the start point and
/// the box, so merits compare across choices too.
fn policy_order(choices: &[ChoiceResult], ranker: &ModuleProblem, start_ch: &Choice) -> Vec<usize> {
    let mut order: Vec<usize> = choices
        .iter()
        .enumerate()
        .filter(|(_, c)| c.best.is_some())
        .map(|(i, _)| i)
        .collect();
    order.sort_by(|&a, &b| {
        let m = |i: usize| ranker.merit(choices[i].best.as_ref().expect("filtered"));
        m(b).total_cmp(&m(a))
    });
    order.truncate(4);
    if let Some(si) = choices.iter().position(|c| &c.choice == start_ch) {
        if !order.contains(&si) {
            order.push(si);
        }
    }
    order
}

/// The optimised design at the winner's point, named and described after its start,
/// and validated.
fn optimised_design(
    base: &Design,
    settings: &ModuleSettings,
    (p, best, win): (&ModuleProblem, &Evaluation, &Choice),
    start_objective: f64,
) -> anyhow::Result<Design> {
    let mut design = p.design_at(&best.x);
    design.name = format!("{}-optimised", base.name.trim_end_matches("-optimised"));
    design.description = Some(format!(
        "Optimised by fbgforge optimize from `{}` for {} ({}): {} = {:.4} {} (start {:.4})",
        base.name,
        match settings.objective {
            Objective::Q => "Q",
            Objective::Sensitivity => "sensitivity",
        },
        win,
        match settings.objective {
            Objective::Q => "Q",
            Objective::Sensitivity => "|K|",
        },
        best.objective,
        settings.objective.unit(),
        start_objective
    ));
    design
        .validate()
        .map_err(|e| anyhow::anyhow!("internal: the optimised design does not validate: {e}"))?;
    Ok(design)
}

/// Optimise a module design. `progress` hears one stage with one step per choice.
pub fn optimise_module(
    base: &Design,
    lib: &MaterialLibrary,
    settings: &ModuleSettings,
    measured: Option<&MeasuredPrototype>,
    predictor: Predictor,
    progress: &dyn Progress,
) -> anyhow::Result<ModuleOutcome> {
    let t0 = Instant::now();
    check_settings(lib, settings)?;
    let start_ch = start_choice(base)?;
    let mut inputs = ProblemInputs {
        base,
        lib,
        settings,
        predictor,
        cal: Calibration::identity(&settings.quality),
    };
    let start = inputs.evaluate_start(&start_ch, measured)?;
    let scale = if start.feasible() && start.objective > 0.0 {
        start.objective
    } else {
        1.0
    };
    let list = choices(base, lib, settings)?;
    progress.begin("optimise", list.len() as u64);
    let results: Vec<anyhow::Result<ChoiceResult>> = list
        .par_iter()
        .enumerate()
        .map(|(ci, ch)| {
            let r = inputs.optimise_choice(ci, ch, scale)?;
            progress.advance(1);
            Ok(r)
        })
        .collect();
    progress.end();
    let mut choices_done: Vec<ChoiceResult> = results.into_iter().collect::<anyhow::Result<_>>()?;
    // Near-ties of merit go to the least change from the start.
    let mut ranker = inputs.problem(start_ch.clone())?;
    ranker.set_scale(scale);
    let best_choice = choices_done
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.best.as_ref().map(|b| (i, ranker.merit(b))))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i);
    let Some(bi) = best_choice else {
        return Err(infeasible_error(&choices_done, settings));
    };
    // Away from its anchor the optimiser's K is an estimate (closed-form trend, FE level
    // at the anchor); the answer is refined on the policy itself, so what is reported
    // and written is the policy's own prediction of the design.
    let order = policy_order(&choices_done, &ranker, &start_ch);
    let (bi, p, best_eval) = inputs.policy_refined(&choices_done, &order, bi)?;
    // The other choices keep their estimated answers; the winner's is the policy's.
    choices_done[bi].best = Some(best_eval.clone());
    let winner = (&p, &best_eval, &choices_done[bi].choice);
    let design = optimised_design(base, settings, winner, start.objective)?;
    Ok(ModuleOutcome {
        objective: settings.objective,
        objective_unit: settings.objective.unit(),
        variables: p.variables.clone(),
        lower_bounds: p.lo.clone(),
        upper_bounds: p.hi.clone(),
        start_choice: start_ch,
        start,
        model: p.model_description().to_string(),
        best_choice: bi,
        choices: choices_done,
        design,
        time_s: t0.elapsed().as_secs_f64(),
        calibration: inputs.cal,
    })
}

/// The winning choice's answer as the policy predicts it. Away from its anchor the
/// optimiser's model is an estimate (closed-form trend, FE level at the anchor), and in
/// Case I the closed form's trend can be far off the FE's. So the answer is refined by
/// a trust region on the policy itself: anchor on the current design with a
/// first-order correction (value and slope of the policy's K there, one anchoring per
/// variable), search that estimate within a box around it, score the step by the
/// policy anchored on the step; accept it when the policy agrees it is better (and
/// feasible), widen the box when the estimate was right, shrink it when not. Each
/// anchoring costs one FE solve per configuration. The global search's answer is a
/// candidate too.
fn policy_answer(
    p: ModuleProblem,
    found: Evaluation,
    settings: &ModuleSettings,
) -> anyhow::Result<(ModuleProblem, Evaluation)> {
    let (lo, hi) = p.box_bounds();
    let exact = |x: &[f64]| -> anyhow::Result<(ModuleProblem, Evaluation)> {
        let q = p.anchored_at(x)?;
        let e = q.evaluate(x);
        Ok((q, e))
    };
    // The problem is anchored on its start, so the start is scored exactly.
    let x0 = p.start_point();
    let mut cur = (p.clone(), p.evaluate(&x0));
    // Feasible beats infeasible; between feasible designs the objective decides,
    // between infeasible ones the smaller violation (so a start the policy finds
    // infeasible can be walked into the feasible region).
    let better = |a: &Evaluation, b: &Evaluation| match (a.feasible(), b.feasible()) {
        (true, false) => true,
        (false, true) => false,
        (true, true) => a.objective > b.objective,
        (false, false) => a.total_violation() < b.total_violation(),
    };
    let cand = exact(&found.x)?;
    if better(&cand.1, &cur.1) {
        cur = cand;
    }
    let mut radius = 0.25;
    for k in 0..24u64 {
        let xc = cur.1.x.clone();
        let (tl, th): (Vec<f64>, Vec<f64>) = xc
            .iter()
            .zip(lo.iter().zip(&hi))
            .map(|(x, (l, h))| {
                let d = radius * (h - l);
                ((x - d).max(*l), (x + d).min(*h))
            })
            .unzip();
        let q = cur.0.corrected_at(&xc)?.within(tl, th);
        let runs = multi_start(
            &q,
            &settings.solvers,
            std::slice::from_ref(&xc),
            settings.seed.wrapping_add(1000 + k),
            &settings.run,
        )?;
        let evals: Vec<Evaluation> = runs.iter().map(|r| q.evaluate(&r.best_x)).collect();
        let step = q
            .best_feasible(&evals)
            .filter(|t| !cur.1.feasible() || t.objective > cur.1.objective * (1.0 + 1e-9))
            .cloned();
        match step {
            Some(t) => {
                let trial = exact(&t.x)?;
                if better(&trial.1, &cur.1) {
                    let predicted = t.objective - cur.1.objective;
                    let actual = trial.1.objective - cur.1.objective;
                    if cur.1.feasible() && actual > 0.75 * predicted {
                        radius = (2.0 * radius).min(0.5);
                    }
                    cur = trial;
                } else {
                    radius *= 0.5;
                }
            }
            None => radius *= 0.5,
        }
        if radius < 1e-4 {
            break;
        }
    }
    anyhow::ensure!(
        cur.1.feasible(),
        "infeasible: under the model policy's own prediction neither the optimised design nor the start meets every constraint ({})",
        cur.1
            .constraints
            .iter()
            .filter(|c| c.violation > 0.0)
            .map(|c| format!("{}: {}", c.name, c.detail))
            .collect::<Vec<_>>()
            .join("; ")
    );
    Ok(cur)
}

/// Name the constraint that cannot be met: across choices, the one violated at the
/// least violating design (by its largest share of the violation).
fn infeasible_error(choices: &[ChoiceResult], settings: &ModuleSettings) -> anyhow::Error {
    let least = choices
        .iter()
        .filter_map(|c| c.least_violating.as_ref().map(|e| (c, e)))
        .min_by(|a, b| {
            let (ra, rb) = (a.1.infeasibility_rank(), b.1.infeasibility_rank());
            ra.0.cmp(&rb.0).then(ra.1.total_cmp(&rb.1))
        });
    match least {
        None => anyhow::anyhow!("infeasible: no candidate design could be evaluated"),
        Some((c, e)) => {
            let worst = e
                .constraints
                .iter()
                .filter(|c| c.violation > 0.0)
                .max_by(|a, b| a.violation.total_cmp(&b.violation))
                .expect("infeasible evaluations violate something");
            let vars: Vec<String> = settings
                .vary
                .iter()
                .zip(&e.x)
                .map(|(v, x)| format!("{} = {x:.3}", v.name()))
                .collect();
            anyhow::anyhow!(
                "infeasible: constraint `{}` cannot be met ({}); the closest design ({}, {}) has {}",
                worst.name,
                worst.requirement,
                c.choice,
                vars.join(", "),
                worst.detail
            )
        }
    }
}

/// One point of a landscape.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LandscapePoint {
    /// Value of the first variable.
    pub a: f64,
    /// Value of the second variable.
    pub b: f64,
    /// Objective (NaN where the geometry or the model fails).
    pub objective: f64,
    /// Whether every constraint is met.
    pub feasible: bool,
}

/// Objective over a grid of two variables around a point (others fixed), for the
/// landscape plot. Infeasible points keep their objective when the model could
/// evaluate them (strain or window broken), so the plot shows what the limits cut off.
pub fn landscape(
    p: &ModuleProblem,
    at: &[f64],
    a: usize,
    b: usize,
    steps: usize,
) -> Vec<LandscapePoint> {
    let (lo, hi) = p.box_bounds();
    let steps = steps.max(2);
    let cells: Vec<(f64, f64)> = (0..steps)
        .flat_map(|i| {
            let va = lo[a] + (hi[a] - lo[a]) * i as f64 / (steps - 1) as f64;
            let (lb, hb) = (lo[b], hi[b]);
            (0..steps).map(move |j| (va, lb + (hb - lb) * j as f64 / (steps - 1) as f64))
        })
        .collect();
    cells
        .par_iter()
        .map(|&(va, vb)| {
            let mut x = at.to_vec();
            x[a] = va;
            x[b] = vb;
            let e = p.evaluate(&x);
            LandscapePoint {
                a: va,
                b: vb,
                objective: if e.gratings.is_empty() {
                    f64::NAN
                } else {
                    e.objective
                },
                feasible: e.feasible(),
            }
        })
        .collect()
}
