//! Design spec: shipped designs load, bad specs are rejected with the field named.

use crate::common;
use fbgforge::profile::{ArrayLayout, ModuleProfile};
use std::path::Path;

use common::shipped;

/// Every design shipped in `designs/` (found by listing the folder, so a new one is
/// covered too) loads, says in its name what it is, and survives a TOML round trip.
#[test]
fn every_shipped_design_loads_is_what_its_name_says_and_round_trips() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("designs");
    let designs = fbgforge::design::load_designs(&dir).unwrap_or_else(|e| panic!("{e:#}"));
    let stems: Vec<String> = designs
        .iter()
        .map(|(p, _)| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    // The five of the paper and the size family; a lost file fails here.
    for name in [
        "clip-on-10mm",
        "clip-on-16mm",
        "clip-on-22mm",
        "clip-on-34mm",
        "tactile-array-60x80",
    ] {
        assert!(stems.iter().any(|s| s == name), "{name} missing: {stems:?}");
    }
    for ((path, d), stem) in designs.iter().zip(&stems) {
        assert_eq!(
            &d.name,
            stem,
            "{}: name differs from the file",
            path.display()
        );
        if let Some(size) = stem.strip_prefix("clip-on-") {
            // `clip-on-<D>mm`: a module of outer diameter D and no array.
            let diameter: f64 = size.trim_end_matches("mm").parse().unwrap();
            let m = d
                .module
                .as_ref()
                .unwrap_or_else(|| panic!("{stem}: no module"));
            assert_eq!(m.outer_diameter_mm, diameter, "{stem}");
            assert!(d.array.is_none(), "{stem}");
            assert!(!m.cores.is_empty() && !m.gratings.is_empty(), "{stem}");
        } else if let Some(size) = stem.strip_prefix("tactile-array-") {
            // `tactile-array-<W>x<H>`: an array sheet of those sides (either way round).
            let (w, h) = size.split_once('x').unwrap();
            let (w, h): (f64, f64) = (w.parse().unwrap(), h.parse().unwrap());
            let a = d
                .array
                .as_ref()
                .unwrap_or_else(|| panic!("{stem}: no array"));
            let mut sides = [a.size_x_mm, a.size_y_mm];
            sides.sort_by(f64::total_cmp);
            assert_eq!(sides, [w.min(h), w.max(h)], "{stem}");
            assert!(d.module.is_none(), "{stem}");
            assert!(!a.gratings.is_empty(), "{stem}");
        } else {
            panic!("{stem}: a shipped design is named clip-on-<D>mm or tactile-array-<W>x<H>");
        }
        // What the optimisers write (`to_toml`) reads back as the same design.
        let back = fbgforge::design::parse(&d.to_toml())
            .unwrap_or_else(|e| panic!("{stem} after a round trip: {e}"));
        assert_eq!(&back, d, "{stem}");
    }
}

#[test]
fn paper_module_profile_has_the_stated_dimensions() {
    let d = shipped("clip-on-34mm.toml");
    let m = d.module.as_ref().unwrap();
    let p = ModuleProfile::from_module(m);
    assert_eq!(p.cap_outer_radius_mm, 17.0);
    assert!((p.cap_inner_radius_mm - 15.5).abs() < 1e-12);
    assert!((p.core_outer_radius_mm - p.core_inner_radius_mm - 1.5).abs() < 1e-12);
    // Hemispherical dome: the cap's junctions sit at the sphere centre, H − D/2, and
    // so do the pillar tops.
    assert!((p.dome_center_z_mm - 60.0).abs() < 1e-12);
    assert!((p.cap_outer_junction_z_mm - 60.0).abs() < 1e-9);
    assert!((p.cap_inner_junction_z_mm - 60.0).abs() < 1e-9);
    assert!((p.pillar_top_mm - 60.0).abs() < 1e-9);
    // The core's dome is one clearance inside the cap's (they bear on each other), so
    // its cylinder, one pillar height further in, meets it above the centre.
    let gap = p.cap_dome_inner_sphere_radius_mm - p.core_dome_outer_sphere_radius_mm;
    assert!((gap - 0.1).abs() < 1e-12);
    let rho = p.core_dome_outer_sphere_radius_mm;
    let expected = 60.0 + (rho * rho - p.core_outer_radius_mm.powi(2)).sqrt();
    assert!((p.core_outer_junction_z_mm - expected).abs() < 1e-9);
    assert!(p.core_inner_junction_z_mm > p.pillar_top_mm);
    assert_eq!(m.gratings.len(), 5);
    assert_eq!(m.inserts.len(), 3);
}

#[test]
fn derived_array_layout_reproduces_table_1_distances() {
    let d = shipped("tactile-array-60x80.toml");
    let a = d.array.as_ref().unwrap();
    let l = ArrayLayout::from_array(a);
    // Reference §2, Table 1: distance of each grating to a load at the array centre.
    let expected = [39.53, 25.74, 14.58, 14.58, 25.74, 39.53];
    for ((x, y), e) in l.grating_positions_mm.iter().zip(expected) {
        assert!(((x * x + y * y).sqrt() - e).abs() < 0.01, "{x},{y} vs {e}");
    }
    assert_eq!(l.cell_centers_mm.len(), 8);
    assert_eq!(l.cell_size_mm, (20.0, 30.0));
    assert_eq!(l.mold_outer_mm, (111.0, 81.0, 7.0));
}

