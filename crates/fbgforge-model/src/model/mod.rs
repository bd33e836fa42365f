//! Opto-mechanical model of the clip-on module: predicted sensitivity K (pm/N) of
//! every grating from the design spec, for Case I (core on a solid insert) and Case II
//! (hollow core).
//!
//! Layers, cheapest first:
//! - [`closed_form`]: pure functions of a [`ModuleModelParams`] (a small `Copy`
//!   struct) giving strains per newton; this is what an optimiser calls in its loop;
//! - [`ModuleModelParams::from_design`]: reads the profile and materials once;
//! - [`predict`] / [`predict_with`]: every strain grating in every configuration,
//!   with shifts, strains, temperature and validity warnings;
//! - [`sweep`]: one spec parameter swept over a range (the paper's Figs. 8–11).
//!
//! The derivation, its assumptions and their range of validity are in `docs/model.md`.

pub mod closed_form;
pub mod params;
pub mod sweep;
pub mod validity;

pub use params::{Elastic, ModuleGeometry, ModuleModelParams};

use crate::profile::{module_gratings, GratingPlacement, ModuleProfile};
use crate::spec::{Design, GratingRole};
use serde::{Deserialize, Serialize};

/// Loading case of the paper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum LoadCase {
    /// Case I: core with a solid insert, assembly clamped to the table.
    #[serde(rename = "I")]
    I,
    /// Case II: hollow core, no insert.
    #[serde(rename = "II")]
    II,
}

impl std::fmt::Display for LoadCase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LoadCase::I => "I",
            LoadCase::II => "II",
        })
    }
}

/// Prediction for one grating in one configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GratingPrediction {
    /// Grating name from the spec.
    pub grating: String,
    /// Core the grating is bonded in.
    pub core: String,
    /// Loading case.
    pub case: LoadCase,
    /// Insert used (Case I only).
    pub insert: Option<String>,
    /// Predicted sensitivity, pm/N, signed (positive = red shift).
    pub sensitivity_pm_per_n: f64,
    /// Predicted shift at the requested force, pm.
    pub shift_pm: f64,
    /// Axial strain at the grating at the requested force (dimensionless).
    pub strain: f64,
    /// Validity warnings (thin-shell ratio, strain range, ...).
    pub warnings: Vec<String>,
}

/// Errors of the model, each saying what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// The design has no `[module]`.
    #[error("the design has no [module] section: the clip-on model needs one")]
    NoModule,
    /// Case I was requested but the spec lists no insert.
    #[error("Case I needs a solid insert, but the design lists none under [[module.inserts]]")]
    NoInsert,
    /// An insert name that the spec does not list.
    #[error("no insert named `{name}`; the design has: {}", known.join(", "))]
    UnknownInsert {
        /// Requested name.
        name: String,
        /// Names in the spec.
        known: Vec<String>,
    },
    /// A core name that the spec does not list.
    #[error("no core named `{name}`; the design has: {}", known.join(", "))]
    UnknownCore {
        /// Requested name.
        name: String,
        /// Names in the spec.
        known: Vec<String>,
    },
    /// A grating name that is not a strain grating of the spec.
    #[error("no strain grating named `{name}`; the design's strain gratings are: {}", known.join(", "))]
    UnknownGrating {
        /// Requested name.
        name: String,
        /// Strain gratings in the spec.
        known: Vec<String>,
    },
    /// A material key that the material table lacks.
    #[error("field `{field}`: unknown material `{key}`")]
    UnknownMaterial {
        /// Field that referenced it.
        field: String,
        /// Missing key.
        key: String,
    },
    /// A modulus that is zero, negative or not finite.
    #[error("{what} modulus must be a positive finite number of MPa, got {value_mpa}")]
    BadModulus {
        /// Which modulus.
        what: String,
        /// Its value, MPa.
        value_mpa: f64,
    },
    /// A derived dimension that is not positive and finite.
    #[error("{what} must be positive and finite, got {value}")]
    BadGeometry {
        /// Which quantity.
        what: String,
        /// Its value.
        value: f64,
    },
    /// A force that is not finite.
    #[error("the force must be a finite number of newtons, got {0}")]
    BadForce(f64),
    /// Case I was asked for without naming an insert.
    #[error("Case I needs an insert name; the design has: {}", known.join(", "))]
    InsertRequired {
        /// Insert names in the spec.
        known: Vec<String>,
    },
    /// Case II was given an insert.
    #[error("Case II is the hollow core: give no insert")]
    InsertInCaseII,
}

