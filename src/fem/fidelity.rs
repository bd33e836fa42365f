//! `fbgforge predict --fidelity`: each grating prediction from the model that a
//! configuration needs — the closed form inside its measured validity region
//! ([`super::validity`]), the finite-element model outside it — labelled with the
//! model that produced it.
//!
//! The closed form is always evaluated (microseconds) because it also gives the
//! details the FE solve does not (load share, reference grating); rows that go to the
//! FE model keep those details but take K, strain and shifts from the FE solve. Each
//! FE configuration (core, case, insert) is solved once, at 1 N, and only when a
//! row asks for it.

use super::{solve_configuration, Configuration, FemOptions, Fidelity};
use crate::model::{self, DetailedPrediction, LoadCase, PredictOptions};
use crate::spec::Design;
use anyhow::{Context, Result};
use serde::Serialize;

/// Which model `predict` should use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FidelityChoice {
    /// Per case: the closed form inside its measured validity region, FE outside
    /// ([`super::choose_fidelity_for`]).
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
            FidelityChoice::Auto => super::choose_fidelity_for(design, case),
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
    let mut solved: Vec<super::ConfigurationResult> = Vec::new();
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
                    let r =
                        solve_configuration(design, &config, fem_options).with_context(|| {
                            format!("finite-element solve of {}", super::bench::label(&config))
                        })?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fem_strain_replaces_k_and_keeps_compensation_consistent() {
        let design = super::super::bench::paper_design().unwrap();
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
