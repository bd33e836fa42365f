//! Solids of the clip-on module: cap (CC), core (PSC) and insert (PSC-solid), with
//! their exact volumes in closed form.
//!
//! Each part is an extruded band z ∈ [0, pillar top] (the cross-section with pillars,
//! grooves and fiber holes) joined to a revolved upper body (cylinder, dome, apex
//! flat or top hole). Every circle is cut at the same angles (the pillar edges, plus
//! extra cuts so no patch spans more than 90°), so the band's top edges are the upper
//! body's bottom edges and the faces share them through the [`Assembler`].
//!
//! Loops and meridians run with the material on their left; the outward side of each
//! face is stated explicitly and checked against the surface normal.

use super::brep::{Assembler, BrepError, Seg};
use crate::profile::ModuleProfile;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use truck_modeling::{Point3, Solid, Vector3};

/// Largest angular span of one face patch, radians.
const MAX_PATCH_RAD: f64 = FRAC_PI_2;
/// Profile segments shorter than this are skipped (e.g. a zero-height cylinder
/// between the pillar top and a junction at the same height), mm.
const MIN_SEGMENT_MM: f64 = 1.0e-6;

fn pt(c: (f64, f64), r: f64, th: f64, z: f64) -> Point3 {
    Point3::new(c.0 + r * th.cos(), c.1 + r * th.sin(), z)
}

const O: (f64, f64) = (0.0, 0.0);

/// Angles (radians, increasing, spanning one turn) where every circle of a part is cut.
#[derive(Debug, Clone)]
struct Angles(Vec<f64>);

impl Angles {
    /// Subdivide the increasing `base` angles so no interval exceeds 90°; returns the
    /// set and the new index of each base angle.
    fn new(base: &[f64]) -> (Self, Vec<usize>) {
        let mut th = Vec::new();
        let mut idx = Vec::new();
        for (i, &a) in base.iter().enumerate() {
            idx.push(th.len());
            let b = if i + 1 < base.len() {
                base[i + 1]
            } else {
                base[0] + TAU
            };
            let n = ((b - a) / MAX_PATCH_RAD).ceil().max(1.0) as usize;
            for k in 0..n {
                th.push(a + (b - a) * k as f64 / n as f64);
            }
        }
        (Angles(th), idx)
    }

    fn len(&self) -> usize {
        self.0.len()
    }

    /// Interval k as (start, end) with end > start.
    fn interval(&self, k: usize) -> (f64, f64) {
        let n = self.len();
        let a = self.0[k % n];
        let b = if k % n + 1 < n {
            self.0[k % n + 1]
        } else {
            self.0[0] + TAU
        };
        (a, b)
    }

    /// Interval indices walking counter-clockwise from angle index `from` to `to`
    /// (a full turn when they are equal).
    fn walk(&self, from: usize, to: usize) -> Vec<usize> {
        let n = self.len();
        let mut out = vec![from % n];
        let mut k = (from + 1) % n;
        while k != to % n {
            out.push(k);
            k = (k + 1) % n;
        }
        out
    }
}

/// An arc of the circle of radius `r` about `c` at height `z` from angle a0 to a1
/// (counter-clockwise if a1 > a0).
fn arc(c: (f64, f64), r: f64, a0: f64, a1: f64, z: f64) -> Seg {
    Seg::Arc(
        pt(c, r, a0, z),
        pt(c, r, 0.5 * (a0 + a1), z),
        pt(c, r, a1, z),
    )
}

/// A cross-section segment, extruded between two heights.
#[derive(Debug, Clone, Copy)]
enum S2 {
    Line((f64, f64), (f64, f64)),
    Arc {
        c: (f64, f64),
        r: f64,
        a0: f64,
        a1: f64,
    },
}

impl S2 {
    fn at(&self, z: f64) -> Seg {
        match *self {
            S2::Line(a, b) => Seg::Line(Point3::new(a.0, a.1, z), Point3::new(b.0, b.1, z)),
            S2::Arc { c, r, a0, a1 } => arc(c, r, a0, a1, z),
        }
    }
    fn start(&self) -> (f64, f64) {
        match *self {
            S2::Line(a, _) => a,
            S2::Arc { c, r, a0, .. } => (c.0 + r * a0.cos(), c.1 + r * a0.sin()),
        }
    }
    fn end(&self) -> (f64, f64) {
        match *self {
            S2::Line(_, b) => b,
            S2::Arc { c, r, a1, .. } => (c.0 + r * a1.cos(), c.1 + r * a1.sin()),
        }
    }
}

