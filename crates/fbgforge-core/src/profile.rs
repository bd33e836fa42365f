//! Derived dimensions: the single source of truth shared by geometry and models.
//!
//! The spec states what a designer chooses (diameter, walls, clearances); this module
//! turns that into every radius and height a solid or a model needs. The B-rep
//! builder, the closed-form opto-mechanical model and the finite-element mesh all read
//! [`ModuleProfile`] and [`ArrayLayout`], so a dimension changed in the spec changes
//! every consumer at once.
//!
//! Conventions: z is the module axis, z = 0 the open base of cap and core, the cap's
//! apex at z = overall height. All domes are concentric spheres centred on the axis at
//! `dome_center_z_mm`, so every wall keeps its thickness through the dome. For the
//! array, x runs along the sheet's long side, fibers run along y, z = 0 is the mold's
//! underside.

use crate::spec::{FiberRouting, GratingRole, Module, TactileArray};
use serde::Serialize;

/// Every derived radius (mm) and height (mm) of the clip-on module.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModuleProfile {
    /// Cap outer radius = outer diameter / 2.
    pub cap_outer_radius_mm: f64,
    /// Cap inner radius = outer radius − cap wall.
    pub cap_inner_radius_mm: f64,
    /// Radius of the core pillars' outer faces = cap inner radius − cap/core clearance.
    pub pillar_outer_radius_mm: f64,
    /// Core outer wall radius = pillar outer radius − pillar height.
    pub core_outer_radius_mm: f64,
    /// Core inner wall radius = core outer radius − core wall.
    pub core_inner_radius_mm: f64,
    /// Insert radius = core inner radius − core/insert clearance.
    pub insert_radius_mm: f64,
    /// Radius of the fiber-hole centres: midway between core wall and groove bottom.
    pub fiber_hole_center_radius_mm: f64,
    /// Radius of the groove bottoms in the core pillars.
    pub groove_bottom_radius_mm: f64,
    /// Inner radius reached by the cap's alignment pillars (they stop one clearance
    /// short of the groove bottom).
    pub cap_pillar_inner_radius_mm: f64,
    /// Tangential width of the cap's alignment pillars = groove width − 2 × clearance.
    pub cap_pillar_width_mm: f64,
    /// Angular position of each pillar centre, radians from +x.
    pub pillar_angles_rad: Vec<f64>,
    /// Overall height (cap apex), mm.
    pub overall_height_mm: f64,
    /// Height of the dome spheres' common centre on the axis.
    pub dome_center_z_mm: f64,
    /// Cap outer dome sphere radius, R_s = (R² + h²) / (2h).
    pub cap_dome_outer_sphere_radius_mm: f64,
    /// Cap inner dome sphere radius = R_s − cap wall.
    pub cap_dome_inner_sphere_radius_mm: f64,
    /// Core outer dome sphere radius: one dome clearance (`[module.contact]`, by default
    /// the cap/core clearance) inside the cap's inner dome.
    pub core_dome_outer_sphere_radius_mm: f64,
    /// Core inner dome sphere radius = core outer sphere − core wall.
    pub core_dome_inner_sphere_radius_mm: f64,
    /// Insert top sphere radius = core inner sphere − core/insert clearance.
    pub insert_sphere_radius_mm: f64,
    /// Height where the cap's outer cylinder meets its dome.
    pub cap_outer_junction_z_mm: f64,
    /// Height where the cap's inner cylinder meets its dome.
    pub cap_inner_junction_z_mm: f64,
    /// Height where the core's outer cylinder meets its dome.
    pub core_outer_junction_z_mm: f64,
    /// Height where the core's inner cylinder meets its dome.
    pub core_inner_junction_z_mm: f64,
    /// Height where the insert's cylinder meets its spherical top.
    pub insert_junction_z_mm: f64,
    /// Top of the core pillars and of the cap's alignment pillars: the lower of the
    /// core's inner and the cap's inner junction, so the pillars run along the whole
    /// cylindrical section of both walls.
    pub pillar_top_mm: f64,
    /// Apex height of the core's outer dome (at the axis, ignoring the top hole).
    pub core_apex_z_mm: f64,
    /// Apex height of the insert's spherical top.
    pub insert_apex_z_mm: f64,
    /// Radius of the core's top hole.
    pub top_hole_radius_mm: f64,
    /// Radius of the apex flats of cap and insert.
    pub apex_flat_radius_mm: f64,
}

/// Height above the sphere centre where a sphere of radius `rho` meets a cylinder of
/// radius `r` (NaN when the cylinder is wider than the sphere).
pub fn sphere_height_at_radius(rho: f64, r: f64) -> f64 {
    (rho * rho - r * r).sqrt()
}

