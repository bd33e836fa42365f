//! Parts that are never wrong in silence (issue 25): each defect the outside checkers
//! found, turned into a rule that refuses it or a check that measures it, on exact
//! dimensions where the meshes could hide it.
//!
//! 1. a fiber passage narrower than the fiber;
//! 2. a reference grating with no room past its end, or inside the insert's bore;
//! 3. a meshing tolerance that lets mating meshes overlap;
//! 4. the fiber clearance measured from the centreline;
//! 5. mold plugs that leave gaps, seats off the layer grid;
//! 6. thin sheets refused by a rule on a field the user never wrote, negative bounds;
//! 7. a snap sized as if the ring stretched evenly;
//! 8. files for a print workflow (3MF, assembly, materials, notes).

use crate::common;
use common::{shipped, shipped_path};
use fbgforge::geometry::{self, assembly, fits, threemf, BuiltPart, PartKind};
use fbgforge::profile::{ring_point_load_coefficients, ring_strain_per_undercut, PartsProfile};
use std::f64::consts::PI;

const MODULES: [&str; 4] = [
    "clip-on-10mm.toml",
    "clip-on-16mm.toml",
    "clip-on-22mm.toml",
    "clip-on-34mm.toml",
];

fn text(name: &str) -> String {
    std::fs::read_to_string(shipped_path(name)).unwrap()
}

/// The error of `file` with `from` replaced by `to`.
fn refused(file: &str, from: &str, to: &str) -> String {
    let t = text(file);
    assert!(t.contains(from), "{file} has no `{from}`");
    fbgforge::design::parse(&t.replacen(from, to, 1))
        .expect_err(to)
        .to_string()
}

fn module_parts(d: &fbgforge::spec::Design, tol: Option<f64>) -> Vec<BuiltPart> {
    let sel: Vec<String> = ["cap", "core", "insert-blue"].map(String::from).to_vec();
    geometry::build_parts(d, tol, Some(&sel)).unwrap()
}

// ---------------------------------------------------------------- 1. passages

#[test]
fn a_fiber_hole_narrower_than_fiber_and_resolution_is_refused_naming_the_field() {
    // The case: a 0.22 mm hole for the 0.25 mm fiber.
    let e = refused(
        "clip-on-34mm.toml",
        "fiber_hole_diameter_mm = 1.0",
        "fiber_hole_diameter_mm = 0.22",
    );
    assert!(
        e.contains("module.pillars.fiber_hole_diameter_mm") && e.contains("0.300"),
        "{e}"
    );
    // On the edge: fiber + resolution passes, just under it does not.
    assert!(fbgforge::design::parse(&text("clip-on-34mm.toml").replacen(
        "fiber_hole_diameter_mm = 1.0",
        "fiber_hole_diameter_mm = 0.3",
        1
    ))
    .is_ok());
    refused(
        "clip-on-34mm.toml",
        "fiber_hole_diameter_mm = 1.0",
        "fiber_hole_diameter_mm = 0.299",
    );
    // Slots and bores are channels: with no clearance they are still made at the
    // printer's floor (PolyJet: fiber + resolution), never under it.
    let mut d = shipped("clip-on-34mm.toml");
    d.fiber_routing.channel_clearance_mm = 0.0;
    d.validate().unwrap();
    let w = d.fiber_routing.channel_width_mm(&d.printer);
    assert!((w - 0.30).abs() < 1e-12, "{w}");
}

#[test]
fn the_exact_passage_check_refuses_a_hole_the_validation_did_not_see() {
    // A design changed after loading (as a program may do) is checked on exact
    // dimensions by the build itself, whatever the meshing tolerance.
    let mut d = shipped("clip-on-34mm.toml");
    d.module.as_mut().unwrap().pillars.fiber_hole_diameter_mm = 0.22;
    let parts = module_parts(&d, None);
    let e = geometry::check_assembly(&d, &parts)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("module.pillars.fiber_hole_diameter_mm") && e.contains("0.0150 mm into it"),
        "{e}"
    );
}

#[test]
fn passages_are_the_closed_forms_of_the_profile() {
    let d = shipped("clip-on-34mm.toml");
    let profile = geometry::DesignProfile::new(&d);
    let all = fits::fiber_passages(&profile);
    assert_eq!(all.len(), 5);
    let gap = |g: &str, what: &str| {
        all.iter()
            .find(|f| f.grating == g)
            .unwrap()
            .passages
            .iter()
            .find(|p| p.passage.starts_with(what))
            .unwrap_or_else(|| panic!("{g}: no {what}"))
            .surface_gap_mm
    };
    // Hole 1.0 mm, fiber 0.25 mm: 0.375 mm a side. Channels 0.45 mm: 0.1 mm.
    assert!((gap("lambda_11", "fiber hole") - 0.375).abs() < 1e-12);
    assert!((gap("lambda_11", "cap slot") - 0.1).abs() < 1e-12);
    assert!((gap("lambda_temp", "insert bore") - (0.325 - 0.125)).abs() < 1e-12);
    // The roofs clear the bend by the channel clearance (they are placed so).
    for (g, roof) in [
        ("lambda_11", "cap slot roof"),
        ("lambda_temp", "cap slot roof"),
        ("lambda_temp", "core slot roof"),
        ("lambda_temp", "insert slot roof"),
    ] {
        let r = gap(g, roof);
        assert!(r >= 0.1 - 1e-9, "{g} {roof}: {r}");
    }
    // The plate: exit height 1 mm less the fiber's radius.
    assert!((gap("lambda_11", "plate") - 0.875).abs() < 1e-12);
}

// ---------------------------------------------------------------- 2. reference grating

