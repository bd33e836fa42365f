//! The module assembled in software: the parts in their common frame (every part is
//! built coaxial, standing on z = 0, which is how they assemble), each fiber's
//! centreline traced from its grating to the outside through them, and the check that
//! no two parts overlap.
//!
//! Both work on the checked triangle meshes: a mesh is the printed surface to within
//! its chord tolerance, and a triangle test needs no B-rep boolean (which truck cannot
//! do reliably, reference §4).

use super::design_profile::DesignProfile;
use super::mesh::TriMesh;
use super::part::PartKind;
use super::registry::first_of_each_kind;
use super::BuiltPart;
use crate::profile::{module_gratings, PartsProfile};
use crate::spec::{Design, GratingRole};
use serde::Serialize;

use super::triangle::{add_scaled, closest_on_triangle, cross, dot, norm, sub, P3};

/// A mesh prepared for point queries: triangles with their bounding boxes.
pub struct Solid<'a> {
    /// Part name.
    pub name: &'a str,
    mesh: &'a TriMesh,
    boxes: Vec<(P3, P3)>,
}

impl<'a> Solid<'a> {
    /// Prepare a part's mesh.
    pub fn new(name: &'a str, mesh: &'a TriMesh) -> Self {
        let boxes = mesh
            .triangles
            .iter()
            .map(|t| {
                let v = t.map(|i| mesh.positions[i as usize]);
                let lo = [0, 1, 2].map(|k| v[0][k].min(v[1][k]).min(v[2][k]));
                let hi = [0, 1, 2].map(|k| v[0][k].max(v[1][k]).max(v[2][k]));
                (lo, hi)
            })
            .collect();
        Solid { name, mesh, boxes }
    }

    fn tri(&self, k: usize) -> [P3; 3] {
        self.mesh.triangles[k].map(|i| self.mesh.positions[i as usize])
    }

    /// Distance from `p` to the surface, if it is below `within` (else None;
    /// `f64::INFINITY` gives the distance to the nearest triangle).
    pub fn distance_within(&self, p: P3, within: f64) -> Option<f64> {
        let mut best: Option<f64> = None;
        for (k, (lo, hi)) in self.boxes.iter().enumerate() {
            let lim = best.unwrap_or(within);
            if (0..3).any(|i| p[i] < lo[i] - lim || p[i] > hi[i] + lim) {
                continue;
            }
            let [a, b, c] = self.tri(k);
            let d = norm(sub(p, closest_on_triangle(p, a, b, c)));
            if d < lim {
                best = Some(d);
            }
        }
        best
    }

    /// Whether `p` lies inside the closed mesh (crossings of a ray, Möller–Trumbore).
    pub fn contains(&self, p: P3) -> bool {
        // An oblique direction: no mesh edge or face of these parts is parallel to it.
        let d = [0.573_412, 0.577_931, 0.580_744];
        let mut crossings = 0;
        for k in 0..self.mesh.triangles.len() {
            let [a, b, c] = self.tri(k);
            let (e1, e2) = (sub(b, a), sub(c, a));
            let h = cross(d, e2);
            let det = dot(e1, h);
            if det.abs() < 1e-14 {
                continue;
            }
            let s = sub(p, a);
            let u = dot(s, h) / det;
            if !(0.0..=1.0).contains(&u) {
                continue;
            }
            let q = cross(s, e1);
            let v = dot(d, q) / det;
            if v < 0.0 || u + v > 1.0 {
                continue;
            }
            if dot(e2, q) / det > 0.0 {
                crossings += 1;
            }
        }
        crossings % 2 == 1
    }
}

