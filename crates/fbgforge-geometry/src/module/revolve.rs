//! Faces of revolution from the (r, z) profile: cylinder walls, cones and domes as
//! meridian segments revolved about the module axis, patch by patch between the cut
//! angles.

use super::angles::Angles;
use super::section::{arc, pt, O};
use crate::brep::{Assembler, BrepError, Seg};
use std::f64::consts::TAU;
use truck_modeling::Point3;

/// Profile segments shorter than this are skipped (e.g. a zero-height cylinder
/// between the pillar top and a junction at the same height), mm.
pub(super) const MIN_SEGMENT_MM: f64 = 1.0e-6;

/// One meridian of a revolved profile, in the (r, z) half-plane.
#[derive(Debug, Clone, Copy)]
pub(super) struct Prof {
    pub(super) a: (f64, f64),
    pub(super) b: (f64, f64),
    /// Sphere radius for a dome, None for a vertical cylinder wall.
    pub(super) sphere: Option<f64>,
    /// +1 if the outward normal points away from the axis / sphere centre.
    pub(super) out: f64,
}

pub(super) fn meridian(p: &Prof, zc: f64, th: f64) -> Seg {
    let (a, b) = (pt(O, p.a.0, th, p.a.1), pt(O, p.b.0, th, p.b.1));
    match p.sphere {
        None => Seg::Line(a, b),
        Some(rho) => {
            let pa = p.a.0.atan2(p.a.1 - zc);
            let pb = p.b.0.atan2(p.b.1 - zc);
            let pm = 0.5 * (pa + pb);
            Seg::Arc(a, pt(O, rho * pm.sin(), th, zc + rho * pm.cos()), b)
        }
    }
}

/// Revolve a chain of profile segments through every interval of `ang`.
pub(super) fn revolve_chain(
    asm: &mut Assembler,
    chain: &[Prof],
    zc: f64,
    ang: &Angles,
) -> Result<(), BrepError> {
    revolve_chain_above(asm, chain, zc, ang, f64::INFINITY)
}

/// Revolve a chain of profile segments: with every cut of `ang` where both ends of a
/// segment lie at or below `fine_up_to_z`, on the coarse cuts ([`Angles::coarse`])
/// above it, and on coarse patches whose lower edge is split at every cut where a
/// segment crosses that height.
pub(super) fn revolve_chain_above(
    asm: &mut Assembler,
    chain: &[Prof],
    zc: f64,
    ang: &Angles,
    fine_up_to_z: f64,
) -> Result<(), BrepError> {
    let (coarse, cidx) = ang.coarse();
    for p in chain {
        if (p.a.0 - p.b.0).hypot(p.a.1 - p.b.1) < MIN_SEGMENT_MM {
            continue;
        }
        let p = *p;
        let fine = |z: f64| z <= fine_up_to_z + 1e-9;
        let (fa, fb) = (fine(p.a.1), fine(p.b.1));
        let (set, n) = if fa && fb {
            (ang, ang.len())
        } else {
            (&coarse, coarse.len())
        };
        for k in 0..n {
            let (t0, t1) = set.interval(k);
            // The arcs of an end: one per fine cut inside the patch on a fine end.
            let arcs = |r: f64, z: f64, fine_end: bool| -> Vec<Seg> {
                if fine_end && !(fa && fb) {
                    ang.walk(cidx[k], cidx[(k + 1) % cidx.len()])
                        .into_iter()
                        .map(|j| {
                            let (a0, a1) = ang.interval(j);
                            let shift = if a0 < t0 - 1e-9 { TAU } else { 0.0 };
                            arc(O, r, a0 + shift, a1 + shift, z)
                        })
                        .collect()
                } else {
                    vec![arc(O, r, t0, t1, z)]
                }
            };
            let mut boundary = arcs(p.a.0, p.a.1, fa);
            boundary.push(meridian(&p, zc, t1));
            boundary.extend(
                arcs(p.b.0, p.b.1, fb)
                    .into_iter()
                    .rev()
                    .map(|s| s.reversed()),
            );
            boundary.push(meridian(&p, zc, t0).reversed());
            let m = move |th: f64| meridian(&p, zc, th);
            let centre = p.sphere.map(|_| Point3::new(0.0, 0.0, zc));
            let name = if p.sphere.is_some() { "dome" } else { "wall" };
            asm.revolved(
                name,
                &[boundary],
                Point3::new(0.0, 0.0, 0.0),
                (t0, t1),
                &m,
                centre,
                p.out,
            )?;
        }
    }
    Ok(())
}

/// A domed wall as every part's profile draws it: the cylinder of radius `r` from
/// `z_base` up to its junction `zj` with the sphere of radius `rho`, then the sphere on
/// to `end`. An outer wall (`facing_out`) runs upwards with outward normals; an inner
/// wall runs the same meridian downwards, facing the axis.
pub(super) fn domed_wall(
    r: f64,
    z_base: f64,
    zj: f64,
    rho: f64,
    end: (f64, f64),
    facing_out: bool,
) -> [Prof; 2] {
    let cylinder = Prof {
        a: (r, z_base),
        b: (r, zj),
        sphere: None,
        out: 1.0,
    };
    let dome = Prof {
        a: (r, zj),
        b: end,
        sphere: Some(rho),
        out: 1.0,
    };
    if facing_out {
        [cylinder, dome]
    } else {
        let down = |q: Prof| Prof {
            a: q.b,
            b: q.a,
            out: -1.0,
            ..q
        };
        [down(dome), down(cylinder)]
    }
}

/// A vertical wall segment of the (r, z) profile: cylinder of radius r from z0 to z1
/// (or a cone when the radii differ), facing away from the axis if `out` > 0.
pub(super) fn wall(r0: f64, z0: f64, r1: f64, z1: f64, out: f64) -> Prof {
    Prof {
        a: (r0, z0),
        b: (r1, z1),
        sphere: None,
        out,
    }
}
