//! The one model policy: every command that needs a grating's predicted sensitivity
//! (`predict`, `sweep`, `verify`'s verdict, `optimize`'s objective and constraints)
//! asks [`predict`] here (the optimiser through [`Anchored`], built by the same
//! policy), so no two commands can answer the same design with two models. Each row
//! names the model that produced it.
//!
//! The policy ([`FidelityChoice::Auto`]):
//! - **Case II**: the closed form inside its measured validity region ([`validity`]),
//!   the finite-element model outside it.
//! - **Case I**: the finite-element model with the design's contact reading
//!   (`[module.contact]`: by default the cylinders slide above the base clip and the
//!   domes bear on each other within 1.376 × the apex patch; docs/model.md §5.6). The
//!   closed form is nowhere within 8 % of any FE reading in Case I (docs/model.md §9).
//! - **Band** (on request): every row carries the range of K between the physically
//!   bounding contact readings, both FE: pillars bonded (most coupled) and cylinders
//!   sliding with the domes touching over the apex patch only (least coupled).
//!
//! The closed form is always evaluated (microseconds) because it also gives the
//! details the FE solve does not (load share, reference grating); rows that go to the
//! FE model keep those details but take K, strain and shifts from the FE solve. Each FE
//! configuration (core, case, insert, reading) is solved once, at 1 N, in parallel.

mod error;
mod rows;
mod run;
pub mod spectrum;
mod statements;
mod uncertainty;

pub use error::{
    design_interval, modelling_fraction, ErrorSource, IntervalReadings, LimitCheck, ModelError,
    DISCRETISATION_FLOOR, MAX_MODEL_ERROR, STRAIN_MARGIN_FRACTION,
};

pub use run::{
    paper_figures, predict_into, sweep, FigureSwept, PaperFiguresRequest, PredictSink, Predicted,
    RunError, Spacing, SweepRequest, SweepSink, Swept, Trend, AUTO_LOG_RATIO,
};
pub use statements::{check_paper_statements, PaperStatements, StatementCheck, UP_TO_TWICE_MAX};
pub use uncertainty::{readings, with_contact_ratio, KReadings, ReadingsRequest, Robustness};

use crate::fem::{solve_configuration, ContactReading, FemOptions, GeometryCache};
use crate::model::{
    self, Configuration, DetailedPrediction, GratingPrediction, LoadCase, PredictOptions,
};
use crate::profile::ModuleProfile;
use crate::spec::Design;
use anyhow::{Context, Result};
use serde::Serialize;

/// The closed form's error bound claimed by the paper.
pub const TOLERANCE: f64 = 0.08;

/// The warning every Case I row resting on the shipped default contact radius carries.
pub const DEFAULT_CONTACT_WARNING: &str = "contact radius by the family rule, chosen so that the FE model meets the paper's statements on the 34 mm module, not measured: calibrate with `verify VerifyRequest.calibrate_into`";

/// Outer diameters over which the closed form was compared with the FE model, mm
/// (the `fem` study's grid, 10 to 40 mm).
pub(crate) const MEASURED_DIAMETER_RANGE_MM: (f64, f64) = (10.0, 40.0);

/// Which model answers a prediction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fidelity {
    /// The closed-form model (microseconds).
    ClosedForm,
    /// The finite-element model (a fraction of a second per configuration).
    Fem,
}

impl Fidelity {
    /// The name printed in tables and reports.
    pub fn name(self) -> &'static str {
        match self {
            Fidelity::ClosedForm => "closed-form",
            Fidelity::Fem => "fem",
        }
    }
}

/// Which model `predict` should use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FidelityChoice {
    /// The policy: Case II by the closed form inside its measured validity region,
    /// everything else by the FE model with the design's contact reading.
    Auto,
    /// The closed form everywhere.
    ClosedForm,
    /// The finite-element model (design's contact reading) everywhere.
    Fem,
}

impl FidelityChoice {
    /// The model used for `case` of `design`.
    pub fn resolve(self, design: &Design, case: LoadCase) -> Fidelity {
        match self {
            FidelityChoice::Auto => choose_fidelity_for(design, case),
            FidelityChoice::ClosedForm => Fidelity::ClosedForm,
            FidelityChoice::Fem => Fidelity::Fem,
        }
    }
}

/// The contact readings behind a row's band, K in pm/N.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BandReadings {
    /// FE, pillars bonded to cap and core, domes tied over the apex patch.
    pub bonded_pillars_pm_per_n: f64,
    /// FE, cylinders sliding above the base clip, domes touching over the apex patch only.
    pub sliding_apex_patch_pm_per_n: f64,
}