impl ModuleProfile {
    /// Derive the profile from a validated module spec.
    pub fn from_module(m: &Module) -> Self {
        Self::from_module_unchecked(m)
    }

    /// Derive the profile without validation (validation itself calls this to check
    /// the derived sizes); results may be negative or NaN for a bad spec.
    pub fn from_module_unchecked(m: &Module) -> Self {
        let r = m.outer_diameter_mm / 2.0;
        let pl = &m.pillars;
        let cap_inner = r - m.cap_wall_mm;
        let pillar_outer = cap_inner - m.cap_core_clearance_mm;
        let core_outer = pillar_outer - pl.height_mm;
        let core_inner = core_outer - m.core_wall_mm;
        let insert = core_inner - m.core_insert_clearance_mm;
        let groove_bottom = pillar_outer - pl.groove_depth_mm;
        let h = m.dome_height_mm;
        let rs = (r * r + h * h) / (2.0 * h);
        let zc = m.overall_height_mm - rs;
        let cap_in_s = rs - m.cap_wall_mm;
        // The core's dome sits one clearance inside the cap's dome, so the cap bears on
        // it as the model assumes (force on the core's dome); its cylinder is one pillar
        // height further in, and meets the larger sphere a little higher up.
        let core_out_s = cap_in_s - m.dome_clearance_mm();
        let core_in_s = core_out_s - m.core_wall_mm;
        let insert_s = core_in_s - m.core_insert_clearance_mm;
        let junction = |rho: f64, rad: f64| zc + sphere_height_at_radius(rho, rad);
        let core_inner_junction = junction(core_in_s, core_inner);
        let cap_inner_junction = junction(cap_in_s, cap_inner);
        let first = pl.first_pillar_angle_deg.to_radians();
        let n = pl.count.max(1) as usize;
        ModuleProfile {
            cap_outer_radius_mm: r,
            cap_inner_radius_mm: cap_inner,
            pillar_outer_radius_mm: pillar_outer,
            core_outer_radius_mm: core_outer,
            core_inner_radius_mm: core_inner,
            insert_radius_mm: insert,
            fiber_hole_center_radius_mm: (core_outer + groove_bottom) / 2.0,
            groove_bottom_radius_mm: groove_bottom,
            cap_pillar_inner_radius_mm: cap_inner - pl.groove_depth_mm,
            cap_pillar_width_mm: pl.groove_width_mm - 2.0 * m.cap_core_clearance_mm,
            pillar_angles_rad: (0..n)
                .map(|i| first + i as f64 * std::f64::consts::TAU / n as f64)
                .collect(),
            overall_height_mm: m.overall_height_mm,
            dome_center_z_mm: zc,
            cap_dome_outer_sphere_radius_mm: rs,
            cap_dome_inner_sphere_radius_mm: cap_in_s,
            core_dome_outer_sphere_radius_mm: core_out_s,
            core_dome_inner_sphere_radius_mm: core_in_s,
            insert_sphere_radius_mm: insert_s,
            cap_outer_junction_z_mm: junction(rs, r),
            cap_inner_junction_z_mm: cap_inner_junction,
            core_outer_junction_z_mm: junction(core_out_s, core_outer),
            core_inner_junction_z_mm: core_inner_junction,
            insert_junction_z_mm: junction(insert_s, insert),
            // The pillars stop where the cap's wall or the core's wall turns into a dome.
            pillar_top_mm: core_inner_junction.min(cap_inner_junction),
            core_apex_z_mm: zc + core_out_s,
            insert_apex_z_mm: zc + insert_s,
            top_hole_radius_mm: m.top_hole_diameter_mm / 2.0,
            apex_flat_radius_mm: m.apex_flat_diameter_mm / 2.0,
        }
    }
}

/// Where a module grating sits, in the module's frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GratingPlacement {
    /// Grating name from the spec.
    pub name: String,
    /// Core name (None for a reference grating that serves every core).
    pub core: Option<String>,
    /// Strain or temperature reference.
    pub role: GratingRole,
    /// Radius of the fiber axis, mm (0 for the reference grating on the axis).
    pub radius_mm: f64,
    /// Angle of the pillar, radians (0 for the reference grating).
    pub angle_rad: f64,
    /// Lower end of the grating, mm above the base.
    pub z_start_mm: f64,
    /// Upper end of the grating, mm above the base.
    pub z_end_mm: f64,
    /// Nominal Bragg wavelength, nm.
    pub bragg_wavelength_nm: f64,
}

