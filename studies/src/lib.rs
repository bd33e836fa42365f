//! fbgforge-studies: the project's measured tables and charts, kept out of the
//! library. Each module is one study (a benchmark that prints a table and writes
//! CSV/JSON/SVG, a paper reproduction or a failure study) with its own `clap` args,
//! a `--quick` form that the test suite runs so no study can rot, and a `run`
//! function. Nothing in the `fbgforge` library imports this crate.
//!
//! Run one with `cargo run --release -p fbgforge-studies -- <study> [--quick]`.

pub mod build;
pub mod calibrate;
pub mod fe_speed;
pub mod fem;
pub mod fem_compare;
pub mod fem_contact;
pub mod live_starts;
pub mod model_error;
pub mod optimize;
pub mod predict;
pub mod print_files;
/// Terminal bars: the binary's own implementation of the library's `Progress`.
#[path = "../../src/cli/progress.rs"]
pub mod progress;
pub mod reconstruct;
pub mod reconstruct_budget;
pub mod reconstruct_faults;
pub mod reconstruct_flags;
pub mod reconstruct_scaling;
pub mod sheet;
pub mod spectra;
pub mod spectrum_forward;
pub mod verdicts;
pub mod verify;
