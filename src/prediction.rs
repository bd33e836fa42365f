//! The one model policy: every command that needs a grating's predicted sensitivity
//! (`predict`, `sweep`, `verify`'s verdict, `optimize`'s objective and constraints)
//! asks [`predict`] here, so no two commands can answer the same design with two
//! models. Each row names the model that produced it.

use crate::fem::fidelity::predict_with_fidelity;
pub use crate::fem::fidelity::{FidelityChoice, ModelledPrediction};
use crate::fem::FemOptions;
use crate::model::{LoadCase, PredictOptions};
use crate::spec::Design;
use anyhow::Result;

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