/// Where a reference grating hangs on the module's axis, mm above the base: in a
/// closed chamber of the insert (or, without an insert, in the hollow core) whose top
/// lies one core wall under the insert's apex flat (the load path over the apex keeps
/// a wall as thick as the core's dome); the fiber's cleaved tip one core wall under
/// the chamber's top (room past the tip: the cap, the core's dome and the insert's
/// apex can all come down without reaching it); the grating `tail_mm` below the tip;
/// and the chamber's floor one core wall under the grating's start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReferenceSpan {
    /// Lower end of the grating, mm.
    pub z_start_mm: f64,
    /// Upper end of the grating, mm.
    pub z_end_mm: f64,
    /// The fiber's cleaved tip, mm.
    pub tip_z_mm: f64,
    /// Top of the insert's reference chamber, mm.
    pub chamber_top_z_mm: f64,
    /// Floor of the insert's reference chamber, mm.
    pub chamber_bottom_z_mm: f64,
}

/// The span of a reference grating of length `length_mm` with `tail_mm` of fiber
/// past its end (see [`ReferenceSpan`]).
pub(crate) fn reference_span(
    m: &Module,
    p: &ModuleProfile,
    length_mm: f64,
    tail_mm: f64,
) -> ReferenceSpan {
    let rho = p.insert_sphere_radius_mm;
    let a = p.apex_flat_radius_mm;
    let apex_flat = p.dome_center_z_mm + (rho * rho - a * a).sqrt();
    let wall = m.core_wall_mm;
    let top = apex_flat - wall;
    let tip = top - wall;
    let z1 = tip - tail_mm;
    let z0 = z1 - length_mm;
    ReferenceSpan {
        z_start_mm: z0,
        z_end_mm: z1,
        tip_z_mm: tip,
        chamber_top_z_mm: top,
        chamber_bottom_z_mm: z0 - wall,
    }
}

/// Place every grating of a module.
pub fn module_gratings(m: &Module, p: &ModuleProfile) -> Vec<GratingPlacement> {
    m.gratings
        .iter()
        .map(|g| {
            let (radius, angle, z0, z1) = match (g.role, g.pillar, g.center_height_mm) {
                (GratingRole::Strain, Some(i), Some(zc)) => (
                    p.fiber_hole_center_radius_mm,
                    p.pillar_angles_rad[i as usize % p.pillar_angles_rad.len()],
                    zc - g.length_mm / 2.0,
                    zc + g.length_mm / 2.0,
                ),
                // The reference grating hangs free on the axis, strain free.
                _ => {
                    let s = reference_span(m, p, g.length_mm, g.tail_mm());
                    (0.0, 0.0, s.z_start_mm, s.z_end_mm)
                }
            };
            GratingPlacement {
                name: g.name.clone(),
                core: g.core.clone(),
                role: g.role,
                radius_mm: radius,
                angle_rad: angle,
                z_start_mm: z0,
                z_end_mm: z1,
                bragg_wavelength_nm: g.bragg_wavelength_nm,
            }
        })
        .collect()
}

/// Derived layout of the flat array and its mold.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArrayLayout {
    /// Cell centres (x, y), mm from the array centre, row-major from the −y row,
    /// −x column; cell k is labelled `A` + k.
    pub cell_centers_mm: Vec<(f64, f64)>,
    /// Cell size (x, y), mm.
    pub cell_size_mm: (f64, f64),
    /// Grating centres (x, y), mm from the array centre, in spec order.
    pub grating_positions_mm: Vec<(f64, f64)>,
    /// x of each slit centre, mm from the centre: one per fiber, the same in both walls.
    pub slit_x_mm: Vec<f64>,
    /// Mold outer size (x, y, z), mm; the mold is centred on the array in x and y.
    pub mold_outer_mm: (f64, f64, f64),
    /// Height of the cavity floor above the mold's underside, mm.
    pub cavity_floor_z_mm: f64,
    /// Height of the fibers' axes above the mold's underside (the cavity floor plus the
    /// fiber depth below the loaded face, which is cast against the floor), mm.
    pub fiber_z_mm: f64,
    /// Height of the slit bottoms, where the coated fiber rests, mm.
    pub slit_bottom_z_mm: f64,
    /// Silicone level: the sheet's top above the mold's underside, mm.
    pub silicone_level_z_mm: f64,
}

/// Cell label: A, B, … Z, then AA, AB, …
pub fn cell_label(k: usize) -> String {
    let letters = b"ABCDEFGHIJKLMNOPQRSTUVWXYZ";
    if k < 26 {
        (letters[k] as char).to_string()
    } else {
        format!(
            "{}{}",
            letters[(k / 26 - 1) % 26] as char,
            letters[k % 26] as char
        )
    }
}