fn ring_ccw(ang: &Angles, r: f64, from: usize, to: usize) -> Vec<S2> {
    ang.walk(from, to)
        .into_iter()
        .map(|k| {
            let (a0, a1) = ang.interval(k);
            S2::Arc { c: O, r, a0, a1 }
        })
        .collect()
}

fn ring_cw(ang: &Angles, r: f64, from: usize, to: usize) -> Vec<S2> {
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

fn at(loop2: &[S2], z: f64) -> Vec<Seg> {
    loop2.iter().map(|s| s.at(z)).collect()
}

/// Side faces of the cross-section loops extruded from z0 to z1.
fn band_sides(asm: &mut Assembler, loops: &[Vec<S2>], z0: f64, z1: f64) -> Result<(), BrepError> {
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

/// One meridian of a revolved profile, in the (r, z) half-plane.
#[derive(Debug, Clone, Copy)]
struct Prof {
    a: (f64, f64),
    b: (f64, f64),
    /// Sphere radius for a dome, None for a vertical cylinder wall.
    sphere: Option<f64>,
    /// +1 if the outward normal points away from the axis / sphere centre.
    out: f64,
}

fn meridian(p: &Prof, zc: f64, th: f64) -> Seg {
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
fn revolve_chain(
    asm: &mut Assembler,
    chain: &[Prof],
    zc: f64,
    ang: &Angles,
) -> Result<(), BrepError> {
    revolve_chain_above(asm, chain, zc, ang, f64::INFINITY)
}

impl Angles {
    /// A coarser set of cuts: some of these angles, no interval over 90°. The features
    /// that need every cut (pillars, slots) end below the domes, and the small circles
    /// near an apex would otherwise be cut into arcs too short to mesh.
    fn coarse(&self) -> (Angles, Vec<usize>) {
        let n = self.len();
        let end = self.0[0] + TAU;
        let mut idx = vec![0];
        let mut i = 0;
        while end - self.0[i] > MAX_PATCH_RAD + 1e-12 {
            let mut j = i + 1;
            while j + 1 < n && self.0[j + 1] - self.0[i] <= MAX_PATCH_RAD + 1e-12 {
                j += 1;
            }
            if j >= n {
                break;
            }
            idx.push(j);
            i = j;
        }
        (Angles(idx.iter().map(|&k| self.0[k]).collect()), idx)
    }
}

/// Revolve a chain of profile segments: with every cut of `ang` where both ends of a
/// segment lie at or below `fine_up_to_z`, on the coarse cuts ([`Angles::coarse`])
/// above it, and on coarse patches whose lower edge is split at every cut where a
/// segment crosses that height.
fn revolve_chain_above(
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
fn domed_wall(
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

/// Flat disc of radius r at height z (apex flats, the insert's base).
fn disc(asm: &mut Assembler, ang: &Angles, r: f64, z: f64, up: bool) -> Result<(), BrepError> {
    let l = at(&ring_ccw(ang, r, 0, 0), z);
    let n = if up {
        Vector3::unit_z()
    } else {
        -Vector3::unit_z()
    };
    asm.plane("flat", &[l], n)
}

/// Solid of revolution bounded by a cylinder of radius `r` from `z_base` up to `zj`, a
/// sphere of radius `rho` centred at `zc` above it, cut flat at `z_top`: its volume,
/// mm³ (the volume inside a [`domed_wall`]).
fn capped_cylinder_volume(r: f64, z_base: f64, zj: f64, rho: f64, zc: f64, z_top: f64) -> f64 {
    PI * r * r * (zj - z_base) + zone_volume(rho, zj - zc, z_top - zc)
}

/// Volume of the part of a ball of radius rho between heights h1 < h2 above its
/// centre (a spherical zone), mm³.
pub fn zone_volume(rho: f64, h1: f64, h2: f64) -> f64 {
    PI * (rho * rho * (h2 - h1) - (h2.powi(3) - h1.powi(3)) / 3.0)
}

/// Area of the slice |t| < h of a disc of radius r, mm².
pub fn slice_area(r: f64, h: f64) -> f64 {
    h * (r * r - h * h).sqrt() + r * r * (h / r).asin()
}

fn sphere_z(p: &ModuleProfile, rho: f64, r: f64) -> f64 {
    p.dome_center_z_mm + (rho * rho - r * r).sqrt()
}

/// A solid with its exact volume.
pub struct BuiltSolid {
    /// The B-rep.
    pub solid: Solid,
    /// Exact volume from the closed form, mm³.
    pub exact_volume_mm3: f64,
}

/// The cut angles of one part: `special` angles (pillar and slot edges, any order,
/// any turn) sorted into one increasing set from the first, subdivided so no interval
/// exceeds 90°, with a lookup from a special angle to its index.
struct Cuts {
    ang: Angles,
    base: Vec<f64>,
    idx: Vec<usize>,
}

impl Cuts {
    fn new(special: &[f64]) -> Self {
        let a0 = special[0];
        let mut base: Vec<f64> = special
            .iter()
            .map(|&a| a0 + (a - a0).rem_euclid(TAU))
            .collect();
        base.sort_by(|a, b| a.total_cmp(b));
        base.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        let (ang, idx) = Angles::new(&base);
        Cuts { ang, base, idx }
    }

    /// Index in the subdivided set of a special angle.
    fn at(&self, angle: f64) -> usize {
        let a = self.base[0] + (angle - self.base[0]).rem_euclid(TAU);
        let k = self
            .base
            .iter()
            .position(|&b| (b - a).abs() < 1e-9 || (b - a).abs() > TAU - 1e-9)
            .expect("a special angle of this part");
        self.idx[k]
    }
}

/// A vertical wall segment of the (r, z) profile: cylinder of radius r from z0 to z1
/// (or a cone when the radii differ), facing away from the axis if `out` > 0.
fn wall(r0: f64, z0: f64, r1: f64, z1: f64, out: f64) -> Prof {
    Prof {
        a: (r0, z0),
        b: (r1, z1),
        sphere: None,
        out,
    }
}

/// Flat annular sector between radii r0 < r1 from interval index `from` to `to`
/// (counter-clockwise) at height z; `up` says which way it faces.
fn sector(
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

/// Parts-profile heights and angles the solids need (see [`crate::profile::PartsProfile`]).
pub use crate::profile::PartsProfile;

/// The insert: solid cylinder with a spherical top and an apex flat, an axial bore for
/// the reference fiber, and a slot in its base through which that fiber bends out.
pub fn insert(p: &ModuleProfile, pp: &PartsProfile, part: &str) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new(part);
    let r = p.insert_radius_mm;
    let rb = pp.insert_bore_radius_mm;
    let hw = pp.insert_slot_half_width_mm;
    let th = pp.reference_exit_angle_rad;
    let (bo, bb) = ((hw / r).asin(), (hw / rb).asin());
    let cuts = Cuts::new(&[th - bo, th + bo, th - bb, th + bb]);
    let ang = &cuts.ang;
    let rho = p.insert_sphere_radius_mm;
    let zc = p.dome_center_z_mm;
    let zj = p.insert_junction_z_mm;
    let a = p.apex_flat_radius_mm;
    let hs = pp.insert_slot_top_mm;
    let (io0, io1, ib0, ib1) = (
        cuts.at(th - bo),
        cuts.at(th + bo),
        cuts.at(th - bb),
        cuts.at(th + bb),
    );
    // Keyhole cross-section below the slot roof: the outer circle outside the slot, the
    // slot's sides, the bore's far side.
    let mut key = ring_ccw(ang, r, io1, io0);
    key.push(S2::Line(
        (r * (th - bo).cos(), r * (th - bo).sin()),
        (rb * (th - bb).cos(), rb * (th - bb).sin()),
    ));
    key.extend(ring_cw(ang, rb, ib0, ib1));
    key.push(S2::Line(
        (rb * (th + bb).cos(), rb * (th + bb).sin()),
        (r * (th + bo).cos(), r * (th + bo).sin()),
    ));
    asm.plane("base", &[at(&key, 0.0)], -Vector3::unit_z())?;
    band_sides(&mut asm, std::slice::from_ref(&key), 0.0, hs)?;
    // Slot roof: between the bore's near side and the outer circle's slot arc.
    let mut roof = ring_ccw(ang, r, io0, io1);
    roof.push(S2::Line(
        (r * (th + bo).cos(), r * (th + bo).sin()),
        (rb * (th + bb).cos(), rb * (th + bb).sin()),
    ));
    roof.extend(ring_cw(ang, rb, ib1, ib0));
    roof.push(S2::Line(
        (rb * (th - bb).cos(), rb * (th - bb).sin()),
        (r * (th - bo).cos(), r * (th - bo).sin()),
    ));
    asm.plane("slot roof", &[at(&roof, hs)], -Vector3::unit_z())?;
    // Above the roof: cylinder, dome, apex flat (if the bore leaves one) and the bore.
    let top_r = a.max(rb);
    let z_top = sphere_z(p, rho, top_r);
    let chain = domed_wall(r, hs, zj, rho, (top_r, z_top), true);
    revolve_chain(&mut asm, &chain, zc, ang)?;
    if rb < a - MIN_SEGMENT_MM {
        let l = [
            at(&ring_ccw(ang, a, 0, 0), z_top),
            at(&ring_cw(ang, rb, 0, 0), z_top),
        ];
        asm.plane("apex flat", &l, Vector3::unit_z())?;
    }
    revolve_chain(&mut asm, &[wall(rb, z_top, rb, hs, -1.0)], zc, ang)?;
    let slot_area = slice_area(r, hw) - slice_area(rb, hw);
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: capped_cylinder_volume(r, 0.0, zj, rho, zc, z_top)
            - PI * rb * rb * z_top
            - slot_area * hs,
    })
}

/// The core (PSC): hollow cylinder with a domed top and a top hole; outer pillars from
/// the pillar bottom to the pillar top, each with an axial groove in its outer face and
/// a fiber through-hole; a radial slot in the wall's base for the reference fiber.
pub fn core(
    p: &ModuleProfile,
    pp: &PartsProfile,
    pillar_width_mm: f64,
    fiber_hole_diameter_mm: f64,
    groove_width_mm: f64,
) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new("core");
    let f = CoreFrame::new(
        p,
        pp,
        pillar_width_mm,
        fiber_hole_diameter_mm,
        groove_width_mm,
    );
    f.slotted_base(&mut asm)?;
    f.pillars(&mut asm)?;
    let upper = f.dome(&mut asm)?;
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: f.band_volume_mm3() + upper,
    })
}

