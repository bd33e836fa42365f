//! fbgforge: design, build, model and verify fiber Bragg grating (FBG) tactile sensors.
//!
//! One design spec ([`spec`]) drives everything. [`profile`] derives every dimension
//! once; the geometry, the models and the verifier all read it.

pub mod array;
pub mod design;
pub mod family;
pub mod fem;
pub mod geometry;
pub mod grating;
pub mod logs;
pub mod model;
pub mod optimize;
pub mod output;
pub mod plot;
pub mod prediction;
pub mod profile;
pub mod progress;
pub mod solvers;
pub mod spec;
pub mod verify;