#[test]
fn the_reference_grating_hangs_free_with_room_past_its_end() {
    for name in MODULES {
        let d = shipped(name);
        let m = d.module.as_ref().unwrap();
        let (p, pp) = PartsProfile::of_design(&d).unwrap();
        let c = pp
            .reference_chamber
            .unwrap_or_else(|| panic!("{name}: no chamber"));
        let g = &m.gratings[c.grating];
        let s = c.span;
        let wall = m.core_wall_mm;
        // Tail past the grating, room past the tip, a wall over the chamber.
        assert!(
            (s.tip_z_mm - s.z_end_mm - g.tail_mm()).abs() < 1e-12,
            "{name}"
        );
        assert!(g.tail_mm() >= 3.0);
        assert!(
            (s.chamber_top_z_mm - s.tip_z_mm - wall).abs() < 1e-12,
            "{name}"
        );
        let apex_flat = p.dome_center_z_mm
            + (p.insert_sphere_radius_mm.powi(2) - p.apex_flat_radius_mm.powi(2)).sqrt();
        assert!(
            (apex_flat - s.chamber_top_z_mm - wall).abs() < 1e-12,
            "{name}"
        );
        // The cap cannot reach the tip even with the domes touching.
        let cap_inner_apex = p.dome_center_z_mm + p.cap_dome_inner_sphere_radius_mm;
        let dome_gap = p.cap_dome_inner_sphere_radius_mm - p.core_dome_outer_sphere_radius_mm;
        assert!(cap_inner_apex - dome_gap - s.tip_z_mm > wall, "{name}");
        // The whole grating in the chamber (not the bore), a wall from its floor.
        assert!(
            s.z_start_mm - s.chamber_bottom_z_mm >= wall - 1e-12,
            "{name}"
        );
        assert!(c.radius_mm >= 2.0 * pp.insert_bore_radius_mm - 1e-12);
        // Free-hanging: the grating's surface is as far from the chamber wall as twice
        // the bore's gap plus its radius.
        let free = c.radius_mm - pp.fiber_radius_mm;
        assert!(
            free > 2.0 * (pp.insert_bore_radius_mm - pp.fiber_radius_mm),
            "{name}"
        );
        // The meshes agree: the fiber traced from its tip meets nothing, and the
        // grating's centre is in no part.
        let parts = module_parts(&d, None);
        let traces = geometry::check_assembly(&d, &parts).unwrap().unwrap();
        let t = traces.iter().find(|t| t.grating == g.name).unwrap();
        assert!(
            (t.points[0][2] - s.tip_z_mm).abs() < 1e-12,
            "{name}: traced from the tip"
        );
        assert!(t.min_surface_gap_mm > 0.0, "{name}: {t:?}");
        let ins = parts.iter().find(|b| b.kind == PartKind::Insert).unwrap();
        let solid = assembly::Solid::new("insert", &ins.mesh);
        for z in [s.z_start_mm + 1e-3, s.z_end_mm - 1e-3, s.tip_z_mm] {
            assert!(!solid.contains([0.0, 0.0, z]), "{name}: {z}");
            // Across the grating, a chamber radius off the axis less the fiber is open.
            let q = [c.radius_mm - pp.fiber_radius_mm, 0.0, z];
            assert!(!solid.contains(q), "{name}: chamber at {z}");
        }
        assert!(solid.contains([0.0, 0.0, s.chamber_top_z_mm + wall / 2.0]));
    }
}

#[test]
fn a_reference_grating_too_long_for_its_insert_is_refused_naming_a_written_field() {
    // The 10 mm module: 3 mm grating + 3 mm tail hang well above its insert's slot; a
    // 15 mm tail does not.
    let e = refused(
        "clip-on-10mm.toml",
        "role = \"temperature_reference\"",
        "role = \"temperature_reference\"\ntail_mm = 15.0",
    );
    assert!(
        e.contains("module.gratings[4].length_mm") && e.contains("tail_mm"),
        "{e}"
    );
    // A tail on a strain grating is refused too.
    let e = refused(
        "clip-on-10mm.toml",
        "center_height_mm = 9.0",
        "center_height_mm = 9.0\ntail_mm = 3.0",
    );
    assert!(e.contains("module.gratings[0].tail_mm"), "{e}");
}

// ---------------------------------------------------------------- 3. tolerance

#[test]
fn a_coarse_tolerance_keeps_every_designed_gap_in_the_meshes() {
    // Issue 39: the tolerance applies to the parts' surfaces at large; the surfaces
    // facing a designed gap are meshed finer until the meshes keep 80 % of it. At 0.1
    // and 0.2 mm (twice and four times the 0.1 mm clearances) the 34 mm module builds,
    // and the manifest states each gap designed and meshed.
    let d = shipped("clip-on-34mm.toml");
    let dir = tempfile::tempdir().unwrap();
    for tol in [0.1, 0.2] {
        let out = dir.path().join(format!("t{tol}"));
        let r = crate::build(&d, &out, Some(tol)).unwrap();
        assert!(!r.fibers.is_empty());
        let m: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap())
                .unwrap();
        let gaps = m["meshed_gaps"].as_array().unwrap();
        assert!(gaps.len() >= 10, "{tol}: {} gaps", gaps.len());
        for g in gaps {
            let (designed, meshed) = (
                g["designed_gap_mm"].as_f64().unwrap(),
                g["meshed_gap_mm"].as_f64().unwrap(),
            );
            assert!(meshed >= 0.8 * designed, "{tol}: {g}");
            assert!(
                g["surface_tolerance_mm"].as_f64().unwrap() < tol,
                "{tol}: {g}"
            );
        }
        // The dome gap of the issue, stated both ways in the fits.
        let dome = m["fits"]
            .as_array()
            .unwrap()
            .iter()
            .find(|f| f["what"] == "cap inner dome to core outer dome")
            .unwrap();
        assert!(dome["meshed_gap_mm"].as_f64().unwrap() >= 0.8 * dome["gap_mm"].as_f64().unwrap());
    }
}