/// The core's radii, heights and cut angles, shared by the steps that build it.
struct CoreFrame<'a> {
    p: &'a ModuleProfile,
    cuts: Cuts,
    r_co: f64,
    r_ci: f64,
    r_po: f64,
    r_gb: f64,
    /// Half widths of a pillar and of its groove, mm.
    hw: f64,
    hg: f64,
    /// Fiber hole radius, mm.
    rh: f64,
    r_fh: f64,
    top: f64,
    bottom: f64,
    /// Half angle of a pillar on the core wall.
    beta: f64,
    /// Reference fiber slot: angle, half angle, roof height.
    th: f64,
    phi: f64,
    hs: f64,
}

impl<'a> CoreFrame<'a> {
    /// Read the dimensions and cut every circle at the pillar and slot edges.
    fn new(
        p: &'a ModuleProfile,
        pp: &PartsProfile,
        pillar_width_mm: f64,
        fiber_hole_diameter_mm: f64,
        groove_width_mm: f64,
    ) -> Self {
        let (r_co, r_ci) = (p.core_outer_radius_mm, p.core_inner_radius_mm);
        let (r_po, r_gb) = (p.pillar_outer_radius_mm, p.groove_bottom_radius_mm);
        let (hw, hg) = (pillar_width_mm / 2.0, groove_width_mm / 2.0);
        let beta = (hw / r_co).asin();
        let (th, phi, hs) = (
            pp.reference_exit_angle_rad,
            pp.core_slot_half_angle_rad,
            pp.core_slot_top_mm,
        );
        let mut special: Vec<f64> = p
            .pillar_angles_rad
            .iter()
            .flat_map(|&t| [t - beta, t + beta])
            .collect();
        special.extend([th - phi, th + phi]);
        CoreFrame {
            p,
            cuts: Cuts::new(&special),
            r_co,
            r_ci,
            r_po,
            r_gb,
            hw,
            hg,
            rh: fiber_hole_diameter_mm / 2.0,
            r_fh: p.fiber_hole_center_radius_mm,
            top: p.pillar_top_mm,
            bottom: pp.pillar_bottom_mm,
            beta,
            th,
            phi,
            hs,
        }
    }

