//! The plug that closes a mold slit above its fiber: a block that fills the slit's
//! pocket (one file, printed once per slit), line to line, so that with it in place
//! nothing but the fiber's own seat is open through the wall below the silicone level.

use super::brep::{Assembler, BrepError};
use super::design_profile::{DesignProfile, Pocket};
use super::mold::{poly, print_material};
use super::part::{BuiltSolid, PartKind, Print, PrintablePart};
use super::GeometryError;
use crate::profile::ArrayLayout;
use crate::spec::{Design, Mold};
use truck_modeling::{Point3, Vector3};

/// Clearance between the plug and each side of its pocket, mm: none, a press fit. An
/// FDM printer draws a pocket a little narrow and a block a little wide, so a
/// line-to-line fit is tight; a plug that does not go in is sanded, never left loose
/// (a 0.1 mm gap beside an 0.8 mm plug let silicone through the wall).
pub const PLUG_FIT_MM: f64 = 0.0;

/// The plug that fills one pocket: a block `fit_mm` narrower than the pocket on each
/// side, from the pocket bottom to the wall top, as long as the wall is thick.
pub fn plug(
    m: &Mold,
    layout: &ArrayLayout,
    pocket: Pocket,
    fit_mm: f64,
) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new("mold-plug");
    let w = pocket.width_mm - 2.0 * fit_mm;
    let h = layout.mold_outer_mm.2 - pocket.bottom_z_mm;
    let l = m.wall_thickness_mm;
    let p = Point3::new;
    let c = [
        p(0.0, 0.0, 0.0),
        p(w, 0.0, 0.0),
        p(w, l, 0.0),
        p(0.0, l, 0.0),
    ];
    let up = |q: Point3| p(q.x, q.y, h);
    asm.plane("bottom", &[poly(&c)], -Vector3::unit_z())?;
    asm.plane("top", &[poly(&c.map(up))], Vector3::unit_z())?;
    let normals = [
        -Vector3::unit_y(),
        Vector3::unit_x(),
        Vector3::unit_y(),
        -Vector3::unit_x(),
    ];
    for i in 0..4 {
        let (a, b) = (c[i], c[(i + 1) % 4]);
        asm.plane("side", &[poly(&[a, b, up(b), up(a)])], normals[i])?;
    }
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: w * l * h,
    })
}

/// The mold plug, in the registry: `mold-plug` for an array whose mold has plugs.
pub(crate) struct MoldPlugPart;

impl PrintablePart for MoldPlugPart {
    fn kind(&self) -> PartKind {
        PartKind::MoldPlug
    }

    fn names(&self, design: &Design) -> Vec<String> {
        design
            .array
            .iter()
            .filter(|a| a.mold.plugs)
            .map(|_| "mold-plug".to_string())
            .collect()
    }

    fn solid(&self, profile: &DesignProfile, _name: &str) -> Result<BuiltSolid, GeometryError> {
        let a = profile
            .array
            .as_ref()
            .expect("a plug only in an array design");
        let pocket = a.pocket.expect("a plug only for a mold with plugs");
        Ok(plug(&a.spec.mold, &a.layout, pocket, PLUG_FIT_MM)?)
    }

    fn materials(&self, design: &Design, _name: &str) -> Vec<String> {
        print_material(design)
    }

    /// One plug per slit (two walls × the fibers), so the 3MF plate holds every plug
    /// to print: `mold-plug-1` … `mold-plug-<n>`.
    fn prints(&self, design: &Design, _name: &str) -> Vec<Print> {
        let slits = design.array.as_ref().map_or(0, |a| 2 * a.fiber_x_mm.len());
        super::mold::print_pieces(design, "mold-plug")
            .into_iter()
            .flat_map(|p| {
                (1..=slits).map(move |i| Print {
                    label: format!("{}-{i}", p.label),
                    material: p.material.clone(),
                })
            })
            .collect()
    }

    fn preview_colour(&self) -> &'static str {
        "#ff7f0e"
    }
}
