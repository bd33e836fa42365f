//! Property tests over the design range: every valid module (diameter 10–40 mm, walls
//! from the printer minimum to 3 mm, 3–8 pillars, random clearances, holes, grooves
//! and domes) and every valid mold yields parts that pass every mesh check at the
//! printer's default tolerance, with the mesh volume within the bound of the exact one.
//!
//! Specs are drawn so that most are valid, and the rest are discarded by the spec's
//! own validation (`prop_assume!`), so each property runs its full count of valid
//! designs. 160 modules × 3 parts + 120 molds = 600 checked parts.

use crate::common;
use fbgforge::geometry;
use fbgforge::spec::{Design, PrintProcess};
use proptest::prelude::*;

use common::shipped;

pub(crate) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Printer: J750-like PolyJet or a fine FDM machine.
fn printer(fdm: bool, d: &mut Design) {
    if fdm {
        d.printer.process = PrintProcess::Fdm;
        d.printer.resolution_mm = 0.1;
        d.printer.min_wall_mm = 0.4;
    } else {
        d.printer.process = PrintProcess::Polyjet;
        d.printer.resolution_mm = 0.05;
        d.printer.min_wall_mm = 0.3;
    }
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn module_design(diameter: f64, fdm: bool, count: u32, f: [f64; 14]) -> Design {
    let mut d = shipped("clip-on-34mm.toml");
    printer(fdm, &mut d);
    let w = d.printer.min_wall_mm;
    let res = d.printer.resolution_mm;
    let m = d.module.as_mut().unwrap();
    m.gratings
        .retain(|g| g.role == fbgforge::spec::GratingRole::TemperatureReference);
    let r = diameter / 2.0;
    m.outer_diameter_mm = diameter;
    m.cap_wall_mm = lerp(w, 3.0_f64.min(0.25 * r), f[0]);
    m.core_wall_mm = lerp(w, 3.0_f64.min(0.25 * r), f[1]);
    // Fit clearances: a press fit (0) for the lowest draws, else from the printer's
    // resolution (the least gap it makes) to 0.3 mm.
    let fit = |f: f64| if f < 0.05 { 0.0 } else { lerp(res, 0.3, f) };
    m.cap_core_clearance_mm = fit(f[2]);
    m.core_insert_clearance_mm = fit(f[3]);
    let pl = &mut m.pillars;
    pl.count = count;
    let passage = d.fiber_routing.min_passage_mm(&d.printer);
    pl.fiber_hole_diameter_mm = lerp(passage, 1.2, f[4]);
    pl.groove_depth_mm = lerp(0.05, 1.0, f[5]);
    // At most 0.3 × the radius (the field's range), so small modules stay valid.
    pl.height_mm =
        (pl.fiber_hole_diameter_mm + 2.0 * w + pl.groove_depth_mm + lerp(0.05, 1.5, f[6]))
            .min(0.3 * r);
    pl.groove_width_mm = lerp(w + 2.0 * m.cap_core_clearance_mm, 2.0, f[7]).max(0.1);
    pl.width_mm =
        pl.groove_width_mm.max(pl.fiber_hole_diameter_mm) + 2.0 * w + lerp(0.01, 2.0, f[8]);
    pl.first_pillar_angle_deg = 360.0 * f[9];
    m.dome_height_mm = lerp(0.3 * r, r, f[10]);
    m.overall_height_mm = m.dome_height_mm + lerp(4.0, 3.0 * r + 4.0, f[11]);
    m.top_hole_diameter_mm = lerp(passage, 1.0, f[12]);
    m.apex_flat_diameter_mm = lerp(0.1, 1.0, f[13]);
    // Snap and fiber exit sized to the draw (reusing its fractions): an undercut under
    // 0.8 % of the radius, a bend radius a third of the cylinder's height (2 to 10 mm).
    let snap = m.snap.as_mut().unwrap();
    snap.bead_height_mm = lerp(0.1, 0.6, f[3]);
    let cylinder = m.overall_height_mm - m.dome_height_mm;
    d.fiber_routing.min_bend_radius_mm = (cylinder / 3.0).clamp(2.0, 10.0);
    // The reference grating hangs from under the apex with its tail past it: a
    // quarter of the cylinder (1 to 5 mm) and a tail from the least allowed (0.5 mm)
    // to the default 3 mm, so it stays above the fiber's bend in most draws.
    let g = &mut m.gratings[0];
    g.length_mm = (0.25 * cylinder).clamp(1.0, 5.0);
    g.tail_mm = Some(lerp(0.5, 3.0, f[13]));
    // The undercut drawn between the least the printer makes and the most the ring
    // permits; a module with no such undercut is a sliding fit (no snap).
    let range = fbgforge::profile::PartsProfile::of_design(&d)
        .and_then(|(p, pp)| fbgforge::profile::snap_report(&d, &p, &pp))
        .map(|r| {
            (
                r.min_undercut_mm,
                r.max_undercut_mm
                    .min(d.module.as_ref().unwrap().pillars.groove_depth_mm),
            )
        });
    let m = d.module.as_mut().unwrap();
    match range {
        Some((lo, hi)) if hi >= lo => {
            m.snap.as_mut().unwrap().undercut_mm = lerp(lo, hi, f[2]);
        }
        _ => m.snap = None,
    }
    d
}

/// The case count: `default`, or `PROPTEST_CASES` when set (for long soak runs).
pub(crate) fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

pub(crate) fn fractions<const N: usize>() -> impl Strategy<Value = [f64; N]> {
    proptest::array::uniform::<_, N>(0.0..1.0f64)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(160), max_global_rejects: 20_000, ..ProptestConfig::default() })]

    #[test]
    fn every_valid_module_yields_checked_parts(
        diameter in 10.0..40.0f64,
        fdm in proptest::bool::weighted(0.25),
        count in 3u32..=8,
        f in fractions::<14>(),
    ) {
        let d = module_design(diameter, fdm, count, f);
        prop_assume!(d.validate().is_ok());
        let sel = ["cap".to_string(), "core".into(), "insert-blue".into()];
        let parts = geometry::build_parts(&d, None, Some(&sel))
            .map_err(|e| TestCaseError::fail(format!("{e}\n{}", d.to_toml())))?;
        prop_assert_eq!(parts.len(), 3);
        for p in &parts {
            p.mesh.check(&p.name).map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert!(p.volume_error().abs() <= geometry::VOLUME_TOLERANCE_AT_DEFAULT, "{} {}", p.name, p.volume_error());
        }
        // Assembled, the parts do not overlap and the reference fiber finds its way
        // out (the generator lists no strain grating).
        let traced = geometry::check_assembly(&d, &parts)
            .map_err(|e| TestCaseError::fail(format!("{e}\n{}", d.to_toml())))?;
        prop_assert!(traced.is_some());
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(120), max_global_rejects: 20_000, ..ProptestConfig::default() })]

    #[test]
    fn every_valid_mold_is_exact_and_checked(
        fdm in proptest::bool::ANY,
        fibers in 1usize..=8,
        f in fractions::<9>(),
    ) {
        let mut d = shipped("tactile-array-60x80.toml");
        printer(fdm, &mut d);
        let w = d.printer.min_wall_mm;
        let a = d.array.as_mut().unwrap();
        a.size_x_mm = lerp(20.0, 150.0, f[0]);
        a.size_y_mm = lerp(20.0, 150.0, f[1]);
        a.thickness_mm = lerp(1.0, 8.0, f[2]);
        let m = &mut a.mold;
        m.internal_x_mm = a.size_x_mm + lerp(2.0, 30.0, f[3]);
        m.internal_y_mm = a.size_y_mm + lerp(0.0, 30.0, f[3]);
        m.wall_thickness_mm = lerp(w, 5.0, f[4]);
        m.base_thickness_mm = lerp(w, 5.0, f[5]);
        m.wall_height_mm = a.thickness_mm + lerp(0.0, 5.0, f[6]);
        m.plugs = f[7] < 0.5;
        m.slit_width_mm = lerp(d.fiber_routing.channel_width_mm(&d.printer), 1.0, f[8]);
        m.slit_depth_mm = f64::NAN;
        // Fibers evenly over the sheet, away from its edges.
        let pitch = a.size_x_mm / fibers as f64;
        a.fiber_x_mm = (0..fibers).map(|i| -a.size_x_mm / 2.0 + (i as f64 + 0.5) * pitch).collect();
        let g = a.gratings[0].clone();
        a.gratings = vec![g];
        a.gratings[0].y_mm = 0.0;
        d.fill_derived();
        prop_assume!(d.validate().is_ok());
        let parts = geometry::build_parts(&d, None, None)
            .map_err(|e| TestCaseError::fail(format!("{e}\n{}", d.to_toml())))?;
        let mold = &parts[0];
        mold.mesh.check("mold").map_err(|e| TestCaseError::fail(e.to_string()))?;
        // All faces are planar: the mesh is the solid, to rounding.
        let a = d.array.as_ref().unwrap();
        let m = &a.mold;
        let outer = (m.internal_x_mm + 2.0 * m.wall_thickness_mm) * (m.internal_y_mm + 2.0 * m.wall_thickness_mm)
            * (m.base_thickness_mm + m.wall_height_mm);
        // A slit: the seat (as wide as the slit, on the layer nearest where the fiber's
        // axis is at mid-sheet, up to the layer at or above the fiber's top) under a
        // pocket as wide as a printable plug plus clearances, or one width throughout.
        let coated = d.fiber_routing.coated_diameter_mm;
        let h = d.printer.layer_height_mm();
        let top = m.base_thickness_mm + m.wall_height_mm;
        let seat = ((m.base_thickness_mm + a.thickness_mm / 2.0 - coated / 2.0) / h).round() * h;
        prop_assert!((top - m.slit_depth_mm - seat).abs() < 1e-9);
        let slit_area = if m.plugs {
            let pocket = m.slit_width_mm.max(d.printer.min_wall_mm + 2.0 * d.fiber_routing.channel_clearance_mm);
            let ledge = ((seat + coated) / h - 1e-9).ceil() * h;
            m.slit_width_mm * (ledge - seat) + pocket * (top - ledge)
        } else {
            m.slit_width_mm * m.slit_depth_mm
        };
        let exact = outer - m.internal_x_mm * m.internal_y_mm * m.wall_height_mm
            - 2.0 * fibers as f64 * slit_area * m.wall_thickness_mm;
        prop_assert!((mold.mesh_volume_mm3 - exact).abs() < 1e-9 * exact, "{} vs {}", mold.mesh_volume_mm3, exact);
        // The slits stop on a layer boundary where the fiber's axis is within half a
        // layer of the sheet's mid-thickness.
        let lowest = mold.mesh.positions.iter()
            .filter(|q| q[1].abs() > m.internal_y_mm / 2.0 + 1e-9 && q[2] > m.base_thickness_mm + 1e-9)
            .map(|q| q[2]).fold(f64::INFINITY, f64::min);
        prop_assert!((lowest - seat).abs() < 1e-9);
        prop_assert!((lowest + coated / 2.0 - (m.base_thickness_mm + a.thickness_mm / 2.0)).abs() <= h / 2.0 + 1e-9);
    }
}

