//! Parts a lab can assemble and wire: the assembled module has no overlapping parts,
//! every fiber's centreline runs from its grating to the outside without touching
//! material or bending below its minimum radius, the snap-fit strains the cap less
//! than its material permits (shipped designs and the 10–22 mm family), the snap bead
//! and the reference bore are where the profile says, and bad routing or snap fields
//! are errors naming the field.

use crate::common;
use common::shipped;
use fbgforge::geometry::{self, assembly, BuiltPart, PartKind};
use fbgforge::profile::{ramp_force_n, snap_report, PartsProfile};

const MODULES: [&str; 4] = [
    "clip-on-10mm.toml",
    "clip-on-16mm.toml",
    "clip-on-22mm.toml",
    "clip-on-34mm.toml",
];

fn module_parts(name: &str) -> (fbgforge::spec::Design, Vec<BuiltPart>) {
    let d = shipped(name);
    let sel: Vec<String> = ["cap", "core", "insert-blue"].map(String::from).to_vec();
    let parts = geometry::build_parts(&d, None, Some(&sel)).unwrap();
    (d, parts)
}

#[test]
fn assembled_parts_do_not_overlap_and_a_displaced_part_does() {
    for name in MODULES {
        let (_, parts) = module_parts(name);
        assembly::check_no_interference(&parts, &|_, _| true)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        // The check can fail: the insert pushed 0.3 mm sideways cuts into the core.
        let mut moved = parts.clone();
        let ins = moved
            .iter_mut()
            .find(|b| b.kind == PartKind::Insert)
            .unwrap();
        for q in &mut ins.mesh.positions {
            q[0] += 0.3;
        }
        let e = assembly::check_no_interference(&moved, &|_, _| true).unwrap_err();
        assert!(
            e.to_string().contains("core") && e.to_string().contains("insert"),
            "{e}"
        );
    }
}

#[test]
fn every_fiber_runs_from_its_grating_to_the_outside() {
    for name in MODULES {
        let (d, parts) = module_parts(name);
        let m = d.module.as_ref().unwrap();
        let (p, pp) = PartsProfile::of_design(&d).unwrap();
        let traces = geometry::check_assembly(&d, &parts).unwrap().unwrap();
        assert_eq!(traces.len(), m.gratings.len(), "{name}");
        let tol = parts
            .iter()
            .map(|b| b.mesh_tolerance_mm)
            .fold(0.0, f64::max);
        for t in &traces {
            let what = format!("{name} {}", t.grating);
            // The coated fiber's surface never meets material: on exact dimensions
            // the gap is the tightest passage's, and on the meshes it is that gap
            // less at most the chord tolerance.
            assert!(t.min_exact_surface_gap_mm > 0.0, "{what}: {t:?}");
            assert!(
                t.min_surface_gap_mm >= t.min_exact_surface_gap_mm - tol - 1e-9,
                "{what}: {t:?}"
            );
            // No bend below the fiber's minimum: measured on the samples themselves.
            assert!(pp.bend_radius_mm >= d.fiber_routing.min_bend_radius_mm);
            assert!(
                assembly::min_bend_radius_mm(&t.points) >= pp.bend_radius_mm * (1.0 - 1e-6),
                "{what}"
            );
            // From the grating (inside the module) to beyond the cap, above the plate.
            let first = t.points[0];
            let last = t.points[t.points.len() - 1];
            assert!(first[0].hypot(first[1]) < p.cap_inner_radius_mm, "{what}");
            assert!(last[0].hypot(last[1]) > p.cap_outer_radius_mm, "{what}");
            assert!(
                t.points.iter().all(|q| q[2] >= pp.fiber_radius_mm),
                "{what}"
            );
            // Where it crosses the cap's outer radius: on the bend's circle (strain
            // fibers, which start bending one fiber-hole radius out) or on the
            // horizontal run (the reference fiber, from the axis).
            let r0 = t.points[0][0].hypot(t.points[0][1]);
            let dr = p.cap_outer_radius_mm - r0;
            let rb = pp.bend_radius_mm;
            let z_exit = if dr < rb {
                pp.bend_start_z_mm - (rb * rb - (rb - dr) * (rb - dr)).sqrt()
            } else {
                pp.exit_height_mm
            };
            let step = pp.fiber_radius_mm / 2.0;
            assert!(
                (t.exit_point_mm[2] - z_exit).abs() < step,
                "{what}: {t:?} vs {z_exit}"
            );
        }
    }
}

