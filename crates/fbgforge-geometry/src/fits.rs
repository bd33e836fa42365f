//! Fits and fiber passages on exact dimensions: every gap between mating parts and
//! every gap between a fiber and the material it passes, in closed form from the
//! derived profile (radii, heights, slot widths, the fiber's centreline as lines and a
//! circular bend). Nothing here reads a mesh, so no result depends on the meshing
//! tolerance; the meshes are checked against each other separately
//! ([`super::assembly`]); each designed gap is measured again on the written meshes
//! ([`super::gaps`], [`super::meshing`]).
//!
//! A fiber lies in a vertical plane through the module's axis; every revolved surface
//! (walls, domes, the snap bead, slot roofs) cuts that plane in its (r, z) profile, so
//! the gap to it is a distance in that plane. Slot sides, holes and bores are
//! measured across the plane: half their width less the fiber's radius.

use super::design_profile::{DesignProfile, ModuleDims};
use super::gaps::{Between, GapSpec, Meridian, Surface};
use super::part::PartKind;
use crate::profile::module_gratings;
use crate::spec::{err, GratingRole, SpecError};
use serde::Serialize;

type P2 = (f64, f64);

/// A designed gap between two mating parts of the assembled module.
#[derive(Debug, Clone, Serialize)]
pub struct FitGap {
    /// The outer part (the one whose concave wall faces the gap).
    pub outer: PartKind,
    /// The inner part.
    pub inner: PartKind,
    /// Which surfaces, in words.
    pub what: String,
    /// The gap on exact dimensions, mm.
    pub gap_mm: f64,
    /// The spec field that sets it.
    pub field: String,
    /// A press fit (designed touching, gap 0): its meshes are not compared.
    pub press_fit: bool,
    /// The gap between the written meshes, mm (None when the two parts were not
    /// built together, or for a press fit).
    pub meshed_gap_mm: Option<f64>,
    /// Chord tolerance of the outer part's surfaces facing the gap, mm (None as
    /// `meshed_gap_mm`).
    pub surface_tolerance_mm: Option<f64>,
    /// The surfaces the gap lies between (outer's, inner's).
    #[serde(skip)]
    pub surfaces: (Vec<Surface>, Vec<Surface>),
}

