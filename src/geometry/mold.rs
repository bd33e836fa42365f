//! Solid of the array's casting mold: base plate, four walls around the cavity, and
//! one fiber slit per fiber through each of the two walls normal to y; and the plug
//! that closes a slit above its fiber.
//!
//! Every face is planar, so the solid is a polyhedron assembled face by face: outer
//! and inner wall faces are polygons with a notch per slit, the slits contribute their
//! side faces and bottoms, and the wall top is split by the slits into pieces. A slit
//! runs from the wall top down to where the coated fiber rests with its axis at the
//! sheet's mid-thickness. With plugs it is stepped: a seat as wide as the slit and as
//! high as the fiber, under a wider pocket up to the wall top that a printed plug
//! fills, so below the silicone level only the fiber's own seat is open.

use super::brep::{Assembler, BrepError, Seg};
use super::module::BuiltSolid;
use crate::profile::ArrayLayout;
use crate::spec::Mold;
use truck_modeling::{Point3, Vector3};

fn poly(pts: &[Point3]) -> Vec<Seg> {
    (0..pts.len())
        .map(|i| Seg::Line(pts[i], pts[(i + 1) % pts.len()]))
        .collect()
}

/// The stepped slit's pocket for a plug: its width and the height of its bottom
/// (the fiber's top), mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pocket {
    /// Pocket width, mm.
    pub width_mm: f64,
    /// Height of the pocket bottom above the mold's underside, mm.
    pub bottom_z_mm: f64,
}

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