#[test]
fn a_tolerance_too_coarse_for_a_part_names_the_option_and_the_range() {
    // Issue 39: on the 10 mm design `--tolerance 0.2` failed inside the mesher with
    // "mesh check `closed` failed" and no field. Now it builds (the gaps' surfaces
    // refined); at the coarsest tolerances a part that does not mesh is refused naming
    // the option and the range that meshes it.
    let d = shipped("clip-on-10mm.toml");
    let dir = tempfile::tempdir().unwrap();
    let r = crate::build(&d, &dir.path().join("t0.2"), Some(0.2)).unwrap();
    assert!(r.gaps.len() >= 10);
    for g in &r.gaps {
        assert!(g.kept_percent >= 80.0, "{g:?}");
    }
    for tol in [0.5, 1.0] {
        let out = dir.path().join(format!("t{tol}"));
        match crate::build(&d, &out, Some(tol)) {
            Ok(r) => {
                assert!(r.gaps.iter().all(|g| g.kept_percent >= 80.0));
            }
            Err(e) => {
                let e = format!("{e:#}");
                eprintln!("10 mm at {tol} mm: {e}");
                assert!(
                    e.contains("BuildRequest.tolerance_mm") && e.contains("allowed 0.001 to"),
                    "{e}"
                );
                assert!(!out.exists() || std::fs::read_dir(&out).unwrap().count() == 0);
            }
        }
    }
}

#[test]
fn the_shipped_10mm_module_is_checked_for_overlap_at_its_default_tolerance() {
    // Its 0.05 mm clearances were skipped before; now every pair is compared: an
    // insert moved sideways by 0.06 mm, more than its clearance, is caught.
    let d = shipped("clip-on-10mm.toml");
    let parts = module_parts(&d, None);
    geometry::check_assembly(&d, &parts).unwrap();
    let mut moved = parts.clone();
    let ins = moved
        .iter_mut()
        .find(|b| b.kind == PartKind::Insert)
        .unwrap();
    for q in &mut ins.mesh.positions {
        q[0] += 0.06;
    }
    let e = geometry::check_assembly(&d, &moved)
        .unwrap_err()
        .to_string();
    assert!(e.contains("overlap") && e.contains("insert"), "{e}");
    // A clearance between 0 and the printer's resolution is refused: it could not
    // be printed, nor meshed apart at the default tolerance.
    let e = refused(
        "clip-on-10mm.toml",
        "core_insert_clearance_mm = 0.05",
        "core_insert_clearance_mm = 0.03",
    );
    assert!(
        e.contains("module.core_insert_clearance_mm") && e.contains("press fit"),
        "{e}"
    );
}

#[test]
fn exact_fits_are_the_clearances_and_none_is_a_press_fit() {
    let d = shipped("clip-on-34mm.toml");
    let profile = geometry::DesignProfile::new(&d);
    let f = fits::module_fits(profile.module.as_ref().unwrap());
    for g in &f {
        assert!(g.gap_mm > 0.0, "{g:?}");
        assert!(!g.press_fit, "{g:?}");
        assert_eq!(g.meshed_gap_mm, None, "not measured before a build");
    }
    let radial = f
        .iter()
        .find(|g| g.what.starts_with("cap inner wall"))
        .unwrap();
    assert!((radial.gap_mm - 0.1).abs() < 1e-12);
    // The bead sits one axial gap (max(c, 0.05) = 0.1 mm) under the pillar bottoms at
    // the inner wall; at the pillar's outer edge the retention cone (45°) is a further
    // clearance away, normal to the cone.
    let bead = f
        .iter()
        .find(|g| g.what.starts_with("snap bead to"))
        .unwrap();
    assert!(
        bead.gap_mm > 0.1 * 0.5f64.sqrt() - 1e-9 && bead.gap_mm < 0.2,
        "{bead:?}"
    );
}

// ---------------------------------------------------------------- 4. surface gap

#[test]
fn the_manifest_gives_the_fiber_surface_gap_not_the_centreline_distance() {
    let d = shipped("clip-on-34mm.toml");
    let dir = tempfile::tempdir().unwrap();
    let r = crate::build(&d, dir.path(), None).unwrap();
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("manifest.json")).unwrap())
            .unwrap();
    let tol = r
        .parts
        .iter()
        .map(|b| b.mesh_tolerance_mm)
        .fold(0.0, f64::max);
    for f in m["fibers"].as_array().unwrap() {
        assert!(f.get("min_clearance_mm").is_none(), "{f}");
        let mesh = f["min_surface_gap_mm"].as_f64().unwrap();
        let exact = f["min_exact_surface_gap_mm"].as_f64().unwrap();
        // The strain fibers' tightest passage is the cap's slot: 0.1 mm a side (the
        // issue read 0.2237 mm from the centreline where the gap is 0.099 mm).
        if f["grating"] != "lambda_temp" {
            assert!((exact - 0.1).abs() < 1e-12, "{f}");
        }
        assert!(mesh <= exact + 1e-9 && mesh >= exact - tol, "{f}");
        assert!(!f["passages"].as_array().unwrap().is_empty());
    }
}

// ---------------------------------------------------------------- 5. mold