/// Every designed gap between mating parts of the module: cap and core (pillar
/// faces, alignment pillars in the grooves, domes, the snap bead under the pillars),
/// core and insert (wall, dome); each with the surfaces it lies between.
pub fn module_fits(md: &ModuleDims) -> Vec<FitGap> {
    let (m, p, pp) = (md.spec, &md.profile, &md.parts);
    let cap_core = "module.cap_core_clearance_mm";
    let core_insert = "module.core_insert_clearance_mm";
    let dome_field = if m.contact.dome_clearance_mm.is_some() {
        "module.contact.dome_clearance_mm"
    } else {
        cap_core
    };
    let cyl = |r: f64| Surface::cylinder(r, -Z_FAR_MM, Z_FAR_MM);
    let sphere = |rho: f64| Surface::sphere(p.dome_center_z_mm, rho);
    let sides = |half: f64, r: (f64, f64)| -> Vec<Surface> {
        p.pillar_angles_rad
            .iter()
            .flat_map(|&a| {
                [-half, half].map(|o| Surface::Side {
                    angle_rad: a,
                    offset_mm: o,
                    r_mm: r,
                })
            })
            .collect()
    };
    let groove = m.pillars.groove_width_mm;
    let mut fits = vec![
        (
            PartKind::Cap,
            PartKind::Core,
            "cap inner wall to core pillar faces",
            p.cap_inner_radius_mm - p.pillar_outer_radius_mm,
            cap_core,
            (
                vec![cyl(p.cap_inner_radius_mm)],
                vec![cyl(p.pillar_outer_radius_mm)],
            ),
        ),
        (
            PartKind::Cap,
            PartKind::Core,
            "cap alignment pillar sides to groove sides",
            (groove - p.cap_pillar_width_mm) / 2.0,
            cap_core,
            (
                sides(
                    p.cap_pillar_width_mm / 2.0,
                    (p.cap_pillar_inner_radius_mm, p.cap_inner_radius_mm),
                ),
                sides(
                    groove / 2.0,
                    (p.groove_bottom_radius_mm, p.pillar_outer_radius_mm),
                ),
            ),
        ),
        (
            PartKind::Cap,
            PartKind::Core,
            "cap alignment pillar faces to groove bottoms",
            p.cap_pillar_inner_radius_mm - p.groove_bottom_radius_mm,
            cap_core,
            (
                vec![cyl(p.cap_pillar_inner_radius_mm)],
                vec![cyl(p.groove_bottom_radius_mm)],
            ),
        ),
        (
            PartKind::Cap,
            PartKind::Core,
            "cap inner dome to core outer dome",
            p.cap_dome_inner_sphere_radius_mm - p.core_dome_outer_sphere_radius_mm,
            dome_field,
            (
                vec![sphere(p.cap_dome_inner_sphere_radius_mm)],
                vec![sphere(p.core_dome_outer_sphere_radius_mm)],
            ),
        ),
    ];
    if let Some(s) = &pp.snap {
        let bead = bead_polyline(md);
        let z_b = pp.pillar_bottom_mm;
        let bottom = (
            (p.core_outer_radius_mm, z_b),
            (p.pillar_outer_radius_mm, z_b),
        );
        let gap = bead
            .windows(2)
            .map(|w| segment_segment(bottom, (w[0], w[1])))
            .fold(f64::INFINITY, f64::min);
        let bead_surfaces: Vec<Surface> =
            bead.windows(2).map(|w| Surface::cone(w[0], w[1])).collect();
        fits.push((
            PartKind::Cap,
            PartKind::Core,
            "snap bead to pillar bottoms",
            gap,
            cap_core,
            (
                bead_surfaces,
                vec![
                    Surface::cone(bottom.0, bottom.1),
                    cyl(p.pillar_outer_radius_mm),
                ],
            ),
        ));
        fits.push((
            PartKind::Cap,
            PartKind::Core,
            "snap bead crest to core wall",
            s.crest_radius_mm - p.core_outer_radius_mm,
            "module.snap.undercut_mm",
            (
                vec![cyl(s.crest_radius_mm)],
                vec![cyl(p.core_outer_radius_mm)],
            ),
        ));
    }
    if !m.inserts.is_empty() {
        fits.push((
            PartKind::Core,
            PartKind::Insert,
            "core inner wall to insert",
            p.core_inner_radius_mm - p.insert_radius_mm,
            core_insert,
            (
                vec![cyl(p.core_inner_radius_mm)],
                vec![cyl(p.insert_radius_mm)],
            ),
        ));
        fits.push((
            PartKind::Core,
            PartKind::Insert,
            "core inner dome to insert dome",
            p.core_dome_inner_sphere_radius_mm - p.insert_sphere_radius_mm,
            core_insert,
            (
                vec![sphere(p.core_dome_inner_sphere_radius_mm)],
                vec![sphere(p.insert_sphere_radius_mm)],
            ),
        ));
    }
    fits.into_iter().map(fit_gap).collect()
}

/// The parts, surfaces in words, gap (mm), field and surfaces (outer's, inner's) of a
/// fit.
type FitRow = (
    PartKind,
    PartKind,
    &'static str,
    f64,
    &'static str,
    (Vec<Surface>, Vec<Surface>),
);

/// A fit as designed, not yet measured on meshes.
fn fit_gap((outer, inner, what, gap, field, surfaces): FitRow) -> FitGap {
    FitGap {
        outer,
        inner,
        what: what.into(),
        gap_mm: gap,
        field: field.into(),
        press_fit: gap <= PRESS_FIT_MM,
        meshed_gap_mm: None,
        surface_tolerance_mm: None,
        surfaces,
    }
}

/// Half the height a surface of revolution is taken to span when it is named by its
/// radius alone (every face on that cylinder belongs to it), mm.
const Z_FAR_MM: f64 = 1.0e4;

