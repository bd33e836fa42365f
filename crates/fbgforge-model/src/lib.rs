//! The models of fbgforge: what a design's gratings will read.
//!
//! - [`solvers`]: the one solver layer (Nelder–Mead, particle swarm, differential
//!   evolution as argmin `Solver`s, run by one executor loop);
//! - [`model`]: the closed-form opto-mechanical model, the one `Configuration` type, sweeps;
//! - [`fem`]: the axisymmetric finite-element model of the clip-on module;
//! - [`prediction`]: the one model policy every command asks.

// Sibling crates under the names the modules used inside one crate.
#[allow(unused_imports)]
use fbgforge_core::{design, family, grating, logs, output, profile, progress, spec};

pub mod fem;
pub mod model;
pub mod prediction;
pub mod solvers;
