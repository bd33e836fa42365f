//! Verification of a printed part from interrogator and force-stand logs.
pub mod analysis;
pub mod assign;
pub mod calibrate;
pub mod fit;
pub mod report;
pub mod synth;
pub mod verdict;