/// One grating prediction and the model that produced it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelledPrediction {
    /// The model that produced K, strain and shifts of this row.
    pub model: Fidelity,
    /// The model in words, with the contact reading for FE rows.
    pub model_description: String,
    /// The range of K (pm/N, low then high) between the physically bounding contact
    /// readings ([`BandReadings`]) and the nominal K; `None` when the caller did not ask.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band_pm_per_n: Option<[f64; 2]>,
    /// The readings that make the band.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band_readings: Option<BandReadings>,
    /// The nominal K's stated error as a fraction of |K| (`model_error.total_fraction`):
    /// `None` only for the closed form in Case I, which states none (docs/model.md §5.8).
    pub model_error_fraction: Option<f64>,
    /// Its parts: discretisation and modelling, and what the modelling term is for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model_error: Option<ModelError>,
    /// The interval the design is held to, pm/N (low, high by value): every reading
    /// the spec implies, each widened by its own model's error; it contains the
    /// nominal. `None` when the caller did not ask (`PredictionRequest.design_interval`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub design_interval_pm_per_n: Option<[f64; 2]>,
    /// The readings that make the design interval.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub design_interval_readings: Option<IntervalReadings>,
    /// The strain at the design's largest force from the far end of the design
    /// interval, against the strain limit, with its margin.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limit_check: Option<LimitCheck>,
    /// The policy mesh level (`FemOptions::mesh_level`) the row's FE readings were
    /// solved at: the level asked for, or finer where the policy refined the row's
    /// configuration to state an error within [`MAX_MODEL_ERROR`]
    /// (`PredictionRequest.refine_to_level`). `None` for a row without FE readings or on a
    /// custom mesh.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh_level: Option<u32>,
    /// The reflection spectrum the grating will make over the design's force range
    /// (transfer-matrix model on the FE strain profile along it); `None` unless asked
    /// (`PredictionRequest.spectrum`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spectrum: Option<spectrum::GratingSpectrum>,
    /// The prediction. For FE rows `core_load_share` is NaN (null in JSON): the FE
    /// model does not split the force into the closed form's paths.
    #[serde(flatten)]
    pub detail: DetailedPrediction,
}

impl ModelledPrediction {
    /// Whether `k_pm_per_n` lies inside the band (false when there is none).
    pub fn band_contains(&self, k_pm_per_n: f64) -> bool {
        self.band_pm_per_n
            .is_some_and(|[lo, hi]| k_pm_per_n >= lo && k_pm_per_n <= hi)
    }

    /// The bounding readings widened by the row's model error (low, high by value);
    /// `None` without a band or a stated error.
    pub fn widened_readings(&self) -> Option<[f64; 2]> {
        let (b, f) = (self.band_readings?, self.model_error_fraction?);
        let (x, y) = (b.bonded_pillars_pm_per_n, b.sliding_apex_patch_pm_per_n);
        let (lo, hi) = (x.min(y), x.max(y));
        Some([lo - f * lo.abs(), hi + f * hi.abs()])
    }

    /// Whether the nominal K lies inside its bounding readings widened by its model
    /// error (`None` when there is nothing to check it against).
    pub fn nominal_contained(&self) -> Option<bool> {
        let [lo, hi] = self.widened_readings()?;
        let k = self.detail.prediction.sensitivity_pm_per_n;
        Some(k >= lo && k <= hi)
    }
}

/// Predict every strain grating (of `case` only, when given) with the model `choice`
/// picks per configuration. FE rows are solved with `fem_options` (mesh and solver;
/// the contact choices come from the design).
pub fn predict_with_fidelity(
    design: &Design,
    opts: &PredictOptions,
    choice: FidelityChoice,
    case: Option<LoadCase>,
    fem_options: &FemOptions,
) -> Result<Vec<ModelledPrediction>> {
    predict(
        design,
        &PredictionRequest {
            force_n: opts.force_n,
            delta_t_k: opts.delta_t_k,
            case,
            insert: None,
            core: None,
            fidelity: choice,
            band: false,
            design_interval: false,
            spectrum: false,
            fem_options: *fem_options,
            // The mesh exactly as the caller gives it.
            refine_to_level: None,
            cache: GeometryCache::default(),
        },
    )
}

fn config_of(p: &GratingPrediction) -> Configuration {
    Configuration {
        core: p.core.clone(),
        case: p.case,
        insert: p.insert.clone(),
    }
}

