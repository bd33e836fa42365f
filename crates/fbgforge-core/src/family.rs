//! The clip-on family: a module design at any diameter. One place derives "the module
//! at diameter D" for every caller: [`interpolate`] between the shipped, hand-sized
//! family members (what `build` and the geometry studies use), and [`scaled_design`],
//! the paper's module scaled in proportion with printable floors (the grid on which the
//! closed form is compared with the FE model).
//!
//! Interpolation:
//!
//! Plain proportional scaling of the 34 mm module fails below ~16 mm: a 1.5 mm wall
//! scaled to 10 mm is 0.44 mm, fine, but the fiber hole and the groove then leave
//! pillar walls thinner than the printer can make. The shipped 10, 16 and 22 mm
//! designs were sized by hand to stay printable, so a module of diameter D is made by
//! piecewise-linear interpolation of every length (walls, clearances, pillars, holes,
//! heights, grating lengths and heights) between the two shipped designs whose
//! diameters bracket D.
//!
//! The contact reading (`[module.contact]`) follows the family rule of
//! [`crate::spec::ContactRatios`] in both: each of its lengths keeps its ratio to the
//! feature it scales with (the domes' contact zone to the apex patch, the clip band to
//! the cap wall, the dome clearance to the fit clearance), interpolated between the
//! knots' ratios; a length a design gives in mm is first restated as its ratio.
//! Counts, names, materials and wavelengths come from the lower knot. The result is
//! validated like any spec.

use crate::spec::{ContactRatios, Design, Module, SpecError};

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a * (1.0 - t) + b * t
}

fn lerp_module(a: &Module, b: &Module, t: f64) -> Module {
    let mut m = a.clone();
    m.outer_diameter_mm = lerp(a.outer_diameter_mm, b.outer_diameter_mm, t);
    m.overall_height_mm = lerp(a.overall_height_mm, b.overall_height_mm, t);
    m.dome_height_mm = lerp(a.dome_height_mm, b.dome_height_mm, t);
    m.cap_wall_mm = lerp(a.cap_wall_mm, b.cap_wall_mm, t);
    m.core_wall_mm = lerp(a.core_wall_mm, b.core_wall_mm, t);
    m.cap_core_clearance_mm = lerp(a.cap_core_clearance_mm, b.cap_core_clearance_mm, t);
    m.core_insert_clearance_mm = lerp(a.core_insert_clearance_mm, b.core_insert_clearance_mm, t);
    m.top_hole_diameter_mm = lerp(a.top_hole_diameter_mm, b.top_hole_diameter_mm, t);
    m.apex_flat_diameter_mm = lerp(a.apex_flat_diameter_mm, b.apex_flat_diameter_mm, t);
    let (pa, pb) = (&a.pillars, &b.pillars);
    m.pillars.width_mm = lerp(pa.width_mm, pb.width_mm, t);
    m.pillars.height_mm = lerp(pa.height_mm, pb.height_mm, t);
    m.pillars.groove_width_mm = lerp(pa.groove_width_mm, pb.groove_width_mm, t);
    m.pillars.groove_depth_mm = lerp(pa.groove_depth_mm, pb.groove_depth_mm, t);
    m.pillars.fiber_hole_diameter_mm =
        lerp(pa.fiber_hole_diameter_mm, pb.fiber_hole_diameter_mm, t);
    // The contact by the family rule: its ratios to their features, interpolated.
    let (ra, rb) = (a.contact_ratios(), b.contact_ratios());
    m.set_contact_ratios(&ContactRatios {
        clip_height_to_cap_wall: lerp(ra.clip_height_to_cap_wall, rb.clip_height_to_cap_wall, t),
        dome_clearance_to_fit_clearance: lerp(
            ra.dome_clearance_to_fit_clearance,
            rb.dome_clearance_to_fit_clearance,
            t,
        ),
        dome_contact_radius_to_patch: lerp(
            ra.dome_contact_radius_to_patch,
            rb.dome_contact_radius_to_patch,
            t,
        ),
    });
    match (&mut m.snap, &b.snap) {
        _ if t >= 1.0 => m.snap = b.snap.clone(),
        (Some(sa), Some(sb)) => {
            sa.undercut_mm = lerp(sa.undercut_mm, sb.undercut_mm, t);
            sa.bead_height_mm = lerp(sa.bead_height_mm, sb.bead_height_mm, t);
        }
        // One knot without a snap (the 10 mm module: no undercut fits its ring): the
        // other's, which `fit_snap` keeps only if an undercut fits this member's ring.
        (None, Some(sb)) => m.snap = Some(sb.clone()),
        (Some(_), None) | (None, None) => {}
    }
    for (g, gb) in m.gratings.iter_mut().zip(&b.gratings) {
        g.length_mm = lerp(g.length_mm, gb.length_mm, t);
        if let (Some(za), Some(zb)) = (g.center_height_mm, gb.center_height_mm) {
            g.center_height_mm = Some(lerp(za, zb, t));
        }
    }
    m
}