fn paper_text() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("designs/clip-on-34mm.toml"))
        .unwrap()
}

fn rejects(text: &str, field: &str) {
    let e = fbgforge::design::parse(text).expect_err("spec should be rejected");
    assert!(
        e.to_string().contains(field),
        "error should name `{field}`: {e}"
    );
}

#[test]
fn bad_specs_name_the_field() {
    let t = paper_text();
    rejects(
        &t.replace("cap_wall_mm = 1.5", "cap_wall_mm = 17.0"),
        "module.cap_wall_mm",
    );
    rejects(
        &t.replace(
            "fiber_hole_diameter_mm = 1.0",
            "fiber_hole_diameter_mm = 2.5",
        ),
        "module.pillars.fiber_hole_diameter_mm",
    );
    rejects(
        &t.replace("width_mm = 3.0", "width_mm = 19.0"),
        "module.pillars",
    );
    rejects(
        &t.replace(
            "cap_core_clearance_mm = 0.1",
            "cap_core_clearance_mm = -0.1",
        ),
        "module.cap_core_clearance_mm",
    );
    rejects(
        &t.replace("core_wall_mm = 1.5", "core_wall_mm = nan"),
        "module.core_wall_mm",
    );
    rejects(
        &t.replace("outer_diameter_mm = 34.0", "outer_diameter_mm = -34.0"),
        "module.outer_diameter_mm",
    );
    rejects(&t.replace("core_wall_mm = 1.5\n", ""), "core_wall_mm");
    rejects(
        &t.replace(
            "core_wall_mm = 1.5",
            "core_wall_mm = 1.5\ncore_wal_mm = 1.5",
        ),
        "core_wal_mm",
    );
    rejects(
        &t.replace("material = \"insert_green\"", "material = \"nope\""),
        "module.inserts[1].material",
    );
    rejects(&t.replace("pillar = 1", "pillar = 7"), "pillar");
    let a = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("designs/tactile-array-60x80.toml"),
    )
    .unwrap();
    rejects(
        &a.replace("plugs = true", "plugs = true\nslit_depth_mm = 6.0"),
        "array.mold.slit_depth_mm",
    );
    rejects(
        &a.replace("internal_x_mm = 105.0", "internal_x_mm = 70.0"),
        "array.mold.internal_x_mm",
    );
}

#[test]
fn toml_syntax_errors_report_the_line() {
    let e = fbgforge::design::parse("name = \"x\"\n[printer\n").unwrap_err();
    assert!(e.to_string().contains("line 2"), "{e}");
}

/// An unknown key names its table and line (toml gives no key path of its own), and a
/// file-level error names no field.
#[test]
fn unknown_keys_name_their_table_and_line() {
    let text = std::fs::read_to_string(common::shipped_path("clip-on-34mm.toml")).unwrap();
    let bad = text.replace(
        "groove_depth_mm = 0.6",
        "groove_depth_mm = 0.6\ngroove_dept_mm = 0.6",
    );
    let line = bad
        .lines()
        .position(|l| l.starts_with("groove_dept_mm"))
        .unwrap()
        + 1;
    let e = fbgforge::design::parse(&bad).unwrap_err();
    assert_eq!(e.field, "module.pillars");
    let msg = e.to_string();
    assert!(
        msg.contains(&format!("line {line}:")) && msg.contains("unknown field `groove_dept_mm`"),
        "{msg}"
    );
    let missing = fbgforge::design::load(Path::new("/no/such/design.toml")).unwrap_err();
    assert!(
        missing
            .to_string()
            .starts_with("/no/such/design.toml: cannot read"),
        "{missing}"
    );
}

#[test]
fn duplicate_names_are_refused_naming_the_second() {
    let t = paper_text();
    for (from, to, field, what) in [
        (
            "name = \"psc2\"",
            "name = \"psc1\"",
            "module.cores[1].name",
            "core",
        ),
        (
            "name = \"green\"",
            "name = \"blue\"",
            "module.inserts[1].name",
            "insert",
        ),
        (
            "name = \"lambda_12\"",
            "name = \"lambda_11\"",
            "module.gratings[1].name",
            "grating",
        ),
    ] {
        let e = fbgforge::design::parse(&t.replacen(from, to, 1)).expect_err(field);
        let msg = e.to_string();
        assert!(
            msg.contains(field) && msg.contains(&format!("duplicate {what} name")),
            "{msg}"
        );
    }
    let array = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("designs/tactile-array-60x80.toml"),
    )
    .unwrap();
    let e = fbgforge::design::parse(&array.replacen("name = \"fbg2\"", "name = \"fbg1\"", 1))
        .expect_err("duplicate array grating");
    assert!(e.to_string().contains("array.gratings[1].name"), "{e}");
}