impl ArrayLayout {
    /// Derive the layout from a validated array spec.
    pub fn from_array(a: &TactileArray) -> Self {
        let (nx, ny) = (a.cells_x as usize, a.cells_y as usize);
        let (cw, ch) = (a.size_x_mm / nx as f64, a.size_y_mm / ny as f64);
        let mut cells = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                cells.push((
                    -a.size_x_mm / 2.0 + (i as f64 + 0.5) * cw,
                    -a.size_y_mm / 2.0 + (j as f64 + 0.5) * ch,
                ));
            }
        }
        let m = &a.mold;
        ArrayLayout {
            cell_centers_mm: cells,
            cell_size_mm: (cw, ch),
            grating_positions_mm: a
                .gratings
                .iter()
                .map(|g| (a.fiber_x_mm[g.fiber as usize], g.y_mm))
                .collect(),
            slit_x_mm: a.fiber_x_mm.clone(),
            mold_outer_mm: (
                m.internal_x_mm + 2.0 * m.wall_thickness_mm,
                m.internal_y_mm + 2.0 * m.wall_thickness_mm,
                m.base_thickness_mm + m.wall_height_mm,
            ),
            cavity_floor_z_mm: m.base_thickness_mm,
            fiber_z_mm: m.base_thickness_mm + a.fiber_depth(),
            slit_bottom_z_mm: m.base_thickness_mm + m.wall_height_mm - m.slit_depth_mm,
            silicone_level_z_mm: m.base_thickness_mm + a.thickness_mm,
        }
    }
}

/// Dimensions of what makes the module's parts assemble and wire: the fiber exits,
/// the reference fiber's bore and the snap-fit bead. Derived from the module, the
/// printer and `[fiber_routing]`; the solids and the fiber tracer read them.
///
/// Every fiber leaves the module the same way: straight down its hole (or, for the
/// reference fiber, down the axis) to `bend_start_z_mm`, then along a quarter circle
/// of radius `bend_radius_mm` that turns it horizontal at `exit_height_mm`, outward in
/// the vertical plane through its angle. The core's pillars end at the bend start,
/// so the strain fibers leave their holes before bending, and slots open to the base
/// in every part the bend crosses (cap, core wall, insert) let it out and let the
/// parts slide together with the fibers in place.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PartsProfile {
    /// Width of every fiber slot and channel, mm.
    pub channel_width_mm: f64,
    /// Coated fiber radius, mm.
    pub fiber_radius_mm: f64,
    /// Radius of every exit bend (the fiber's minimum), mm.
    pub bend_radius_mm: f64,
    /// Height of the fiber axis where the bend ends horizontal, mm.
    pub exit_height_mm: f64,
    /// Height where every fiber starts to bend: exit height + bend radius, mm.
    pub bend_start_z_mm: f64,
    /// Bottom of the core's pillars (they run up to the profile's pillar top), mm.
    pub pillar_bottom_mm: f64,
    /// Angle of the reference fiber's exit: midway between the last and the first
    /// pillar, radians.
    pub reference_exit_angle_rad: f64,
    /// Radius of the axial bore through each insert for the reference fiber, mm.
    pub insert_bore_radius_mm: f64,
    /// Half-width of the parallel slot in each insert's base (reference exit), mm.
    pub insert_slot_half_width_mm: f64,
    /// Height of the insert's slot roof, mm.
    pub insert_slot_top_mm: f64,
    /// Half-angle of the radial slot in the core wall (reference exit), radians.
    pub core_slot_half_angle_rad: f64,
    /// Height of the core wall's slot roof, mm.
    pub core_slot_top_mm: f64,
    /// Half-angle of the radial slots in the cap (one per pillar and one for the
    /// reference fiber), radians.
    pub cap_slot_half_angle_rad: f64,
    /// Height of the cap's slot roofs, mm.
    pub cap_slot_top_mm: f64,
    /// Snap bead, when the module has a `[module.snap]`.
    pub snap: Option<SnapProfile>,
    /// The insert's chamber for the reference grating (when the module has one): a
    /// coaxial cylinder of twice the bore's radius from its floor to its top (see
    /// [`ReferenceSpan`]); the bore runs up to its floor and no further.
    pub reference_chamber: Option<ReferenceChamber>,
}

/// The insert's chamber in which the reference grating hangs free.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReferenceChamber {
    /// Chamber radius: twice the bore's, mm.
    pub radius_mm: f64,
    /// Where the grating and the fiber's tip hang in it.
    pub span: ReferenceSpan,
    /// Name of the grating.
    #[serde(skip)]
    pub grating: usize,
}

