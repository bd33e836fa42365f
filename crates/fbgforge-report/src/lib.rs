//! The printers (ripgrep's `grep-printer`): every way a use case's results are shown,
//! each an implementation of that use case's sink trait.
//!
//! A use case hands its results to a sink (`fbgforge_verify::VerifySink`, ...) whose
//! methods all have no-op defaults; the terminal tables, JSON, CSV and the SVG/HTML
//! report folders here are implementations, and so is the Python package's collector.
//! A new front end (a web view, say) is one more implementation: see
//! `docs/architecture.md`, "A new front end".

// Sibling crates under the names the modules used inside one crate (the use cases
// whose printers are modules here of the same name are named in full: `fbgforge_verify`).
#[allow(unused_imports)]
use fbgforge_array as array;
#[allow(unused_imports)]
use fbgforge_core::{design, family, grating, logs, output, profile, progress, spec};
#[allow(unused_imports)]
use fbgforge_geometry as geometry;
#[allow(unused_imports)]
use fbgforge_model::{fem, model, prediction, solvers};
#[allow(unused_imports)]
use fbgforge_plot as plot;
#[allow(unused_imports)]
use fbgforge_plot::html;

pub mod build;
pub mod calibrate;
pub mod live;
pub mod optimize;
pub mod peaks;
pub mod place;
pub mod predict;
pub mod reconstruct;
pub mod synth;
pub mod terminal;
pub mod verify;
