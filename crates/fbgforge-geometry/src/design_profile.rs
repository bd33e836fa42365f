//! A design with every dimension its parts need, derived once per build.
//!
//! [`DesignProfile::new`] is the one place in `geometry` that calls the derivations of
//! [`crate::profile`] ([`ModuleProfile`], [`PartsProfile`], [`ArrayLayout`]) and sizes
//! the mold's slit pockets; the part builders, the assembly check, the previews and the
//! manifest all borrow the result.

use crate::profile::{ArrayLayout, ModuleProfile, PartsProfile};
use crate::spec::{Design, Module, SpecError, TactileArray};

/// The stepped slit's pocket for a plug: its width and the height of its bottom
/// (the fiber's top), mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pocket {
    /// Pocket width, mm.
    pub width_mm: f64,
    /// Height of the pocket bottom above the mold's underside, mm.
    pub bottom_z_mm: f64,
}

/// The design and its derived dimensions.
#[derive(Debug, Clone)]
pub struct DesignProfile<'a> {
    /// The design itself.
    pub design: &'a Design,
    /// The clip-on module's dimensions (None without `[module]`).
    pub module: Option<ModuleDims<'a>>,
    /// The array's layout and mold slits (None without `[array]`).
    pub array: Option<ArrayDims<'a>>,
}

/// The module's spec with its derived profile.
#[derive(Debug, Clone)]
pub struct ModuleDims<'a> {
    /// `[module]`.
    pub spec: &'a Module,
    /// Radii and heights of cap, core and insert.
    pub profile: ModuleProfile,
    /// Fiber exits, bore and snap bead.
    pub parts: PartsProfile,
}

/// The array's spec with its derived layout.
#[derive(Debug, Clone)]
pub struct ArrayDims<'a> {
    /// `[array]`.
    pub spec: &'a TactileArray,
    /// Cells, slits and levels of the mold.
    pub layout: ArrayLayout,
    /// Width of each slit where it is widest (the plug pocket with plugs, else the
    /// slit), mm.
    pub slot_width_mm: f64,
    /// The plug pocket of every slit (None without plugs): as wide as a printable plug
    /// plus a channel clearance each side, from the layer boundary at or above the
    /// coated fiber's top up.
    pub pocket: Option<Pocket>,
}

impl<'a> DesignProfile<'a> {
    /// Derive every dimension of `design`.
    pub fn new(design: &'a Design) -> Self {
        let routing = &design.fiber_routing;
        let module = design.module.as_ref().map(|m| {
            let profile = ModuleProfile::from_module(m);
            let parts = PartsProfile::new(
                m,
                &profile,
                routing,
                routing.channel_width_mm(&design.printer),
            );
            ModuleDims {
                spec: m,
                profile,
                parts,
            }
        });
        let array = design.array.as_ref().map(|a| {
            let layout = ArrayLayout::from_array(a);
            let slot_width_mm = crate::spec::mold_slot_width_mm(design, &a.mold);
            // The pocket's ledge on the first layer boundary at or above the fiber's
            // top: the plug rests on it, never on the fiber.
            let pocket = a.mold.plugs.then_some(Pocket {
                width_mm: slot_width_mm,
                bottom_z_mm: design
                    .printer
                    .layer_at_or_above_mm(layout.slit_bottom_z_mm + routing.coated_diameter_mm),
            });
            ArrayDims {
                spec: a,
                layout,
                slot_width_mm,
                pocket,
            }
        });
        DesignProfile {
            design,
            module,
            array,
        }
    }
}

impl ModuleDims<'_> {
    /// Geometric preconditions beyond the spec's ranges: every radius and height in
    /// the order the construction needs. The spec's validation should already
    /// guarantee these; this keeps the builders from panicking on a design that slips
    /// through.
    pub(crate) fn check_buildable(&self) -> Result<(), SpecError> {
        let p = &self.profile;
        let e = |field: &str, msg: String| crate::spec::err(field, msg);
        let radii = [
            (
                "module.cap_wall_mm",
                p.cap_inner_radius_mm,
                p.cap_outer_radius_mm,
            ),
            (
                "module.pillars.groove_depth_mm",
                p.cap_pillar_inner_radius_mm,
                p.cap_inner_radius_mm,
            ),
            (
                "module.pillars.groove_depth_mm",
                p.groove_bottom_radius_mm,
                p.pillar_outer_radius_mm,
            ),
            (
                "module.pillars.height_mm",
                p.core_outer_radius_mm,
                p.groove_bottom_radius_mm,
            ),
            (
                "module.core_wall_mm",
                p.core_inner_radius_mm,
                p.core_outer_radius_mm,
            ),
            (
                "module.core_insert_clearance_mm",
                p.insert_radius_mm,
                p.core_inner_radius_mm,
            ),
            (
                "module.top_hole_diameter_mm",
                p.top_hole_radius_mm,
                p.core_inner_radius_mm,
            ),
            (
                "module.apex_flat_diameter_mm",
                p.apex_flat_radius_mm,
                p.insert_radius_mm,
            ),
        ];
        for (field, lo, hi) in radii {
            // A zero clearance (press fit) is a valid spec: the insert is its own
            // solid, so its radius may equal the core's inner radius.
            let fits = if field == "module.core_insert_clearance_mm" {
                lo <= hi
            } else {
                lo < hi
            };
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && fits) {
                return Err(e(
                    field,
                    format!("leaves a radius of {lo:.4} mm that must lie between 0 and {hi:.4} mm"),
                ));
            }
        }
        let heights = [
            p.pillar_top_mm,
            p.core_outer_junction_z_mm,
            p.cap_outer_junction_z_mm,
            p.cap_inner_junction_z_mm,
            p.insert_junction_z_mm,
        ];
        if heights.iter().any(|z| !z.is_finite() || *z <= 0.0)
            || p.pillar_top_mm > p.core_outer_junction_z_mm + 1e-9
            || p.pillar_top_mm > p.cap_inner_junction_z_mm + 1e-9
        {
            return Err(e(
                "module.dome_height_mm",
                "the dome leaves no cylindrical section for the pillars; make the module taller or the dome lower".into(),
            ));
        }
        Ok(())
    }
}
