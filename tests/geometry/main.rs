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
mod held_out;
mod parts_rules;
mod printer_floor;
mod prusaslicer;
mod refusals;

/// Build every part of `design` into `dir` as the command line does (with its
/// previews), at `tolerance_mm` or the design's default.
fn build(
    design: &fbgforge::spec::Design,
    dir: &std::path::Path,
    tolerance_mm: Option<f64>,
) -> anyhow::Result<fbgforge::geometry::BuildReport> {
    let request = fbgforge::geometry::BuildRequest {
        tolerance_mm,
        parts: None,
    };
    fbgforge::geometry::build_design(
        design,
        dir,
        &request,
        &mut fbgforge::report::build::Previews,
    )
}