/// Every designed gap of the module the meshes must keep: the fits (all but press
/// fits) and the fiber passages around a revolved wall (each pillar's hole, the
/// insert's bore and reference chamber); slots and the rest are planar and meshed
/// exactly.
pub fn module_gap_specs(md: &ModuleDims) -> Vec<GapSpec> {
    let (m, p, pp) = (md.spec, &md.profile, &md.parts);
    let mut out: Vec<GapSpec> = module_fits(md)
        .into_iter()
        .filter(|f| !f.press_fit)
        .map(|f| GapSpec {
            what: f.what,
            field: f.field,
            outer: f.outer,
            outer_surfaces: f.surfaces.0,
            inner: Between::Part {
                kind: f.inner,
                surfaces: f.surfaces.1,
            },
            designed_gap_mm: f.gap_mm,
        })
        .collect();
    let rf = pp.fiber_radius_mm;
    let hole = |axis: (f64, f64), r: f64| Surface::Revolved {
        axis_xy_mm: axis,
        meridian: Meridian::Segment((r, -Z_FAR_MM), (r, Z_FAR_MM)),
    };
    let d = m.pillars.fiber_hole_diameter_mm;
    for (i, &a) in p.pillar_angles_rad.iter().enumerate() {
        let axis = (
            p.fiber_hole_center_radius_mm * a.cos(),
            p.fiber_hole_center_radius_mm * a.sin(),
        );
        out.push(GapSpec {
            what: format!("fiber hole in pillar {i} around the coated fiber"),
            field: "module.pillars.fiber_hole_diameter_mm".into(),
            outer: PartKind::Core,
            outer_surfaces: vec![hole(axis, d / 2.0)],
            inner: Between::Fiber {
                axis_xy_mm: axis,
                radius_mm: rf,
            },
            designed_gap_mm: d / 2.0 - rf,
        });
    }
    if !m.inserts.is_empty() {
        let fiber = Between::Fiber {
            axis_xy_mm: (0.0, 0.0),
            radius_mm: rf,
        };
        let rb = pp.insert_bore_radius_mm;
        out.push(GapSpec {
            what: "insert bore around the reference fiber".into(),
            field: CLEARANCE.into(),
            outer: PartKind::Insert,
            outer_surfaces: vec![hole((0.0, 0.0), rb)],
            inner: fiber.clone(),
            designed_gap_mm: rb - rf,
        });
        if let Some(c) = &pp.reference_chamber {
            out.push(GapSpec {
                what: "reference chamber around the reference grating".into(),
                field: CLEARANCE.into(),
                outer: PartKind::Insert,
                outer_surfaces: vec![hole((0.0, 0.0), c.radius_mm)],
                inner: fiber,
                designed_gap_mm: c.radius_mm - rf,
            });
        }
    }
    // A passage designed narrower than its fiber (a design changed after validation)
    // has no gap to keep: the exact passage check refuses it, naming the field.
    out.retain(|g| g.designed_gap_mm > PRESS_FIT_MM);
    out
}

/// Gaps at or below this are a press fit (designed touching), mm.
pub(crate) const PRESS_FIT_MM: f64 = 1e-9;

/// The bead's (r, z) profile from the lead-in to the retention cone's top (empty
/// without a snap).
fn bead_polyline(md: &ModuleDims) -> Vec<P2> {
    let (p, pp) = (&md.profile, &md.parts);
    let Some(s) = &pp.snap else {
        return Vec::new();
    };
    let r_ci = p.cap_inner_radius_mm;
    vec![
        (r_ci, s.lead_in_z_mm),
        (s.crest_radius_mm, s.crest_bottom_z_mm),
        (s.crest_radius_mm, s.crest_top_z_mm),
        (r_ci, s.retention_top_z_mm),
    ]
}

/// One passage of one fiber, on exact dimensions.
#[derive(Debug, Clone, Serialize)]
pub struct Passage {
    /// The part the passage is in (`plate` for the plate the module stands on).
    pub part: String,
    /// The passage, in words.
    pub passage: String,
    /// Its width across the fiber (hole or bore diameter, slot width), mm; None for a
    /// gap measured along the fiber's path (a slot roof over the bend, the plate).
    pub width_mm: Option<f64>,
    /// Gap between the coated fiber's surface and the material, mm.
    pub surface_gap_mm: f64,
    /// The spec field that sets it.
    pub field: String,
}