#[test]
fn a_fiber_that_meets_material_is_reported_with_its_grating_and_the_part() {
    let (d, parts) = module_parts("clip-on-34mm.toml");
    // Turn the cap 10° about the axis: its slots no longer line up with the fibers.
    let mut turned = parts.clone();
    let cap = turned.iter_mut().find(|b| b.kind == PartKind::Cap).unwrap();
    let (c, s) = (10f64.to_radians().cos(), 10f64.to_radians().sin());
    for q in &mut cap.mesh.positions {
        *q = [c * q[0] - s * q[1], s * q[0] + c * q[1], q[2]];
    }
    let e = assembly::trace_fibers(&d, &turned).unwrap_err().to_string();
    assert!(
        e.contains("lambda_11") && e.contains("blocked by the cap"),
        "{e}"
    );
}

#[test]
fn the_snap_strains_the_cap_less_than_its_material_permits_across_the_family() {
    let knots: Vec<_> = [
        "clip-on-10mm.toml",
        "clip-on-16mm.toml",
        "clip-on-22mm.toml",
    ]
    .iter()
    .map(|n| shipped(n))
    .collect();
    let mut designs: Vec<_> = MODULES.iter().map(|n| shipped(n)).collect();
    for k in 0..=12 {
        designs.push(fbgforge::family::interpolate(&knots, 10.0 + k as f64).unwrap());
    }
    let mut with_snap = 0;
    for d in &designs {
        let (p, pp) = PartsProfile::of_design(d).unwrap();
        // The 10 mm knot has no snap (no undercut fits its ring): neither do the
        // members between 10 and 16 mm.
        let Some(r) = snap_report(d, &p, &pp) else {
            assert!(d.module.as_ref().unwrap().snap.is_none(), "{}", d.name);
            continue;
        };
        with_snap += 1;
        let m = d.module.as_ref().unwrap();
        let s = m.snap.as_ref().unwrap();
        // Uniform hoop strain y / crest radius, for comparison; the checked strain is
        // the ring bending between the pillars, above it.
        let crest = p.pillar_outer_radius_mm - s.undercut_mm;
        assert!((r.hoop_strain_percent - 100.0 * s.undercut_mm / crest).abs() < 1e-12);
        let ring = 100.0
            * s.undercut_mm
            * fbgforge::profile::ring_strain_per_undercut(
                4,
                m.cap_wall_mm,
                p.cap_inner_radius_mm + m.cap_wall_mm / 2.0,
            );
        assert!((r.cap_strain_percent - ring).abs() < 1e-12);
        assert!(r.cap_strain_percent > r.hoop_strain_percent, "{}", d.name);
        assert!(s.undercut_mm >= r.min_undercut_mm - 1e-9, "{}", d.name);
        assert!(
            r.cap_strain_percent < r.permissible_strain_percent,
            "{}: {} % ≥ {} %",
            d.name,
            r.cap_strain_percent,
            r.permissible_strain_percent
        );
        for c in &r.cores {
            // Springs in series: the cap's share of the undercut and the force agree,
            // the assembly force exceeds the sliding friction, the retention force
            // exceeds the assembly force (45° holds harder than a 30° lead-in).
            assert!(
                (c.cap_deflection_mm * r.ring_stiffness_n_per_mm - c.transverse_force_n).abs()
                    < 1e-9
            );
            let pillars = (s.undercut_mm - c.cap_deflection_mm) * c.pillar_stiffness_n_per_mm;
            assert!((pillars - c.transverse_force_n).abs() < 1e-9);
            assert!(c.assembly_force_n > c.sliding_force_n);
            assert!(c.retention_force_n.unwrap() > c.assembly_force_n);
        }
        d.validate().unwrap();
    }
    assert!(with_snap >= 10, "{with_snap} designs with a snap");
    // The ramp equation at its limits: no friction and 45° gives W = P; a ramp at
    // μ·tan α ≥ 1 is self-locking.
    assert!((ramp_force_n(2.0, 0.0, 45.0).unwrap() - 2.0).abs() < 1e-12);
    assert!((ramp_force_n(1.0, 0.3, 0.0).unwrap() - 0.3).abs() < 1e-12);
    assert!(ramp_force_n(1.0, 0.5, 70.0).is_none());
}

