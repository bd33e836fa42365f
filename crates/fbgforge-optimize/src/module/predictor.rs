//! The model the optimiser asks: the model policy anchored on a design (with a cache
//! of the anchors built), or any function (synthetic models in tests). Anchored with
//! its readings, the policy also states its own uncertainty about K at the design
//! (`prediction::readings`: the contact window's ends and the bounding readings).

use crate::fem::{FemOptions, GeometryCache};
use crate::model::{Configuration, GratingPrediction};
use crate::prediction::{readings, Anchored, FidelityChoice, KReadings, ReadingsRequest};
use crate::spec::Design;
use std::sync::{Arc, Mutex};

/// A function that predicts every grating of a design at a force.
pub type PredictFn =
    Arc<dyn Fn(&Design, f64) -> anyhow::Result<Vec<GratingPrediction>> + Send + Sync>;

/// Anchored policies already built, keyed by the TOML of the design they were anchored
/// on (one FE solve per configuration saved when a problem is set up again).
pub type AnchorCache = Arc<Mutex<Vec<(String, Arc<Anchored>)>>>;

/// The policy's readings already computed, keyed by configuration and design TOML.
pub type ReadingsCache = Arc<Mutex<Vec<(String, Arc<Vec<KReadings>>)>>>;

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
        /// Readings (K with its uncertainty) computed so far.
        readings: ReadingsCache,
        /// The FE structures of the optimisation's solves (its own, for its run).
        structures: GeometryCache,
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
            Predictor::Policy {
                fidelity,
                cache,
                structures,
                ..
            } => {
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
                            Anchored::new(design, *fidelity, &FemOptions::default(), structures)
                                .map_err(|e| {
                                    e.context("anchoring the model policy on the start design")
                                })?,
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

/// An anchored model: its function, its description, and the policy's readings at
/// the anchor (`None`: no stated uncertainty).
pub(super) type AnchoredModel = (PredictFn, String, Option<Arc<Vec<KReadings>>>);

impl Predictor {
    /// The model anchored on `design` for `config` with the policy's readings of it
    /// there (`None` for a plain function: no stated uncertainty). One policy
    /// prediction with the band, and two more at the contact window's ends when the
    /// configuration rests on the default contact radius.
    pub(super) fn anchored_with_readings(
        &self,
        design: &Design,
        config: &Configuration,
    ) -> anyhow::Result<AnchoredModel> {
        match self {
            Predictor::Function(f) => Ok((f.clone(), "custom predictor".into(), None)),
            Predictor::Policy {
                fidelity,
                readings: cache,
                structures,
                ..
            } => {
                let key = format!("{}\n{}", config.label(), design.to_toml());
                let found = cache
                    .lock()
                    .expect("readings cache")
                    .iter()
                    .find(|(k, _)| k == &key)
                    .map(|(_, r)| r.clone());
                let r = match found {
                    Some(r) => r,
                    None => {
                        let r = Arc::new(
                            readings(
                                design,
                                &ReadingsRequest {
                                    case: Some(config.case),
                                    insert: config.insert.clone(),
                                    core: Some(config.core.clone()),
                                    fidelity: *fidelity,
                                    fem_options: FemOptions::default(),
                                    cache: structures.clone(),
                                },
                            )
                            .map_err(|e| e.context("the model policy's readings of a candidate"))?,
                        );
                        cache.lock().expect("readings cache").push((key, r.clone()));
                        r
                    }
                };
                let a = Arc::new(Anchored::from_readings(design, *fidelity, &r)?);
                let name = a.description().to_string();
                Ok((
                    Arc::new(move |d: &Design, f: f64| a.predict(d, f)),
                    name,
                    Some(r),
                ))
            }
        }
    }
}

/// The opto-mechanical model policy as a [`Predictor`], with an FE cache of its own
/// (every problem set up from it shares the cache).
pub fn model_predictor() -> Predictor {
    Predictor::Policy {
        fidelity: FidelityChoice::Auto,
        cache: Arc::new(Mutex::new(Vec::new())),
        readings: Arc::new(Mutex::new(Vec::new())),
        structures: GeometryCache::default(),
    }
}
