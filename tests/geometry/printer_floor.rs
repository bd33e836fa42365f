//! The printer's floor for a fiber passage, measured where the printer makes it: in
//! PrusaSlicer's toolpaths (issue 39, point 1). The smallest hole a module design
//! accepts on an FDM printer (`FiberRouting::min_passage_mm`: the nozzle + the channel
//! clearance) is cut through a tube alone and through the pillars of a built core;
//! each is sliced with the printer's nozzle and layer height, and on every layer the
//! hole left open between the innermost extrusions' edges is measured in the G-code:
//! it must pass the coated fiber on every layer. The rival, the old rule (fiber +
//! resolution, 0.35 mm), is measured the same way in the core, where the issue found
//! it closing on the fiber.
//!
//! `.ci/run` installs the slicer, so in CI (`CI` set) a missing slicer fails the test;
//! elsewhere it is skipped with a notice.

use crate::common::shipped;
use fbgforge::spec::{Design, PrintProcess};
use std::path::Path;
use std::process::Command;

/// Outer radius and height of the tube the hole is cut through, mm.
const TUBE_RADIUS_MM: f64 = 3.0;
const TUBE_HEIGHT_MM: f64 = 3.0;
/// Sides of the polygons (chord error at a 0.25 mm radius: 0.25 (1 − cos(π/128)) ≈ 0.08 µm).
const SIDES: usize = 128;
/// Where `--center` puts the tube's axis on the bed, mm.
const BED_CENTRE_MM: (f64, f64) = (100.0, 100.0);

fn slicer_present() -> bool {
    if Command::new("prusa-slicer").arg("--help").output().is_ok() {
        return true;
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "prusa-slicer is not installed (apt-get install -y prusa-slicer); CI requires it"
    );
    eprintln!("notice: prusa-slicer not found, SKIPPING the printer-floor slicing test (apt-get install -y prusa-slicer)");
    false
}

/// An STL of a tube about the z axis: outer radius [`TUBE_RADIUS_MM`], a hole of
/// `hole_mm` diameter, [`TUBE_HEIGHT_MM`] high.
fn tube_stl(hole_mm: f64) -> Vec<u8> {
    let ring = |r: f64, z: f64| -> Vec<[f64; 3]> {
        (0..SIDES)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / SIDES as f64;
                [r * a.cos(), r * a.sin(), z]
            })
            .collect()
    };
    let (ob, ot) = (
        ring(TUBE_RADIUS_MM, 0.0),
        ring(TUBE_RADIUS_MM, TUBE_HEIGHT_MM),
    );
    let (ib, it) = (
        ring(hole_mm / 2.0, 0.0),
        ring(hole_mm / 2.0, TUBE_HEIGHT_MM),
    );
    let mut tris: Vec<[[f64; 3]; 3]> = Vec::new();
    let mut quad = |a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]| {
        tris.push([a, b, c]);
        tris.push([a, c, d]);
    };
    for i in 0..SIDES {
        let j = (i + 1) % SIDES;
        quad(ob[i], ob[j], ot[j], ot[i]); // outer wall, facing out
        quad(ib[j], ib[i], it[i], it[j]); // hole wall, facing the axis
        quad(ot[i], ot[j], it[j], it[i]); // top annulus, facing up
        quad(ib[i], ib[j], ob[j], ob[i]); // bottom annulus, facing down
    }
    binary_stl(&tris)
}

/// A binary STL of `tris` (outward winding; the normals left zero, as readers
/// recompute them from the winding).
fn binary_stl(tris: &[[[f64; 3]; 3]]) -> Vec<u8> {
    let mut b = vec![0u8; 80];
    b.extend_from_slice(&u32::try_from(tris.len()).unwrap().to_le_bytes());
    for t in tris {
        b.extend_from_slice(&[0u8; 12]);
        for p in t {
            for c in p {
                b.extend_from_slice(&(*c as f32).to_le_bytes());
            }
        }
        b.extend_from_slice(&[0u8; 2]);
    }
    b
}

