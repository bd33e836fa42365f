//! Known-truth data: synthetic interrogator logs and a simulated interrogator, each with
//! the answers a verifier, a calibration or the live mode should recover.
//!
//! - [`module_log`]: a clip-on module pressed by a force profile: the wavelength log,
//!   the force-stand log and `truth.json` (K, lag, clock offset, expected R²);
//! - [`array_log`]: a flat array loaded cell by cell as a schedule says, with the true
//!   sensing matrix;
//! - [`from_model`]: the K of every grating as the design's model predicts it (a log
//!   whose `verify` PASSes);
//! - [`files`]: the use case `synth-log` calls: a run written to a folder, each file
//!   atomically ([`files::write_synth_log`]);
//! - [`stream`]: a simulated Luna Hyperion on loopback serving a design under a load
//!   script ([`stream::serve`]).

// Sibling crates under the names the modules used inside one crate.
#[allow(unused_imports)]
use fbgforge_array as array;
#[allow(unused_imports)]
use fbgforge_core::{design, family, grating, logs, output, profile, progress, spec};
#[allow(unused_imports)]
use fbgforge_live as live;
#[allow(unused_imports)]
use fbgforge_model::{fem, model, prediction, solvers};
#[allow(unused_imports)]
use fbgforge_verify as verify;

pub mod array_log;
pub mod files;
pub mod from_model;
pub mod module_log;
pub mod stream;