#[test]
fn the_plugs_seal_their_pockets_and_the_seat_is_on_a_layer() {
    let d = shipped("tactile-array-60x80.toml");
    let parts = geometry::build_parts(&d, None, None).unwrap();
    let mold = parts.iter().find(|b| b.kind == PartKind::Mold).unwrap();
    let plug = parts.iter().find(|b| b.kind == PartKind::MoldPlug).unwrap();
    let a = d.array.as_ref().unwrap();
    let profile = geometry::DesignProfile::new(&d);
    let pocket = profile.array.as_ref().unwrap().pocket.unwrap();
    // The plug is as wide as its pocket (measured on the two meshes: the pocket's
    // sides in the wall at fiber 0, the plug's extent), as long as the wall is thick,
    // and fills it from the ledge to the wall top.
    let x = a.fiber_x_mm[0];
    let hy = a.mold.internal_y_mm / 2.0 + a.mold.wall_thickness_mm;
    let xs: Vec<f64> = mold
        .mesh
        .positions
        .iter()
        .filter(|q| {
            (q[1] - hy).abs() < 1e-9 && (q[0] - x).abs() < 1.0 && q[2] > pocket.bottom_z_mm + 1e-9
        })
        .map(|q| q[0])
        .collect();
    let pocket_w =
        xs.iter().cloned().fold(f64::MIN, f64::max) - xs.iter().cloned().fold(f64::MAX, f64::min);
    let (lo, hi) = plug.mesh.bbox_mm();
    assert!(
        (hi[0] - lo[0] - pocket_w).abs() < 1e-9,
        "plug {} vs pocket {pocket_w}",
        hi[0] - lo[0]
    );
    assert!((hi[1] - lo[1] - a.mold.wall_thickness_mm).abs() < 1e-9);
    let top = a.mold.base_thickness_mm + a.mold.wall_height_mm;
    assert!((hi[2] - lo[2] - (top - pocket.bottom_z_mm)).abs() < 1e-9);
    // The seat and the ledge are layer boundaries (0.2 mm, stated in the design), the
    // ledge at or above the fiber's top, the fiber's axis within half a layer of
    // mid-sheet (the issue: one layer low with the slicer's defaults).
    let h = d.printer.layer_height_mm();
    assert_eq!(h, 0.2);
    let l = &profile.array.as_ref().unwrap().layout;
    let on_layer = |z: f64| ((z / h) - (z / h).round()).abs() < 1e-9;
    assert!(on_layer(l.slit_bottom_z_mm) && on_layer(pocket.bottom_z_mm));
    let coated = d.fiber_routing.coated_diameter_mm;
    assert!(pocket.bottom_z_mm >= l.slit_bottom_z_mm + coated - 1e-12);
    assert!(pocket.bottom_z_mm < l.slit_bottom_z_mm + coated + h);
    assert!((l.slit_bottom_z_mm + coated / 2.0 - l.fiber_z_mm).abs() <= h / 2.0 + 1e-12);
    // With the plug in, the open section below the silicone level is the seat less
    // the fiber, as the manifest states.
    let dir = tempfile::tempdir().unwrap();
    crate::build(&d, dir.path(), None).unwrap();
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("manifest.json")).unwrap())
            .unwrap();
    let open = a.mold.slit_width_mm * (pocket.bottom_z_mm - l.slit_bottom_z_mm)
        - PI * (coated / 2.0).powi(2);
    assert!((m["mold"]["open_area_per_slit_mm2"].as_f64().unwrap() - open).abs() < 1e-12);
    assert_eq!(m["mold"]["plug_fit_mm"].as_f64().unwrap(), 0.0);
    assert_eq!(m["mold"]["layer_height_mm"].as_f64().unwrap(), 0.2);
    // PrusaSlicer's default 0.3 mm layers: the seat moves to its grid.
    let mut d3 = d.clone();
    d3.printer.layer_height_mm = Some(0.3);
    d3.array.as_mut().unwrap().mold.slit_depth_mm = f64::NAN;
    d3.fill_derived();
    d3.validate().unwrap();
    let l3 = fbgforge::profile::ArrayLayout::from_array(d3.array.as_ref().unwrap());
    assert!(
        (l3.slit_bottom_z_mm - 4.5).abs() < 1e-9,
        "{}",
        l3.slit_bottom_z_mm
    );
}

// ---------------------------------------------------------------- 6. sheets, bounds

#[test]
fn thin_sheets_are_judged_on_the_real_stack() {
    // 1.0 mm and 0.8 mm sheets in 1.0 mm walls without plugs: the fiber's seat is above
    // the cavity floor, the base under it; nothing refuses them.
    for t in ["1.0", "0.8"] {
        let s = text("tactile-array-60x80.toml")
            .replacen("thickness_mm = 5.0", &format!("thickness_mm = {t}"), 1)
            .replacen("wall_height_mm = 5.0", "wall_height_mm = 1.0", 1)
            .replacen("plugs = true", "plugs = false", 1);
        let d = fbgforge::design::parse(&s).unwrap_or_else(|e| panic!("{t}: {e}"));
        let parts = geometry::build_parts(&d, None, None).unwrap();
        let mold = parts.iter().find(|b| b.kind == PartKind::Mold).unwrap();
        mold.mesh.check("mold").unwrap();
        let l = fbgforge::profile::ArrayLayout::from_array(d.array.as_ref().unwrap());
        assert!(l.slit_bottom_z_mm > l.cavity_floor_z_mm, "{t}");
    }
    // With plugs, a wall too low for a printable plug names the wall height (a field
    // the user wrote), never the derived slit depth.
    let s = text("tactile-array-60x80.toml")
        .replacen("thickness_mm = 5.0", "thickness_mm = 1.0", 1)
        .replacen("wall_height_mm = 5.0", "wall_height_mm = 1.0", 1);
    let e = fbgforge::design::parse(&s).unwrap_err().to_string();
    assert!(
        e.contains("array.mold.wall_height_mm") && !e.contains("slit_depth"),
        "{e}"
    );
}

#[test]
fn a_refused_field_is_one_the_user_wrote_and_no_bound_is_negative() {
    let cases = [
        // Pillars too small for their groove and hole: the pillar is named, with a
        // positive minimum (the issue: the groove or hole named, "up to −0.3 mm").
        (
            "width_mm = 3.0",
            "width_mm = 0.8",
            "module.pillars.width_mm",
        ),
        (
            "height_mm = 2.4",
            "height_mm = 1.0",
            "module.pillars.height_mm",
        ),
        (
            "groove_width_mm = 1.2",
            "groove_width_mm = 2.8",
            "module.pillars.width_mm",
        ),
    ];
    for (from, to, field) in cases {
        let e = refused("clip-on-34mm.toml", from, to);
        assert!(e.contains(field), "{to}: {e}");
        // No negative number after "allowed", "at least" or "up to".
        for key in ["allowed", "at least", "up to", "at most"] {
            if let Some(i) = e.find(key) {
                let rest = &e[i + key.len()..];
                let num = rest.trim_start_matches(|c: char| !c.is_ascii_digit() && c != '-');
                assert!(!num.starts_with('-'), "{to}: negative bound in {e}");
            }
        }
    }
}