#[test]
fn the_bead_reaches_inside_the_pillars_below_their_bottoms() {
    let (d, parts) = module_parts("clip-on-34mm.toml");
    let (p, pp) = PartsProfile::of_design(&d).unwrap();
    let s = pp.snap.as_ref().unwrap();
    let cap = parts.iter().find(|b| b.kind == PartKind::Cap).unwrap();
    let core = parts.iter().find(|b| b.kind == PartKind::Core).unwrap();
    // The cap's innermost points below the ribs are the crest, at its radius and heights.
    let crest: Vec<_> = cap
        .mesh
        .positions
        .iter()
        .filter(|q| q[2] < pp.pillar_bottom_mm - 1e-9)
        .filter(|q| (q[0].hypot(q[1]) - s.crest_radius_mm).abs() < 1e-6)
        .collect();
    assert!(!crest.is_empty());
    let (lo, hi) = crest
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), q| (a.min(q[2]), b.max(q[2])));
    assert!((lo - s.crest_bottom_z_mm).abs() < 1e-9 && (hi - s.crest_top_z_mm).abs() < 1e-9);
    // The undercut: the pillars reach further out than the crest, and start above it.
    let undercut = p.pillar_outer_radius_mm - s.crest_radius_mm;
    assert!(
        (undercut
            - d.module
                .as_ref()
                .unwrap()
                .snap
                .as_ref()
                .unwrap()
                .undercut_mm)
            .abs()
            < 1e-12
    );
    let pillar_low = core
        .mesh
        .positions
        .iter()
        .filter(|q| q[0].hypot(q[1]) > s.crest_radius_mm + 1e-6)
        .map(|q| q[2])
        .fold(f64::INFINITY, f64::min);
    assert!((pillar_low - pp.pillar_bottom_mm).abs() < 1e-9);
    assert!(s.retention_top_z_mm < pp.pillar_bottom_mm);
}

#[test]
fn the_insert_has_a_bore_up_to_a_closed_chamber_and_a_whole_apex() {
    let (d, parts) = module_parts("clip-on-16mm.toml");
    let (p, pp) = PartsProfile::of_design(&d).unwrap();
    let c = pp.reference_chamber.unwrap();
    let ins = parts.iter().find(|b| b.kind == PartKind::Insert).unwrap();
    let (_, hi) = ins.mesh.bbox_mm();
    let top_of = |r: f64| {
        ins.mesh
            .positions
            .iter()
            .filter(|q| (q[0].hypot(q[1]) - r).abs() < 1e-6)
            .map(|q| q[2])
            .fold(f64::MIN, f64::max)
    };
    // The bore stops at the chamber's floor, the chamber at its top, under the apex.
    assert!((top_of(pp.insert_bore_radius_mm) - c.span.chamber_bottom_z_mm).abs() < 1e-9);
    assert!((top_of(c.radius_mm) - c.span.chamber_top_z_mm).abs() < 1e-9);
    assert!(c.span.chamber_top_z_mm < hi[2] - d.module.as_ref().unwrap().core_wall_mm + 1e-9);
    // The apex flat is whole: just under it, on the axis, is material.
    assert!(p.apex_flat_radius_mm > 0.0);
    let centre = [0.0, 0.0, hi[2] - 1e-3];
    assert!(
        assembly::Solid::new("insert", &ins.mesh).contains(centre),
        "apex not solid"
    );
    let in_chamber = [0.0, 0.0, 0.5 * (c.span.z_start_mm + c.span.z_end_mm)];
    assert!(!assembly::Solid::new("insert", &ins.mesh).contains(in_chamber));
    // Nothing of the insert lies inside the bore, below the chamber.
    assert!(ins
        .mesh
        .positions
        .iter()
        .filter(|q| q[2] < c.span.chamber_bottom_z_mm + 1e-9)
        .all(|q| q[0].hypot(q[1]) >= pp.insert_bore_radius_mm - 1e-9));
}

