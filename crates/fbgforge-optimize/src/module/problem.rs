//! The problem of one discrete choice ([`ModuleProblem`], a [`BoxProblem`]): the
//! search box, the model anchored on the start (or corrected around a point for the
//! trust region), the penalised cost the solvers see, and the merit that ranks feasible
//! designs.

use super::choice::{module_of, Choice};
use super::outcome::Evaluation;
use super::predictor::{PredictFn, Predictor};
use super::robust::UncertaintyRatios;
use super::settings::ModuleSettings;
use super::variables::Variable;
use crate::materials::MaterialLibrary;
use crate::model::{Configuration, GratingPrediction, LoadCase};
use crate::quality::Calibration;
use crate::solvers::BoxProblem;
use crate::spec::{Core, Design, GratingRole, Insert, Module};
use std::sync::Arc;

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

/// Weight of the tie-break toward the start design (see [`ModuleProblem::merit`]).
pub const TIE_WEIGHT: f64 = 1e-3;

/// A linear correction of the anchored estimate around `center`: per grating row
/// (grating, case, insert), the relative slope of the policy's K against it along each
/// variable.
#[derive(Debug, Clone)]
pub(super) struct Correction {
    center: Vec<f64>,
    rows: Vec<(RowKey, Vec<f64>)>,
}

/// A prediction row's identity: grating, case, insert.
type RowKey = (String, LoadCase, Option<String>);

