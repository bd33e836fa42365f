//! Verification of a printed part from interrogator and force-stand logs: the use case
//! is [`run::run`] (re-exported as [`run()`]; [`run_with`] hands the results to a
//! [`VerifySink`]); the other modules are its stages. How the results are shown
//! (terminal summary, JSON, the report folder) is `fbgforge-report`'s.

// Sibling crates under the names the modules used inside one crate.
#[allow(unused_imports)]
use fbgforge_core::{design, family, grating, logs, output, profile, progress, spec};
#[allow(unused_imports)]
use fbgforge_model::{fem, model, prediction, solvers};

pub mod analysis;
pub mod fit;
pub(crate) mod force_check;
pub mod lag;
pub mod report;
pub mod run;
pub mod segment;
pub mod sink;
pub mod skew;
pub mod verdict;
pub use report::VerifyReport;
pub use run::{run, run_with, VerifyOutcome, VerifyRequest};
pub use sink::VerifySink;