// ---------------------------------------------------------------- 7. snap

#[test]
fn the_ring_model_matches_the_classic_ring_under_two_loads() {
    // A ring pulled by two opposite forces W (n = 2): moment at a load W R / π, change
    // of the diameter through the loads (π/4 − 2/π) W R³ / E I (Roark, Timoshenko).
    let (k_m, k_d) = ring_point_load_coefficients(2);
    assert!((k_m / 2.0 - 1.0 / PI).abs() < 1e-15);
    assert!((2.0 * k_d - (PI / 4.0 - 2.0 / PI)).abs() < 1e-15);
    // More pillars stiffen the ring: the same undercut bends it more.
    let e: Vec<f64> = (3..=8)
        .map(|n| ring_strain_per_undercut(n, 1.5, 16.25))
        .collect();
    assert!(e.windows(2).all(|w| w[1] > w[0]), "{e:?}");
}

#[test]
fn the_snap_is_sized_for_the_pillars_and_the_printer() {
    // 34 mm: 0.2 mm undercut bends the ring 1.38 % (four pillars), above the 1.32 %
    // of an even stretch.
    let d = shipped("clip-on-34mm.toml");
    let (p, pp) = PartsProfile::of_design(&d).unwrap();
    let r = fbgforge::profile::snap_report(&d, &p, &pp).unwrap();
    assert!(
        (r.cap_strain_percent - 100.0 * 0.2 * ring_strain_per_undercut(4, 1.5, 16.25)).abs()
            < 1e-12
    );
    assert!(r.cap_strain_percent > r.hoop_strain_percent);
    assert!((r.min_undercut_mm - 0.075).abs() < 1e-12);
    // The 10 mm snap (0.05 mm, the printer's resolution) is refused, and so is
    // any undercut there: none fits between the printer and the ring.
    let snap = "\n[module.snap]\nundercut_mm = 0.05\nbead_height_mm = 0.3\n";
    let e = fbgforge::design::parse(&(text("clip-on-10mm.toml") + snap))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("module.snap.undercut_mm") && e.contains("0.0750"),
        "{e}"
    );
    let snap = "\n[module.snap]\nundercut_mm = 0.08\nbead_height_mm = 0.3\n";
    let e = fbgforge::design::parse(&(text("clip-on-10mm.toml") + snap))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("module.snap.undercut_mm") && e.contains("no undercut fits"),
        "{e}"
    );
    // The 16 mm module's old 0.08 mm bent its ring past 1.5 %.
    let e = refused(
        "clip-on-16mm.toml",
        "undercut_mm = 0.075",
        "undercut_mm = 0.08",
    );
    assert!(
        e.contains("module.snap.undercut_mm") && e.contains("ring bending"),
        "{e}"
    );
}

// ---------------------------------------------------------------- 8. files

#[test]
fn build_writes_a_3mf_per_plate_and_the_assembled_module() {
    let mut d = shipped("clip-on-34mm.toml");
    // Optional vendor name and hardness reach the manifest and the 3MF.
    let core = d.materials.get_mut("core_rubber_case_i").unwrap();
    core.vendor_name = Some("Agilus30 FLX935".into());
    core.shore_hardness = Some("30A".into());
    let dir = tempfile::tempdir().unwrap();
    let r = crate::build(&d, dir.path(), None).unwrap();
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("manifest.json")).unwrap())
            .unwrap();
    assert_eq!(
        m["materials"]["core_rubber_case_i"]["shore_hardness"],
        "30A"
    );
    let plate = threemf::read(&std::fs::read(dir.path().join("parts.3mf")).unwrap()).unwrap();
    assert_eq!(plate.unit, "millimeter");
    // One object per printed piece: the cap, a core per core material, each insert.
    let names: Vec<&str> = plate.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "cap",
            "core-psc1",
            "core-psc2",
            "insert-blue",
            "insert-green",
            "insert-light_green"
        ]
    );
    for o in &plate.objects {
        let mat = &plate.materials[o.material];
        let key = mat.name.split(" (").next().unwrap();
        let listed = &m["materials"][key];
        assert_eq!(
            mat.colour,
            listed["display_colour"].as_str().unwrap(),
            "{}",
            o.name
        );
        // The part's mesh, whole: its volume is the manifest's.
        let part = r
            .parts
            .iter()
            .find(|p| {
                o.name.starts_with(p.name.split('-').next().unwrap())
                    && (p.kind != PartKind::Insert || o.name == p.name)
            })
            .unwrap();
        assert!(
            (o.volume_mm3() - part.mesh_volume_mm3).abs() < 1e-6 * part.mesh_volume_mm3,
            "{}",
            o.name
        );
    }
    let core1 = plate
        .objects
        .iter()
        .find(|o| o.name == "core-psc1")
        .unwrap();
    assert_eq!(
        plate.materials[core1.material].name,
        "core_rubber_case_i (Agilus30 FLX935)"
    );
    // Pieces lie apart on the plate.
    let boxes: Vec<([f64; 2], [f64; 2])> = plate
        .objects
        .iter()
        .zip(&plate.offsets_mm)
        .map(|(o, off)| {
            let xs = o.vertices.iter().map(|v| v[0] + off[0]);
            let ys = o.vertices.iter().map(|v| v[1] + off[1]);
            (
                [
                    xs.clone().fold(f64::MAX, f64::min),
                    ys.clone().fold(f64::MAX, f64::min),
                ],
                [xs.fold(f64::MIN, f64::max), ys.fold(f64::MIN, f64::max)],
            )
        })
        .collect();
    for i in 0..boxes.len() {
        for j in i + 1..boxes.len() {
            let (a, b) = (boxes[i], boxes[j]);
            let apart = a.1[0] < b.0[0] || b.1[0] < a.0[0] || a.1[1] < b.0[1] || b.1[1] < a.0[1];
            assert!(apart, "{} and {} overlap on the plate", names[i], names[j]);
        }
    }
    // The assembled module: cap, core, insert in place (no offset), and as STEP.
    let asm =
        threemf::read(&std::fs::read(dir.path().join("module-assembled.3mf")).unwrap()).unwrap();
    let names: Vec<&str> = asm.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["cap", "core-psc1", "insert-blue"]);
    assert!(asm.offsets_mm.iter().all(|o| *o == [0.0; 3]));
    let step = std::fs::read_to_string(dir.path().join("module-assembled.step")).unwrap();
    assert_eq!(step.matches("MANIFOLD_SOLID_BREP").count(), 3);
    assert_eq!(
        m["packages"]["assembled_pieces"].as_array().unwrap().len(),
        3
    );
    // Print notes name the small passages: the 1.0 mm holes, the 0.65 mm bore.
    let notes = m["print_notes"].as_array().unwrap();
    let bore = notes
        .iter()
        .find(|n| n["feature"].as_str().unwrap().contains("bore"))
        .unwrap();
    assert!((bore["width_mm"].as_f64().unwrap() - 0.65).abs() < 1e-12 && bore["small"] == true);
    assert!(bore["note"].as_str().unwrap().contains("wire"));
    let chamber = notes
        .iter()
        .find(|n| n["feature"].as_str().unwrap().contains("chamber"))
        .unwrap();
    assert!(chamber["note"]
        .as_str()
        .unwrap()
        .contains("flush through the bore"));
    // A bad hardness or colour is refused naming the field.
    let e = refused(
        "clip-on-34mm.toml",
        "permissible_strain_percent = 1.5,",
        "permissible_strain_percent = 1.5, shore_hardness = \"hard\",",
    );
    assert!(
        e.contains("materials.cap_digital_abs.shore_hardness"),
        "{e}"
    );
    let e = refused(
        "clip-on-34mm.toml",
        "permissible_strain_percent = 1.5, display_colour = \"#F2EFE6\"",
        "permissible_strain_percent = 1.5, display_colour = \"blue\"",
    );
    assert!(
        e.contains("materials.cap_digital_abs.display_colour"),
        "{e}"
    );
}

