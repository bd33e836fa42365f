//! Geometry: the parts of the shipped designs against closed forms, the profile, each
//! other (fits), and the files written; bad input and unwritable folders.

use crate::common;
use fbgforge::geometry::{self, mesh, module, BuiltPart, PartKind};
use fbgforge::profile::{ArrayLayout, ModuleProfile};
use fbgforge::spec::Design;
use std::f64::consts::PI;
use std::path::Path;

use common::shipped;

fn text(name: &str) -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("designs")
            .join(name),
    )
    .unwrap()
}

fn part<'a>(parts: &'a [BuiltPart], name: &str) -> &'a BuiltPart {
    parts
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("no part {name}"))
}

const MODULES: [&str; 4] = [
    "clip-on-10mm.toml",
    "clip-on-16mm.toml",
    "clip-on-22mm.toml",
    "clip-on-34mm.toml",
];

#[test]
fn closed_form_pieces_match_textbook_volumes() {
    // Hemisphere: 2/3 π ρ³; a zone symmetric about the centre of a ball of radius 1
    // between ±1 is the whole ball.
    assert!((module::zone_volume(2.0, 0.0, 2.0) - 2.0 / 3.0 * PI * 8.0).abs() < 1e-12);
    assert!((module::zone_volume(1.0, -1.0, 1.0) - 4.0 / 3.0 * PI).abs() < 1e-12);
    // A slice |t| < r of the half disc is the half disc; a thin slice is ≈ 2h·r.
    assert!((module::slice_area(3.0, 3.0) - PI * 9.0 / 2.0).abs() < 1e-12);
    assert!((module::slice_area(3.0, 1e-4) - 2e-4 * 3.0).abs() < 1e-10);
}

#[test]
fn every_shipped_part_passes_the_checks_at_the_default_tolerance() {
    for name in MODULES.iter().chain(&["tactile-array-60x80.toml"]) {
        let d = shipped(name);
        let parts = geometry::build_parts(&d, None, None).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(parts.len(), geometry::part_names(&d).len());
        for p in &parts {
            // Re-run the checks on the returned mesh; the volume bound is 0.5 %.
            p.mesh.check(&p.name).unwrap();
            assert!(
                p.volume_error().abs() <= 0.005,
                "{name} {}: {}",
                p.name,
                p.volume_error()
            );
            assert!(p.mesh_tolerance_mm <= d.printer.default_tolerance_mm());
        }
    }
}

#[test]
fn module_meshes_converge_to_the_exact_volumes() {
    // At a fine tolerance the inscribed mesh must approach the closed form; a missing
    // feature (one fiber hole is ~0.5 % of the 34 mm core) would show up here.
    for name in ["clip-on-34mm.toml", "clip-on-10mm.toml"] {
        let d = shipped(name);
        let solids = geometry::build_solids(
            &d,
            Some(&["cap".into(), "core".into(), "insert-blue".into()]),
        )
        .unwrap();
        for s in &solids {
            let r = d.module.as_ref().unwrap().outer_diameter_mm / 2.0;
            // Same relative chord error for every size: tolerance ∝ radius.
            let tol = 0.002 * r / 17.0;
            let m = mesh::mesh_solid(&s.name, &s.solid, tol).unwrap();
            let err = (m.volume_mm3() - s.exact_volume_mm3) / s.exact_volume_mm3;
            assert!(err.abs() < 5e-4, "{name} {}: {:.5} %", s.name, err * 100.0);
        }
    }
}

