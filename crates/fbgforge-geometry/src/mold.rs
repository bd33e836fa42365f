//! Solid of the array's casting mold: base plate, four walls around the cavity, and
//! one fiber slit per fiber through each of the two walls normal to y.
//!
//! Every face is planar, so the solid is a polyhedron assembled face by face: outer
//! and inner wall faces are polygons with a notch per slit, the slits contribute their
//! side faces and bottoms, and the wall top is split by the slits into pieces. A slit
//! runs from the wall top down to where the coated fiber rests with its axis at the
//! sheet's mid-thickness. With plugs it is stepped: a seat as wide as the slit and as
//! high as the fiber, under a wider pocket up to the wall top that a printed plug
//! fills, so below the silicone level only the fiber's own seat is open. The plug
//! itself is `mold_plug`.

use super::brep::{Assembler, BrepError, Seg};
use super::design_profile::{ArrayDims, DesignProfile, Pocket};
use super::part::{BuiltSolid, PartKind, Print, PrintablePart};
use super::GeometryError;
use crate::profile::ArrayLayout;
use crate::spec::{Design, Mold, SpecError};
use truck_modeling::{Point3, Vector3};

/// The closed polygon through `pts`, as line segments.
pub(super) fn poly(pts: &[Point3]) -> Vec<Seg> {
    (0..pts.len())
        .map(|i| Seg::Line(pts[i], pts[(i + 1) % pts.len()]))
        .collect()
}

/// The mold's dimensions as the faces need them, mm: half extents, heights and the
/// slits' half widths.
struct MoldFrame {
    /// Outer half extents.
    hx: f64,
    hy: f64,
    /// Cavity half extents.
    ix: f64,
    iy: f64,
    /// Wall top, cavity floor, slit bottom and pocket bottom heights.
    h: f64,
    zf: f64,
    zs: f64,
    zp: f64,
    /// Half widths of the slit (seat) and of the pocket (the seat's without one).
    sw: f64,
    pw: f64,
    stepped: bool,
    /// Slit centres, ascending.
    xs: Vec<f64>,
}

impl MoldFrame {
    /// The frame of the mold `m` laid out by `layout`, slits stepped for a `pocket`
    /// wider than the seat.
    fn new(m: &Mold, layout: &ArrayLayout, pocket: Option<Pocket>) -> Self {
        let (ox, oy, h) = layout.mold_outer_mm;
        let sw = m.slit_width_mm / 2.0;
        // Without a pocket the slit is one width from the wall top down.
        // A pocket no wider than the seat is no step: one width from the top down.
        let pocket = pocket.filter(|q| q.width_mm / 2.0 > sw + 1e-6);
        let (pw, zp) = pocket.map_or((sw, h), |q| (q.width_mm / 2.0, q.bottom_z_mm));
        let mut xs = layout.slit_x_mm.clone();
        xs.sort_by(|a, b| a.total_cmp(b));
        MoldFrame {
            hx: ox / 2.0,
            hy: oy / 2.0,
            ix: m.internal_x_mm / 2.0,
            iy: m.internal_y_mm / 2.0,
            h,
            zf: layout.cavity_floor_z_mm,
            zs: h - m.slit_depth_mm,
            zp,
            sw,
            pw,
            stepped: pocket.is_some(),
            xs,
        }
    }

    /// The base's underside and the cavity floor.
    fn base_and_floor(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (hx, hy, ix, iy, zf) = (self.hx, self.hy, self.ix, self.iy, self.zf);
        let p = Point3::new;
        let ez = Vector3::unit_z();
        let underside = [
            p(-hx, -hy, 0.0),
            p(hx, -hy, 0.0),
            p(hx, hy, 0.0),
            p(-hx, hy, 0.0),
        ];
        asm.plane("underside", &[poly(&underside)], -ez)?;
        let floor = [
            p(-ix, -iy, zf),
            p(ix, -iy, zf),
            p(ix, iy, zf),
            p(-ix, iy, zf),
        ];
        asm.plane("cavity floor", &[poly(&floor)], ez)
    }

    /// The short walls (normal to x): plain rectangles.
    fn short_walls(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (hx, hy, ix, iy, zf, h) = (self.hx, self.hy, self.ix, self.iy, self.zf, self.h);
        let p = Point3::new;
        let ex = Vector3::unit_x();
        for s in [-1.0, 1.0] {
            let outer = [
                p(s * hx, -hy, 0.0),
                p(s * hx, hy, 0.0),
                p(s * hx, hy, h),
                p(s * hx, -hy, h),
            ];
            asm.plane("outer short wall", &[poly(&outer)], ex * s)?;
            let inner = [
                p(s * ix, -iy, zf),
                p(s * ix, iy, zf),
                p(s * ix, iy, h),
                p(s * ix, -iy, h),
            ];
            asm.plane("inner short wall", &[poly(&inner)], -ex * s)?;
        }
        Ok(())
    }