/// The module design of diameter `diameter_mm`, interpolated between `knots` (module
/// designs sorted or not; at least one on each side of the diameter).
pub fn interpolate(knots: &[Design], diameter_mm: f64) -> Result<Design, SpecError> {
    let mut k: Vec<&Design> = knots.iter().filter(|d| d.module.is_some()).collect();
    let dia = |d: &Design| d.module.as_ref().map_or(0.0, |m| m.outer_diameter_mm);
    k.sort_by(|a, b| dia(a).total_cmp(&dia(b)));
    let out_of_range = || {
        crate::spec::err(
            "module.outer_diameter_mm",
            format!(
                "{diameter_mm} mm is outside the family's range {:.1} to {:.1} mm",
                k.first().map_or(f64::NAN, |d| dia(d)),
                k.last().map_or(f64::NAN, |d| dia(d))
            ),
        )
    };
    let i = k
        .windows(2)
        .position(|w| dia(w[0]) <= diameter_mm && diameter_mm <= dia(w[1]))
        .ok_or_else(out_of_range)?;
    let (a, b) = (k[i], k[i + 1]);
    let t = (diameter_mm - dia(a)) / (dia(b) - dia(a));
    let mut d = a.clone();
    d.module = Some(lerp_module(
        a.module.as_ref().expect("filtered"),
        b.module.as_ref().expect("filtered"),
        t,
    ));
    // The fiber is a choice, not a length: the lower knot's (at the upper knot, that
    // knot's own), so a module between 10 and 16 mm keeps the 10 mm module's
    // bend-insensitive fiber.
    if t >= 1.0 {
        d.fiber_routing = b.fiber_routing.clone();
    }
    d.name = format!("clip-on-{diameter_mm}mm-interpolated");
    d.description = Some(format!(
        "interpolated between {} and {} (t = {t:.3})",
        a.name, b.name
    ));
    fit_snap(&mut d);
    d.validate()?;
    Ok(d)
}

/// Keep a scaled or interpolated module's snap within the rules: its undercut at
/// least what the printer makes (1.5 × resolution) and at most what the cap's ring
/// permits between the pillars; a module with no such undercut (small diameters:
/// the ring is stiff for its size) is a sliding fit and loses its snap.
fn fit_snap(d: &mut Design) {
    let Some((p, pp)) = crate::profile::PartsProfile::of_design(d) else {
        return;
    };
    let Some(r) = crate::profile::snap_report(d, &p, &pp) else {
        return;
    };
    let m = d.module.as_mut().expect("a module, since it has a profile");
    // (NaN bounds, from a design validation will refuse anyway, also drop it.)
    if r.max_undercut_mm.is_nan()
        || r.min_undercut_mm.is_nan()
        || r.max_undercut_mm < r.min_undercut_mm
    {
        m.snap = None;
    } else if let Some(s) = m.snap.as_mut() {
        // Within rounding of a bound is on it (validation allows the same 1e-9), so
        // a knot's own undercut comes back unchanged.
        if s.undercut_mm < r.min_undercut_mm - 1e-9 {
            s.undercut_mm = r.min_undercut_mm;
        } else if s.undercut_mm > r.max_undercut_mm + 1e-9 {
            s.undercut_mm = r.max_undercut_mm;
        }
    }
}

/// A member of the clip-on family: the paper's module scaled by D / 34 mm in every
/// length (height, dome, pillars, holes, clearances, gratings), never below what the
/// shipped 10 mm design prints, with cap and core walls set to `wall_mm`.
pub fn scaled_design(base: &Design, diameter_mm: f64, wall_mm: f64) -> Result<Design, SpecError> {
    let mut d = base.clone();
    let m = d
        .module
        .as_mut()
        .ok_or_else(|| crate::spec::err("module", "the base design has no module"))?;
    // The contact keeps its ratios to its features (the family rule).
    m.restate_contact_relative();
    let s = diameter_mm / m.outer_diameter_mm;
    let floor = |v: f64, min: f64| (v * s).max(min);
    m.outer_diameter_mm = diameter_mm;
    m.overall_height_mm *= s;
    m.dome_height_mm *= s;
    m.cap_wall_mm = wall_mm;
    m.core_wall_mm = wall_mm;
    m.cap_core_clearance_mm = floor(m.cap_core_clearance_mm, 0.05);
    m.core_insert_clearance_mm = floor(m.core_insert_clearance_mm, 0.05);
    m.top_hole_diameter_mm = floor(m.top_hole_diameter_mm, 0.4);
    m.apex_flat_diameter_mm = floor(m.apex_flat_diameter_mm, 0.4);
    let p = &mut m.pillars;
    p.width_mm = floor(p.width_mm, 1.4);
    p.height_mm = floor(p.height_mm, 1.3);
    p.groove_width_mm = floor(p.groove_width_mm, 0.5);
    p.groove_depth_mm = floor(p.groove_depth_mm, 0.25);
    // The hole must leave printable walls in the pillar web (it does not enter the
    // smeared-pillar FE model, only the spec validation).
    let web = p.height_mm - p.groove_depth_mm - 2.0 * base.printer.min_wall_mm;
    p.fiber_hole_diameter_mm = floor(p.fiber_hole_diameter_mm, 0.4).min(web).max(0.13);
    for g in &mut m.gratings {
        g.length_mm = floor(g.length_mm, 3.0);
        if let Some(z) = g.center_height_mm.as_mut() {
            *z *= s;
        }
    }
    if let Some(snap) = m.snap.as_mut() {
        snap.undercut_mm = floor(snap.undercut_mm, 0.05);
        snap.bead_height_mm = floor(snap.bead_height_mm, 0.3);
    }
    // The fiber does not scale: where standard fiber's exit bend would reach the
    // lowest grating, the module takes the bend-insensitive fiber the shipped 10 mm
    // design uses (G.657.B3, 5 mm).
    let lowest = m
        .gratings
        .iter()
        .filter_map(|g| g.center_height_mm.map(|z| z - g.length_mm / 2.0))
        .fold(f64::INFINITY, f64::min);
    let fr = &mut d.fiber_routing;
    let need = fr.exit_height_mm + fr.min_bend_radius_mm + fr.coated_diameter_mm / 2.0;
    if lowest < need {
        fr.min_bend_radius_mm = fr.min_bend_radius_mm.min(5.0);
    }
    d.name = format!("clip-on-{diameter_mm}mm-wall-{wall_mm}mm");
    fit_snap(&mut d);
    d.validate()?;
    Ok(d)
}
