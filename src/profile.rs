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

use crate::spec::{GratingRole, Module, TactileArray};
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
                // The reference grating hangs below the top hole, strain free.
                _ => (0.0, 0.0, p.core_apex_z_mm - g.length_mm, p.core_apex_z_mm),
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
    /// Height of the fibers above the mold's underside (mid-thickness of the sheet), mm.
    pub fiber_z_mm: f64,
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
            fiber_z_mm: m.base_thickness_mm + m.wall_height_mm - m.slit_depth_mm,
        }
    }
}