/// Options of [`predict_with`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictOptions {
    /// Apex force, N (positive pushes the cap down).
    pub force_n: f64,
    /// Temperature change from the reference temperature, K (0: strain only).
    pub delta_t_k: f64,
}

/// A prediction with the quantities behind it, for reports and JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DetailedPrediction {
    /// The prediction of the public interface.
    #[serde(flatten)]
    pub prediction: GratingPrediction,
    /// Nominal Bragg wavelength, nm.
    pub bragg_wavelength_nm: f64,
    /// E1 of the grating's core, MPa.
    pub core_modulus_mpa: f64,
    /// Es of the insert (Case I), MPa.
    pub insert_modulus_mpa: Option<f64>,
    /// Share of F in the path that strains the core (Case I: loop share P/F; Case II: F10/F).
    pub core_load_share: f64,
    /// Shift at the force including the temperature change, pm.
    pub raw_shift_pm: f64,
    /// Shift of the temperature-reference grating at the temperature change, pm
    /// (None when the design has no reference grating).
    pub reference_shift_pm: Option<f64>,
    /// Raw shift after temperature compensation with the reference grating, pm.
    pub compensated_shift_pm: Option<f64>,
}

/// One loading configuration of the module: a core, a case, and the insert in Case I.
/// The one configuration type of the closed form, the FE model and the model policy.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Configuration {
    /// Core name.
    pub core: String,
    /// Loading case.
    pub case: LoadCase,
    /// Insert name (Case I).
    pub insert: Option<String>,
}

impl Configuration {
    /// Label for tables, e.g. `psc1 Case I blue`.
    pub fn label(&self) -> String {
        let case = match self.case {
            LoadCase::I => "Case I",
            LoadCase::II => "Case II",
        };
        match &self.insert {
            Some(i) => format!("{} {case} {i}", self.core),
            None => format!("{} {case}", self.core),
        }
    }
}

/// Every configuration the design allows, in the model's order: for each core,
/// Case II, then Case I with each insert.
pub fn configurations(design: &Design) -> anyhow::Result<Vec<Configuration>> {
    let m = design
        .module
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("the design has no [module] section"))?;
    let mut out = Vec::new();
    for c in &m.cores {
        for (case, insert) in load_setups(m) {
            out.push(Configuration {
                core: c.name.clone(),
                case,
                insert,
            });
        }
    }
    Ok(out)
}

/// The load set-ups of a module, core aside: Case II, then Case I with each insert.
fn load_setups(m: &crate::spec::Module) -> Vec<(LoadCase, Option<String>)> {
    std::iter::once((LoadCase::II, None))
        .chain(
            m.inserts
                .iter()
                .map(|i| (LoadCase::I, Some(i.name.clone()))),
        )
        .collect()
}

fn strain_gratings(placements: &[GratingPlacement]) -> impl Iterator<Item = &GratingPlacement> {
    placements.iter().filter(|g| g.role == GratingRole::Strain)
}

/// Predict every strain grating of the design's module, for Case II and for Case I
/// with each listed insert, at `force_n`.
pub fn predict(design: &Design, force_n: f64) -> anyhow::Result<Vec<GratingPrediction>> {
    Ok(predict_with(
        design,
        &PredictOptions {
            force_n,
            delta_t_k: 0.0,
        },
    )?
    .into_iter()
    .map(|d| d.prediction)
    .collect())
}

/// Predict every strain grating in every configuration, with details.
pub fn predict_with(
    design: &Design,
    opts: &PredictOptions,
) -> Result<Vec<DetailedPrediction>, ModelError> {
    if !opts.force_n.is_finite() {
        return Err(ModelError::BadForce(opts.force_n));
    }
    let m = design.module.as_ref().ok_or(ModelError::NoModule)?;
    let profile = ModuleProfile::from_module(m);
    let placements = module_gratings(m, &profile);
    // A reference grating bonded to no core serves every core; one named after a
    // core serves that core first.
    let references: Vec<&GratingPlacement> = placements
        .iter()
        .filter(|g| g.role == GratingRole::TemperatureReference)
        .collect();
    let reference_for = |core: &Option<String>| {
        references
            .iter()
            .find(|r| r.core.is_some() && &r.core == core)
            .or_else(|| references.iter().find(|r| r.core.is_none()))
            .copied()
    };
    let optics = &design.fiber;
    let mut out = Vec::new();
    for (case, insert) in load_setups(m) {
        for g in strain_gratings(&placements) {
            let core = g.core.as_deref().unwrap_or_default();
            let p = ModuleModelParams::from_parts(design, m, &profile, core, insert.as_deref())?;
            let conf = Configuration {
                core: core.to_owned(),
                case,
                insert: insert.clone(),
            };
            out.push(evaluate(&p, &conf, g, reference_for(&g.core), optics, opts));
        }
    }
    Ok(out)
}

