//! Planar and extruded faces from cross-section loops: a loop of lines and arcs in the
//! (x, y) plane, placed at a height as a flat face or extruded between two heights
//! into side faces (planes and cylinder patches).

use super::angles::Angles;
use crate::brep::{Assembler, BrepError, Seg};
use truck_modeling::{Point3, Vector3};

pub(super) fn pt(c: (f64, f64), r: f64, th: f64, z: f64) -> Point3 {
    Point3::new(c.0 + r * th.cos(), c.1 + r * th.sin(), z)
}

pub(super) const O: (f64, f64) = (0.0, 0.0);

/// An arc of the circle of radius `r` about `c` at height `z` from angle a0 to a1
/// (counter-clockwise if a1 > a0).
pub(super) fn arc(c: (f64, f64), r: f64, a0: f64, a1: f64, z: f64) -> Seg {
    Seg::Arc(
        pt(c, r, a0, z),
        pt(c, r, 0.5 * (a0 + a1), z),
        pt(c, r, a1, z),
    )
}

/// A cross-section segment, extruded between two heights.
#[derive(Debug, Clone, Copy)]
pub(super) enum S2 {
    Line((f64, f64), (f64, f64)),
    Arc {
        c: (f64, f64),
        r: f64,
        a0: f64,
        a1: f64,
    },
}

impl S2 {
    pub(super) fn at(&self, z: f64) -> Seg {
        match *self {
            S2::Line(a, b) => Seg::Line(Point3::new(a.0, a.1, z), Point3::new(b.0, b.1, z)),
            S2::Arc { c, r, a0, a1 } => arc(c, r, a0, a1, z),
        }
    }
    pub(super) fn start(&self) -> (f64, f64) {
        match *self {
            S2::Line(a, _) => a,
            S2::Arc { c, r, a0, .. } => (c.0 + r * a0.cos(), c.1 + r * a0.sin()),
        }
    }
    pub(super) fn end(&self) -> (f64, f64) {
        match *self {
            S2::Line(_, b) => b,
            S2::Arc { c, r, a1, .. } => (c.0 + r * a1.cos(), c.1 + r * a1.sin()),
        }
    }
}

pub(super) fn ring_ccw(ang: &Angles, r: f64, from: usize, to: usize) -> Vec<S2> {
    ang.walk(from, to)
        .into_iter()
        .map(|k| {
            let (a0, a1) = ang.interval(k);
            S2::Arc { c: O, r, a0, a1 }
        })
        .collect()
}

pub(super) fn ring_cw(ang: &Angles, r: f64, from: usize, to: usize) -> Vec<S2> {
    // Clockwise from `from` to `to` is the counter-clockwise walk from `to` to `from`,
    // reversed.
    ang.walk(to, from)
        .into_iter()
        .rev()
        .map(|k| {
            let (a0, a1) = ang.interval(k);
            S2::Arc {
                c: O,
                r,
                a0: a1,
                a1: a0,
            }
        })
        .collect()
}

pub(super) fn at(loop2: &[S2], z: f64) -> Vec<Seg> {
    loop2.iter().map(|s| s.at(z)).collect()
}

/// Side faces of the cross-section loops extruded from z0 to z1.
pub(super) fn band_sides(
    asm: &mut Assembler,
    loops: &[Vec<S2>],
    z0: f64,
    z1: f64,
) -> Result<(), BrepError> {
    for l in loops {
        for s in l {
            let (a, b) = (s.start(), s.end());
            let pa0 = Point3::new(a.0, a.1, z0);
            let pa1 = Point3::new(a.0, a.1, z1);
            let pb0 = Point3::new(b.0, b.1, z0);
            let pb1 = Point3::new(b.0, b.1, z1);
            let boundary = vec![
                s.at(z0),
                Seg::Line(pb0, pb1),
                s.at(z1).reversed(),
                Seg::Line(pa1, pa0),
            ];
            match *s {
                S2::Line(..) => {
                    let out = Vector3::new(b.1 - a.1, a.0 - b.0, 0.0);
                    asm.plane("band side", &[boundary], out)?;
                }
                S2::Arc { c, r, a0, a1 } => {
                    let axis = Point3::new(c.0, c.1, 0.0);
                    let meridian = move |th: f64| Seg::Line(pt(c, r, th, z0), pt(c, r, th, z1));
                    // Material on the left: counter-clockwise → material inside the
                    // circle → outward points away from its centre.
                    let sign = if a1 > a0 { 1.0 } else { -1.0 };
                    asm.revolved(
                        "band wall",
                        &[boundary],
                        axis,
                        (a0.min(a1), a0.max(a1)),
                        &meridian,
                        None,
                        sign,
                    )?;
                }
            }
        }
    }
    Ok(())
}

/// Flat disc of radius r at height z (apex flats, the insert's base).
pub(super) fn disc(
    asm: &mut Assembler,
    ang: &Angles,
    r: f64,
    z: f64,
    up: bool,
) -> Result<(), BrepError> {
    let l = at(&ring_ccw(ang, r, 0, 0), z);
    let n = if up {
        Vector3::unit_z()
    } else {
        -Vector3::unit_z()
    };
    asm.plane("flat", &[l], n)
}

/// Flat annular sector between radii r0 < r1 from interval index `from` to `to`
/// (counter-clockwise) at height z; `up` says which way it faces.
pub(super) fn sector(
    asm: &mut Assembler,
    ang: &Angles,
    (r0, r1): (f64, f64),
    (from, to): (usize, usize),
    z: f64,
    up: bool,
) -> Result<(), BrepError> {
    let mut l = ring_ccw(ang, r1, from, to);
    let end = l.last().expect("an arc").end();
    let k = r0 / r1;
    l.push(S2::Line(end, (end.0 * k, end.1 * k)));
    l.extend(ring_cw(ang, r0, to, from));
    let start = l[0].start();
    l.push(S2::Line(l.last().expect("an arc").end(), start));
    let n = if up {
        Vector3::unit_z()
    } else {
        -Vector3::unit_z()
    };
    asm.plane("sector", &[at(&l, z)], n)
}
