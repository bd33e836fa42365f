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
mod model_error;
mod model_policy;
mod spec;
mod spectrum_forward;
mod sweep_chart;

/// The finite-element structures of this test binary's solves: the tests own one
/// cache (the library keeps none of its own), so solves of one geometry share their
/// structure across tests as a sweep's steps do.
fn fe_cache() -> &'static fbgforge::fem::GeometryCache {
    static CACHE: std::sync::OnceLock<fbgforge::fem::GeometryCache> = std::sync::OnceLock::new();
    CACHE.get_or_init(fbgforge::fem::GeometryCache::default)
}
