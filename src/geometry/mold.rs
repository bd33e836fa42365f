//! Solid of the array's casting mold: base plate, four walls around the cavity, and
//! one fiber slit per fiber through each of the two walls normal to y.
//!
//! Every face is planar, so the solid is a polyhedron assembled face by face: outer
//! and inner wall faces are polygons with a rectangular notch per slit, the slits
//! contribute two side faces and a bottom each, and the wall top is split by the slits
//! into separate pieces.

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

/// Build the mold. Slit centres are `layout.slit_x_mm` (validated to leave walls
/// between them); the caller checks they lie inside the cavity's x span.
pub fn mold(m: &Mold, layout: &ArrayLayout) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new("mold");
    let (ox, oy, h) = layout.mold_outer_mm;
    let (hx, hy) = (ox / 2.0, oy / 2.0);
    let (ix, iy) = (m.internal_x_mm / 2.0, m.internal_y_mm / 2.0);
    let zf = layout.cavity_floor_z_mm;
    let zs = h - m.slit_depth_mm;
    let sw = m.slit_width_mm / 2.0;
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
            v.extend([
                p(x + sw, y, h),
                p(x + sw, y, zs),
                p(x - sw, y, zs),
                p(x - sw, y, h),
            ]);
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
        // The slits: two sides and a bottom each.
        let (ya, yb) = (s * iy, s * hy);
        for &x in &xs {
            for (xx, n) in [(x - sw, ex), (x + sw, -ex)] {
                asm.plane(
                    "slit side",
                    &[poly(&[
                        p(xx, ya, zs),
                        p(xx, yb, zs),
                        p(xx, yb, h),
                        p(xx, ya, h),
                    ])],
                    n,
                )?;
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
            let (x0, x1) = (w[0] + sw, w[1] - sw);
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
    let (x_first, x_last) = (xs[0] - sw, xs[xs.len() - 1] + sw);
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
        - 2.0 * xs.len() as f64 * m.slit_width_mm * m.slit_depth_mm * m.wall_thickness_mm;
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: exact,
    })
}