/// Replace the closed-form numbers of `d` with those of an FE strain per newton.
fn apply_fem_strain(
    d: &mut DetailedPrediction,
    design: &Design,
    opts: &PredictOptions,
    strain_per_n: f64,
) {
    let optics = &design.fiber;
    let lambda = d.bragg_wavelength_nm;
    let f = opts.force_n;
    let k = optics.shift_pm(lambda, strain_per_n, 0.0);
    let strain = strain_per_n * f;
    let raw = optics.shift_pm(lambda, strain, opts.delta_t_k);
    // Compensation subtracts a term that does not depend on the sensor's strain.
    if let Some(c) = d.compensated_shift_pm.as_mut() {
        *c += raw - d.raw_shift_pm;
    }
    d.raw_shift_pm = raw;
    d.core_load_share = f64::NAN;
    let p = &mut d.prediction;
    p.sensitivity_pm_per_n = k;
    p.shift_pm = k * f;
    p.strain = strain;
    // The closed form's warnings are about its own assumptions (thin shell, edge
    // zones, the dome gap); the FE model has only the linear-range limits.
    p.warnings.clear();
    if f < 0.0 {
        p.warnings
            .push("a pulling force lifts the module off its support: both cases need F ≥ 0".into());
    }
    if strain.abs() > model::validity::GRATING_MAX_STRAIN {
        p.warnings.push(format!(
            "grating strain beyond ±{:.0} µε (a third of the 1 % proof test): not reliably linear",
            model::validity::GRATING_MAX_STRAIN * 1e6
        ));
    }
}

/// The predictor a parametric sweep uses for `choice` (`None` for the closed form,
/// which the sweep calls itself): each step answered as `predict --fidelity` would,
/// its FE structures kept in `cache` from step to step (the sweep owns it).
pub fn sweep_predictor(
    choice: FidelityChoice,
    case: Option<LoadCase>,
    fem_options: FemOptions,
    cache: GeometryCache,
) -> Option<Box<model::sweep::Predictor<'static>>> {
    sweep_predictor_with_band(choice, case, fem_options, false, cache)
}

/// [`sweep_predictor`], with each step's band when `band` is set (two more FE solves
/// per configuration and step).
pub fn sweep_predictor_with_band(
    choice: FidelityChoice,
    case: Option<LoadCase>,
    fem_options: FemOptions,
    band: bool,
    cache: GeometryCache,
) -> Option<Box<model::sweep::Predictor<'static>>> {
    if choice == FidelityChoice::ClosedForm {
        return None;
    }
    Some(Box::new(move |d, o| {
        predict(
            d,
            &PredictionRequest {
                force_n: o.force_n,
                delta_t_k: o.delta_t_k,
                case,
                fidelity: choice,
                band,
                fem_options,
                cache: cache.clone(),
                ..Default::default()
            },
        )
        .map(|rows| {
            rows.into_iter()
                .map(|r| model::sweep::SweepPoint {
                    readings_pm_per_n: r
                        .band_readings
                        .map(|b| [b.bonded_pillars_pm_per_n, b.sliding_apex_patch_pm_per_n]),
                    band_pm_per_n: r.band_pm_per_n,
                    prediction: r.detail.prediction,
                })
                .collect()
        })
        .map_err(|e| format!("{e:#}"))
    }))
}

/// Where the closed form is within [`TOLERANCE`] of the FE model, per case, as
/// measured by the `fem` study's comparison (see docs/fem.md for the table it comes from).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ValidityRegion {
    /// Smallest and largest outer diameter measured, mm.
    pub diameter_range_mm: (f64, f64),
    /// Largest core wall-to-radius ratio t/R for which Case II stays within tolerance.
    pub max_wall_to_radius_case_ii: f64,
    /// Largest t/R for which Case I (every insert of the paper) stays within tolerance;
    /// 0 when no measured Case I point does.
    pub max_wall_to_radius_case_i: f64,
    /// Relative error bound, e.g. 0.08.
    pub tolerance: f64,
}

/// The measured validity region of the closed form.
///
/// Measured by the `fem` study (`cargo run --release -p fbgforge-studies -- fem`) (table in docs/fem.md §6 and docs/model.md §9,
/// level-1 meshes; re-run after the profile put the domes one clearance apart): every
/// Case II grid point, D = 10 to 40 mm, t/R = 0.050 to 0.649, is within −0.93 % to
/// +3.49 % of the FE model, so Case II is trusted up to the largest t/R measured. No
/// Case I grid point is within 8 % (the closed form's series load path through a base
/// clip is not how a body with bonded pillars carries the load), so Case I always goes
/// to the FE model.
pub fn validity() -> ValidityRegion {
    ValidityRegion {
        diameter_range_mm: MEASURED_DIAMETER_RANGE_MM,
        max_wall_to_radius_case_ii: 0.65,
        max_wall_to_radius_case_i: 0.0,
        tolerance: TOLERANCE,
    }
}