    /// A long wall's top edge at `y` with one notch per slit, from +x to −x.
    fn notched_top(&self, y: f64) -> Vec<Point3> {
        let (h, zs, zp, sw, pw) = (self.h, self.zs, self.zp, self.sw, self.pw);
        let p = Point3::new;
        let mut v = Vec::new();
        for &x in self.xs.iter().rev() {
            if self.stepped {
                v.extend([
                    p(x + pw, y, h),
                    p(x + pw, y, zp),
                    p(x + sw, y, zp),
                    p(x + sw, y, zs),
                    p(x - sw, y, zs),
                    p(x - sw, y, zp),
                    p(x - pw, y, zp),
                    p(x - pw, y, h),
                ]);
            } else {
                v.extend([
                    p(x + sw, y, h),
                    p(x + sw, y, zs),
                    p(x - sw, y, zs),
                    p(x - sw, y, h),
                ]);
            }
        }
        v
    }

    /// The long wall on side `s` (±1 along y): its outer and inner faces, its slits
    /// and the wall-top pieces between them.
    fn long_wall(&self, asm: &mut Assembler, s: f64) -> Result<(), BrepError> {
        let (hx, hy, ix, iy, zf, h) = (self.hx, self.hy, self.ix, self.iy, self.zf, self.h);
        let p = Point3::new;
        let ey = Vector3::unit_y();
        let mut outer = vec![p(-hx, s * hy, 0.0), p(hx, s * hy, 0.0), p(hx, s * hy, h)];
        outer.extend(self.notched_top(s * hy));
        outer.push(p(-hx, s * hy, h));
        asm.plane("outer long wall", &[poly(&outer)], ey * s)?;
        let mut inner = vec![p(-ix, s * iy, zf), p(ix, s * iy, zf), p(ix, s * iy, h)];
        inner.extend(self.notched_top(s * iy));
        inner.push(p(-ix, s * iy, h));
        asm.plane("inner long wall", &[poly(&inner)], -ey * s)?;
        let (ya, yb) = (s * iy, s * hy);
        for &x in &self.xs {
            self.slit(asm, x, (ya, yb))?;
        }
        for w in self.xs.windows(2) {
            let (x0, x1) = (w[0] + self.pw, w[1] - self.pw);
            let top = [p(x0, ya, h), p(x1, ya, h), p(x1, yb, h), p(x0, yb, h)];
            asm.plane("wall top", &[poly(&top)], Vector3::unit_z())?;
        }
        Ok(())
    }

    /// One slit at `x` through the wall between `ya` and `yb`: two sides and a bottom,
    /// and with a pocket its two sides and the two ledges it stands on.
    fn slit(&self, asm: &mut Assembler, x: f64, (ya, yb): (f64, f64)) -> Result<(), BrepError> {
        let (h, zs, zp, sw, pw) = (self.h, self.zs, self.zp, self.sw, self.pw);
        let p = Point3::new;
        let (ex, ez) = (Vector3::unit_x(), Vector3::unit_z());
        let side = |asm: &mut Assembler, xx: f64, z0: f64, z1: f64, n: Vector3| {
            let face = [p(xx, ya, z0), p(xx, yb, z0), p(xx, yb, z1), p(xx, ya, z1)];
            asm.plane("slit side", &[poly(&face)], n)
        };
        for (xx, px, n) in [(x - sw, x - pw, ex), (x + sw, x + pw, -ex)] {
            side(asm, xx, zs, zp, n)?;
            if self.stepped {
                side(asm, px, zp, h, n)?;
                let (x0, x1) = (xx.min(px), xx.max(px));
                let ledge = [p(x0, ya, zp), p(x1, ya, zp), p(x1, yb, zp), p(x0, yb, zp)];
                asm.plane("pocket ledge", &[poly(&ledge)], ez)?;
            }
        }
        let bottom = [
            p(x - sw, ya, zs),
            p(x + sw, ya, zs),
            p(x + sw, yb, zs),
            p(x - sw, yb, zs),
        ];
        asm.plane("slit bottom", &[poly(&bottom)], ez)
    }