#[test]
fn the_mold_plate_holds_the_mold_and_a_plug_per_slit() {
    let d = shipped("tactile-array-60x80.toml");
    let dir = tempfile::tempdir().unwrap();
    let r = crate::build(&d, dir.path(), None).unwrap();
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("manifest.json")).unwrap())
            .unwrap();
    let plugs = m["mold"]["plugs_to_print"].as_u64().unwrap() as usize;
    assert_eq!(plugs, 2 * d.array.as_ref().unwrap().fiber_x_mm.len());
    let plate = threemf::read(&std::fs::read(dir.path().join("parts.3mf")).unwrap()).unwrap();
    let names: Vec<&str> = plate.objects.iter().map(|o| o.name.as_str()).collect();
    let want: Vec<String> = std::iter::once("mold".to_string())
        .chain((1..=plugs).map(|i| format!("mold-plug-{i}")))
        .collect();
    assert_eq!(names, want);
    // Every plug is the plug's mesh, in the mold's print material; none overlaps
    // another piece on the plate.
    let plug = r
        .parts
        .iter()
        .find(|p| p.kind == PartKind::MoldPlug)
        .unwrap();
    let pla = plate.materials[plate.objects[0].material].name.clone();
    assert_eq!(pla, "pla");
    let boxes: Vec<([f64; 2], [f64; 2])> = plate
        .objects
        .iter()
        .zip(&plate.offsets_mm)
        .map(|(o, off)| {
            let xs = o.vertices.iter().map(|v| v[0] + off[0]);
            let ys = o.vertices.iter().map(|v| v[1] + off[1]);
            (
                [
                    xs.clone().fold(f64::MAX, f64::min),
                    ys.clone().fold(f64::MAX, f64::min),
                ],
                [xs.fold(f64::MIN, f64::max), ys.fold(f64::MIN, f64::max)],
            )
        })
        .collect();
    for (i, o) in plate.objects.iter().enumerate().skip(1) {
        assert_eq!(plate.materials[o.material].name, pla);
        assert!((o.volume_mm3() - plug.mesh_volume_mm3).abs() < 1e-6 * plug.mesh_volume_mm3);
        for j in 0..i {
            let (a, b) = (boxes[i], boxes[j]);
            let apart = a.1[0] < b.0[0] || b.1[0] < a.0[0] || a.1[1] < b.0[1] || b.1[1] < a.0[1];
            assert!(apart, "{} and {} overlap on the plate", names[i], names[j]);
        }
    }
}