impl ValidityRegion {
    /// Whether the closed form is trusted for `case` on `design`.
    pub(crate) fn contains_case(&self, design: &Design, case: LoadCase) -> bool {
        let Some(m) = &design.module else {
            return false;
        };
        let p = ModuleProfile::from_module(m);
        let ratio = m.core_wall_mm / (0.5 * (p.core_outer_radius_mm + p.core_inner_radius_mm));
        let d = m.outer_diameter_mm;
        if d < self.diameter_range_mm.0 || d > self.diameter_range_mm.1 {
            return false;
        }
        let limit = match case {
            LoadCase::I => self.max_wall_to_radius_case_i,
            LoadCase::II => self.max_wall_to_radius_case_ii,
        };
        ratio > 0.0 && ratio <= limit
    }

    /// Whether the closed form is trusted for every configuration of `design`
    /// (Case II always; Case I when the design lists inserts).
    pub fn contains(&self, design: &Design) -> bool {
        let Some(m) = &design.module else {
            return false;
        };
        self.contains_case(design, LoadCase::II)
            && (m.inserts.is_empty() || self.contains_case(design, LoadCase::I))
    }
}

/// The model `--fidelity auto` uses for one case of `design`.
pub fn choose_fidelity_for(design: &Design, case: LoadCase) -> Fidelity {
    if validity().contains_case(design, case) {
        Fidelity::ClosedForm
    } else {
        Fidelity::Fem
    }
}

/// The model `--fidelity auto` uses for `design`: the closed form inside its measured
/// validity region, the FE model outside it.
pub fn choose_fidelity(design: &Design) -> Fidelity {
    if validity().contains(design) {
        Fidelity::ClosedForm
    } else {
        Fidelity::Fem
    }
}

/// What a caller asks of the model policy.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictionRequest {
    /// Force at the apex, N (shifts and strains are given at this force).
    pub force_n: f64,
    /// Temperature change from the reference, K.
    pub delta_t_k: f64,
    /// One load case only, or every configuration of the design.
    pub case: Option<LoadCase>,
    /// Case I with this insert only (Case II rows are kept unless `case` drops them).
    pub insert: Option<String>,
    /// Gratings of this core only.
    pub core: Option<String>,
    /// Which model answers: [`FidelityChoice::Auto`] is the policy's default.
    pub fidelity: FidelityChoice,
    /// Also compute each row's prediction band (`band_pm_per_n`): two more FE solves
    /// per configuration. Ignored under [`FidelityChoice::ClosedForm`], which runs no
    /// FE at all (every front end asking for the closed form gets the same rows).
    pub band: bool,
    /// Also compute each row's design interval and its strain at the design's largest
    /// force (`design_interval_pm_per_n`, `limit_check`): in Case I K at both ends of
    /// the contact window (on the default radius), in Case II the FE reading of the
    /// stated `cylinders`; they share the nominal's factorisation where they differ
    /// only in the contact radius. Ignored under [`FidelityChoice::ClosedForm`].
    pub design_interval: bool,
    /// Also predict each row's reflection spectrum over the design's force range
    /// (`ModelledPrediction.spectrum`, [`spectrum`]): the FE strain profile along the
    /// grating from the nominal's own solve, through the transfer-matrix model
    /// (milliseconds per grating; no extra FE solve).
    pub spectrum: bool,
    /// Mesh and solver of the FE solves (the contact choices come from the design).
    pub fem_options: FemOptions,
    /// When set and `fem_options` is a policy mesh (`FemOptions::mesh_level`): the
    /// configurations whose FE rows state a model error above [`MAX_MODEL_ERROR`] are
    /// solved again one level finer, up to this level, so each row gets the cheapest
    /// mesh that states the policy's accuracy (the model-error study found thin walls
    /// on large modules 17–31 % at level 1, docs/fem.md §5.3). `None`: `fem_options`
    /// exactly as given. Default: [`FemOptions::AUTO_FINEST_MESH_LEVEL`].
    pub refine_to_level: Option<u32>,
    /// Where the FE solves' structures come from and go (the caller's, so solves of
    /// one geometry share them across calls; the default is a fresh, empty cache).
    pub cache: GeometryCache,
}

impl Default for PredictionRequest {
    fn default() -> Self {
        PredictionRequest {
            force_n: 1.0,
            delta_t_k: 0.0,
            case: None,
            insert: None,
            core: None,
            fidelity: FidelityChoice::Auto,
            band: false,
            design_interval: false,
            spectrum: false,
            fem_options: FemOptions::default(),
            refine_to_level: Some(FemOptions::AUTO_FINEST_MESH_LEVEL),
            cache: GeometryCache::default(),
        }
    }
}