fn evaluate(
    p: &ModuleModelParams,
    conf: &Configuration,
    g: &GratingPlacement,
    reference: Option<&GratingPlacement>,
    optics: &crate::grating::FiberOptics,
    opts: &PredictOptions,
) -> DetailedPrediction {
    let f = opts.force_n;
    let (core_e, cap_e, share, insert_e) = match (conf.case, p.insert) {
        (LoadCase::I, Some(ins)) => {
            let s = closed_form::case_i_share(p, ins);
            (
                s.core_strain_per_n,
                s.cap_strain_per_n,
                s.loop_share,
                Some((ins, s.insert_strain_per_n * f)),
            )
        }
        _ => {
            let (core, cap, share) = closed_form::case_ii_strain_per_n(p);
            (core, cap, share, None)
        }
    };
    let lambda = g.bragg_wavelength_nm;
    let k = optics.shift_pm(lambda, core_e, 0.0);
    let strain = core_e * f;
    let mut warnings = validity::geometry_warnings(p, Some(g));
    warnings.extend(validity::strain_warnings(
        p.core,
        strain,
        p.cap,
        cap_e * f,
        insert_e,
    ));
    warnings.extend(validity::force_warnings(p, conf.case, f));
    let raw = optics.shift_pm(lambda, strain, opts.delta_t_k);
    let reference_shift =
        reference.map(|r| optics.shift_pm(r.bragg_wavelength_nm, 0.0, opts.delta_t_k));
    let compensated = reference.zip(reference_shift).map(|(r, rs)| {
        crate::grating::compensate_temperature_pm(raw, lambda, rs, r.bragg_wavelength_nm)
    });
    DetailedPrediction {
        prediction: GratingPrediction {
            grating: g.name.clone(),
            core: g.core.clone().unwrap_or_default(),
            case: conf.case,
            insert: conf.insert.clone(),
            sensitivity_pm_per_n: k,
            shift_pm: k * f,
            strain,
            warnings,
        },
        bragg_wavelength_nm: lambda,
        core_modulus_mpa: p.core.youngs_modulus_mpa,
        insert_modulus_mpa: p.insert.map(|i| i.youngs_modulus_mpa),
        core_load_share: share,
        raw_shift_pm: raw,
        reference_shift_pm: reference_shift,
        compensated_shift_pm: compensated,
    }
}

/// Sensitivity K (pm/N, signed) of one strain grating in one configuration: the
/// closed form the FEM comparison and the optimiser call. `insert` must be given for
/// Case I and omitted for Case II.
pub fn sensitivity_pm_per_n(
    design: &Design,
    case: LoadCase,
    insert: Option<&str>,
    grating: &str,
) -> Result<f64, ModelError> {
    let m = design.module.as_ref().ok_or(ModelError::NoModule)?;
    match (case, insert) {
        (LoadCase::I, None) if m.inserts.is_empty() => return Err(ModelError::NoInsert),
        (LoadCase::I, None) => {
            return Err(ModelError::InsertRequired {
                known: m.inserts.iter().map(|i| i.name.clone()).collect(),
            })
        }
        (LoadCase::II, Some(_)) => return Err(ModelError::InsertInCaseII),
        _ => {}
    }
    let g = m
        .gratings
        .iter()
        .find(|g| g.name == grating && g.role == GratingRole::Strain)
        .ok_or_else(|| ModelError::UnknownGrating {
            name: grating.to_string(),
            known: m
                .gratings
                .iter()
                .filter(|g| g.role == GratingRole::Strain)
                .map(|g| g.name.clone())
                .collect(),
        })?;
    let core = g.core.as_deref().unwrap_or_default();
    let p = ModuleModelParams::from_design(design, core, insert)?;
    Ok(
        closed_form::sensitivity_pm_per_n(&p, case, g.bragg_wavelength_nm, &design.fiber)
            .expect("Case I was checked to have an insert"),
    )
}