/// The cap's snap bead: a ring on the cap's inner wall just below the pillar bottoms.
/// From the base up, the inner wall runs at the cap's inner radius to `lead_in_z_mm`,
/// the lead-in cone rises to the crest radius at `crest_bottom_z_mm`, the crest runs
/// to `crest_top_z_mm`, and the retention cone returns to the inner radius at
/// `retention_top_z_mm`, passing one clearance (normal to it) under the pillars'
/// bottom edge.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SnapProfile {
    /// Inner radius of the bead's crest: pillar outer radius − undercut, mm.
    pub crest_radius_mm: f64,
    /// Where the lead-in cone leaves the cap's inner wall, mm.
    pub lead_in_z_mm: f64,
    /// Bottom of the crest, mm.
    pub crest_bottom_z_mm: f64,
    /// Top of the crest, mm.
    pub crest_top_z_mm: f64,
    /// Where the retention cone meets the cap's inner wall again, mm.
    pub retention_top_z_mm: f64,
    /// How far the cap can rise off a seated core before the retention cone meets
    /// the pillars' bottom edge: the snap's clearance ([`snap_clearance_mm`]) over
    /// sin α₂, mm.
    pub free_travel_mm: f64,
}

/// Clearance between the snap's retention cone and the pillars' bottom edge, normal to
/// the cone: the cap/core clearance, at least 0.05 mm (so a press-fit design still
/// seats), mm.
pub fn snap_clearance_mm(cap_core_clearance_mm: f64) -> f64 {
    cap_core_clearance_mm.max(0.05)
}

/// Height above `bend_start_z` at which a slot roof's inner corner, `r_rel` outward from
/// the fiber's vertical run, clears a bend of radius `bend` by `gap` (the fiber radius
/// plus its clearance); where the bend has already turned horizontal, the roof only has
/// to clear the horizontal run.
pub(crate) fn slot_roof_z_mm(
    r_rel: f64,
    bend_start_z: f64,
    bend: f64,
    gap: f64,
    exit_z: f64,
) -> f64 {
    let reach = bend - gap;
    let dx = bend - r_rel;
    if dx <= 0.0 || reach <= dx {
        // The corner lies above the horizontal run (or beyond the bend's reach).
        return exit_z + gap;
    }
    bend_start_z - (reach * reach - dx * dx).sqrt()
}

impl PartsProfile {
    /// Derive from a module and its profile; `printer_min_gap_mm` and `routing` come
    /// from the design. Results may be out of range for a bad spec: validation checks
    /// them ([`crate::design`]).
    pub fn new(
        m: &Module,
        p: &ModuleProfile,
        routing: &FiberRouting,
        channel_width_mm: f64,
    ) -> Self {
        let w = channel_width_mm;
        let rf = routing.coated_diameter_mm / 2.0;
        let gap = rf + routing.channel_clearance_mm;
        let bend = routing.min_bend_radius_mm;
        let z_h = routing.exit_height_mm;
        let z_b = z_h + bend;
        let n = p.pillar_angles_rad.len().max(1) as f64;
        let first = p.pillar_angles_rad.first().copied().unwrap_or(0.0);
        let bore = w / 2.0 + routing.channel_clearance_mm.max(0.05 * w);
        let roof = |r_rel: f64| slot_roof_z_mm(r_rel, z_b, bend, gap, z_h);
        // The cap's slots carry the strain fibers (bend starting at the fiber hole)
        // and the reference fiber (bend starting on the axis): the higher roof wins.
        let cap_roof = roof(p.cap_inner_radius_mm - p.fiber_hole_center_radius_mm)
            .max(roof(p.cap_inner_radius_mm));
        let snap = m.snap.as_ref().map(|s| {
            let lift = s.undercut_mm + m.cap_core_clearance_mm;
            // The retention cone passes one clearance (at least 0.05 mm), measured
            // normal to it, under the pillars' bottom edge: the cap's free upward
            // travel is that clearance over sin α₂ (SnapProfile::free_travel_mm), not
            // the clearance plus the cone's rise over the fit's radial clearance.
            let normal_gap = snap_clearance_mm(m.cap_core_clearance_mm);
            let (sin2, cot2) = {
                let a = s.retention_angle_deg.to_radians();
                (a.sin(), 1.0 / a.tan())
            };
            let crest_top = z_b - normal_gap / sin2 - s.undercut_mm * cot2;
            let retention_top = crest_top + lift * cot2;
            let crest_bottom = crest_top - s.bead_height_mm;
            SnapProfile {
                crest_radius_mm: p.pillar_outer_radius_mm - s.undercut_mm,
                lead_in_z_mm: crest_bottom - lift / s.lead_in_angle_deg.to_radians().tan(),
                crest_bottom_z_mm: crest_bottom,
                crest_top_z_mm: crest_top,
                retention_top_z_mm: retention_top,
                free_travel_mm: normal_gap / sin2,
            }
        });
        // The first reference grating fixes the chamber (a module has one reference).
        let reference_chamber = m
            .gratings
            .iter()
            .position(|g| g.role == GratingRole::TemperatureReference)
            .map(|i| {
                let g = &m.gratings[i];
                ReferenceChamber {
                    radius_mm: 2.0 * bore,
                    span: reference_span(m, p, g.length_mm, g.tail_mm()),
                    grating: i,
                }
            });
        PartsProfile {
            reference_chamber,
            channel_width_mm: w,
            fiber_radius_mm: rf,
            bend_radius_mm: bend,
            exit_height_mm: z_h,
            bend_start_z_mm: z_b,
            pillar_bottom_mm: z_b,
            reference_exit_angle_rad: first - std::f64::consts::PI / n,
            insert_bore_radius_mm: bore,
            insert_slot_half_width_mm: w / 2.0,
            insert_slot_top_mm: roof(bore),
            core_slot_half_angle_rad: (w / 2.0 / p.core_inner_radius_mm).asin(),
            core_slot_top_mm: roof(p.core_inner_radius_mm),
            cap_slot_half_angle_rad: (w / 2.0 / p.cap_inner_radius_mm).asin(),
            cap_slot_top_mm: cap_roof,
            snap,
        }
    }