/// Predict every strain grating of `design` (of `request.case` only, when given) with
/// the model the policy picks for each configuration.
///
/// ```
/// use fbgforge_model::model::LoadCase;
/// use fbgforge_model::prediction::{predict, Fidelity, FidelityChoice, PredictionRequest};
///
/// let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
/// let design = fbgforge_core::design::load(&root.join("designs/clip-on-34mm.toml"))?;
/// let closed = PredictionRequest {
///     case: Some(LoadCase::II),
///     fidelity: FidelityChoice::ClosedForm,
///     ..PredictionRequest::default()
/// };
/// let rows = predict(&design, &closed)?;
/// // Every row is a Case II row of the closed form, and it states its model.
/// assert!(!rows.is_empty());
/// assert!(rows.iter().all(|r| r.model == Fidelity::ClosedForm));
/// assert!(rows.iter().all(|r| r.detail.prediction.case == LoadCase::II));
/// // The policy answers the same rows (the 34 mm module lies in the closed form's
/// // validity region for Case II), so both give the same K.
/// let auto = predict(&design, &PredictionRequest { fidelity: FidelityChoice::Auto, ..closed })?;
/// for (a, c) in auto.iter().zip(&rows) {
///     assert_eq!(a.detail.prediction.sensitivity_pm_per_n, c.detail.prediction.sensitivity_pm_per_n);
/// }
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn predict(design: &Design, request: &PredictionRequest) -> Result<Vec<ModelledPrediction>> {
    let opts = PredictOptions {
        force_n: request.force_n,
        delta_t_k: request.delta_t_k,
    };
    let mut rows = model::predict_with(design, &opts)?;
    rows.retain(|d| {
        let p = &d.prediction;
        request.case.is_none_or(|c| c == p.case)
            && request.core.as_ref().is_none_or(|c| c == &p.core)
            && (p.case == LoadCase::II || request.insert.is_none() || p.insert == request.insert)
    });
    let models: Vec<Fidelity> = rows
        .iter()
        .map(|d| request.fidelity.resolve(design, d.prediction.case))
        .collect();
    let fe = request.fidelity != FidelityChoice::ClosedForm;
    let want = rows::Wanted {
        band: request.band && fe,
        interval: request.design_interval && fe,
    };
    // Every FE solve the rows need, once each, in one batch.
    let readings = rows::Readings::solve(design, &rows, &models, want, request)?;
    let mut answered = rows
        .iter()
        .zip(&models)
        .map(|(d, &model)| readings.row(d.clone(), model, want, request))
        .collect::<Result<Vec<_>>>()?;
    rows::refine(design, &rows, &models, want, request, &mut answered)?;
    if request.spectrum {
        // The profile's shape from the first solve, scaled to each row's nominal (a
        // refined row keeps its finer mean; the shape changes far less than the level).
        spectrum::attach(
            design,
            request,
            |c, g| readings.design_profile(c, g),
            &mut answered,
        )?;
    }
    Ok(answered)
}

/// The policy's predictions as the optimiser needs them: fast enough for an inner loop,
/// equal to [`predict`] at the design it was anchored on.
///
/// Rows the policy answers with the closed form stay closed form. Rows it answers with
/// the FE model are the closed form scaled by the ratio FE/closed form of the same
/// configuration at the anchor design (a multiplicative correction: the closed form
/// carries the trend in the optimiser's variables, the FE solve at the anchor the
/// contact reading's level). So at the anchor `predict` and the optimiser agree exactly;
/// away from it the optimiser's K is an estimate, and the optimiser re-predicts its
/// answer with [`predict`].
#[derive(Debug, Clone)]
pub struct Anchored {
    fidelity: FidelityChoice,
    /// (configuration, grating, FE K / closed-form K at the anchor).
    factors: Vec<(Configuration, String, f64)>,
    description: String,
    /// The configurations it answers for (`None`: every configuration of a design).
    only: Option<Vec<Configuration>>,
}