    /// The two end pieces of the wall top: a short wall and the ends of both long
    /// walls up to the first (last) slit.
    fn wall_top_ends(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (hx, hy, ix, iy, h) = (self.hx, self.hy, self.ix, self.iy, self.h);
        let p = Point3::new;
        let ez = Vector3::unit_z();
        let xs = &self.xs;
        let (x_first, x_last) = (xs[0] - self.pw, xs[xs.len() - 1] + self.pw);
        let first = [
            p(-hx, -hy, h),
            p(x_first, -hy, h),
            p(x_first, -iy, h),
            p(-ix, -iy, h),
            p(-ix, iy, h),
            p(x_first, iy, h),
            p(x_first, hy, h),
            p(-hx, hy, h),
        ];
        asm.plane("wall top", &[poly(&first)], ez)?;
        let last = [
            p(hx, hy, h),
            p(x_last, hy, h),
            p(x_last, iy, h),
            p(ix, iy, h),
            p(ix, -iy, h),
            p(x_last, -iy, h),
            p(x_last, -hy, h),
            p(hx, -hy, h),
        ];
        asm.plane("wall top", &[poly(&last)], ez)
    }

    /// The exact volume: the block less the cavity and every slit (seat and pocket)
    /// through both long walls, mm³.
    fn exact_volume_mm3(&self, m: &Mold) -> f64 {
        let (ox, oy) = (2.0 * self.hx, 2.0 * self.hy);
        ox * oy * self.h
            - m.internal_x_mm * m.internal_y_mm * m.wall_height_mm
            - 2.0
                * self.xs.len() as f64
                * m.wall_thickness_mm
                * (m.slit_width_mm * (self.zp - self.zs) + 2.0 * self.pw * (self.h - self.zp))
    }
}

/// Build the mold. Slit centres are `layout.slit_x_mm` (validated to leave walls
/// between them); the caller checks they lie inside the cavity's x span. With a
/// `pocket` each slit is stepped for a plug.
pub fn mold(
    m: &Mold,
    layout: &ArrayLayout,
    pocket: Option<Pocket>,
) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new("mold");
    let frame = MoldFrame::new(m, layout, pocket);
    frame.base_and_floor(&mut asm)?;
    frame.short_walls(&mut asm)?;
    for s in [-1.0, 1.0] {
        frame.long_wall(&mut asm, s)?;
    }
    frame.wall_top_ends(&mut asm)?;
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: frame.exact_volume_mm3(m),
    })
}

/// A slit that would cut into the mold's corner is refused, naming the fiber.
fn check_slits_in_cavity(a: &ArrayDims) -> Result<(), SpecError> {
    let half = a.spec.mold.internal_x_mm / 2.0;
    let sw = a.slot_width_mm / 2.0;
    for (i, &x) in a.spec.fiber_x_mm.iter().enumerate() {
        if x.abs() + sw >= half - 1e-9 {
            return Err(crate::spec::err(
                &format!("array.fiber_x_mm[{i}]"),
                format!(
                    "{x} mm puts the slit (± {sw} mm) into the mold's corner; allowed within ±{:.3} mm",
                    half - sw
                ),
            ));
        }
    }
    Ok(())
}

/// The mold, in the registry: `mold` for every array design.
pub(crate) struct MoldPart;

impl PrintablePart for MoldPart {
    fn kind(&self) -> PartKind {
        PartKind::Mold
    }

    fn names(&self, design: &Design) -> Vec<String> {
        design.array.iter().map(|_| "mold".to_string()).collect()
    }

    fn solid(&self, profile: &DesignProfile, _name: &str) -> Result<BuiltSolid, GeometryError> {
        let a = profile
            .array
            .as_ref()
            .expect("a mold only in an array design");
        check_slits_in_cavity(a)?;
        Ok(mold(&a.spec.mold, &a.layout, a.pocket)?)
    }

    fn materials(&self, design: &Design, _name: &str) -> Vec<String> {
        print_material(design)
    }

    fn prints(&self, design: &Design, _name: &str) -> Vec<Print> {
        print_pieces(design, "mold")
    }

    fn preview_colour(&self) -> &'static str {
        "#7f7f7f"
    }
}

/// What the mold and its plugs are printed in (not the silicone cast in them).
pub(super) fn print_material(design: &Design) -> Vec<String> {
    design
        .array
        .iter()
        .map(|a| {
            a.mold
                .print_material
                .clone()
                .unwrap_or_else(|| "not stated (array.mold.print_material)".into())
        })
        .collect()
}

/// The one piece of a mold part, in the mold's print material.
pub(super) fn print_pieces(design: &Design, label: &str) -> Vec<Print> {
    design
        .array
        .iter()
        .map(|a| Print {
            label: label.into(),
            material: a.mold.print_material.clone(),
        })
        .collect()
}