    /// Pillar outline from its −t edge to its +t edge on the core wall.
    fn rib(&self, t: f64) -> Vec<S2> {
        let (r_co, r_po, r_gb, hw, hg) = (self.r_co, self.r_po, self.r_gb, self.hw, self.hg);
        let (rh_, th_) = ((t.cos(), t.sin()), (-t.sin(), t.cos()));
        let e = |s: f64, q: f64| (s * rh_.0 + q * th_.0, s * rh_.1 + q * th_.1);
        let s1 = (r_co * r_co - hw * hw).sqrt();
        let s2 = (r_po * r_po - hw * hw).sqrt();
        let s3 = (r_po * r_po - hg * hg).sqrt();
        let s4 = (r_gb * r_gb - hg * hg).sqrt();
        let (aw, ag, gb) = ((hw / r_po).asin(), (hg / r_po).asin(), (hg / r_gb).asin());
        vec![
            S2::Line(e(s1, -hw), e(s2, -hw)),
            S2::Arc {
                c: O,
                r: r_po,
                a0: t - aw,
                a1: t - ag,
            },
            S2::Line(e(s3, -hg), e(s4, -hg)),
            S2::Arc {
                c: O,
                r: r_gb,
                a0: t - gb,
                a1: t + gb,
            },
            S2::Line(e(s4, hg), e(s3, hg)),
            S2::Arc {
                c: O,
                r: r_po,
                a0: t + ag,
                a1: t + aw,
            },
            S2::Line(e(s2, hw), e(s1, hw)),
        ]
    }