#[test]
fn previews_carry_a_scale_bar_and_dimensions_drawn_to_it() {
    let d = shipped("clip-on-34mm.toml");
    let dir = tempfile::tempdir().unwrap();
    crate::build(&d, dir.path(), None).unwrap();
    let svg = std::fs::read_to_string(dir.path().join("preview-module.svg")).unwrap();
    let attr = |el: &str, k: &str| -> f64 {
        let i = el.find(&format!("{k}=\"")).unwrap() + k.len() + 2;
        el[i..el[i..].find('"').unwrap() + i].parse().unwrap()
    };
    let bars: Vec<&str> = svg.split("<g class=\"scale-bar\"").skip(1).collect();
    assert_eq!(bars.len(), 2, "one scale bar per panel");
    let px_per_mm = attr(bars[0], "data-px") / attr(bars[0], "data-mm");
    let dims: Vec<&str> = svg.split("<g class=\"dim\"").skip(1).collect();
    let find = |name: &str| {
        *dims
            .iter()
            .find(|e| e.contains(&format!("data-name=\"{name}\"")))
            .unwrap_or_else(|| panic!("no dimension {name}"))
    };
    let p = fbgforge::profile::ModuleProfile::from_module(d.module.as_ref().unwrap());
    for (name, mm) in [
        ("cap wall", 1.5),
        ("core wall", 1.5),
        ("cap/core clearance", 0.1),
        ("core/insert clearance", 0.1),
        ("lambda_11", 5.0),
    ] {
        let e = find(name);
        assert!((attr(e, "data-mm") - mm).abs() < 1e-4, "{name}");
        // Drawn to the scale bar's scale.
        let px = (attr(e, "data-x1") - attr(e, "data-x0"))
            .hypot(attr(e, "data-y1") - attr(e, "data-y0"));
        assert!((px / px_per_mm - mm).abs() < 2e-3, "{name}: {px} px");
    }
    assert!(p.cap_outer_radius_mm > 0.0);
    let mold = tempfile::tempdir().unwrap();
    crate::build(&shipped("tactile-array-60x80.toml"), mold.path(), None).unwrap();
    let svg = std::fs::read_to_string(mold.path().join("preview-mold.svg")).unwrap();
    assert!(svg.contains("data-name=\"wall\"") && svg.contains("class=\"scale-bar\""));
    assert!(svg.contains("fiber axis 4.525"));
}

/// Issue 39, point 8: the previews draw only what is built (no clearance to an insert
/// the module does not have), print lengths at the manifest's precision (0.075, not
/// 0.07), put the mold's fiber axis where the manifest does, and mark a reference
/// fiber that nothing supports, with its free length.
#[test]
fn previews_draw_what_is_built_at_the_manifest_precision() {
    let dir = tempfile::tempdir().unwrap();
    let caption = |svg: &str| -> String {
        svg.split("<text x=\"10\"")
            .skip(1)
            .map(|t| t.split('>').nth(1).unwrap().split('<').next().unwrap())
            .collect::<Vec<_>>()
            .join("; ")
    };
    // A 0.075 mm cap/core clearance, printed as the manifest has it.
    let mut d = shipped("clip-on-34mm.toml");
    d.module.as_mut().unwrap().cap_core_clearance_mm = 0.075;
    d.validate().unwrap();
    let out = dir.path().join("fine");
    crate::build(&d, &out, None).unwrap();
    let svg = std::fs::read_to_string(out.join("preview-module.svg")).unwrap();
    assert!(svg.contains(">cap/core clearance 0.075<"), "no 0.075 label");
    assert!(svg.contains(">core/insert clearance 0.1<"));
    assert!(!caption(&svg).contains("UNSUPPORTED"), "{}", caption(&svg));
    // Without inserts: no insert clearance drawn, and the reference fiber marked with
    // its free length.
    let mut bare = shipped("clip-on-34mm.toml");
    bare.module.as_mut().unwrap().inserts.clear();
    bare.validate().unwrap();
    let out = dir.path().join("bare");
    crate::build(&bare, &out, None).unwrap();
    let svg = std::fs::read_to_string(out.join("preview-module.svg")).unwrap();
    assert!(!svg.contains("core/insert clearance"));
    let cap = caption(&svg);
    let reference = &bare
        .module
        .as_ref()
        .unwrap()
        .gratings
        .iter()
        .find(|g| g.role == fbgforge::spec::GratingRole::TemperatureReference)
        .unwrap()
        .name;
    let note = cap
        .split("UNSUPPORTED: fiber ")
        .nth(1)
        .unwrap_or_else(|| panic!("no mark: {cap}"));
    assert!(
        note.starts_with(&format!("{reference} hangs free for ")),
        "{note}"
    );
    let free: f64 = note
        .split("hangs free for ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let (p, pp) = PartsProfile::of_design(&bare).unwrap();
    // In closed form: down the axis from the core's inner dome to the bend start, the
    // quarter bend, then level out to the inner wall.
    assert!(pp.bend_radius_mm < p.core_inner_radius_mm);
    let exact = p.dome_center_z_mm + p.core_dome_inner_sphere_radius_mm - pp.bend_start_z_mm
        + PI / 2.0 * pp.bend_radius_mm
        + (p.core_inner_radius_mm - pp.bend_radius_mm);
    assert!(
        (free - exact).abs() < 0.05,
        "{free} mm free, {exact} mm in closed form"
    );
    // The mold's caption puts the fiber axis where the manifest does (4.525, not the
    // 4.500 mid-sheet).
    let mold = dir.path().join("mold");
    crate::build(&shipped("tactile-array-60x80.toml"), &mold, None).unwrap();
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(mold.join("manifest.json")).unwrap())
            .unwrap();
    let axis = m["mold"]["fiber_axis_z_mm"].as_f64().unwrap();
    assert!((axis - 4.525).abs() < 1e-9, "{axis}");
    let svg = std::fs::read_to_string(mold.join("preview-mold.svg")).unwrap();
    assert!(
        caption(&svg).contains("the fiber axis lies at 4.525 mm"),
        "{}",
        caption(&svg)
    );
}

/// The label boxes of a preview (`data-box`: left, top, right, bottom, px).
fn label_boxes(svg: &str) -> Vec<([f64; 4], String)> {
    svg.split("<text class=\"label\" data-box=\"")
        .skip(1)
        .map(|t| {
            let (b, rest) = t.split_once('"').unwrap();
            let v: Vec<f64> = b.split(' ').map(|x| x.parse().unwrap()).collect();
            let text = rest.split('>').nth(1).unwrap().split('<').next().unwrap();
            ([v[0], v[1], v[2], v[3]], text.to_string())
        })
        .collect()
}

