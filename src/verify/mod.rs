//! Verification of a printed part from interrogator and force-stand logs: the use case
//! is [`run::run`] (re-exported as [`run()`]); the other modules are its stages.
pub mod analysis;
pub mod assign;
pub mod calibrate;
pub mod charts;
pub mod files;
pub mod fit;
pub mod force_check;
pub mod lag;
pub mod report;
pub mod report_html;
pub mod run;
pub mod segment;
pub mod skew;
pub mod synth;
pub mod verdict;
pub use run::{run, VerifyOutcome, VerifyRequest};
