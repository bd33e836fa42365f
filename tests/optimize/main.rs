//! Integration tests: Module optimisation and grating placement, library and CLI.
//!
//! One test binary per area (issue 26: few binaries, one link each); each file below
//! is one concern.

#[path = "../common/chromium.rs"]
mod chromium;
#[path = "../common/mod.rs"]
mod common;

mod optimize;
mod optimize_cli;
mod optimize_model;
mod optimize_place;
mod optimize_spectrum;
mod report_html;
