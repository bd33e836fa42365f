//! Integration tests: Interrogator and force logs, verification, calibration, synthetic logs.
//!
//! One test binary per area (issue 26: few binaries, one link each); each file below
//! is one concern.

#[path = "../common/chromium.rs"]
mod chromium;
#[path = "../common/mod.rs"]
mod common;

mod logs_fixtures;
mod report_html;
mod verify_cli;
mod verify_edges;
mod verify_errors;
mod verify_protocols;
mod verify_spectra;
mod verify_synth;