#[test]
fn mold_volume_and_size_are_exact() {
    let d = shipped("tactile-array-60x80.toml");
    let parts = geometry::build_parts(&d, None, None).unwrap();
    let mold = part(&parts, "mold");
    // Reference §2 mold: 105 × 75 internal, 3 mm walls (81 × 111 outside), 2 mm base,
    // 5 mm walls; through each 3 mm long wall six slits: a 0.5 mm seat (the FDM floor:
    // the 0.4 mm nozzle + the 0.1 mm clearance) from 4.4 mm (the 0.2 mm layer nearest 4.375 mm,
    // where the fiber's axis would be at mid-sheet, 2 + 5/2 mm) up to the layer at or
    // above the fiber's top (4.65 → 4.8 mm), under a 1.0 mm pocket (a 1.0 mm plug,
    // press fit) up to the wall top at 7 mm.
    let slit = 0.5 * (4.8 - 4.4) + 1.0 * (7.0 - 4.8);
    let exact = 111.0 * 81.0 * 7.0 - 105.0 * 75.0 * 5.0 - 2.0 * 6.0 * 3.0 * slit;
    assert!((mold.exact_volume_mm3 - exact).abs() < 1e-9);
    assert!((mold.mesh_volume_mm3 - exact).abs() < 1e-6 * exact);
    let (lo, hi) = mold.mesh.bbox_mm();
    let l = ArrayLayout::from_array(d.array.as_ref().unwrap());
    for k in 0..3 {
        let size = [l.mold_outer_mm.0, l.mold_outer_mm.1, l.mold_outer_mm.2][k];
        assert!((hi[k] - lo[k] - size).abs() < 1e-9, "axis {k}");
    }
    // Each slit stops where the coated fiber resting in it has its axis at the fiber
    // height (mid-thickness of the sheet); nothing is cut lower.
    assert!((l.slit_bottom_z_mm - 4.4).abs() < 1e-9);
    assert!((l.slit_bottom_z_mm / 0.2 - (l.slit_bottom_z_mm / 0.2).round()).abs() < 1e-9);
    assert!((l.slit_bottom_z_mm + 0.125 - l.fiber_z_mm).abs() <= 0.1 + 1e-12);
    assert!((l.fiber_z_mm - 4.5).abs() < 1e-12);
    let floor_pts = mold
        .mesh
        .positions
        .iter()
        .filter(|p| (p[2] - l.slit_bottom_z_mm).abs() < 1e-9)
        .count();
    let lowest_in_walls = mold
        .mesh
        .positions
        .iter()
        .filter(|p| p[1].abs() > 75.0 / 2.0 - 1e-9 && p[2] > l.cavity_floor_z_mm + 1e-9)
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min);
    assert!((lowest_in_walls - l.slit_bottom_z_mm).abs() < 1e-9);
    assert_eq!(
        floor_pts,
        6 * 2 * 4,
        "four corners per slit bottom, six slits, two walls"
    );
}

#[test]
fn cap_and_insert_bounding_boxes_follow_the_profile() {
    let d = shipped("clip-on-34mm.toml");
    let p = ModuleProfile::from_module(d.module.as_ref().unwrap());
    let parts = geometry::build_parts(&d, None, None).unwrap();
    let (lo, hi) = part(&parts, "cap").mesh.bbox_mm();
    let apex = p.dome_center_z_mm
        + (p.cap_dome_outer_sphere_radius_mm.powi(2) - p.apex_flat_radius_mm.powi(2)).sqrt();
    assert!((hi[2] - apex).abs() < 1e-9 && lo[2].abs() < 1e-12);
    // The fiber slots cut the circle's vertices at 0°: the extent is the radius to
    // within the chord tolerance.
    let tol = part(&parts, "cap").mesh_tolerance_mm;
    assert!(
        (hi[0] - p.cap_outer_radius_mm).abs() < tol && (lo[1] + p.cap_outer_radius_mm).abs() < tol
    );
    let (lo, hi) = part(&parts, "insert-green").mesh.bbox_mm();
    let top = p.dome_center_z_mm
        + (p.insert_sphere_radius_mm.powi(2) - p.apex_flat_radius_mm.powi(2)).sqrt();
    assert!((hi[2] - top).abs() < 1e-9 && lo[2].abs() < 1e-12);
    let tol = part(&parts, "insert-green").mesh_tolerance_mm;
    assert!((hi[0] - p.insert_radius_mm).abs() < tol);
}