/// A fiber's centreline in its vertical plane, as (s, z) with s the distance from the
/// axis along the plane's direction: straight down at s = r0 from `z_top` to the
/// bend's start, a quarter circle of radius `bend` outward, then horizontal at the
/// exit height out to `s_out`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Centreline {
    /// Radius of the vertical run, mm.
    pub r0: f64,
    /// Top of the path (the grating's upper end, or the reference fiber's tip), mm.
    pub z_top: f64,
    /// Where the bend starts, mm.
    pub z_bend: f64,
    /// Bend radius, mm.
    pub bend: f64,
    /// Where the path ends, mm from the axis.
    pub s_out: f64,
}

impl Centreline {
    fn pieces(&self) -> (Seg2, (P2, f64), Seg2) {
        let (r0, zb, rb) = (self.r0, self.z_bend, self.bend);
        (
            ((r0, self.z_top), (r0, zb)),
            ((r0 + rb, zb), rb),
            ((r0 + rb, zb - rb), (self.s_out.max(r0 + rb), zb - rb)),
        )
    }

    /// Distance from a point of the plane, mm (the tests' check of the closed form).
    #[cfg(test)]
    fn distance_to_point(&self, q: P2) -> f64 {
        let (v, (c, r), h) = self.pieces();
        point_segment(q, v)
            .min(point_arc(q, c, r))
            .min(point_segment(q, h))
    }

    /// Distance from a segment of the plane, mm.
    pub(crate) fn distance_to_segment(&self, a: P2, b: P2) -> f64 {
        let (v, (c, r), h) = self.pieces();
        segment_segment((a, b), v)
            .min(segment_arc((a, b), c, r))
            .min(segment_segment((a, b), h))
    }

    /// Distance from a polyline of the plane, mm.
    pub(crate) fn distance_to_polyline(&self, pts: &[P2]) -> f64 {
        pts.windows(2)
            .map(|w| self.distance_to_segment(w[0], w[1]))
            .fold(f64::INFINITY, f64::min)
    }
}

type Seg2 = (P2, P2);

fn sub(a: P2, b: P2) -> P2 {
    (a.0 - b.0, a.1 - b.1)
}
fn dot(a: P2, b: P2) -> f64 {
    a.0 * b.0 + a.1 * b.1
}
fn len(a: P2) -> f64 {
    a.0.hypot(a.1)
}

