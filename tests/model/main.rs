//! Integration tests: The spec and the models: closed form, finite elements, contact, the one model policy, predict/sweep CLI.
//!
//! One test binary per area (issue 26: few binaries, one link each); each file below
//! is one concern.

#[path = "../common/mod.rs"]
mod common;

mod family_statements;
mod fem_contact;
mod fem_exact;
mod fem_fidelity;
mod fem_module;
mod model;
mod model_cli;
mod model_policy;
mod spec;
mod sweep_chart;
