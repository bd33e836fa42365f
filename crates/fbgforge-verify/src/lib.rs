//! Verification of a printed part from interrogator and force-stand logs: the use case
//! is [`run::run`] (re-exported as [`run()`]); the other modules are its stages.

// Sibling crates under the names the modules used inside one crate.
#[allow(unused_imports)]
use fbgforge_core::{design, family, grating, logs, output, profile, progress, spec};
#[allow(unused_imports)]
use fbgforge_model::{fem, model, prediction, solvers};
#[allow(unused_imports)]
use fbgforge_plot as plot;
#[allow(unused_imports)]
use fbgforge_plot::html;

pub mod analysis;
pub mod charts;
pub mod fit;
pub mod force_check;
pub mod lag;
pub mod report;
pub mod report_html;
pub mod run;
pub mod segment;
pub mod skew;
pub mod verdict;
pub use run::{run, VerifyOutcome, VerifyRequest};