    /// The fiber through-hole of the pillar at angle t, as four quarter arcs.
    fn hole(&self, t: f64) -> Vec<S2> {
        let c = (self.r_fh * t.cos(), self.r_fh * t.sin());
        (0..4)
            .map(|k| S2::Arc {
                c,
                r: self.rh,
                a0: t - k as f64 * FRAC_PI_2,
                a1: t - (k + 1) as f64 * FRAC_PI_2,
            })
            .collect()
    }

    /// Base band (the wall with the reference fiber's slot), then the plain wall up to
    /// the pillar bottoms (outside) and the pillar top (inside).
    fn slotted_base(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (r_co, r_ci, th, phi, hs) = (self.r_co, self.r_ci, self.th, self.phi, self.hs);
        let ang = &self.cuts.ang;
        let (s0, s1) = (self.cuts.at(th - phi), self.cuts.at(th + phi));
        let radial = |a: f64, r0: f64, r1: f64| {
            S2::Line((r0 * a.cos(), r0 * a.sin()), (r1 * a.cos(), r1 * a.sin()))
        };
        let mut c_loop = ring_ccw(ang, r_co, s1, s0);
        c_loop.push(radial(th - phi, r_co, r_ci));
        c_loop.extend(ring_cw(ang, r_ci, s0, s1));
        c_loop.push(radial(th + phi, r_ci, r_co));
        asm.plane("base", &[at(&c_loop, 0.0)], -Vector3::unit_z())?;
        band_sides(asm, std::slice::from_ref(&c_loop), 0.0, hs)?;
        sector(asm, ang, (r_ci, r_co), (s0, s1), hs, false)?;
        band_sides(asm, &[ring_ccw(ang, r_co, 0, 0)], hs, self.bottom)?;
        band_sides(asm, &[ring_cw(ang, r_ci, 0, 0)], hs, self.top)
    }

    /// Pillars: sides and holes, then each one's bottom and top faces.
    fn pillars(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (ang, angles) = (&self.cuts.ang, &self.p.pillar_angles_rad);
        let (bottom, top) = (self.bottom, self.top);
        let n = angles.len();
        let pillar_edges: Vec<(usize, usize)> = angles
            .iter()
            .map(|&t| (self.cuts.at(t - self.beta), self.cuts.at(t + self.beta)))
            .collect();
        let mut outer = Vec::new();
        for i in 0..n {
            outer.extend(self.rib(angles[i]));
            outer.extend(ring_ccw(
                ang,
                self.r_co,
                pillar_edges[i].1,
                pillar_edges[(i + 1) % n].0,
            ));
        }
        let holes: Vec<Vec<S2>> = angles.iter().map(|&t| self.hole(t)).collect();
        let mut loops = vec![outer];
        loops.extend(holes.iter().cloned());
        band_sides(asm, &loops, bottom, top)?;
        for i in 0..n {
            let mut l = self.rib(angles[i]);
            l.extend(ring_cw(
                ang,
                self.r_co,
                pillar_edges[i].1,
                pillar_edges[i].0,
            ));
            asm.plane(
                "pillar bottom",
                &[at(&l, bottom), at(&holes[i], bottom)],
                -Vector3::unit_z(),
            )?;
            asm.plane(
                "pillar top",
                &[at(&l, top), at(&holes[i], top)],
                Vector3::unit_z(),
            )?;
        }
        Ok(())
    }