impl Anchored {
    /// Anchor the policy on `design` (one FE solve per configuration that needs one,
    /// on `cache`'s structures).
    pub fn new(
        design: &Design,
        fidelity: FidelityChoice,
        fem_options: &FemOptions,
        cache: &GeometryCache,
    ) -> Result<Self> {
        let rows = predict(
            design,
            &PredictionRequest {
                fidelity,
                fem_options: *fem_options,
                cache: cache.clone(),
                ..PredictionRequest::default()
            },
        )?;
        let closed = model::predict(design, 1.0)?;
        let mut factors = Vec::new();
        let mut description = "closed form".to_string();
        for (r, c) in rows.iter().zip(&closed) {
            let p = &r.detail.prediction;
            if r.model == Fidelity::Fem {
                factors.push((
                    config_of(p),
                    p.grating.clone(),
                    p.sensitivity_pm_per_n / c.sensitivity_pm_per_n,
                ));
                description = format!(
                    "closed form, FE rows scaled to the policy's {} at the anchor design",
                    r.model_description
                );
            }
        }
        Ok(Anchored {
            fidelity,
            factors,
            description,
            only: None,
        })
    }

    /// Anchor the policy on `design` for the configurations of `readings` (the
    /// nominal K of [`readings`] at that design), with no FE solve of its own; its
    /// predictions hold those configurations' rows only.
    pub fn from_readings(
        design: &Design,
        fidelity: FidelityChoice,
        readings: &[KReadings],
    ) -> Result<Self> {
        let m = design
            .module
            .as_ref()
            .context("the design has no [module] section")?;
        let closed = model::predict(design, 1.0)?;
        let mut factors = Vec::new();
        let mut only: Vec<Configuration> = Vec::new();
        let mut description = "closed form".to_string();
        for r in readings {
            if !only.contains(&r.configuration) {
                only.push(r.configuration.clone());
            }
            if r.model != Fidelity::Fem {
                continue;
            }
            let c = closed
                .iter()
                .find(|c| config_of(c) == r.configuration && c.grating == r.grating)
                .with_context(|| {
                    format!(
                        "the closed form has no row for grating `{}` in {}",
                        r.grating,
                        r.configuration.label()
                    )
                })?;
            factors.push((
                r.configuration.clone(),
                r.grating.clone(),
                r.nominal_pm_per_n / c.sensitivity_pm_per_n,
            ));
            description = format!(
                "closed form, FE rows scaled to the policy's FE, {} at the anchor design",
                ContactReading::Design.describe(m, r.configuration.case)
            );
        }
        Ok(Anchored {
            fidelity,
            factors,
            description,
            only: Some(only),
        })
    }

    /// The model in words.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// Every grating of `design` at `force_n`, in [`model::predict`]'s order.
    pub fn predict(&self, design: &Design, force_n: f64) -> Result<Vec<GratingPrediction>> {
        let mut rows = model::predict(design, force_n)?;
        if let Some(only) = &self.only {
            rows.retain(|p| only.contains(&config_of(p)));
        }
        for p in rows.iter_mut() {
            if self.fidelity.resolve(design, p.case) != Fidelity::Fem {
                continue;
            }
            let config = config_of(p);
            let Some((_, _, f)) = self
                .factors
                .iter()
                .find(|(c, g, _)| c == &config && g == &p.grating)
            else {
                anyhow::bail!(
                    "the optimiser's model was anchored without {} for grating `{}`",
                    config.label(),
                    p.grating
                );
            };
            p.sensitivity_pm_per_n *= f;
            p.shift_pm *= f;
            p.strain *= f;
            // The closed form's warnings concern its own assumptions.
            p.warnings.clear();
        }
        Ok(rows)
    }
}

/// One grating of a contact calibration, K in pm/N.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibratedGrating {
    /// Grating name.
    pub grating: String,
    /// Measured K.
    pub measured_pm_per_n: f64,
    /// The policy's K before the calibration.
    pub before_pm_per_n: f64,
    /// The policy's K with the calibrated contact.
    pub after_pm_per_n: f64,
}

/// A calibration of the design's contact reading on a measured Case I sensitivity.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContactCalibration {
    /// The configuration measured.
    pub configuration: Configuration,
    /// `[module.contact].dome_contact_radius_mm` before, mm.
    pub previous_radius_mm: f64,
    /// The calibrated radius, mm.
    pub radius_mm: f64,
    /// The radii searched, mm (low, high).
    pub searched_mm: [f64; 2],
    /// Per grating: measured, before and after.
    pub gratings: Vec<CalibratedGrating>,
    /// FE solves spent.
    pub evaluations: usize,
}

/// The dome contact radii a calibration searches, mm: from half to four times the apex
/// patch (at most 0.6 × the core dome's outer radius).
fn calibration_radii_mm(m: &crate::spec::Module) -> [f64; 2] {
    let patch = m.apex_patch_radius_mm();
    let profile = ModuleProfile::from_module(m);
    [
        0.5 * patch,
        (4.0 * patch).min(0.6 * profile.core_dome_outer_sphere_radius_mm),
    ]
}

