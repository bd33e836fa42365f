//! fbgforge's ground floor: what every use case stands on.
//!
//! - [`grating`]: Bragg physics (strain and temperature to wavelength shift);
//! - [`spec`]: the design spec (TOML types, field checks);
//! - [`profile`]: every derived dimension, the one source solids, model and FE read;
//! - [`design`]: loading a design (parse, check fields, check the derived profile);
//! - [`family`]: a clip-on module at any diameter;
//! - [`logs`]: interrogator and force-stand logs, and the small CSV tables;
//! - [`fields`]: the library's own words for its options (front ends map them once);
//! - [`output`]: atomic writes (temporary file + rename), CSV and JSON;
//! - [`progress`]: progress of long runs, as the library reports it.

pub mod design;
pub mod family;
pub mod fields;
pub mod grating;
pub mod logs;
pub mod output;
pub mod profile;
pub mod progress;
pub mod spec;