    /// The revolved body above the pillar top (walls, domes, top hole); its volume, mm³.
    fn dome(&self, asm: &mut Assembler) -> Result<f64, BrepError> {
        let (p, top) = (self.p, self.top);
        let zc = p.dome_center_z_mm;
        let tr = p.top_hole_radius_mm;
        let (rs_o, rs_i) = (
            p.core_dome_outer_sphere_radius_mm,
            p.core_dome_inner_sphere_radius_mm,
        );
        let (z_oj, z_ij) = (p.core_outer_junction_z_mm, p.core_inner_junction_z_mm);
        let (z_oh, z_ih) = (sphere_z(p, rs_o, tr), sphere_z(p, rs_i, tr));
        let [outer_wall, outer_dome] = domed_wall(self.r_co, top, z_oj, rs_o, (tr, z_oh), true);
        let [inner_dome, inner_wall] = domed_wall(self.r_ci, top, z_ij, rs_i, (tr, z_ih), false);
        let top_hole = Prof {
            a: (tr, z_oh),
            b: (tr, z_ih),
            sphere: None,
            out: -1.0,
        };
        let chain = [outer_wall, outer_dome, top_hole, inner_dome, inner_wall];
        revolve_chain_above(asm, &chain, zc, &self.cuts.ang, top)?;
        Ok(capped_cylinder_volume(self.r_co, top, z_oj, rs_o, zc, z_oh)
            - capped_cylinder_volume(self.r_ci, top, z_ij, rs_i, zc, z_ih)
            - PI * tr * tr * (z_oh - z_ih))
    }

    /// Exact volume of the band z ∈ [0, pillar top]: wall and pillars less holes and slot.
    fn band_volume_mm3(&self) -> f64 {
        let (r_co, r_ci, r_po, r_gb, hw, hg) =
            (self.r_co, self.r_ci, self.r_po, self.r_gb, self.hw, self.hg);
        let (top, bottom, rh) = (self.top, self.bottom, self.rh);
        let n = self.p.pillar_angles_rad.len();
        let rib_area = slice_area(r_po, hw)
            - slice_area(r_co, hw)
            - (slice_area(r_po, hg) - slice_area(r_gb, hg));
        top * PI * (r_co * r_co - r_ci * r_ci)
            + (top - bottom) * n as f64 * (rib_area - PI * rh * rh)
            - self.hs * self.phi * (r_co * r_co - r_ci * r_ci)
    }
}

/// Volume swept about the axis by the region between radius `r_out` and a chain of
/// straight (r, z) segments inside it, mm³ (Pappus, segment by segment).
fn ring_volume(r_out: f64, chain: &[(f64, f64)]) -> f64 {
    chain
        .windows(2)
        .map(|w| {
            let ((r1, z1), (r2, z2)) = (w[0], w[1]);
            PI * (z2 - z1) * (r_out * r_out - (r1 * r1 + r1 * r2 + r2 * r2) / 3.0)
        })
        .sum()
}

/// The cap (CC): hollow cylinder with a domed top and apex flats; inner alignment
/// pillars from the core's pillar bottom up, fitting the core's grooves; the snap bead
/// ring just below them; and a radial slot open to the base for every fiber.
pub fn cap(p: &ModuleProfile, pp: &PartsProfile) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new("cap");
    let f = CapFrame::new(p, pp);
    f.slotted_base(&mut asm)?;
    let inner_chain = f.inner_wall(&mut asm, pp)?;
    f.pillars(&mut asm)?;
    let upper = f.dome(&mut asm)?;
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: f.band_volume_mm3(&inner_chain) + upper,
    })
}

/// The cap's radii, heights, slots and cut angles, shared by the steps that build it.
struct CapFrame<'a> {
    p: &'a ModuleProfile,
    cuts: Cuts,
    r_o: f64,
    r_ci: f64,
    r_pi: f64,
    /// Half width of an alignment pillar, mm.
    hc: f64,
    top: f64,
    bottom: f64,
    /// Half angle of an alignment pillar on the inner wall.
    beta: f64,
    /// Slot half angle and roof height.
    phi: f64,
    hs: f64,
    /// Slot angles: one per pillar, then the reference fiber's.
    slots: Vec<f64>,
}

impl<'a> CapFrame<'a> {
    /// Read the dimensions and cut every circle at the pillar and slot edges.
    fn new(p: &'a ModuleProfile, pp: &PartsProfile) -> Self {
        let hc = p.cap_pillar_width_mm / 2.0;
        let r_ci = p.cap_inner_radius_mm;
        let beta = (hc / r_ci).asin();
        let phi = pp.cap_slot_half_angle_rad;
        let mut slots: Vec<f64> = p.pillar_angles_rad.clone();
        slots.push(pp.reference_exit_angle_rad);
        let mut special: Vec<f64> = p
            .pillar_angles_rad
            .iter()
            .flat_map(|&t| [t - beta, t + beta])
            .collect();
        special.extend(slots.iter().flat_map(|&t| [t - phi, t + phi]));
        CapFrame {
            p,
            cuts: Cuts::new(&special),
            r_o: p.cap_outer_radius_mm,
            r_ci,
            r_pi: p.cap_pillar_inner_radius_mm,
            hc,
            top: p.pillar_top_mm,
            bottom: pp.pillar_bottom_mm,
            beta,
            phi,
            hs: pp.cap_slot_top_mm,
            slots,
        }
    }