    /// Derive for a design's module (None without one).
    pub fn of_design(d: &crate::spec::Design) -> Option<(ModuleProfile, PartsProfile)> {
        let m = d.module.as_ref()?;
        let p = ModuleProfile::from_module_unchecked(m);
        let w = d.fiber_routing.channel_width_mm(&d.printer);
        let pp = PartsProfile::new(m, &p, &d.fiber_routing, w);
        Some((p, pp))
    }
}

/// The snap-fit sized by the standard equations (annular snap on a rigid shaft, Bayer /
/// Covestro snap-fit guide): strain, transverse force and the mating and separating
/// forces of the cap on each core. See docs/geometry.md, "Snap-fit".
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SnapReport {
    /// Radial undercut y, mm.
    pub undercut_mm: f64,
    /// Radius of the bead's crest, mm.
    pub crest_radius_mm: f64,
    /// Largest strain in the cap's ring when the core's pillars (taken as rigid: the
    /// conservative bound) push it out by the whole undercut at the pillars and it
    /// ovalises between them ([`ring_strain_per_undercut`]: bending plus the ring's
    /// tension), percent. This is the number checked.
    pub cap_strain_percent: f64,
    /// How the strain was found, in words.
    pub strain_model: String,
    /// Hoop strain were the ring opened evenly by the undercut (a continuous rigid
    /// shaft): y / crest radius, percent; below the bending strain for separate
    /// pillars, for comparison.
    pub hoop_strain_percent: f64,
    /// Largest undercut the cap's material permits by that strain, mm.
    pub max_undercut_mm: f64,
    /// Smallest undercut the printer can make reliably (1.5 × its resolution), mm.
    pub min_undercut_mm: f64,
    /// The cap material's permissible strain, percent.
    pub permissible_strain_percent: f64,
    /// Lead-in and retention angles, degrees; friction coefficient.
    pub lead_in_angle_deg: f64,
    /// Retention angle, degrees.
    pub retention_angle_deg: f64,
    /// Friction coefficient.
    pub friction_coefficient: f64,
    /// Radial stiffness of the cap's ring under a ring load, N/mm.
    pub ring_stiffness_n_per_mm: f64,
    /// Forces for each core (cores differ in material, so in how much of the undercut
    /// their pillars take).
    pub cores: Vec<SnapCoreForces>,
    /// How far a seated cap can rise before the retention cone meets the pillars'
    /// bottom edge ([`SnapProfile::free_travel_mm`]): the snap's clearance over
    /// sin α₂, mm.
    pub free_travel_mm: f64,
}