/// One fiber's way out, as built and as traced.
#[derive(Debug, Clone, Serialize)]
pub struct FiberTrace {
    /// Grating the fiber carries.
    pub grating: String,
    /// Angle of the vertical plane the fiber leaves in, degrees from +x.
    pub exit_angle_deg: f64,
    /// Radius of its exit bend, mm.
    pub bend_radius_mm: f64,
    /// Smallest radius of curvature measured along the sampled centreline, mm.
    pub min_measured_bend_radius_mm: f64,
    /// Smallest gap between the coated fiber's surface and any part's mesh between
    /// the grating (the reference fiber's tip) and the outside: the centreline's
    /// distance less the fiber's radius, mm. The mesh's chords may take up to its
    /// tolerance off it.
    pub min_surface_gap_mm: f64,
    /// The part nearest the centreline at that point.
    pub nearest_part: String,
    /// The same gap on exact dimensions: the tightest of `passages`, mm.
    pub min_exact_surface_gap_mm: f64,
    /// Every passage of the fiber on exact dimensions (hole, slots, roofs, bore,
    /// chamber, plate), with the field that sets it.
    pub passages: Vec<super::fits::Passage>,
    /// Where the centreline leaves the module's outer radius (x, y, z), mm.
    pub exit_point_mm: P3,
    /// Centreline samples (x, y, z), mm: from the grating's centre to the outside.
    #[serde(skip)]
    pub points: Vec<P3>,
}

/// Why a fiber has no way out.
#[derive(Debug, thiserror::Error)]
pub enum RouteError {
    /// The centreline runs through (or too close to) a part.
    #[error("fiber of grating `{grating}` is blocked by the {part} at ({:.3}, {:.3}, {:.3}) mm: {detail}", at[0], at[1], at[2])]
    Blocked {
        /// Grating name.
        grating: String,
        /// Part in the way.
        part: String,
        /// Where.
        at: P3,
        /// What was found.
        detail: String,
    },
    /// The centreline bends tighter than the fiber allows.
    #[error("fiber of grating `{grating}` bends at a radius of {radius_mm:.3} mm, below its minimum {min_mm} mm (fiber_routing.min_bend_radius_mm)")]
    Bend {
        /// Grating name.
        grating: String,
        /// Radius found, mm.
        radius_mm: f64,
        /// Minimum, mm.
        min_mm: f64,
    },
}

/// The centreline of a fiber leaving at angle `theta` from a vertical run at radius
/// `r0`, from height `z_from` down to the bend start, around the bend and out to
/// radius `r_out`, sampled every `step` mm.
pub fn centreline(
    r0: f64,
    theta: f64,
    z_from: f64,
    pp: &PartsProfile,
    r_out: f64,
    step: f64,
) -> Vec<P3> {
    let (c, s) = (theta.cos(), theta.sin());
    let at = |r: f64, z: f64| [r * c, r * s, z];
    let mut pts = Vec::new();
    let z_b = pp.bend_start_z_mm;
    let rb = pp.bend_radius_mm;
    let n = ((z_from - z_b) / step).ceil().max(1.0) as usize;
    for i in 0..n {
        pts.push(at(r0, z_from - (z_from - z_b) * i as f64 / n as f64));
    }
    let n = (rb * std::f64::consts::FRAC_PI_2 / step).ceil() as usize;
    for i in 0..=n {
        let phi = std::f64::consts::FRAC_PI_2 * i as f64 / n as f64;
        pts.push(at(r0 + rb * (1.0 - phi.cos()), z_b - rb * phi.sin()));
    }
    // The horizontal run, if the bend has not already carried the fiber past r_out.
    let r1 = r0 + rb;
    if r_out > r1 {
        let n = ((r_out - r1) / step).ceil().max(1.0) as usize;
        for i in 1..=n {
            pts.push(at(
                r1 + (r_out - r1) * i as f64 / n as f64,
                pp.exit_height_mm,
            ));
        }
    }
    pts
}