/// Build the mold. Slit centres are `layout.slit_x_mm` (validated to leave walls
/// between them); the caller checks they lie inside the cavity's x span. With a
/// `pocket` each slit is stepped for a plug.
pub fn mold(
    m: &Mold,
    layout: &ArrayLayout,
    pocket: Option<Pocket>,
) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new("mold");
    let (ox, oy, h) = layout.mold_outer_mm;
    let (hx, hy) = (ox / 2.0, oy / 2.0);
    let (ix, iy) = (m.internal_x_mm / 2.0, m.internal_y_mm / 2.0);
    let zf = layout.cavity_floor_z_mm;
    let zs = h - m.slit_depth_mm;
    let sw = m.slit_width_mm / 2.0;
    // Without a pocket the slit is one width from the wall top down.
    // A pocket no wider than the seat is no step: one width from the top down.
    let pocket = pocket.filter(|q| q.width_mm / 2.0 > sw + 1e-6);
    let (pw, zp) = pocket.map_or((sw, h), |q| (q.width_mm / 2.0, q.bottom_z_mm));
    let stepped = pocket.is_some();
    let mut xs = layout.slit_x_mm.clone();
    xs.sort_by(|a, b| a.total_cmp(b));
    let p = Point3::new;
    let (ex, ey, ez) = (Vector3::unit_x(), Vector3::unit_y(), Vector3::unit_z());

    // Base and cavity floor.
    asm.plane(
        "underside",
        &[poly(&[
            p(-hx, -hy, 0.0),
            p(hx, -hy, 0.0),
            p(hx, hy, 0.0),
            p(-hx, hy, 0.0),
        ])],
        -ez,
    )?;
    asm.plane(
        "cavity floor",
        &[poly(&[
            p(-ix, -iy, zf),
            p(ix, -iy, zf),
            p(ix, iy, zf),
            p(-ix, iy, zf),
        ])],
        ez,
    )?;
    // Short walls (normal to x): plain rectangles.
    for s in [-1.0, 1.0] {
        asm.plane(
            "outer short wall",
            &[poly(&[
                p(s * hx, -hy, 0.0),
                p(s * hx, hy, 0.0),
                p(s * hx, hy, h),
                p(s * hx, -hy, h),
            ])],
            ex * s,
        )?;
        asm.plane(
            "inner short wall",
            &[poly(&[
                p(s * ix, -iy, zf),
                p(s * ix, iy, zf),
                p(s * ix, iy, h),
                p(s * ix, -iy, h),
            ])],
            -ex * s,
        )?;
    }
    // Long walls (normal to y) with one notch per slit, seen along the top edge from
    // +x to −x.
    let notched_top = |y: f64| -> Vec<Point3> {
        let mut v = Vec::new();
        for &x in xs.iter().rev() {
            if stepped {
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
    };
    for s in [-1.0, 1.0] {
        let mut outer = vec![p(-hx, s * hy, 0.0), p(hx, s * hy, 0.0), p(hx, s * hy, h)];
        outer.extend(notched_top(s * hy));
        outer.push(p(-hx, s * hy, h));
        asm.plane("outer long wall", &[poly(&outer)], ey * s)?;
        let mut inner = vec![p(-ix, s * iy, zf), p(ix, s * iy, zf), p(ix, s * iy, h)];
        inner.extend(notched_top(s * iy));
        inner.push(p(-ix, s * iy, h));
        asm.plane("inner long wall", &[poly(&inner)], -ey * s)?;
        // The slits: two sides and a bottom each, and with a pocket its two sides and
        // the two ledges it stands on.
        let (ya, yb) = (s * iy, s * hy);
        let side = |asm: &mut Assembler, xx: f64, z0: f64, z1: f64, n: Vector3| {
            asm.plane(
                "slit side",
                &[poly(&[
                    p(xx, ya, z0),
                    p(xx, yb, z0),
                    p(xx, yb, z1),
                    p(xx, ya, z1),
                ])],
                n,
            )
        };
        for &x in &xs {
            for (xx, px, n) in [(x - sw, x - pw, ex), (x + sw, x + pw, -ex)] {
                side(&mut asm, xx, zs, zp, n)?;
                if stepped {
                    side(&mut asm, px, zp, h, n)?;
                    let (x0, x1) = (xx.min(px), xx.max(px));
                    asm.plane(
                        "pocket ledge",
                        &[poly(&[
                            p(x0, ya, zp),
                            p(x1, ya, zp),
                            p(x1, yb, zp),
                            p(x0, yb, zp),
                        ])],
                        ez,
                    )?;
                }
            }
            asm.plane(
                "slit bottom",
                &[poly(&[
                    p(x - sw, ya, zs),
                    p(x + sw, ya, zs),
                    p(x + sw, yb, zs),
                    p(x - sw, yb, zs),
                ])],
                ez,
            )?;
        }
        // Wall-top pieces of this long wall between neighbouring slits.
        for w in xs.windows(2) {
            let (x0, x1) = (w[0] + pw, w[1] - pw);
            asm.plane(
                "wall top",
                &[poly(&[
                    p(x0, ya, h),
                    p(x1, ya, h),
                    p(x1, yb, h),
                    p(x0, yb, h),
                ])],
                ez,
            )?;
        }
    }
    // The two end pieces of the wall top: a short wall and the ends of both long
    // walls up to the first (last) slit.
    let (x_first, x_last) = (xs[0] - pw, xs[xs.len() - 1] + pw);
    asm.plane(
        "wall top",
        &[poly(&[
            p(-hx, -hy, h),
            p(x_first, -hy, h),
            p(x_first, -iy, h),
            p(-ix, -iy, h),
            p(-ix, iy, h),
            p(x_first, iy, h),
            p(x_first, hy, h),
            p(-hx, hy, h),
        ])],
        ez,
    )?;
    asm.plane(
        "wall top",
        &[poly(&[
            p(hx, hy, h),
            p(x_last, hy, h),
            p(x_last, iy, h),
            p(ix, iy, h),
            p(ix, -iy, h),
            p(x_last, -iy, h),
            p(x_last, -hy, h),
            p(hx, -hy, h),
        ])],
        ez,
    )?;
    let exact = ox * oy * h
        - m.internal_x_mm * m.internal_y_mm * m.wall_height_mm
        - 2.0
            * xs.len() as f64
            * m.wall_thickness_mm
            * (m.slit_width_mm * (zp - zs) + 2.0 * pw * (h - zp));
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: exact,
    })
}