impl Correction {
    pub(super) fn apply(&self, x: &[f64], preds: &mut [GratingPrediction]) {
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
            // A linear factor is trusted near its centre only (the trust region
            // checks every step on the policy); it may cross zero, since the policy's K
            // can change sign where the closed form's trend cannot.
            let f = f.clamp(-5.0, 5.0);
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
    /// Lower bounds of the search box, in `variables` order.
    pub(super) lo: Vec<f64>,
    /// Upper bounds of the search box.
    pub(super) hi: Vec<f64>,
    /// The start design.
    pub(super) base: Design,
    /// The start design with this choice's materials, core, inserts and gratings: what
    /// the derivation rules fill in.
    pub(super) template: Design,
    /// The core under optimisation.
    pub(super) core_name: String,
    /// Its insert's name (None: hollow).
    pub(super) insert_name: Option<String>,
    /// The material library (the Q model's numbers).
    pub(super) lib: MaterialLibrary,
    /// The optimisation's settings.
    pub(super) settings: ModuleSettings,
    /// Calibration of the Q model.
    pub(super) calibration: Calibration,
    /// Builds the model anchored on a design.
    predictor: Predictor,
    /// The model as anchored (on the start, or where `anchored_at` put it).
    pub(super) model: PredictFn,
    /// That model in words.
    model_description: String,
    /// First-order correction of the anchored estimate (the trust region's).
    pub(super) correction: Option<Correction>,
    /// The model's uncertainty about K as ratios to the nominal (from the readings at
    /// the last full anchoring, or carried from the start's).
    pub(super) uncertainty: UncertaintyRatios,
    /// Where the model was last anchored with its readings (its numbers there are the
    /// policy's own).
    anchor_x: Option<Vec<f64>>,
    /// Each grating's wavelength window (name, lower, upper), nm.
    pub(super) windows_nm: Vec<(String, f64, f64)>,
    /// Normalises the objective in the cost.
    scale: f64,
    /// The start point.
    x0: Vec<f64>,
}

/// The start design as `choice` makes it: its first core in the choice's material, the
/// choice's insert (or none), the gratings of that core and the reference, the
/// materials it uses (from the design, else the library); with the core's name and
/// the gratings' wavelength windows.
#[allow(clippy::type_complexity)]
fn template_for(
    base: &Design,
    choice: &Choice,
    lib: &MaterialLibrary,
    settings: &ModuleSettings,
) -> anyhow::Result<(Design, String, Vec<(String, f64, f64)>)> {
    let m = module_of(base)?;
    let core0 = m
        .cores
        .first()
        .ok_or_else(|| anyhow::anyhow!("the design lists no core"))?;
    let mut t = base.clone();
    let tm = t.module.as_mut().expect("checked above");
    // The family rule: every candidate keeps the start's contact ratios.
    tm.restate_contact_relative();
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
    tm.inserts = choice
        .insert_material
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
    Ok((t, core0.name.clone(), windows_nm))
}

/// The search box of the varied variables: each one's default range around the start
/// module (or the settings' bounds), checked; every bound names a varied variable.
fn search_box(
    m: &Module,
    settings: &ModuleSettings,
    min_wall: f64,
) -> anyhow::Result<(Vec<f64>, Vec<f64>)> {
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
                "a bound is given for `{}`, which is not in ModuleSettings.vary",
                v.name()
            );
        }
    }
    Ok((lo, hi))
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
        let (template, core_name, windows_nm) = template_for(base, &choice, lib, settings)?;
        let (lo, hi) = search_box(module_of(base)?, settings, base.printer.min_wall_mm)?;
        let mut p = ModuleProblem {
            core_name,
            insert_name: choice.insert_material.clone(),
            choice,
            variables: settings.vary.clone(),
            lo,
            hi,
            base: base.clone(),
            template,
            lib: lib.clone(),
            settings: settings.clone(),
            calibration,
            predictor: predictor.clone(),
            model: Arc::new(|_: &Design, _: f64| anyhow::bail!("the model is not anchored yet")),
            model_description: String::new(),
            correction: None,
            uncertainty: UncertaintyRatios::default(),
            anchor_x: None,
            windows_nm,
            scale: 1.0,
            x0: Vec::new(),
        };
        p.x0 = p.start_point();
        (p.model, p.model_description) = predictor.anchored_on(&p.design_at(&p.x0))?;
        Ok(p)
    }

    /// The configuration under optimisation.
    pub fn configuration(&self) -> Configuration {
        Configuration {
            core: self.core_name.clone(),
            case: if self.insert_name.is_some() {
                LoadCase::I
            } else {
                LoadCase::II
            },
            insert: self.insert_name.clone(),
        }
    }

    /// The same problem with the model anchored on the design at `x` with the policy's
    /// readings there: its K, the contact window's ends and the bounding readings at
    /// `x` are the policy's own.
    pub(crate) fn anchored_at(&self, x: &[f64]) -> anyhow::Result<Self> {
        let mut p = self.clone();
        let (model, name, readings) = self
            .predictor
            .anchored_with_readings(&self.design_at(x), &self.configuration())?;
        (p.model, p.model_description) = (model, name);
        if let Some(r) = readings {
            p.uncertainty = self
                .uncertainty
                .clone()
                .merged(&UncertaintyRatios::from_readings(&r));
        }
        p.correction = None;
        p.anchor_x = Some(x.to_vec());
        Ok(p)
    }

    /// The same problem with the model anchored on the design at `x` for its nominal K
    /// only (one FE solve per configuration), keeping the uncertainty ratios it has.
    pub(crate) fn anchored_nominal_at(&self, x: &[f64]) -> anyhow::Result<Self> {
        let mut p = self.clone();
        (p.model, p.model_description) = self.predictor.anchored_on(&self.design_at(x))?;
        p.correction = None;
        p.anchor_x = None;
        Ok(p)
    }

    /// The same problem with `u` as its uncertainty ratios (e.g. the start's, carried
    /// to another choice until its candidates are scored exactly).
    pub fn with_uncertainty(&self, u: &UncertaintyRatios) -> Self {
        let mut p = self.clone();
        p.uncertainty = self.uncertainty.clone().merged(u);
        p
    }

    /// The uncertainty ratios of the problem.
    pub fn uncertainty(&self) -> &UncertaintyRatios {
        &self.uncertainty
    }

    /// Whether an evaluation at `x` gives the model's own numbers, not an estimate: a
    /// plain function is the model; the policy is only at its full anchor.
    pub(super) fn is_exact_at(&self, x: &[f64]) -> bool {
        matches!(self.predictor, Predictor::Function(_))
            || (self.correction.is_none() && self.anchor_x.as_deref() == Some(x))
    }

    /// The model anchored at `x` with a first-order correction: the ratio of the
    /// policy's K to the anchored estimate is measured a step along each variable (one
    /// anchoring each) and applied as a linear factor, so the estimate has the
    /// policy's value and slope at `x` (what a trust region needs to converge).
    pub(crate) fn corrected_at(&self, x: &[f64]) -> anyhow::Result<Self> {
        let mut p = self.anchored_at(x)?;
        if matches!(self.predictor, Predictor::Function(_)) {
            return Ok(p);
        }
        let at = |q: &ModuleProblem, x: &[f64]| -> anyhow::Result<Vec<GratingPrediction>> {
            (q.model)(&q.design_at(x), 1.0)
        };
        let base = at(&p, x)?;
        // The slopes need the nominal only: the readings' ratios to it are held
        // within the trust region.
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
            let exact = at(&p.anchored_nominal_at(&xs)?, &xs)?;
            for (i, e) in estimate.iter().enumerate() {
                let t = exact
                    .iter()
                    .find(|t| t.grating == e.grating && t.case == e.case && t.insert == e.insert);
                if let (Some(t), true) = (t, e.sensitivity_pm_per_n != 0.0) {
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
    pub(crate) fn set_scale(&mut self, scale: f64) {
        self.scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            1.0
        };
    }

    /// Smallest printable fit clearance, mm: the settings' or the printer's resolution.
    pub(super) fn min_fit_clearance_mm(&self) -> f64 {
        self.settings
            .min_fit_clearance_mm
            .unwrap_or(self.base.printer.resolution_mm)
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
    pub(crate) fn box_bounds(&self) -> (Vec<f64>, Vec<f64>) {
        (self.lo.clone(), self.hi.clone())
    }

    /// Of the runs' best points (argmin's state), the feasible one of highest merit.
    pub(crate) fn best_feasible<'e>(&self, evals: &'e [Evaluation]) -> Option<&'e Evaluation> {
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
