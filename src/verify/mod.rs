//! Verification of a printed part from interrogator and force-stand logs.
pub mod fit;
pub mod assign;
pub mod analysis;
pub mod synth;
pub mod verdict;
pub mod report;
pub mod calibrate;
