//! Verification of a printed part from interrogator and force-stand logs.
pub mod fit;
