//! fbgforge: design, build, model and verify fiber Bragg grating (FBG) tactile sensors.
//!
//! One design spec drives everything. The library owns every use case; the `fbgforge`
//! binary only turns flags into a request, calls one use case and prints the result;
//! the `fbgforge-studies` crate beside it holds the benchmarks and paper studies.
//!
//! Layers, bottom-up (a module imports only from layers below it, never from the
//! binary or a study; `docs/architecture.md` draws the rooms and the data path):
//!
//! 1. foundations: [`grating`] (Bragg physics), [`output`] (atomic writes),
//!    [`progress`], [`plot`] (SVG charts), [`html`] (self-contained HTML reports),
//!    [`logs`] (interrogator and force logs);
//! 2. the spec: [`spec`] (TOML types, field checks);
//! 3. derived: [`profile`] (every derived dimension, read by solids, model and FE),
//!    [`design`] (loading: parse and check, profile rules included), [`family`]
//!    (a module at any diameter);
//! 4. methods: [`solvers`] (Nelder–Mead, particle swarm, differential evolution),
//!    [`model`] (closed form), [`fem`] (finite elements);
//! 5. policy: [`prediction`] (the one model policy every command asks);
//! 6. use cases: [`geometry`] (`build_design`), [`mod@array`] (`reconstruct_file`),
//!    [`verify`] (`run`), [`optimize`] (`run::run_module`, `run::run_placement`).

pub mod array;
pub mod design;
pub mod family;
pub mod fem;
pub mod geometry;
pub mod grating;
pub mod html;
pub mod live;
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
