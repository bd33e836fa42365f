//! Integration tests: Printable parts: solids, meshes, exports, assembly, outside checkers (admesh, OCCT, PrusaSlicer).
//!
//! One test binary per area (issue 26: few binaries, one link each); each file below
//! is one concern.

#[path = "../common/mod.rs"]
mod common;

mod admesh;
mod geometry;
mod geometry_parts;
mod geometry_props;
mod geometry_step;
mod parts_rules;
mod prusaslicer;
