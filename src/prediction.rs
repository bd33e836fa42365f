//! The one model policy: every command that needs a grating's predicted sensitivity
//! (`predict`, `sweep`, `verify`'s verdict, `optimize`'s objective and constraints)
//! asks [`predict`] here, so no two commands can answer the same design with two
//! models. Each row names the model that produced it.
//!
//! The policy: the closed form inside its measured validity region ([`validity`]),
//! the finite-element model outside it. The closed form is always evaluated
//! (microseconds) because it also gives the details the FE solve does not (load
//! share, reference grating); rows that go to the FE model keep those details but
//! take K, strain and shifts from the FE solve. Each FE configuration (core, case,
//! insert) is solved once, at 1 N, and only when a row asks for it.

use crate::fem::{solve_configuration, FemOptions};
use crate::model::{self, Configuration, DetailedPrediction, LoadCase, PredictOptions};
use crate::profile::ModuleProfile;
use crate::spec::Design;
use anyhow::{Context, Result};
use serde::Serialize;

/// The closed form's error bound claimed by the paper.
pub const TOLERANCE: f64 = 0.08;

/// Outer diameters over which the closed form was compared with the FE model, mm
/// (the `fem` study's grid, 10 to 40 mm).
pub const MEASURED_DIAMETER_RANGE_MM: (f64, f64) = (10.0, 40.0);

/// Which model answers a prediction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fidelity {
    /// The closed-form model (microseconds).
    ClosedForm,
    /// The finite-element model (a fraction of a second per configuration).
    Fem,
}

/// Which model `predict` should use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FidelityChoice {
    /// Per case: the closed form inside its measured validity region, FE outside
    /// ([`choose_fidelity_for`]).
    Auto,
    /// The closed form everywhere.
    ClosedForm,
    /// The finite-element model everywhere.
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

/// One grating prediction and the model that produced it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelledPrediction {
    /// The model that produced K, strain and shifts of this row.
    pub model: Fidelity,
    /// Case I: the range of K (pm/N, low then high) between the physically bounding
    /// contact readings of cap and core; `None` where the model has no such spread
    /// (Case II) or the caller did not ask for it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band_pm_per_n: Option<[f64; 2]>,
    /// The prediction. For FE rows `core_load_share` is NaN (null in JSON): the FE
    /// model does not split the force into the closed form's paths.
    #[serde(flatten)]
    pub detail: DetailedPrediction,
}

/// Predict every strain grating (of `case` only, when given) with the model `choice`
/// picks per configuration. FE rows are solved with `fem_options`.
pub fn predict_with_fidelity(
    design: &Design,
    opts: &PredictOptions,
    choice: FidelityChoice,
    case: Option<LoadCase>,
    fem_options: &FemOptions,
) -> Result<Vec<ModelledPrediction>> {
    let mut rows = model::predict_with(design, opts)?;
    rows.retain(|d| case.is_none_or(|c| c == d.prediction.case));
    // A handful of configurations at most: a list is enough.
    let mut solved: Vec<crate::fem::ConfigurationResult> = Vec::new();
    let mut out = Vec::with_capacity(rows.len());
    for mut d in rows {
        let model = choice.resolve(design, d.prediction.case);
        if model == Fidelity::Fem {
            let p = &d.prediction;
            let config = Configuration {
                core: p.core.clone(),
                case: p.case,
                insert: p.insert.clone(),
            };
            let i = match solved.iter().position(|r| r.configuration == config) {
                Some(i) => i,
                None => {
                    let r = solve_configuration(design, &config, fem_options)
                        .with_context(|| format!("finite-element solve of {}", config.label()))?;
                    solved.push(r);
                    solved.len() - 1
                }
            };
            let strain_per_n = solved[i]
                .strain_per_n
                .iter()
                .find(|(name, _, _)| name == &p.grating)
                .map(|(_, _, e)| *e)
                .with_context(|| {
                    format!("the FE model gave no strain for grating `{}`", p.grating)
                })?;
            apply_fem_strain(&mut d, design, opts, strain_per_n);
        }
        out.push(ModelledPrediction {
            model,
            band_pm_per_n: None,
            detail: d,
        });
    }
    Ok(out)
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
/// which the sweep calls itself): each step answered as `predict --fidelity` would.
pub fn sweep_predictor(
    choice: FidelityChoice,
    case: Option<LoadCase>,
    fem_options: FemOptions,
) -> Option<Box<model::sweep::Predictor<'static>>> {
    if choice == FidelityChoice::ClosedForm {
        return None;
    }
    Some(Box::new(move |d, o| {
        predict_with_fidelity(d, o, choice, case, &fem_options)
            .map(|rows| rows.into_iter().map(|r| r.detail.prediction).collect())
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
    pub fn contains_case(&self, design: &Design, case: LoadCase) -> bool {
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
    /// Which model answers: [`FidelityChoice::Auto`] is the policy's default.
    pub fidelity: FidelityChoice,
    /// Also compute each Case I row's prediction band (`band_pm_per_n`); callers in
    /// inner loops (the optimiser) leave it off.
    pub band: bool,
}

impl Default for PredictionRequest {
    fn default() -> Self {
        PredictionRequest {
            force_n: 1.0,
            delta_t_k: 0.0,
            case: None,
            fidelity: FidelityChoice::Auto,
            band: false,
        }
    }
}

/// Predict every strain grating of `design` (of `request.case` only, when given) with
/// the model the policy picks for each configuration.
pub fn predict(design: &Design, request: &PredictionRequest) -> Result<Vec<ModelledPrediction>> {
    predict_with_fidelity(
        design,
        &PredictOptions {
            force_n: request.force_n,
            delta_t_k: request.delta_t_k,
        },
        request.fidelity,
        request.case,
        &FemOptions::default(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fem_strain_replaces_k_and_keeps_compensation_consistent() {
        let design = crate::design::parse(include_str!("../designs/clip-on-34mm.toml")).unwrap();
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
