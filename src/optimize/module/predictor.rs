//! The model the optimiser asks: the model policy anchored on a design (with a cache
//! of the anchors built), or any function (synthetic models in tests).

use crate::fem::FemOptions;
use crate::model::GratingPrediction;
use crate::prediction::{Anchored, FidelityChoice};
use crate::spec::Design;
use std::sync::{Arc, Mutex};

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
    pub(super) fn anchored_on(&self, design: &Design) -> anyhow::Result<(PredictFn, String)> {
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