/// Distance from `q` to segment `s`.
pub(crate) fn point_segment(q: P2, s: Seg2) -> f64 {
    let d = sub(s.1, s.0);
    let l2 = dot(d, d);
    let t = if l2 > 0.0 {
        (dot(sub(q, s.0), d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    len(sub(q, (s.0 .0 + t * d.0, s.0 .1 + t * d.1)))
}

fn cross(a: P2, b: P2) -> f64 {
    a.0 * b.1 - a.1 * b.0
}

/// Distance between two segments (0 when they cross).
pub(crate) fn segment_segment(s: Seg2, u: Seg2) -> f64 {
    let (d1, d2) = (sub(s.1, s.0), sub(u.1, u.0));
    let den = cross(d1, d2);
    if den.abs() > 1e-15 {
        let w = sub(u.0, s.0);
        let t = cross(w, d2) / den;
        let v = cross(w, d1) / den;
        if (0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&v) {
            return 0.0;
        }
    }
    point_segment(s.0, u)
        .min(point_segment(s.1, u))
        .min(point_segment(u.0, s))
        .min(point_segment(u.1, s))
}

/// Whether the direction `d` from a bend's centre lies on the bend: the quarter from
/// pointing at the axis (−s) to pointing down (−z).
fn on_bend(d: P2) -> bool {
    d.0 <= 0.0 && d.1 <= 0.0
}

/// Distance from `q` to the bend (centre `c`, radius `r`).
fn point_arc(q: P2, c: P2, r: f64) -> f64 {
    let d = sub(q, c);
    if on_bend(d) {
        (len(d) - r).abs()
    } else {
        len(sub(q, (c.0 - r, c.1))).min(len(sub(q, (c.0, c.1 - r))))
    }
}

/// Distance from segment `s` to the bend (centre `c`, radius `r`): 0 where it crosses
/// the arc, else the least of its ends to the arc, the arc's ends to it, and the
/// segment's point nearest the centre when that lies towards the arc.
fn segment_arc(s: Seg2, c: P2, r: f64) -> f64 {
    let ends = [(c.0 - r, c.1), (c.0, c.1 - r)];
    let mut best = point_arc(s.0, c, r)
        .min(point_arc(s.1, c, r))
        .min(point_segment(ends[0], s))
        .min(point_segment(ends[1], s));
    let d = sub(s.1, s.0);
    let l2 = dot(d, d);
    if l2 > 0.0 {
        let t = (dot(sub(c, s.0), d) / l2).clamp(0.0, 1.0);
        let foot = (s.0 .0 + t * d.0, s.0 .1 + t * d.1);
        if on_bend(sub(foot, c)) {
            best = best.min((len(sub(foot, c)) - r).abs());
        }
        // Crossings of the segment's line with the circle.
        let f = sub(s.0, c);
        let (a, b, cc) = (l2, 2.0 * dot(f, d), dot(f, f) - r * r);
        let disc = b * b - 4.0 * a * cc;
        if disc >= 0.0 {
            for sign in [-1.0, 1.0] {
                let t = (-b + sign * disc.sqrt()) / (2.0 * a);
                let x = (s.0 .0 + t * d.0, s.0 .1 + t * d.1);
                if (0.0..=1.0).contains(&t) && on_bend(sub(x, c)) {
                    return 0.0;
                }
            }
        }
    }
    best
}

/// One fiber's exact passages.
#[derive(Debug, Clone, Serialize)]
pub struct FiberPassages {
    /// The grating the fiber carries.
    pub grating: String,
    /// Every passage from the grating (or the reference fiber's tip) to the outside.
    pub passages: Vec<Passage>,
}

impl FiberPassages {
    /// The tightest passage.
    pub fn tightest(&self) -> Option<&Passage> {
        self.passages
            .iter()
            .min_by(|a, b| a.surface_gap_mm.total_cmp(&b.surface_gap_mm))
    }
}

/// The field a channel's width and its gaps come from.
const CLEARANCE: &str = "fiber_routing.channel_clearance_mm";

/// One fiber's passages as they are found, along its centreline.
struct Route<'a> {
    md: &'a ModuleDims<'a>,
    line: Centreline,
    passages: Vec<Passage>,
}

impl Route<'_> {
    fn add(&mut self, part: &str, passage: &str, width: Option<f64>, gap: f64, field: &str) {
        self.passages.push(Passage {
            part: part.into(),
            passage: passage.into(),
            width_mm: width,
            surface_gap_mm: gap,
            field: field.into(),
        })
    }

    /// The gap between the fiber's surface and the outline `pts`.
    fn along(&self, pts: &[P2]) -> f64 {
        self.line.distance_to_polyline(pts) - self.md.parts.fiber_radius_mm
    }

    /// A slot of the channel's width in `part`, and its roof over the bend.
    fn slot(&mut self, part: &str, (slot, roof_name): (&str, &str), roof: &[P2]) {
        let (w, rf) = (
            self.md.parts.channel_width_mm,
            self.md.parts.fiber_radius_mm,
        );
        self.add(part, slot, Some(w), w / 2.0 - rf, CLEARANCE);
        let gap = self.along(roof);
        self.add(part, roof_name, None, gap, CLEARANCE);
    }

    /// A strain fiber: its hole in the pillar, the cap's pillar over the bend and the
    /// core wall below the pillars.
    fn strain(&mut self) {
        let (m, p, pp) = (self.md.spec, &self.md.profile, &self.md.parts);
        let rf = pp.fiber_radius_mm;
        let d = m.pillars.fiber_hole_diameter_mm;
        self.add(
            "core",
            "fiber hole in the pillar",
            Some(d),
            d / 2.0 - rf,
            "module.pillars.fiber_hole_diameter_mm",
        );
        let pillar = [
            (p.cap_inner_radius_mm, pp.pillar_bottom_mm),
            (p.cap_pillar_inner_radius_mm, pp.pillar_bottom_mm),
            (p.cap_pillar_inner_radius_mm, p.pillar_top_mm),
        ];
        let gap = self.along(&pillar);
        self.add(
            "cap",
            "cap alignment pillar over the bend",
            None,
            gap,
            "module.pillars.groove_depth_mm",
        );
        let wall = [
            (p.core_outer_radius_mm, 0.0),
            (p.core_outer_radius_mm, pp.pillar_bottom_mm),
        ];
        let gap = self.along(&wall);
        self.add(
            "core",
            "core wall below the pillars",
            None,
            gap,
            "module.pillars.height_mm",
        );
    }

    /// The reference fiber in an insert: its chamber, the bore and the insert's slot.
    fn reference_in_insert(&mut self) {
        let (p, pp) = (&self.md.profile, &self.md.parts);
        let rf = pp.fiber_radius_mm;
        let rb = pp.insert_bore_radius_mm;
        if let Some(c) = &pp.reference_chamber {
            self.add(
                "insert",
                "reference chamber around the grating (free-hanging)",
                Some(2.0 * c.radius_mm),
                c.radius_mm - rf,
                CLEARANCE,
            );
            self.add(
                "insert",
                "reference chamber's top over the fiber's tip",
                None,
                c.span.chamber_top_z_mm - c.span.tip_z_mm,
                "module.core_wall_mm",
            );
        }
        self.add("insert", "insert bore", Some(2.0 * rb), rb - rf, CLEARANCE);
        let bore_top = pp
            .reference_chamber
            .map_or(pp.insert_slot_top_mm, |c| c.span.chamber_bottom_z_mm);
        let roof = [
            (p.insert_radius_mm, pp.insert_slot_top_mm),
            (rb, pp.insert_slot_top_mm),
            (rb, bore_top),
        ];
        self.slot(
            "insert",
            ("insert slot", "insert slot roof over the bend"),
            &roof,
        );
    }

    /// The reference fiber (grating `i`, its tip at `z_top`): in the insert or the
    /// hollow core, then through the core's slot.
    fn reference(&mut self, i: usize, z_top: f64) {
        let (p, pp) = (&self.md.profile, &self.md.parts);
        if self.md.spec.inserts.is_empty() {
            // In the hollow core: the core's inner dome over the tip.
            let dome = p.dome_center_z_mm + p.core_dome_inner_sphere_radius_mm;
            self.add(
                "core",
                "core's inner dome over the fiber's tip",
                None,
                dome - z_top,
                &format!("module.gratings[{i}].tail_mm"),
            );
        } else {
            self.reference_in_insert();
        }
        let r_ci = p.core_inner_radius_mm;
        let roof = [
            (p.core_outer_radius_mm, pp.core_slot_top_mm),
            (r_ci, pp.core_slot_top_mm),
            (r_ci, p.pillar_top_mm),
        ];
        self.slot(
            "core",
            ("core wall slot", "core slot roof over the bend"),
            &roof,
        );
    }

    /// Every fiber's way out: the cap's slot and roof, the snap bead, the plate.
    fn exit(&mut self, bead: &[P2]) {
        let (p, pp) = (&self.md.profile, &self.md.parts);
        let next_up = pp
            .snap
            .as_ref()
            .map_or(pp.pillar_bottom_mm, |s| s.lead_in_z_mm);
        let roof = [
            (p.cap_outer_radius_mm, pp.cap_slot_top_mm),
            (p.cap_inner_radius_mm, pp.cap_slot_top_mm),
            (p.cap_inner_radius_mm, next_up),
        ];
        self.slot("cap", ("cap slot", "cap slot roof over the bend"), &roof);
        if !bead.is_empty() {
            let gap = self.along(bead);
            self.add(
                "cap",
                "snap bead over the bend",
                None,
                gap,
                "module.snap.undercut_mm",
            );
        }
        self.add(
            "plate",
            "plate under the horizontal run",
            None,
            pp.exit_height_mm - pp.fiber_radius_mm,
            "fiber_routing.exit_height_mm",
        );
    }
}

/// Every fiber's passages through the assembled module, on exact dimensions.
pub fn fiber_passages(profile: &DesignProfile) -> Vec<FiberPassages> {
    let Some(md) = &profile.module else {
        return Vec::new();
    };
    let (m, p, pp) = (md.spec, &md.profile, &md.parts);
    let s_out = p.cap_outer_radius_mm + 2.0 * pp.fiber_radius_mm + 0.5;
    let bead = bead_polyline(md);
    let mut out = Vec::new();
    for (i, g) in module_gratings(m, p).iter().enumerate() {
        let strain = g.role == GratingRole::Strain;
        let (r0, z_top) = match (strain, &pp.reference_chamber) {
            (true, _) => (g.radius_mm, g.z_end_mm),
            (false, Some(c)) => (0.0, c.span.tip_z_mm),
            (false, None) => (0.0, g.z_end_mm),
        };
        let mut route = Route {
            md,
            line: Centreline {
                r0,
                z_top,
                z_bend: pp.bend_start_z_mm,
                bend: pp.bend_radius_mm,
                s_out,
            },
            passages: Vec::new(),
        };
        if strain {
            route.strain();
        } else {
            route.reference(i, z_top);
        }
        route.exit(&bead);
        out.push(FiberPassages {
            grating: g.name.clone(),
            passages: route.passages,
        });
    }
    out
}

/// The fits and passages of a module on exact dimensions; an error names the field
/// of the first fit that overlaps or the first passage the coated fiber does not get
/// through.
pub(crate) fn check_exact(
    profile: &DesignProfile,
) -> Result<(Vec<FitGap>, Vec<FiberPassages>), SpecError> {
    let Some(md) = &profile.module else {
        return Ok((Vec::new(), Vec::new()));
    };
    let fits = module_fits(md);
    for f in &fits {
        // (A NaN gap, from a design validation refuses anyway, is refused too.)
        if f.gap_mm.is_nan() || f.gap_mm < -PRESS_FIT_MM {
            return Err(err(
                &f.field,
                format!(
                    "the {} and the {} overlap by {:.4} mm ({}) on exact dimensions",
                    f.outer.name(),
                    f.inner.name(),
                    -f.gap_mm,
                    f.what
                ),
            ));
        }
    }
    let passages = fiber_passages(profile);
    for fp in &passages {
        for q in &fp.passages {
            if q.surface_gap_mm.is_nan() || q.surface_gap_mm < 0.0 {
                return Err(err(
                    &q.field,
                    format!(
                        "the coated fiber of grating `{}` ({} mm) does not pass the {}'s {}{}: it would cut {:.4} mm into it",
                        fp.grating,
                        2.0 * md.parts.fiber_radius_mm,
                        q.part,
                        q.passage,
                        q.width_mm.map_or(String::new(), |w| format!(" ({w:.3} mm wide)")),
                        -q.surface_gap_mm
                    ),
                ));
            }
        }
    }
    Ok((fits, passages))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_distances_are_exact() {
        // Parallel segments 1 apart; crossing segments; a segment beside a segment's end.
        let a = ((0.0, 0.0), (2.0, 0.0));
        assert!((segment_segment(a, ((0.0, 1.0), (2.0, 1.0))) - 1.0).abs() < 1e-15);
        assert_eq!(segment_segment(a, ((1.0, -1.0), (1.0, 1.0))), 0.0);
        assert!((segment_segment(a, ((3.0, 0.0), (3.0, 5.0))) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn the_centreline_measures_points_and_segments_in_closed_form() {
        // Vertical at s = 1 from z = 20 to the bend at z = 10, bend radius 5.
        let c = Centreline {
            r0: 1.0,
            z_top: 20.0,
            z_bend: 10.0,
            bend: 5.0,
            s_out: 30.0,
        };
        // Beside the vertical run.
        assert!((c.distance_to_point((1.4, 15.0)) - 0.4).abs() < 1e-12);
        // At the bend's centre: the radius.
        assert!((c.distance_to_point((6.0, 10.0)) - 5.0).abs() < 1e-12);
        // Outside the bend at 45°: 1 mm beyond the arc.
        let q = (6.0 - 6.0 / 2f64.sqrt(), 10.0 - 6.0 / 2f64.sqrt());
        assert!((c.distance_to_point(q) - 1.0).abs() < 1e-12);
        // Over the horizontal run.
        assert!((c.distance_to_point((20.0, 5.3)) - 0.3).abs() < 1e-12);
        // A roof segment over the horizontal run and one crossing the bend.
        assert!((c.distance_to_segment((8.0, 5.5), (12.0, 5.5)) - 0.5).abs() < 1e-12);
        assert_eq!(c.distance_to_segment((0.0, 6.0), (4.0, 6.0)), 0.0);
        // A corner inside the bend: its distance to the circle.
        let corner = (5.0, 9.0);
        let want = 5.0 - (1.0f64 + 1.0).sqrt();
        assert!((c.distance_to_segment(corner, (5.0, 9.0 + 1e-9)) - want).abs() < 1e-6);
    }
}