/// What a contact calibration can reach: every grating's Case I K at the two ends of
/// the radii [`calibrate_contact`] searches (two FE solves). A measured K between a
/// grating's two values is one some contact radius reproduces.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibrationReach {
    /// The radii searched, mm (small, large).
    pub radii_mm: [f64; 2],
    /// Per grating: K at the small and at the large radius, pm/N.
    pub k_pm_per_n: Vec<(String, [f64; 2])>,
}

/// The K a contact calibration of `config` (Case I) can reach; see [`CalibrationReach`].
pub fn calibration_reach(
    design: &Design,
    config: &Configuration,
    fem_options: &FemOptions,
) -> Result<CalibrationReach> {
    let m = design
        .module
        .as_ref()
        .context("the design has no [module] section")?;
    anyhow::ensure!(
        config.case == LoadCase::I,
        "only Case I depends on the contact radius"
    );
    let radii = calibration_radii_mm(m);
    // This call owns the cache of its solves.
    let cache = GeometryCache::default();
    let (small, large) = rayon::join(
        || case_i_k_at(design, config, radii[0], fem_options, &cache),
        || case_i_k_at(design, config, radii[1], fem_options, &cache),
    );
    let (small, large) = (small?, large?);
    Ok(CalibrationReach {
        radii_mm: radii,
        k_pm_per_n: small
            .into_iter()
            .map(|(g, a)| {
                let b = large
                    .iter()
                    .find(|(n, _)| *n == g)
                    .map_or(f64::NAN, |(_, k)| *k);
                (g, [a, b])
            })
            .collect(),
    })
}

/// `design` with its domes' contact radius set to `radius_mm`, stated relative to the
/// apex patch (the family rule), so the design carries it to other sizes.
pub fn with_contact_radius(design: &Design, radius_mm: f64) -> Design {
    match design.module.as_ref() {
        Some(m) => with_contact_ratio(design, radius_mm / m.apex_patch_radius_mm()),
        None => design.clone(),
    }
}

/// The policy's Case I K of every grating of `config` with the domes' contact radius
/// set to `radius_mm`.
fn case_i_k_at(
    design: &Design,
    config: &Configuration,
    radius_mm: f64,
    fem_options: &FemOptions,
    cache: &GeometryCache,
) -> Result<Vec<(String, f64)>> {
    let d = with_contact_radius(design, radius_mm);
    let m = d
        .module
        .as_ref()
        .context("the design has no [module] section")?;
    let r = solve_configuration(
        &d,
        config,
        &fem_options.with_reading(m, ContactReading::Design, config.case),
        cache,
    )?;
    Ok(r.strain_per_n
        .into_iter()
        .map(|(name, lambda, e)| (name, d.fiber.shift_pm(lambda, e, 0.0)))
        .collect())
}

/// The model's K over the measured K, averaged over the measured gratings, minus one:
/// falls as the contact radius grows.
fn mean_ratio_minus_one(
    ks: &[(String, f64)],
    measured: &[(String, f64)],
    config: &Configuration,
) -> Result<f64> {
    let mut sum = 0.0;
    for (g, k) in measured {
        let model = ks
            .iter()
            .find(|(n, _)| n == g)
            .map(|(_, v)| *v)
            .with_context(|| {
                format!(
                    "grating `{g}` is not a strain grating of {}",
                    config.label()
                )
            })?;
        sum += model / k;
    }
    Ok(sum / measured.len() as f64 - 1.0)
}

/// The root of `f` on a bracket `(a, f(a))`, `(b, f(b))` of opposite signs by regula
/// falsi (Illinois), at most 40 steps: the best point found and the steps taken.
fn illinois(
    mut f: impl FnMut(f64) -> Result<f64>,
    (mut a, mut fa): (f64, f64),
    (mut b, mut fb): (f64, f64),
) -> Result<(f64, usize)> {
    let mut side = 0i8;
    let mut best = (a, fa.abs());
    let mut steps = 0;
    for _ in 0..40 {
        let c = (a * fb - b * fa) / (fb - fa);
        let fc = f(c)?;
        steps += 1;
        if fc.abs() < best.1 {
            best = (c, fc.abs());
        }
        if fc.abs() < 1e-4 || (b - a).abs() < 1e-5 * c {
            break;
        }
        if fc.signum() == fb.signum() {
            b = c;
            fb = fc;
            if side == -1 {
                fa *= 0.5;
            }
            side = -1;
        } else {
            a = c;
            fa = fc;
            if side == 1 {
                fb *= 0.5;
            }
            side = 1;
        }
    }
    Ok((best.0, steps))
}