/// How the cap is held on the core, stated in the manifest (issue 39): by the snap
/// (its retention force and free travel), or by nothing, which is a warning. A press
/// fit (clearance 0) is designed touching with no interference: its computed holding
/// force is 0 N, so it counts as nothing.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "by", rename_all = "snake_case")]
pub enum Retention {
    /// The snap bead under the pillars.
    Snap {
        /// Least force, over the cores, that pulls the seated cap off, N (None when
        /// the retention cone is self-locking on every core: it breaks before it
        /// slides).
        retention_force_n: Option<f64>,
        /// How far the seated cap can rise before the bead holds it, mm.
        free_travel_mm: f64,
        /// The printer's resolution, mm: a free travel within it is zero as printed.
        resolution_mm: f64,
    },
    /// Nothing holds the cap on: the warning, in words.
    Nothing {
        /// What the lab must do, in words.
        warning: String,
    },
}

impl Retention {
    /// The warning to show, if any.
    pub fn warning(&self) -> Option<&str> {
        match self {
            Retention::Nothing { warning } => Some(warning),
            Retention::Snap { .. } => None,
        }
    }
}

/// How the cap of `d`'s module is held (None for an array design).
///
/// ```
/// use fbgforge_core::profile::{retention, PartsProfile, Retention};
/// let mut d = fbgforge_core::design::load(std::path::Path::new(concat!(
///     env!("CARGO_MANIFEST_DIR"),
///     "/../../designs/clip-on-34mm.toml"
/// )))
/// .unwrap();
/// let (p, pp) = PartsProfile::of_design(&d).unwrap();
/// assert!(matches!(retention(&d, &p, &pp), Some(Retention::Snap { .. })));
/// d.module.as_mut().unwrap().snap = None;
/// let (p, pp) = PartsProfile::of_design(&d).unwrap();
/// let r = retention(&d, &p, &pp).unwrap();
/// assert!(r.warning().unwrap().contains("[module.snap]"));
/// ```
pub fn retention(
    d: &crate::spec::Design,
    p: &ModuleProfile,
    pp: &PartsProfile,
) -> Option<Retention> {
    let m = d.module.as_ref()?;
    if let Some(r) = snap_report(d, p, pp) {
        let force = r
            .cores
            .iter()
            .filter_map(|c| c.retention_force_n)
            .reduce(f64::min);
        return Some(Retention::Snap {
            retention_force_n: force,
            free_travel_mm: r.free_travel_mm,
            resolution_mm: d.printer.resolution_mm,
        });
    }
    let fit = if m.cap_core_clearance_mm <= 0.0 {
        "a press fit (module.cap_core_clearance_mm = 0) has no designed interference, so its computed holding force is 0 N"
    } else {
        "the cap slides on the pillars with module.cap_core_clearance_mm of clearance, so no friction holds it"
    };
    Some(Retention::Nothing {
        warning: format!(
            "nothing holds the cap on the core: the design has no [module.snap] and {fit}; add [module.snap] (docs/geometry.md, \"Snap-fit\"), or bond or clamp the cap before loading"
        ),
    })
}

/// Snap forces for one core.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SnapCoreForces {
    /// Core name.
    pub core: String,
    /// Radial stiffness of all pillars pressed by the bead crest, N/mm.
    pub pillar_stiffness_n_per_mm: f64,
    /// Total radial (transverse) force at full undercut, N.
    pub transverse_force_n: f64,
    /// Part of the undercut the cap's ring takes (the rest squeezes the pillars), mm.
    pub cap_deflection_mm: f64,
    /// Force to push the cap on over the lead-in cone, N.
    pub assembly_force_n: f64,
    /// Friction force while the crest slides along the pillars, N.
    pub sliding_force_n: f64,
    /// Force to pull the cap off over the retention cone, N; None when the retention
    /// cone is self-locking (μ·tan α ≥ 1: the joint does not come apart without
    /// damage).
    pub retention_force_n: Option<f64>,
}

/// W = P (μ + tan α) / (1 − μ tan α): the axial force that pushes a transverse force P
/// over a ramp at angle α to the axis; None when the ramp is self-locking.
pub fn ramp_force_n(p: f64, mu: f64, alpha_deg: f64) -> Option<f64> {
    let t = alpha_deg.to_radians().tan();
    let den = 1.0 - mu * t;
    (alpha_deg < 90.0 && den > 0.0).then(|| p * (mu + t) / den)
}

/// Roark's ring under `n` equal radial point loads W, equally spaced (Young &
/// Budynas, Roark's Formulas, table 9.2; α = π / n, half the pitch): the bending moment
/// at a load is M = (W R / 2)(1/α − cot α), the radial displacement at a load is
/// δ = (W R³ / E I)[(α + sin α cos α) / (4 sin² α) − 1 / (2α)] (bending energy only),
/// and the ring's tension between the loads is W / (2 sin α). Returns the moment
/// coefficient (1/α − cot α) and the displacement coefficient.
pub fn ring_point_load_coefficients(n: usize) -> (f64, f64) {
    let a = std::f64::consts::PI / n as f64;
    let (s, c) = a.sin_cos();
    (
        1.0 / a - c / s,
        (a + s * c) / (4.0 * s * s) - 1.0 / (2.0 * a),
    )
}

