//! Design optimisation: maximise the predicted quality Q (or the sensitivity) of a
//! clip-on module over printable designs, and place the gratings of a flat array so
//! that reconstruction works best.
//!
//! * [`materials`]: the material library (E, ν and the Q model's viscoelastic numbers).
//! * [`quality`]: the Q model, Q = |K|·R²/Δt_max, and its calibration by a verifier JSON.
//! * the solvers are the crate's one solver layer, [`crate::solvers`].
//! * [`module`]: the module problem: variables, constraints, discrete material choices.
//! * [`place`]: grating placement in the flat array, scored on the reconstruction protocol.
//! * [`run`]: the use cases the front ends call: optimise a module, place gratings; both
//!   write the design and hand what they found to a sink (`run::ModuleSink`,
//!   `run::PlaceSink`; the report folders, tables and JSON are in `fbgforge-report`).

// Sibling crates under the names the modules used inside one crate.
#[allow(unused_imports)]
use fbgforge_array as array;
#[allow(unused_imports)]
use fbgforge_core::{design, family, fields, grating, logs, output, profile, progress, spec};
#[allow(unused_imports)]
use fbgforge_model::{fem, model, prediction, solvers};

pub mod materials;
pub mod module;
pub mod place;
pub mod quality;
pub mod run;