/// Distance from `q` to the segment ab, in plan.
fn point_segment(q: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l = dx * dx + dy * dy;
    let t = if l > 0.0 {
        (((q.0 - a.0) * dx + (q.1 - a.1) * dy) / l).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (q.0 - a.0 - t * dx).hypot(q.1 - a.1 - t * dy)
}

/// Per layer (its z), the diameter left open around `axis` (on the bed): twice the least
/// distance from the tube's axis to an extrusion's edge (its centreline less half its
/// `;WIDTH:`). Travel moves and the first layer (squashed, elephant-foot compensated)
/// are left out.
fn open_diameters(gcode: &str, axis: (f64, f64)) -> Vec<(f64, f64)> {
    let (mut x, mut y, mut z, mut width) = (0.0, 0.0, 0.0, 0.0);
    let mut relative_e = false;
    let mut e_abs = 0.0;
    let mut layers: Vec<(f64, f64)> = Vec::new();
    let word = |l: &str, c: char| -> Option<f64> {
        l.split_whitespace()
            .find_map(|w| w.strip_prefix(c).and_then(|v| v.parse().ok()))
    };
    for line in gcode.lines() {
        let code = line.split(';').next().unwrap_or("").trim();
        if let Some(w) = line.strip_prefix(";WIDTH:") {
            width = w.trim().parse().unwrap_or(width);
        }
        match code.split_whitespace().next() {
            Some("M83") => relative_e = true,
            Some("M82") => relative_e = false,
            Some("G92") => e_abs = word(code, 'E').unwrap_or(e_abs),
            Some("G1") => {
                let (nx, ny) = (word(code, 'X').unwrap_or(x), word(code, 'Y').unwrap_or(y));
                z = word(code, 'Z').unwrap_or(z);
                let extrudes = word(code, 'E').is_some_and(|e| {
                    let de = if relative_e { e } else { e - e_abs };
                    if !relative_e {
                        e_abs = e;
                    }
                    de > 0.0
                });
                if extrudes && (nx, ny) != (x, y) {
                    let edge = point_segment(axis, (x, y), (nx, ny)) - width / 2.0;
                    match layers.last_mut() {
                        Some((lz, d)) if (*lz - z).abs() < 1e-9 => *d = d.min(2.0 * edge),
                        _ => layers.push((z, 2.0 * edge)),
                    }
                }
                (x, y) = (nx, ny);
            }
            _ => {}
        }
    }
    layers.into_iter().skip(1).collect()
}

/// Slice `stl` on `d`'s FDM printer with its plan centre (`centre_xy`, mm) at
/// [`BED_CENTRE_MM`]; the G-code.
fn slice(d: &Design, stl: &Path) -> String {
    let gcode = stl.with_extension("gcode");
    let p = &d.printer;
    let nozzle = p.nozzle_mm().expect("an FDM printer").to_string();
    let layer = p.layer_height_mm().to_string();
    let centre = format!("{},{}", BED_CENTRE_MM.0, BED_CENTRE_MM.1);
    let o = Command::new("prusa-slicer")
        .args(["--export-gcode", "--nozzle-diameter", &nozzle])
        .args(["--layer-height", &layer, "--first-layer-height", &layer])
        .args(["--center", &centre])
        .arg(stl)
        .arg("--output")
        .arg(&gcode)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "slicing {}: {}",
        stl.display(),
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::read_to_string(&gcode).unwrap()
}

/// Slice a tube with a `hole_mm` hole on `d`'s FDM printer; the open diameter per layer.
fn slice_tube(d: &Design, hole_mm: f64, dir: &Path) -> Vec<(f64, f64)> {
    let stl = dir.join(format!("tube-{hole_mm}.stl"));
    std::fs::write(&stl, tube_stl(hole_mm)).unwrap();
    let layers = open_diameters(&slice(d, &stl), BED_CENTRE_MM);
    let expected = (TUBE_HEIGHT_MM / d.printer.layer_height_mm()).round() as usize - 1;
    assert_eq!(
        layers.len(),
        expected,
        "one measurement per layer but the first"
    );
    words(&format!("tube, {hole_mm} mm hole"), &layers);
    layers
}

fn words(what: &str, layers: &[(f64, f64)]) {
    let lo = layers.iter().map(|l| l.1).fold(f64::INFINITY, f64::min);
    let hi = layers.iter().map(|l| l.1).fold(f64::NEG_INFINITY, f64::max);
    eprintln!(
        "{what}: open {lo:.3} to {hi:.3} mm over {} layers",
        layers.len()
    );
}

/// Build the core of `d` with `hole_mm` fiber holes, slice it, and measure the hole of
/// every pillar on every layer between 1 mm above the fiber's bend and 1 mm under the
/// pillar top (where the hole runs straight up): (pillar, z, open diameter).
fn slice_core(d: &Design, hole_mm: f64, dir: &Path) -> Vec<(usize, f64, f64)> {
    let mut d = d.clone();
    d.module.as_mut().unwrap().pillars.fiber_hole_diameter_mm = hole_mm;
    let parts = fbgforge::geometry::build_parts(&d, None, Some(&["core".to_string()])).unwrap();
    let core = &parts[0].mesh;
    let stl = dir.join(format!("core-{hole_mm}.stl"));
    let tris: Vec<[[f64; 3]; 3]> = core
        .triangles
        .iter()
        .map(|t| t.map(|i| core.positions[i as usize]))
        .collect();
    std::fs::write(&stl, binary_stl(&tris)).unwrap();
    // `--center` puts the mesh's plan box centre on the bed centre.
    let (lo, hi) = core.positions.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    );
    let box_centre = ((lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0);
    let (p, pp) = fbgforge::profile::PartsProfile::of_design(&d).unwrap();
    let gcode = slice(&d, &stl);
    let (z0, z1) = (pp.bend_start_z_mm + 1.0, p.pillar_top_mm - 1.0);
    let mut out = Vec::new();
    for (i, a) in p.pillar_angles_rad.iter().enumerate() {
        let r = p.fiber_hole_center_radius_mm;
        let axis = (
            BED_CENTRE_MM.0 + r * a.cos() - box_centre.0,
            BED_CENTRE_MM.1 + r * a.sin() - box_centre.1,
        );
        let layers: Vec<(f64, f64)> = open_diameters(&gcode, axis)
            .into_iter()
            .filter(|(z, _)| (z0..=z1).contains(z))
            .collect();
        words(&format!("core pillar {i}, {hole_mm} mm hole"), &layers);
        out.extend(layers.into_iter().map(|(z, o)| (i, z, o)));
    }
    out
}

/// The shipped 34 mm module on the FDM printer of the shipped array design.
fn fdm_module() -> Design {
    let mut d = shipped("clip-on-34mm.toml");
    d.printer = shipped("tactile-array-60x80.toml").printer;
    assert_eq!(d.printer.process, PrintProcess::Fdm);
    // Pillars tall enough for the FDM walls round the hole (the range the refusal
    // names: 2.7 to 5.1 mm).
    d.module.as_mut().unwrap().pillars.height_mm = 3.0;
    d
}

fn with_hole(d: &Design, hole_mm: f64) -> Result<(), String> {
    let mut d = d.clone();
    d.module.as_mut().unwrap().pillars.fiber_hole_diameter_mm = hole_mm;
    d.validate().map_err(|e| e.to_string())
}

#[test]
fn the_smallest_fdm_hole_accepted_stays_open_round_the_fiber_in_the_toolpaths() {
    let d = fdm_module();
    let floor = d.fiber_routing.min_passage_mm(&d.printer);
    // The nozzle (0.4) + the clearance (0.1): the rule, and the spec at its edge.
    assert!((floor - 0.5).abs() < 1e-12, "{floor}");
    with_hole(&d, floor).unwrap();
    let e = with_hole(&d, floor - 0.01).unwrap_err();
    assert!(
        e.contains("module.pillars.fiber_hole_diameter_mm") && e.contains("nozzle"),
        "{e}"
    );
    if !slicer_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let fiber = d.fiber_routing.coated_diameter_mm;
    let tube = slice_tube(&d, floor, dir.path());
    let core = slice_core(&d, floor, dir.path());
    assert!(
        core.len() > 20,
        "{} layers measured in the core",
        core.len()
    );
    let narrowest = core.iter().map(|l| l.2).fold(f64::INFINITY, f64::min);
    eprintln!(
        "{floor} mm hole: open {narrowest:.3} mm at its narrowest over {} pillar layers",
        core.len()
    );
    for (z, open) in &tube {
        assert!(
            *open >= fiber,
            "tube, {floor} mm hole at z = {z}: {open:.3} mm open"
        );
    }
    for (i, z, open) in &core {
        assert!(
            *open >= fiber,
            "pillar {i}, {floor} mm hole at z = {z}: {open:.3} mm open, under the {fiber} mm fiber"
        );
    }
    // The rival: the old rule's 0.35 mm hole (fiber + resolution) in the same core.
    let old = fiber + d.printer.resolution_mm;
    let rival = slice_core(&d, old, dir.path());
    let closed = rival.iter().filter(|l| l.2 < fiber).count();
    eprintln!(
        "{old} mm hole: {closed} of {} pillar layers under the fiber",
        rival.len()
    );
    assert!(
        closed > 0,
        "the {old} mm hole stays open on every layer: the test cannot fail"
    );
}
