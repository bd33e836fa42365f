//! The judged report of a verification: what was measured and the verdict against the
//! model (what `verify --json` prints and a report folder's `report.json` holds).

use crate::analysis::Measurement;
use crate::verdict::Verdict;
use serde::Serialize;

/// What `verify --json` prints and `report.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct VerifyReport {
    /// Design name.
    pub design: String,
    /// Measurements.
    pub measurement: Measurement,
    /// Verdict against the model.
    pub verdict: Verdict,
}
