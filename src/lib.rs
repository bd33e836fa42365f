//! fbgforge: design, build, model and verify fiber Bragg grating (FBG) tactile sensors.
//!
//! One design spec drives everything. This crate is the facade (fornjot's example): the
//! house is a workspace of crates listed from the ground up, each with one job, and
//! this crate hands their modules on under one name, so `fbgforge::verify::run` or
//! `fbgforge::geometry::build_design` is where a front end (the `fbgforge` binary, the
//! Python package, the studies) finds each use case. An import from a lower crate to
//! a higher one is a compile error (`docs/architecture.md` draws the floors).
//!
//! 1. ground ([`fbgforge_core`]): [`grating`], [`spec`], [`profile`], [`design`],
//!    [`family`], [`fields`], [`logs`], [`output`], [`progress`];
//! 2. drawing ([`fbgforge_plot`]): [`plot`] (SVG charts), [`html`] (self-contained
//!    HTML documents);
//! 3. parts ([`fbgforge_geometry`]): [`geometry`] (`build_design`);
//! 4. models ([`fbgforge_model`]): [`solvers`], [`model`], [`fem`], [`prediction`];
//! 5. use cases: [`mod@array`] ([`fbgforge_array`]), [`verify`] ([`fbgforge_verify`]),
//!    [`optimize`] ([`fbgforge_optimize`]), [`live`] ([`fbgforge_live`]);
//! 6. known-truth data ([`fbgforge_synth`]): [`synth`] (synthetic logs, a simulated
//!    interrogator);
//! 7. printers ([`fbgforge_report`]): [`report`] (terminal tables, JSON, CSV, SVG/HTML
//!    reports: the implementations of each use case's sink); [`publish`]
//!    ([`fbgforge_publish`]): ROS 2 messages in MCAP and the browser view, from plain
//!    data.

pub use fbgforge_core::{design, family, fields, grating, logs, output, profile, progress, spec};
pub use fbgforge_model::{fem, model, prediction, solvers};
pub use fbgforge_plot::html;

pub use fbgforge_array as array;
pub use fbgforge_geometry as geometry;
pub use fbgforge_live as live;
pub use fbgforge_optimize as optimize;
pub use fbgforge_plot as plot;
pub use fbgforge_publish as publish;
pub use fbgforge_report as report;
pub use fbgforge_spectra as spectra;
pub use fbgforge_synth as synth;
pub use fbgforge_verify as verify;

pub use fbgforge_array;
pub use fbgforge_core;
pub use fbgforge_geometry;
pub use fbgforge_live;
pub use fbgforge_model;
pub use fbgforge_optimize;
pub use fbgforge_plot;
pub use fbgforge_publish;
pub use fbgforge_report;
pub use fbgforge_spectra;
pub use fbgforge_synth;
pub use fbgforge_verify;