/// Smallest circumradius of consecutive sample triples (∞ on a straight run), mm.
pub fn min_bend_radius_mm(pts: &[P3]) -> f64 {
    pts.windows(3)
        .map(|w| {
            let (a, b, c) = (w[0], w[1], w[2]);
            let area2 = norm(cross(sub(b, a), sub(c, a)));
            if area2 < 1e-12 {
                f64::INFINITY
            } else {
                norm(sub(b, a)) * norm(sub(c, b)) * norm(sub(c, a)) / (2.0 * area2)
            }
        })
        .fold(f64::INFINITY, f64::min)
}

/// Trace every module fiber through `parts` (the assembled cap, core and inserts):
/// from the grating's centre down its hole (or the axis), around its exit bend and out
/// past the cap. Errors if a centreline comes closer to a surface than the coated
/// fiber's radius (less the mesh's chord tolerance), starts inside material, dips
/// below the plate, or bends tighter than the minimum.
pub fn trace_fibers(design: &Design, parts: &[BuiltPart]) -> Result<Vec<FiberTrace>, RouteError> {
    trace_fibers_for(&DesignProfile::new(design), parts)
}

/// [`trace_fibers`] from dimensions already derived.
pub(crate) fn trace_fibers_for(
    profile: &DesignProfile,
    parts: &[BuiltPart],
) -> Result<Vec<FiberTrace>, RouteError> {
    let Some(md) = &profile.module else {
        return Ok(Vec::new());
    };
    let (m, p, pp) = (md.spec, &md.profile, &md.parts);
    // Parts of one kind share a solid: the first stands for all.
    let solids: Vec<Solid> = first_of_each_kind(parts, |b| b.kind)
        .into_iter()
        .map(|b| Solid::new(&b.name, &b.mesh))
        .collect();
    let tol = parts
        .iter()
        .map(|b| b.mesh_tolerance_mm)
        .fold(0.0, f64::max);
    let need = pp.fiber_radius_mm - tol;
    let exact = super::fits::fiber_passages(profile);
    let r_out = p.cap_outer_radius_mm + 2.0 * pp.fiber_radius_mm + 0.5;
    let step = pp.fiber_radius_mm / 2.0;
    let mut out = Vec::new();
    for g in module_gratings(m, p) {
        let (r0, theta) = match g.role {
            GratingRole::Strain => (g.radius_mm, g.angle_rad),
            GratingRole::TemperatureReference => (0.0, pp.reference_exit_angle_rad),
        };
        let z_mid = 0.5 * (g.z_start_mm + g.z_end_mm);
        // The reference fiber is traced from its tip, so its tail is checked too.
        let z_from = match (g.role, &pp.reference_chamber) {
            (GratingRole::TemperatureReference, Some(c)) => c.span.tip_z_mm,
            _ => z_mid,
        };
        let pts = centreline(r0, theta, z_from, pp, r_out, step);
        let centre = [r0 * theta.cos(), r0 * theta.sin(), z_mid];
        let blocked = |part: &str, at: P3, detail: String| RouteError::Blocked {
            grating: g.name.clone(),
            part: part.to_string(),
            at,
            detail,
        };
        if let Some(s) = solids.iter().find(|s| s.contains(centre)) {
            return Err(blocked(
                s.name,
                centre,
                "the grating lies inside the part".into(),
            ));
        }
        let mut min_clear = f64::INFINITY;
        let mut nearest = String::new();
        for &q in &pts {
            if q[2] < pp.fiber_radius_mm - 1e-9 {
                return Err(blocked("plate", q, "the fiber runs below the base".into()));
            }
            for s in &solids {
                if let Some(d) = s.distance_within(q, min_clear.min(10.0)) {
                    if d < min_clear {
                        min_clear = d;
                        nearest = s.name.to_string();
                    }
                    if d < need {
                        return Err(blocked(
                            s.name,
                            q,
                            format!(
                                "the centreline passes {d:.4} mm from its surface; the coated fiber needs {:.4} mm",
                                pp.fiber_radius_mm
                            ),
                        ));
                    }
                }
            }
        }
        let measured = min_bend_radius_mm(&pts);
        if measured < pp.bend_radius_mm * (1.0 - 1e-6) {
            return Err(RouteError::Bend {
                grating: g.name.clone(),
                radius_mm: measured,
                min_mm: profile.design.fiber_routing.min_bend_radius_mm,
            });
        }
        let exit = pts
            .iter()
            .copied()
            .find(|q| q[0].hypot(q[1]) >= p.cap_outer_radius_mm)
            .unwrap_or(pts[pts.len() - 1]);
        let passages: Vec<super::fits::Passage> = exact
            .iter()
            .find(|f| f.grating == g.name)
            .map(|f| f.passages.clone())
            .unwrap_or_default();
        out.push(FiberTrace {
            grating: g.name.clone(),
            exit_angle_deg: theta.to_degrees(),
            bend_radius_mm: pp.bend_radius_mm,
            min_measured_bend_radius_mm: measured,
            min_surface_gap_mm: min_clear - pp.fiber_radius_mm,
            nearest_part: nearest,
            min_exact_surface_gap_mm: passages
                .iter()
                .map(|q| q.surface_gap_mm)
                .fold(f64::INFINITY, f64::min),
            passages,
            exit_point_mm: exit,
            points: pts,
        });
    }
    Ok(out)
}