/// Largest strain in a ring of mean radius `r_mm` and wall `t_mm` pushed out by
/// `undercut` at `n` equally spaced points (a rigid core's pillars), per unit of
/// undercut: the bending strain at the loads, y t k_M / (4 R² k_δ), plus the ring's
/// tension W / (2 sin α · E t b) with W from the displacement, y t² / (24 R³ k_δ sin α).
/// Both are independent of the modulus and of the ring's axial width.
pub fn ring_strain_per_undercut(n: usize, t_mm: f64, r_mm: f64) -> f64 {
    let (k_m, k_d) = ring_point_load_coefficients(n);
    let s = (std::f64::consts::PI / n as f64).sin();
    t_mm * k_m / (4.0 * r_mm * r_mm * k_d) + t_mm * t_mm / (24.0 * r_mm.powi(3) * k_d * s)
}

/// Size the snap of `m` (None without `[module.snap]` or without the permissible
/// strain of the cap's material).
pub fn snap_report(
    d: &crate::spec::Design,
    p: &ModuleProfile,
    pp: &PartsProfile,
) -> Option<SnapReport> {
    let m = d.module.as_ref()?;
    let s = m.snap.as_ref()?;
    let sp = pp.snap.as_ref()?;
    let cap = d.materials.get(&m.cap_material)?;
    let eps_max = cap.permissible_strain_percent?;
    let y = s.undercut_mm;
    // Long thin cylinder under a ring load (beam on an elastic foundation):
    // w = Q λ / (2k), k = E t / r², λ⁴ = 3(1 − ν²) / (r² t²); P = 2π r Q.
    let t = m.cap_wall_mm;
    let r = p.cap_inner_radius_mm + t / 2.0;
    let nu = cap.poisson_ratio;
    let lambda = (3.0 * (1.0 - nu * nu) / (r * r * t * t)).powf(0.25);
    let k_ring = 4.0 * std::f64::consts::PI * cap.youngs_modulus_mpa * t / (r * lambda);
    // Each pillar's two faces beside the groove are pressed over the crest height
    // through the pillar's radial height.
    let pl = &m.pillars;
    let face_area = (pl.width_mm - pl.groove_width_mm) * s.bead_height_mm;
    let cores = m
        .cores
        .iter()
        .filter_map(|c| {
            let e = d.materials.get(&c.material)?.youngs_modulus_mpa;
            let k_p = p.pillar_angles_rad.len() as f64 * e * face_area / pl.height_mm;
            let force = y / (1.0 / k_ring + 1.0 / k_p);
            Some(SnapCoreForces {
                core: c.name.clone(),
                pillar_stiffness_n_per_mm: k_p,
                transverse_force_n: force,
                cap_deflection_mm: force / k_ring,
                assembly_force_n: ramp_force_n(force, s.friction_coefficient, s.lead_in_angle_deg)
                    .unwrap_or(f64::INFINITY),
                sliding_force_n: s.friction_coefficient * force,
                retention_force_n: ramp_force_n(
                    force,
                    s.friction_coefficient,
                    s.retention_angle_deg,
                ),
            })
        })
        .collect();
    let n = p.pillar_angles_rad.len();
    let per_mm = ring_strain_per_undercut(n, t, r);
    Some(SnapReport {
        undercut_mm: y,
        crest_radius_mm: sp.crest_radius_mm,
        cap_strain_percent: 100.0 * y * per_mm,
        strain_model: format!(
            "ring bending between {n} rigid pillars: the cap's wall ({t} mm, mean radius {r:.3} mm) pushed out by the undercut at each pillar (Roark, ring under {n} equal radial loads), bending plus ring tension"
        ),
        hoop_strain_percent: 100.0 * y / sp.crest_radius_mm,
        max_undercut_mm: eps_max / 100.0 / per_mm,
        min_undercut_mm: crate::spec::MIN_UNDERCUT_PER_RESOLUTION * d.printer.resolution_mm,
        permissible_strain_percent: eps_max,
        lead_in_angle_deg: s.lead_in_angle_deg,
        retention_angle_deg: s.retention_angle_deg,
        friction_coefficient: s.friction_coefficient,
        ring_stiffness_n_per_mm: k_ring,
        cores,
        free_travel_mm: sp.free_travel_mm,
    })
}