/// Radius and tangential offset of a point from the nearest pillar's centre line.
fn polar_to_pillar(q: &[f64; 3], angles: &[f64]) -> (f64, f64, f64) {
    let rho = q[0].hypot(q[1]);
    let (best, t) = angles
        .iter()
        .map(|&a| {
            let s = q[0] * a.cos() + q[1] * a.sin();
            let t = -q[0] * a.sin() + q[1] * a.cos();
            (s, t)
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap();
    (rho, best, t)
}

#[test]
fn cap_pillars_fit_the_core_grooves_with_the_stated_clearance() {
    for name in MODULES {
        let d = shipped(name);
        let m = d.module.as_ref().unwrap();
        let p = ModuleProfile::from_module(m);
        let parts = geometry::build_parts(&d, None, Some(&["cap".into(), "core".into()])).unwrap();
        let eps = 1e-6;
        let (hg, hc) = (m.pillars.groove_width_mm / 2.0, p.cap_pillar_width_mm / 2.0);
        // Core below the pillar top: between its inner wall and the pillar faces, and
        // where it reaches beyond the groove bottom it is outside the groove.
        for q in &part(&parts, "core").mesh.positions {
            if q[2] > p.pillar_top_mm - eps {
                continue;
            }
            let (rho, _, t) = polar_to_pillar(q, &p.pillar_angles_rad);
            assert!(
                rho <= p.pillar_outer_radius_mm + eps && rho >= p.core_inner_radius_mm - eps,
                "{name} core {q:?}"
            );
            if rho > p.groove_bottom_radius_mm + eps {
                assert!(
                    t.abs() >= hg - eps,
                    "{name}: core material inside the groove at {q:?}"
                );
            }
        }
        // Cap between the pillar bottoms and the pillar top: never inside the core's
        // pillar radius except in its alignment pillars, which stay inside the groove
        // with clearance. (Below the pillar bottoms is the snap bead: see
        // tests/geometry_parts.rs.)
        let bottom = fbgforge::profile::PartsProfile::of_design(&d)
            .unwrap()
            .1
            .pillar_bottom_mm;
        for q in &part(&parts, "cap").mesh.positions {
            if q[2] > p.pillar_top_mm - eps || q[2] < bottom + eps {
                continue;
            }
            let (rho, _, t) = polar_to_pillar(q, &p.pillar_angles_rad);
            assert!(
                rho >= p.cap_pillar_inner_radius_mm - eps,
                "{name} cap {q:?}"
            );
            if rho < p.cap_inner_radius_mm - eps {
                assert!(
                    t.abs() <= hc + eps,
                    "{name}: cap pillar wider than {hc} at {q:?}"
                );
                assert!(hg - t.abs() >= m.cap_core_clearance_mm - eps);
                assert!(rho - p.groove_bottom_radius_mm >= m.cap_core_clearance_mm - eps);
            }
        }
    }
}

#[test]
fn core_has_fiber_holes_through_every_pillar_and_a_top_hole() {
    let d = shipped("clip-on-34mm.toml");
    let m = d.module.as_ref().unwrap();
    let p = ModuleProfile::from_module(m);
    let parts = geometry::build_parts(&d, None, Some(&["core".into()])).unwrap();
    let core = part(&parts, "core");
    let rh = m.pillars.fiber_hole_diameter_mm / 2.0;
    for &a in &p.pillar_angles_rad {
        let c = (
            p.fiber_hole_center_radius_mm * a.cos(),
            p.fiber_hole_center_radius_mm * a.sin(),
        );
        let on_wall = |z: f64| {
            core.mesh
                .positions
                .iter()
                .filter(|q| {
                    (q[2] - z).abs() < 1e-9 && ((q[0] - c.0).hypot(q[1] - c.1) - rh).abs() < 1e-6
                })
                .count()
        };
        // The hole's circle appears in the pillar bottom and in the pillar top.
        let bottom = fbgforge::profile::PartsProfile::of_design(&d)
            .unwrap()
            .1
            .pillar_bottom_mm;
        assert!(
            on_wall(bottom) >= 8,
            "hole at {a} missing in the pillar bottom"
        );
        assert!(
            on_wall(p.pillar_top_mm) >= 8,
            "hole at {a} missing in the pillar top"
        );
    }
    // Nothing above the pillars comes closer to the axis than the top hole's radius,
    // and the top hole's rim is the highest point.
    let above: Vec<_> = core
        .mesh
        .positions
        .iter()
        .filter(|q| q[2] > p.pillar_top_mm + 1e-6)
        .collect();
    let min_rho = above
        .iter()
        .map(|q| q[0].hypot(q[1]))
        .fold(f64::INFINITY, f64::min);
    assert!((min_rho - p.top_hole_radius_mm).abs() < 1e-6, "{min_rho}");
    let (_, hi) = core.mesh.bbox_mm();
    let rim = p.dome_center_z_mm
        + (p.core_dome_outer_sphere_radius_mm.powi(2) - p.top_hole_radius_mm.powi(2)).sqrt();
    assert!((hi[2] - rim).abs() < 1e-9);
}

#[test]
fn build_writes_stl_step_and_a_consistent_manifest() {
    let d = shipped("clip-on-16mm.toml");
    let dir = tempfile::tempdir().unwrap();
    let r = crate::build(&d, dir.path(), None).unwrap();
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("manifest.json")).unwrap())
            .unwrap();
    let listed = manifest["parts"].as_array().unwrap();
    assert_eq!(listed.len(), 5);
    for (entry, p) in listed.iter().zip(&r.parts) {
        let stl_path = dir.path().join(entry["stl"].as_str().unwrap());
        let mut f = std::fs::File::open(&stl_path).unwrap();
        let stl = stl_io::read_stl(&mut f).unwrap();
        assert_eq!(stl.faces.len() as u64, entry["triangles"].as_u64().unwrap());
        // Volume of the f32 STL as read back matches the manifest.
        let v: f64 = stl
            .faces
            .iter()
            .map(|t| {
                let [a, b, c] = t.vertices.map(|i| stl.vertices[i].0.map(f64::from));
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum();
        let mv = entry["mesh_volume_mm3"].as_f64().unwrap();
        assert!((v - mv).abs() < 1e-5 * mv, "{}: {v} vs {mv}", p.name);
        // STEP: one B-rep solid with as many faces as the truck solid.
        let step =
            std::fs::read_to_string(dir.path().join(entry["step"].as_str().unwrap())).unwrap();
        assert!(step.starts_with("ISO-10303-21;"));
        assert_eq!(step.matches("MANIFOLD_SOLID_BREP").count(), 1);
        let faces = p.solid.boundaries()[0].len();
        assert_eq!(
            step.matches("ADVANCED_FACE").count() + step.matches("FACE_SURFACE").count(),
            faces
        );
    }
    let c = &manifest["clearances"];
    assert!((c["cap_core_radial_mm"].as_f64().unwrap() - 0.08).abs() < 1e-12);
    assert!((c["core_insert_radial_mm"].as_f64().unwrap() - 0.08).abs() < 1e-12);
    assert!((c["alignment_pillar_side_mm"].as_f64().unwrap() - 0.08).abs() < 1e-12);
    // No temporary files left behind.
    for e in std::fs::read_dir(dir.path()).unwrap() {
        let n = e.unwrap().file_name().into_string().unwrap();
        assert!(!n.starts_with(".fbgforge-"), "{n}");
    }
}

#[test]
fn parts_selection_builds_only_the_named_parts_and_rejects_unknown_ones() {
    let d = shipped("clip-on-34mm.toml");
    let only = geometry::build_parts(&d, None, Some(&["insert-green".into()])).unwrap();
    assert_eq!(only.len(), 1);
    assert_eq!(only[0].kind, PartKind::Insert);
    let e = geometry::build_parts(&d, None, Some(&["lid".into()]))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unknown part `lid`") && e.contains("insert-light_green"),
        "{e}"
    );
}

fn assert_nothing_written(dir: &Path) {
    if dir.exists() {
        let n = std::fs::read_dir(dir).unwrap().count();
        assert_eq!(n, 0, "files were written into {}", dir.display());
    }
}

#[test]
fn impossible_geometry_is_rejected_with_the_field_and_nothing_is_written() {
    let cases = [
        // Wall as thick as the radius.
        (
            "cap_wall_mm = 1.5",
            "cap_wall_mm = 17.0",
            "module.cap_wall_mm",
        ),
        // Fiber hole wider than its pillar.
        (
            "fiber_hole_diameter_mm = 1.0",
            "fiber_hole_diameter_mm = 2.9",
            "module.pillars.fiber_hole_diameter_mm",
        ),
        // Negative clearance.
        (
            "cap_core_clearance_mm = 0.1",
            "cap_core_clearance_mm = -0.1",
            "module.cap_core_clearance_mm",
        ),
        // Overlapping pillars.
        (
            "width_mm = 3.0",
            "width_mm = 19.0",
            "module.pillars.width_mm",
        ),
        // NaN.
        (
            "overall_height_mm = 77.0",
            "overall_height_mm = nan",
            "module.overall_height_mm",
        ),
    ];
    for (from, to, field) in cases {
        let t = text("clip-on-34mm.toml").replacen(from, to, 1);
        let e = fbgforge::design::parse(&t).expect_err(to).to_string();
        assert!(e.contains(field), "{to}: {e}");
    }
    // A slit deeper than the wall, and one narrower than the fiber needs.
    for (line, field) in [
        ("slit_depth_mm = 6.0", "array.mold.slit_depth_mm"),
        ("slit_width_mm = 0.25", "array.mold.slit_width_mm"),
    ] {
        let t = text("tactile-array-60x80.toml").replacen(
            "plugs = true",
            &format!("plugs = true\n{line}"),
            1,
        );
        let e = fbgforge::design::parse(&t).unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
    }
    // A fiber slit in the mold's corner passes the spec's ranges but not the builder.
    let mut d = shipped("tactile-array-60x80.toml");
    let a = d.array.as_mut().unwrap();
    a.mold.internal_x_mm = 80.0;
    a.fiber_x_mm[5] = 40.0;
    d.validate().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mold");
    let e = format!("{:#}", crate::build(&d, &out, None).unwrap_err());
    assert!(
        e.contains("array.fiber_x_mm[5]") && e.contains("nothing was written"),
        "{e}"
    );
    assert_nothing_written(&out);
}

#[test]
fn an_unwritable_output_folder_is_reported_and_leaves_no_file() {
    let d = shipped("clip-on-10mm.toml");
    let dir = tempfile::tempdir().unwrap();
    // A regular file where the output folder's parent should be: cannot be created,
    // even by root.
    let blocker = dir.path().join("not-a-folder");
    std::fs::write(&blocker, b"x").unwrap();
    let out = blocker.join("parts");
    let e = format!("{:#}", crate::build(&d, &out, None).unwrap_err());
    assert!(
        e.contains("cannot create output folder") && e.contains("not-a-folder"),
        "{e}"
    );
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("not-a-folder")]);
}