#[test]
fn routing_and_snap_errors_name_the_field() {
    let text = |n: &str| std::fs::read_to_string(common::shipped_path(n)).unwrap();
    let cases = [
        // Standard SMF cannot turn out below the 10 mm module's low gratings.
        (
            "clip-on-10mm.toml",
            "min_bend_radius_mm = 5.0",
            "min_bend_radius_mm = 10.0",
            "module.gratings[0].center_height_mm",
        ),
        // An undercut that strains the cap past 1.5 %.
        (
            "clip-on-34mm.toml",
            "undercut_mm = 0.2",
            "undercut_mm = 0.3",
            "module.snap.undercut_mm",
        ),
        // A lead-in that jams.
        (
            "clip-on-34mm.toml",
            "lead_in_angle_deg = 30.0",
            "lead_in_angle_deg = 75.0",
            "module.snap.lead_in_angle_deg",
        ),
        // The cap's material without a permissible strain.
        (
            "clip-on-34mm.toml",
            ", permissible_strain_percent = 1.5",
            "",
            "materials.cap_digital_abs.permissible_strain_percent",
        ),
        // A nozzle out of range.
        (
            "tactile-array-60x80.toml",
            "nozzle_diameter_mm = 0.4",
            "nozzle_diameter_mm = 0.0",
            "printer.nozzle_diameter_mm",
        ),
        // A sheet thinner than the coated fiber: the sheet is what the user wrote.
        (
            "tactile-array-60x80.toml",
            "thickness_mm = 5.0",
            "thickness_mm = 0.24",
            "array.thickness_mm",
        ),
    ];
    for (file, from, to, field) in cases {
        let t = text(file);
        assert!(t.contains(from), "{file} has no `{from}`");
        let e = fbgforge::design::parse(&t.replacen(from, to, 1))
            .expect_err(to)
            .to_string();
        assert!(e.contains(field), "{to}: {e}");
    }
}

#[test]
fn the_manifest_reports_snap_fibers_and_the_mold_for_a_lab() {
    let dir = tempfile::tempdir().unwrap();
    let d = shipped("clip-on-34mm.toml");
    let r = crate::build(&d, dir.path(), None).unwrap();
    assert_eq!(r.fibers.len(), 5);
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("manifest.json")).unwrap())
            .unwrap();
    assert!(m["snap"]["cap_strain_percent"].as_f64().unwrap() < 1.5);
    assert_eq!(m["snap"]["cores"].as_array().unwrap().len(), 2);
    assert_eq!(m["fibers"].as_array().unwrap().len(), 5);
    for f in ["preview-module.svg", "cap.step", "core.step"] {
        assert!(dir.path().join(f).is_file(), "{f}");
    }
    let step = std::fs::read_to_string(dir.path().join("cap.step")).unwrap();
    assert!(step.contains("FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));"));
    assert!(!step.contains("(('')),") && !step.contains("ISO-10303-042"));

    let dir = tempfile::tempdir().unwrap();
    let d = shipped("tactile-array-60x80.toml");
    crate::build(&d, dir.path(), None).unwrap();
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("manifest.json")).unwrap())
            .unwrap();
    let parts = m["parts"].as_array().unwrap();
    for p in parts {
        // The mold and its plugs are printed in PLA, not in the casting silicone.
        assert_eq!(p["materials"], serde_json::json!(["pla"]), "{p}");
    }
    assert_eq!(m["mold"]["silicone_level_mm"].as_f64().unwrap(), 7.0);
    // The seat on the 0.2 mm layer nearest 4.375 mm: 4.4 mm; the fiber's axis 0.025 mm
    // over mid-sheet (4.5 mm).
    assert!((m["mold"]["fiber_axis_z_mm"].as_f64().unwrap() - 4.525).abs() < 1e-9);
    assert!((m["mold"]["fiber_axis_offset_mm"].as_f64().unwrap() - 0.025).abs() < 1e-9);
    assert_eq!(m["mold"]["plugs_to_print"].as_u64().unwrap(), 12);
    assert!(dir.path().join("preview-mold.svg").is_file());
}
