//! Opto-mechanical model of the clip-on module: predicted sensitivity K (pm/N) of
//! every grating from the design spec (interface; the model itself lands with the
//! model issue).

use crate::spec::Design;
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

/// Predict every strain grating of the design's module, for Case II and for Case I
/// with each listed insert, at `force_n`.
pub fn predict(design: &Design, force_n: f64) -> anyhow::Result<Vec<GratingPrediction>> {
    let _ = (design, force_n);
    anyhow::bail!("the opto-mechanical model is not available in this build yet")
}