/// Zero clearances are valid specs (a press-fit insert, a core that touches the cap):
/// the parts still build and pass every check, and the insert fills the core exactly.
/// (Found by the property test in CI: the builder once demanded a strict gap.)
#[test]
fn press_fit_zero_clearances_build_checked_parts() {
    for name in MODULES {
        let mut d = shipped(name);
        let m = d.module.as_mut().unwrap();
        m.cap_core_clearance_mm = 0.0;
        m.core_insert_clearance_mm = 0.0;
        d.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        let p = ModuleProfile::from_module(d.module.as_ref().unwrap());
        assert_eq!(p.insert_radius_mm, p.core_inner_radius_mm);
        let parts = geometry::build_parts(&d, None, None).unwrap_or_else(|e| panic!("{name}: {e}"));
        for part in &parts {
            part.mesh
                .check(&part.name)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(
                part.volume_error().abs() <= geometry::VOLUME_TOLERANCE_AT_DEFAULT,
                "{name} {}: {}",
                part.name,
                part.volume_error()
            );
        }
        let insert = parts.iter().find(|q| q.kind == PartKind::Insert).unwrap();
        let (_, hi) = insert.mesh.bbox_mm();
        assert!(
            (hi[1] - p.core_inner_radius_mm).abs() < insert.mesh_tolerance_mm,
            "{name}"
        );
    }
}

#[test]
fn a_tolerance_out_of_range_is_an_error_not_a_panic() {
    let d = shipped("clip-on-10mm.toml");
    for tol in [0.0, -1.0, f64::NAN, 5.0] {
        let e = geometry::build_parts(&d, Some(tol), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("tolerance"), "{e}");
    }
}

#[test]
fn family_interpolation_reproduces_the_knots_and_stays_valid() {
    let knots: Vec<Design> = [
        "clip-on-10mm.toml",
        "clip-on-16mm.toml",
        "clip-on-22mm.toml",
    ]
    .map(shipped)
    .into();
    let d16 = fbgforge::family::interpolate(&knots, 16.0).unwrap();
    assert_eq!(d16.module, knots[1].module);
    let d13 = fbgforge::family::interpolate(&knots, 13.0).unwrap();
    let m = d13.module.as_ref().unwrap();
    assert!(
        (m.cap_wall_mm - 0.75).abs() < 1e-12,
        "midway between 0.6 and 0.9"
    );
    assert!(fbgforge::family::interpolate(&knots, 30.0)
        .unwrap_err()
        .to_string()
        .contains("outer_diameter_mm"));
}