/// Whether triangles t and u overlap (separating-axis test on the two normals and the
/// nine edge-pair directions); touching within `eps` counts as apart.
fn triangles_overlap(t: [P3; 3], u: [P3; 3], eps: f64) -> bool {
    let et = [sub(t[1], t[0]), sub(t[2], t[1]), sub(t[0], t[2])];
    let eu = [sub(u[1], u[0]), sub(u[2], u[1]), sub(u[0], u[2])];
    let mut axes = vec![cross(et[0], et[1]), cross(eu[0], eu[1])];
    for a in et {
        for b in eu {
            axes.push(cross(a, b));
        }
    }
    for ax in axes {
        let l = norm(ax);
        if l < 1e-12 {
            continue;
        }
        let ax = [ax[0] / l, ax[1] / l, ax[2] / l];
        let pt = t.map(|v| dot(v, ax));
        let pu = u.map(|v| dot(v, ax));
        let (t0, t1) = (pt[0].min(pt[1]).min(pt[2]), pt[0].max(pt[1]).max(pt[2]));
        let (u0, u1) = (pu[0].min(pu[1]).min(pu[2]), pu[0].max(pu[1]).max(pu[2]));
        if t1 < u0 + eps || u1 < t0 + eps {
            return false;
        }
    }
    true
}

/// Where two assembled parts overlap.
#[derive(Debug, thiserror::Error)]
#[error("the {a} and the {b} overlap near ({:.3}, {:.3}, {:.3}) mm ({how})", at[0], at[1], at[2])]
pub struct Interference {
    /// First part.
    pub a: String,
    /// Second part.
    pub b: String,
    /// Where.
    pub at: P3,
    /// Surfaces crossing, or one part inside the other.
    pub how: &'static str,
}

/// Check that no two of `parts` overlap: no triangle of one crosses a triangle of the
/// other, and neither lies inside the other. Parts sharing one solid (the inserts) are
/// checked once; pairs for which `check` is false (a press fit: designed without
/// clearance) are skipped.
pub fn check_no_interference(
    parts: &[BuiltPart],
    check: &dyn Fn(PartKind, PartKind) -> bool,
) -> Result<(), Interference> {
    let kept = first_of_each_kind(parts, |b| b.kind);
    let solids: Vec<Solid> = kept.iter().map(|b| Solid::new(&b.name, &b.mesh)).collect();
    for i in 0..solids.len() {
        for j in i + 1..solids.len() {
            if !check(kept[i].kind, kept[j].kind) {
                continue;
            }
            let (a, b) = (&solids[i], &solids[j]);
            for (k, (lo, hi)) in a.boxes.iter().enumerate() {
                for (l, (lo2, hi2)) in b.boxes.iter().enumerate() {
                    if (0..3).any(|q| hi[q] < lo2[q] || hi2[q] < lo[q]) {
                        continue;
                    }
                    if triangles_overlap(a.tri(k), b.tri(l), 1e-9) {
                        return Err(Interference {
                            a: a.name.into(),
                            b: b.name.into(),
                            at: a.tri(k)[0],
                            how: "surfaces cross",
                        });
                    }
                }
            }
            for (x, y) in [(a, b), (b, a)] {
                let v = x.mesh.positions[0];
                if y.contains(v) {
                    return Err(Interference {
                        a: x.name.into(),
                        b: y.name.into(),
                        at: v,
                        how: "one inside the other",
                    });
                }
            }
        }
    }
    Ok(())
}