    /// Fingers between the slots from the base to the slot roofs, the slot roofs, and
    /// the outer wall above the slots.
    fn slotted_base(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (ang, r_o, r_ci, hs) = (&self.cuts.ang, self.r_o, self.r_ci, self.hs);
        // Slots as index ranges, sorted by angle; the fingers lie between them.
        let mut slot_idx: Vec<(usize, usize)> = self
            .slots
            .iter()
            .map(|&t| (self.cuts.at(t - self.phi), self.cuts.at(t + self.phi)))
            .collect();
        slot_idx.sort();
        let radial = |k: usize, r0: f64, r1: f64| {
            let a = ang.interval(k).0;
            S2::Line((r0 * a.cos(), r0 * a.sin()), (r1 * a.cos(), r1 * a.sin()))
        };
        let mut fingers = Vec::new();
        for j in 0..slot_idx.len() {
            let (from, to) = (slot_idx[j].1, slot_idx[(j + 1) % slot_idx.len()].0);
            let mut l = ring_ccw(ang, r_o, from, to);
            l.push(radial(to, r_o, r_ci));
            l.extend(ring_cw(ang, r_ci, to, from));
            l.push(radial(from, r_ci, r_o));
            fingers.push(l);
        }
        let bottoms: Vec<Vec<Seg>> = fingers.iter().map(|l| at(l, 0.0)).collect();
        for b in &bottoms {
            asm.plane("base", std::slice::from_ref(b), -Vector3::unit_z())?;
        }
        band_sides(asm, &fingers, 0.0, hs)?;
        for &(a, b) in &slot_idx {
            sector(asm, ang, (r_ci, r_o), (a, b), hs, false)?;
        }
        band_sides(asm, &[ring_ccw(ang, r_o, 0, 0)], hs, self.top)
    }

    /// Inner wall from the slot roofs to the pillar bottoms, with the snap bead; its
    /// (r, z) chain, for the volume.
    fn inner_wall(
        &self,
        asm: &mut Assembler,
        pp: &PartsProfile,
    ) -> Result<Vec<(f64, f64)>, BrepError> {
        let r_ci = self.r_ci;
        let mut inner_chain = vec![(r_ci, self.hs)];
        if let Some(s) = &pp.snap {
            let rc = s.crest_radius_mm;
            inner_chain.extend([
                (r_ci, s.lead_in_z_mm),
                (rc, s.crest_bottom_z_mm),
                (rc, s.crest_top_z_mm),
                (r_ci, s.retention_top_z_mm),
            ]);
        }
        inner_chain.push((r_ci, self.bottom));
        let profs: Vec<Prof> = inner_chain
            .windows(2)
            .map(|w| wall(w[0].0, w[0].1, w[1].0, w[1].1, -1.0))
            .collect();
        revolve_chain(asm, &profs, self.p.dome_center_z_mm, &self.cuts.ang)?;
        Ok(inner_chain)
    }

    /// Alignment pillar outline at angle t, from its +t edge to its −t edge.
    fn rib(&self, t: f64) -> Vec<S2> {
        let (r_ci, r_pi, hc) = (self.r_ci, self.r_pi, self.hc);
        let (rh_, th_) = ((t.cos(), t.sin()), (-t.sin(), t.cos()));
        let e = |s: f64, q: f64| (s * rh_.0 + q * th_.0, s * rh_.1 + q * th_.1);
        let s1 = (r_ci * r_ci - hc * hc).sqrt();
        let s2 = (r_pi * r_pi - hc * hc).sqrt();
        let b2 = (hc / r_pi).asin();
        vec![
            S2::Line(e(s1, hc), e(s2, hc)),
            S2::Arc {
                c: O,
                r: r_pi,
                a0: t + b2,
                a1: t - b2,
            },
            S2::Line(e(s2, -hc), e(s1, -hc)),
        ]
    }