/// Issue 39, point 8: no two labels of a preview overlap (a collision pass places
/// them), on every shipped design, a module without inserts and one whose gratings
/// share a height on two cores; and the mold's section panel is drawn at its own
/// aspect (its box as high as the mold at the panel's scale, not the detail's height).
#[test]
fn preview_labels_never_overlap_and_panels_keep_their_aspect() {
    let dir = tempfile::tempdir().unwrap();
    let mut designs: Vec<fbgforge::spec::Design> =
        fbgforge::design::load_designs(&fbgforge::design::designs_dir())
            .unwrap()
            .into_iter()
            .map(|(_, d)| d)
            .collect();
    let mut bare = shipped("clip-on-34mm.toml");
    bare.module.as_mut().unwrap().inserts.clear();
    bare.name = "bare".into();
    designs.push(bare);
    // One strain grating per core, each at 30 mm on pillar 0: two cores, one height.
    let mut level = shipped("clip-on-34mm.toml");
    level.name = "level".into();
    let m = level.module.as_mut().unwrap();
    let mut cores = Vec::new();
    m.gratings.retain(|g| {
        g.role != fbgforge::spec::GratingRole::Strain || {
            let first = !cores.contains(&g.core);
            cores.push(g.core.clone());
            first
        }
    });
    for g in m
        .gratings
        .iter_mut()
        .filter(|g| g.role == fbgforge::spec::GratingRole::Strain)
    {
        g.center_height_mm = Some(30.0);
        g.pillar = Some(0);
    }
    let strain_cores = m
        .gratings
        .iter()
        .filter(|g| g.role == fbgforge::spec::GratingRole::Strain)
        .count();
    assert!(
        strain_cores >= 2,
        "{strain_cores} cores with a strain grating"
    );
    level.validate().unwrap();
    designs.push(level);
    let mut checked = 0;
    for d in &designs {
        let out = dir.path().join(&d.name);
        crate::build(d, &out, None).unwrap();
        for svg in ["preview-module.svg", "preview-mold.svg"] {
            let Ok(text) = std::fs::read_to_string(out.join(svg)) else {
                continue;
            };
            let boxes = label_boxes(&text);
            assert!(boxes.len() >= 3, "{} {svg}: {} labels", d.name, boxes.len());
            for (i, (a, ta)) in boxes.iter().enumerate() {
                for (b, tb) in &boxes[..i] {
                    let apart = a[2] <= b[0] || b[2] <= a[0] || a[3] <= b[1] || b[3] <= a[1];
                    assert!(apart, "{} {svg}: `{ta}` over `{tb}`", d.name);
                }
            }
            checked += 1;
        }
    }
    assert!(checked >= 6, "{checked} previews");
    // The mold's whole section: its clip box as high as the mold at its scale.
    let mold = dir.path().join("tactile-array-60x80");
    let svg = std::fs::read_to_string(mold.join("preview-mold.svg")).unwrap();
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(mold.join("manifest.json")).unwrap())
            .unwrap();
    let part = &m["parts"][0];
    let mold_h =
        part["bbox_max_mm"][2].as_f64().unwrap() - part["bbox_min_mm"][2].as_f64().unwrap();
    let num = |el: &str, k: &str| -> f64 {
        let i = el.find(&format!("{k}=\"")).unwrap() + k.len() + 2;
        el[i..el[i..].find('"').unwrap() + i].parse().unwrap()
    };
    let bar = svg.split("<g class=\"scale-bar\"").nth(1).unwrap();
    let px_per_mm = num(bar, "data-px") / num(bar, "data-mm");
    let clips: Vec<&str> = svg.split("<clipPath").skip(1).collect();
    let (h0, h1) = (num(clips[0], "height"), num(clips[1], "height"));
    let want = (mold_h * px_per_mm).max(40.0) + 4.0;
    assert!(
        (h0 - want).abs() < 1.0,
        "whole-mold panel {h0} px high, the mold {want} px"
    );
    assert!(h0 < 0.5 * h1, "{h0} px against the detail's {h1} px");
}

// ---------------------------------------------------------------- 9. retention

#[test]
fn the_manifest_states_how_the_cap_is_held() {
    let dir = tempfile::tempdir().unwrap();
    // The shipped 10 mm module has no snap: nothing holds its cap, and the build says so.
    let d = shipped("clip-on-10mm.toml");
    assert!(d.module.as_ref().unwrap().snap.is_none());
    let out = dir.path().join("10");
    let r = crate::build(&d, &out, None).unwrap();
    assert_eq!(r.warnings.len(), 1, "{:?}", r.warnings);
    assert!(
        r.warnings[0].contains("nothing holds the cap"),
        "{:?}",
        r.warnings
    );
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["retention"]["by"], "nothing", "{}", m["retention"]);
    // The 34 mm module's snap: its free travel is the bead's clearance to the pillars'
    // bottom edge over sin α₂, the same gap the fits find on exact dimensions.
    let d = shipped("clip-on-34mm.toml");
    let out = dir.path().join("34");
    let r = crate::build(&d, &out, None).unwrap();
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    let ret = &m["retention"];
    assert_eq!(ret["by"], "snap", "{ret}");
    assert!(ret["retention_force_n"].as_f64().unwrap() > 0.0, "{ret}");
    let travel = ret["free_travel_mm"].as_f64().unwrap();
    let alpha = d
        .module
        .as_ref()
        .unwrap()
        .snap
        .as_ref()
        .unwrap()
        .retention_angle_deg;
    let bead = m["fits"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["what"] == "snap bead to pillar bottoms")
        .unwrap()["gap_mm"]
        .as_f64()
        .unwrap();
    assert!(
        (travel * alpha.to_radians().sin() - bead).abs() < 1e-9,
        "{travel} vs {bead}"
    );
    assert!(
        (travel - 0.1 / 45f64.to_radians().sin()).abs() < 1e-9,
        "{travel}"
    );
    assert_eq!(ret["resolution_mm"].as_f64(), Some(0.05));
}
