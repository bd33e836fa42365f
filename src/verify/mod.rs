//! Verification of a printed part from interrogator and force-stand logs.
pub mod fit;
pub mod assign;
pub mod analysis;