    /// Alignment pillars from the pillar bottoms to the pillar top.
    fn pillars(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (ang, angles) = (&self.cuts.ang, &self.p.pillar_angles_rad);
        let (r_ci, bottom, top) = (self.r_ci, self.bottom, self.top);
        let n = angles.len();
        let rib_idx: Vec<(usize, usize)> = angles
            .iter()
            .map(|&t| (self.cuts.at(t - self.beta), self.cuts.at(t + self.beta)))
            .collect();
        let mut inner = Vec::new();
        for i in (0..n).rev() {
            inner.extend(self.rib(angles[i]));
            inner.extend(ring_cw(ang, r_ci, rib_idx[i].0, rib_idx[(i + n - 1) % n].1));
        }
        band_sides(asm, &[inner], bottom, top)?;
        for (&t, &(from, to)) in angles.iter().zip(&rib_idx) {
            let mut l = self.rib(t);
            l.extend(ring_ccw(ang, r_ci, from, to));
            asm.plane("pillar bottom", &[at(&l, bottom)], -Vector3::unit_z())?;
            asm.plane("pillar top", &[at(&l, top)], Vector3::unit_z())?;
        }
        Ok(())
    }

    /// The revolved body above the pillar top (walls, domes, apex flats); its volume, mm³.
    fn dome(&self, asm: &mut Assembler) -> Result<f64, BrepError> {
        let (p, top, ang) = (self.p, self.top, &self.cuts.ang);
        let zc = p.dome_center_z_mm;
        let a = p.apex_flat_radius_mm;
        let (rs_o, rs_i) = (
            p.cap_dome_outer_sphere_radius_mm,
            p.cap_dome_inner_sphere_radius_mm,
        );
        let (z_oj, z_ij) = (p.cap_outer_junction_z_mm, p.cap_inner_junction_z_mm);
        let (z_oa, z_ia) = (sphere_z(p, rs_o, a), sphere_z(p, rs_i, a));
        let outer_chain = domed_wall(self.r_o, top, z_oj, rs_o, (a, z_oa), true);
        let inner_dome = domed_wall(self.r_ci, top, z_ij, rs_i, (a, z_ia), false);
        revolve_chain_above(asm, &outer_chain, zc, ang, top)?;
        revolve_chain_above(asm, &inner_dome, zc, ang, top)?;
        let coarse = ang.coarse().0;
        disc(asm, &coarse, a, z_oa, true)?;
        disc(asm, &coarse, a, z_ia, false)?;
        Ok(capped_cylinder_volume(self.r_o, top, z_oj, rs_o, zc, z_oa)
            - capped_cylinder_volume(self.r_ci, top, z_ij, rs_i, zc, z_ia))
    }

    /// Exact volume of the band z ∈ [0, pillar top]: wall and pillars less the slots,
    /// plus the snap bead swept along `inner_chain`.
    fn band_volume_mm3(&self, inner_chain: &[(f64, f64)]) -> f64 {
        let (r_o, r_ci, phi) = (self.r_o, self.r_ci, self.phi);
        let n = self.p.pillar_angles_rad.len();
        let rib_area = slice_area(r_ci, self.hc) - slice_area(self.r_pi, self.hc);
        self.top * PI * (r_o * r_o - r_ci * r_ci) + (self.top - self.bottom) * n as f64 * rib_area
            - self.hs * self.slots.len() as f64 * phi * (r_o * r_o - r_ci * r_ci)
            + ring_volume(r_ci, inner_chain)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_split_long_intervals_and_keep_the_base_angles() {
        // Three pillars: gaps of ~110° must be split, the 10° pillar spans kept.
        let w = 5f64.to_radians();
        let base: Vec<f64> = (0..3)
            .flat_map(|i| {
                let t = i as f64 * TAU / 3.0;
                [t - w, t + w]
            })
            .collect();
        let (ang, idx) = Angles::new(&base);
        assert_eq!(ang.len(), 9);
        for (k, &i) in idx.iter().enumerate() {
            assert!((ang.0[i] - base[k]).abs() < 1e-15);
        }
        let total: f64 = (0..ang.len())
            .map(|k| ang.interval(k).1 - ang.interval(k).0)
            .sum();
        assert!((total - TAU).abs() < 1e-12);
        assert!(
            (0..ang.len()).all(|k| ang.interval(k).1 - ang.interval(k).0 <= MAX_PATCH_RAD + 1e-12)
        );
        // A walk from a pillar's end to the next pillar's start covers the gap only.
        let gap: Vec<usize> = ang.walk(idx[1], idx[2]);
        let span: f64 = gap
            .iter()
            .map(|&k| ang.interval(k).1 - ang.interval(k).0)
            .sum();
        assert!((span - (TAU / 3.0 - 2.0 * w)).abs() < 1e-12);
        assert_eq!(ang.walk(0, 0).len(), ang.len());
    }
}