/// Segments where `mesh` crosses the plane through the z axis at angle `theta`, in that
/// plane's coordinates (s along the angle's direction, signed; z), mm.
pub fn axial_section(mesh: &TriMesh, theta: f64) -> Vec<[(f64, f64); 2]> {
    let n = [-theta.sin(), theta.cos(), 0.0];
    let u = [theta.cos(), theta.sin(), 0.0];
    plane_section(mesh, n, 0.0, |q| (dot(q, u), q[2]))
}

/// Segments where `mesh` crosses the plane n·x = d, mapped by `to2d`.
pub fn plane_section(
    mesh: &TriMesh,
    n: P3,
    d: f64,
    to2d: impl Fn(P3) -> (f64, f64),
) -> Vec<[(f64, f64); 2]> {
    let mut out = Vec::new();
    for t in &mesh.triangles {
        let v = t.map(|i| mesh.positions[i as usize]);
        let s = v.map(|q| dot(q, n) - d);
        let mut pts = Vec::new();
        for k in 0..3 {
            let (a, b) = (k, (k + 1) % 3);
            if (s[a] < 0.0) != (s[b] < 0.0) {
                let f = s[a] / (s[a] - s[b]);
                pts.push(to2d(add_scaled(v[a], sub(v[b], v[a]), f)));
            }
        }
        if pts.len() == 2 {
            out.push([pts[0], pts[1]]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_covers_vertex_edge_and_face_regions() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let near = |p: P3, q: P3| norm(sub(p, q)) < 1e-12;
        // Vertex region, edge region, face interior, the hypotenuse.
        assert!(near(closest_on_triangle([-1.0, -1.0, 0.0], a, b, c), a));
        assert!(near(
            closest_on_triangle([0.5, -1.0, 2.0], a, b, c),
            [0.5, 0.0, 0.0]
        ));
        assert!(near(
            closest_on_triangle([0.2, 0.2, 3.0], a, b, c),
            [0.2, 0.2, 0.0]
        ));
        assert!(near(
            closest_on_triangle([1.0, 1.0, 0.0], a, b, c),
            [0.5, 0.5, 0.0]
        ));
    }

    #[test]
    fn triangles_overlap_only_when_they_cross() {
        let t = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
        let crossing = [[0.5, 0.5, -1.0], [0.5, 0.5, 1.0], [1.5, 0.5, 0.0]];
        let above = [[0.5, 0.5, 0.1], [0.5, 1.0, 1.0], [1.5, 0.5, 0.2]];
        assert!(triangles_overlap(t, crossing, 1e-9));
        assert!(!triangles_overlap(t, above, 1e-9));
    }

    #[test]
    fn a_quarter_bend_measures_its_radius() {
        let pts: Vec<P3> = (0..=90)
            .map(|i| {
                let a = (i as f64).to_radians();
                [10.0 * (1.0 - a.cos()), 0.0, -10.0 * a.sin()]
            })
            .collect();
        assert!((min_bend_radius_mm(&pts) - 10.0).abs() < 1e-9);
    }
}
