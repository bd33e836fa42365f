//! A log that follows the design's own prediction: every strain grating of the core
//! gets the K the model predicts for one configuration (case, insert, core), so that
//! `verify` of the same configuration on it has the model's K as its truth and PASSes.
//! A newcomer's first `synth-log --from-model` + `verify` shows what a PASS looks like.

use crate::model::LoadCase;
use crate::prediction::{predict, PredictionRequest};
use crate::spec::{Design, GratingRole};
use anyhow::{bail, Result};

/// The configuration whose prediction a synthetic log follows.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ModelSource {
    /// The core whose gratings respond (default: the design's first core).
    pub core: Option<String>,
    /// The load case (default: Case I when an insert is named, else Case II: the
    /// default `verify` judges against).
    pub case: Option<LoadCase>,
    /// The insert of Case I.
    pub insert: Option<String>,
}

impl ModelSource {
    /// The load case this source stands for.
    pub fn load_case(&self) -> LoadCase {
        self.case.unwrap_or(if self.insert.is_some() {
            LoadCase::I
        } else {
            LoadCase::II
        })
    }
}

/// Each strain grating of the source's core with the K the model policy predicts for
/// the source's configuration, pm/N (signed), in the design's order: the values to put
/// in `SynthConfig.grating_sensitivity_pm_per_n`.
///
/// ```
/// use fbgforge_synth::from_model::{model_sensitivities, ModelSource};
/// let d = fbgforge_core::design::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../designs/clip-on-34mm.toml")))?;
/// let k = model_sensitivities(&d, &ModelSource::default())?;
/// assert!(!k.is_empty() && k.iter().all(|(_, k)| k.is_finite() && *k != 0.0));
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn model_sensitivities(design: &Design, source: &ModelSource) -> Result<Vec<(String, f64)>> {
    let Some(m) = &design.module else {
        bail!(
            "design `{}` has no [module]: a log that follows the model is a module's (an array's calibration log follows a loading schedule, SynthLogRequest.schedule)",
            design.name
        )
    };
    let case = source.load_case();
    if case == LoadCase::II && source.insert.is_some() {
        bail!("ModelSource.insert names the insert of Case I; Case II has none");
    }
    if case == LoadCase::I && source.insert.is_none() {
        let names: Vec<&str> = m.inserts.iter().map(|i| i.name.as_str()).collect();
        bail!(
            "Case I needs its insert (ModelSource.insert); the design's inserts are: {}",
            names.join(", ")
        );
    }
    if let Some(ins) = &source.insert {
        if !m.inserts.iter().any(|i| &i.name == ins) {
            let names: Vec<&str> = m.inserts.iter().map(|i| i.name.as_str()).collect();
            bail!(
                "design `{}` has no insert named `{ins}` (ModelSource.insert); its inserts are: {}",
                design.name,
                names.join(", ")
            );
        }
    }
    let core = match &source.core {
        Some(c) => c.clone(),
        None => m.cores.first().map(|c| c.name.clone()).unwrap_or_default(),
    };
    let rows = predict(
        design,
        &PredictionRequest {
            case: Some(case),
            insert: source.insert.clone(),
            core: Some(core.clone()),
            ..Default::default()
        },
    )?;
    let k: Vec<(String, f64)> = m
        .gratings
        .iter()
        .filter(|g| g.role == GratingRole::Strain && g.core.as_deref() == Some(core.as_str()))
        .filter_map(|g| {
            rows.iter()
                .find(|r| r.detail.prediction.grating == g.name)
                .map(|r| (g.name.clone(), r.detail.prediction.sensitivity_pm_per_n))
        })
        .collect();
    if k.is_empty() {
        bail!(
            "design `{}`: the model predicts no strain grating of core `{core}` in Case {case}",
            design.name
        );
    }
    Ok(k)
}

/// The largest pulse a log that follows the model should press with, N: every
/// grating's shift stays within half of the window `verify` reads it in by default
/// (half the gap to the nearest grating, at most the interrogator's default), so the
/// peak never leaves it, and within the design's rated force (`[module.limits]`) when
/// it states one. The default protocol's pulses (10 … 50 N) are scaled to it.
///
/// ```
/// use fbgforge_synth::from_model::{largest_force_n, model_sensitivities, ModelSource};
/// let d = fbgforge_core::design::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../designs/clip-on-34mm.toml")))?;
/// let k = model_sensitivities(&d, &ModelSource::default())?;
/// let f = largest_force_n(&d, &k);
/// // |K| ≈ 165 pm/N against a 2.5 nm half-window: about 7.5 N.
/// assert!(f > 1.0 && f < 10.0, "{f}");
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn largest_force_n(design: &Design, k: &[(String, f64)]) -> f64 {
    let Some(m) = &design.module else {
        return f64::NAN;
    };
    let nominals: Vec<f64> = m.gratings.iter().map(|g| g.bragg_wavelength_nm).collect();
    let half_window_pm = crate::logs::assign::default_half_width_nm(&nominals) * 1000.0;
    let k_max = k.iter().map(|(_, v)| v.abs()).fold(0.0, f64::max);
    let by_window = if k_max > 0.0 {
        0.5 * half_window_pm / k_max
    } else {
        f64::INFINITY
    };
    let rated = m.limits.map_or(f64::INFINITY, |l| l.max_force_n);
    let f = by_window.min(rated);
    if f.is_finite() {
        // Two significant figures: the protocol's forces read as a person would set them.
        let scale = 10f64.powf(f.log10().floor() - 1.0);
        (f / scale).floor() * scale
    } else {
        50.0
    }
}