/// The generator must reach the whole range and keep most draws valid, or the
/// properties above would test a corner of it (or run out of accepted cases).
#[test]
fn the_module_generator_covers_the_design_range() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut valid = Vec::new();
    let n = 3000;
    for _ in 0..n {
        let f: [f64; 14] = std::array::from_fn(|_| rng.random());
        let d = module_design(
            rng.random_range(10.0..40.0),
            rng.random_bool(0.25),
            rng.random_range(3..=8),
            f,
        );
        if d.validate().is_ok() {
            valid.push(d);
        }
    }
    assert!(
        valid.len() * 2 > n,
        "only {} of {n} drawn modules are valid",
        valid.len()
    );
    let m = |d: &Design| d.module.clone().unwrap();
    let dia: Vec<f64> = valid.iter().map(|d| m(d).outer_diameter_mm).collect();
    assert!(dia.iter().any(|&x| x < 11.0) && dia.iter().any(|&x| x > 39.0));
    let walls: Vec<(f64, f64)> = valid
        .iter()
        .map(|d| (m(d).cap_wall_mm, d.printer.min_wall_mm))
        .collect();
    assert!(
        walls.iter().any(|&(w, min)| w < min + 0.05),
        "no wall near the printer minimum"
    );
    assert!(walls.iter().any(|&(w, _)| w > 2.9), "no wall near 3 mm");
    for count in 3..=8 {
        assert!(
            valid.iter().any(|d| m(d).pillars.count == count),
            "no valid design with {count} pillars"
        );
    }
}