/// Fit the one contact parameter of the policy, the domes' contact radius
/// (`[module.contact].dome_contact_radius_mm`), to measured Case I sensitivities of
/// `config`'s gratings (`measured`: grating name, K in pm/N): the radius at which the
/// model's K, as a ratio to the measured K and averaged over the gratings, is 1
/// (exact for one grating). Regula falsi (Illinois) on a bracket from half to four
/// times the apex patch; one FE solve per step.
pub fn calibrate_contact(
    design: &Design,
    config: &Configuration,
    measured: &[(String, f64)],
    fem_options: &FemOptions,
) -> Result<ContactCalibration> {
    let m = design
        .module
        .as_ref()
        .context("the design has no [module] section")?;
    anyhow::ensure!(
        config.case == LoadCase::I,
        "calibration fits the domes' contact radius, which only Case I depends on in the model policy (Case II is the closed form); give a Case I log"
    );
    anyhow::ensure!(
        !measured.is_empty(),
        "no grating of {} responded to the force: nothing to calibrate on",
        config.label()
    );
    for (g, k) in measured {
        anyhow::ensure!(
            k.is_finite() && *k > 0.0,
            "grating `{g}`: a measured Case I K of {k} pm/N is not a red shift; the contact reading predicts K > 0 at every radius, so it cannot be calibrated on it"
        );
    }
    let previous = m.dome_contact_radius_mm();
    // The calibration owns the cache of its solves.
    let cache = GeometryCache::default();
    let k_at = |r: f64| case_i_k_at(design, config, r, fem_options, &cache);
    let before = k_at(previous)?;
    let [lo, hi] = calibration_radii_mm(m);
    let h = |ks: &[(String, f64)]| mean_ratio_minus_one(ks, measured, config);
    let k_lo = k_at(lo)?;
    let k_hi = k_at(hi)?;
    let (fa, fb) = (h(&k_lo)?, h(&k_hi)?);
    if fa.signum() == fb.signum() {
        let first = |ks: &[(String, f64)]| ks.first().map_or(f64::NAN, |(_, k)| *k);
        anyhow::bail!(
            "no dome contact radius from {lo:.3} to {hi:.3} mm reproduces the measurement: the model's K of `{}` runs from {:.3} to {:.3} pm/N over that range, the measured K is {:.3} pm/N",
            measured[0].0,
            first(&k_lo),
            first(&k_hi),
            measured[0].1
        );
    }
    let (radius, steps) = illinois(|c| h(&k_at(c)?), (lo, fa), (hi, fb))?;
    // The solve before, the two ends, the steps and the one after.
    let evaluations = 1 + 2 + steps + 1;
    let after = k_at(radius)?;
    let k_of = |ks: &[(String, f64)], g: &str| {
        ks.iter()
            .find(|(n, _)| n == g)
            .map_or(f64::NAN, |(_, k)| *k)
    };
    Ok(ContactCalibration {
        configuration: config.clone(),
        previous_radius_mm: previous,
        radius_mm: radius,
        searched_mm: [lo, hi],
        gratings: measured
            .iter()
            .map(|(g, k)| CalibratedGrating {
                grating: g.clone(),
                measured_pm_per_n: *k,
                before_pm_per_n: k_of(&before, g),
                after_pm_per_n: k_of(&after, g),
            })
            .collect(),
        evaluations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fem_strain_replaces_k_and_keeps_compensation_consistent() {
        let design =
            crate::design::parse(include_str!("../../../designs/clip-on-34mm.toml")).unwrap();
        let opts = PredictOptions {
            force_n: 5.0,
            delta_t_k: 10.0,
        };
        let mut d = model::predict_with(&design, &opts).unwrap().remove(0);
        let before_comp = d.compensated_shift_pm.unwrap();
        let before_raw = d.raw_shift_pm;
        let e = -2.0e-5;
        apply_fem_strain(&mut d, &design, &opts, e);
        let k = design.fiber.shift_pm(d.bragg_wavelength_nm, e, 0.0);
        assert!((d.prediction.sensitivity_pm_per_n - k).abs() < 1e-12);
        assert!((d.prediction.shift_pm - 5.0 * k).abs() < 1e-9);
        // The thermal part cancels in the compensated shift: it moves with the strain
        // shift only.
        let moved = d.compensated_shift_pm.unwrap() - before_comp;
        assert!((moved - (d.raw_shift_pm - before_raw)).abs() < 1e-9);
        // And a reference grating on the same fiber compensates exactly: what is left
        // is the FE strain shift K·F.
        assert!((d.compensated_shift_pm.unwrap() - 5.0 * k).abs() < 1e-6);
        assert!(d.core_load_share.is_nan());
    }
}
