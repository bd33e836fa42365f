//! The frame test's significance: its default and its check (a leaf of its own, so
//! that the problem, which holds a significance, does not import the test).

use crate::ArrayError;

/// The significance of the frame test when none is given: a true answer is flagged
/// (by any of the three tests) with at most this probability, on any array.
pub const DEFAULT_SIGNIFICANCE: f64 = 0.05;

/// A significance must be a probability in (0, 0.5].
pub fn check_significance(significance: f64) -> Result<(), ArrayError> {
    if significance.is_finite() && significance > 0.0 && significance <= 0.5 {
        Ok(())
    } else {
        Err(ArrayError::Input(format!(
            "SensingProblem.significance must be a probability in (0, 0.5], got {significance}"
        )))
    }
}
