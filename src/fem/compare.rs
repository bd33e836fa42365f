//! Closed-form model against the finite-element reference (filled in below).

use crate::spec::Design;

/// Which model answers a prediction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Fidelity {
    /// The closed-form model.
    ClosedForm,
    /// The finite-element model.
    Fem,
}

/// Region of the design space where the closed form is within 8 % of the FE model.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ValidityRegion {}

/// The measured validity region.
pub fn validity() -> ValidityRegion {
    ValidityRegion {}
}

/// Choose the model for a design.
pub fn choose_fidelity(_design: &Design) -> Fidelity {
    Fidelity::Fem
}
