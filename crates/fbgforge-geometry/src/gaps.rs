//! Designed gaps measured on the meshes that are written: between mating parts (the
//! domes, the cylinders, the snap bead and the pillars) and between a fiber and the
//! hole, bore or chamber it passes. A mesh's chords cut into a concave wall by up to
//! about its chord tolerance (truck keeps the error near, not strictly under, it), so a
//! small gap can lose most of its width in the STL even when the B-rep is exact. Each
//! gap names the surfaces it lies between ([`Surface`]); the parts are meshed with a
//! finer tolerance on those surfaces only ([`crate::mesh::mesh_solid_graded`]) until the
//! mesh keeps at least [`KEPT_FRACTION`] of the designed gap, and the build refuses,
//! naming the gap, when it cannot.

use super::mesh::TriMesh;
use super::part::PartKind;
use serde::Serialize;

/// Least fraction of a designed gap the written meshes must keep (80 %).
pub const KEPT_FRACTION: f64 = 0.8;

/// A vertex lies on a surface when within this of it, mm (mesh vertices are evaluated
/// on the exact surfaces).
const ON_SURFACE_MM: f64 = 1e-6;

type P3 = [f64; 3];

/// The meridian of a surface of revolution about a vertical axis, in (r, z).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Meridian {
    /// A straight meridian (cylinder, cone, flat annulus) between two (r, z) points.
    Segment((f64, f64), (f64, f64)),
    /// A sphere centred on the axis at `centre_z_mm`.
    Sphere {
        /// Height of the centre, mm.
        centre_z_mm: f64,
        /// Radius, mm.
        radius_mm: f64,
    },
}

/// A surface of a part on which a gap is measured and refined.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Surface {
    /// Revolved about the vertical line through `axis_xy_mm`.
    Revolved {
        /// Where the axis meets z = 0, mm.
        axis_xy_mm: (f64, f64),
        /// The meridian.
        meridian: Meridian,
    },
    /// A vertical plane parallel to the radial direction at `angle_rad`, offset
    /// `offset_mm` across it (a pillar's or groove's side), between the radii `r_mm`
    /// from the axis, on the side of the axis the direction points to.
    Side {
        /// Direction of the pillar, rad.
        angle_rad: f64,
        /// Signed offset across the direction, mm.
        offset_mm: f64,
        /// Radial extent along the direction, mm.
        r_mm: (f64, f64),
    },
}

fn seg_dist2(q: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let l = dx * dx + dy * dy;
    let t = if l > 0.0 {
        (((q.0 - a.0) * dx + (q.1 - a.1) * dy) / l).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (q.0 - a.0 - t * dx).powi(2) + (q.1 - a.1 - t * dy).powi(2)
}

impl Surface {
    /// A cylinder about the module's axis of radius `r_mm` from `z0` to `z1`.
    pub fn cylinder(r_mm: f64, z0: f64, z1: f64) -> Self {
        Surface::Revolved {
            axis_xy_mm: (0.0, 0.0),
            meridian: Meridian::Segment((r_mm, z0), (r_mm, z1)),
        }
    }

    /// A revolved segment about the module's axis.
    pub fn cone(a: (f64, f64), b: (f64, f64)) -> Self {
        Surface::Revolved {
            axis_xy_mm: (0.0, 0.0),
            meridian: Meridian::Segment(a, b),
        }
    }

    /// A sphere on the module's axis.
    pub fn sphere(centre_z_mm: f64, radius_mm: f64) -> Self {
        Surface::Revolved {
            axis_xy_mm: (0.0, 0.0),
            meridian: Meridian::Sphere {
                centre_z_mm,
                radius_mm,
            },
        }
    }

    /// Whether point `p` lies on the surface.
    pub fn contains(&self, p: P3) -> bool {
        match *self {
            Surface::Revolved {
                axis_xy_mm: (x0, y0),
                meridian,
            } => {
                let r = (p[0] - x0).hypot(p[1] - y0);
                match meridian {
                    Meridian::Segment(a, b) => {
                        seg_dist2((r, p[2]), a, b) <= ON_SURFACE_MM * ON_SURFACE_MM
                    }
                    Meridian::Sphere {
                        centre_z_mm,
                        radius_mm,
                    } => (r.hypot(p[2] - centre_z_mm) - radius_mm).abs() <= ON_SURFACE_MM,
                }
            }
            Surface::Side {
                angle_rad,
                offset_mm,
                r_mm: (r0, r1),
            } => {
                let (s, c) = angle_rad.sin_cos();
                let across = -s * p[0] + c * p[1];
                let along = c * p[0] + s * p[1];
                let r = p[0].hypot(p[1]);
                (across - offset_mm).abs() <= ON_SURFACE_MM
                    && along > 0.0
                    && r >= r0 - ON_SURFACE_MM
                    && r <= r1 + ON_SURFACE_MM
            }
        }
    }
}

impl Surface {
    /// The surface's unit normal direction (either sense) at a point near it.
    fn normal_at(&self, p: P3) -> P3 {
        let unit = |v: P3| {
            let l = dot(v, v).sqrt();
            if l > 0.0 {
                v.map(|x| x / l)
            } else {
                [0.0; 3]
            }
        };
        match *self {
            Surface::Revolved {
                axis_xy_mm: (x0, y0),
                meridian,
            } => {
                let radial = unit([p[0] - x0, p[1] - y0, 0.0]);
                match meridian {
                    Meridian::Segment(a, b) => {
                        let (dr, dz) = (b.0 - a.0, b.1 - a.1);
                        unit([radial[0] * dz, radial[1] * dz, -dr])
                    }
                    Meridian::Sphere { centre_z_mm, .. } => {
                        unit([p[0] - x0, p[1] - y0, p[2] - centre_z_mm])
                    }
                }
            }
            Surface::Side { angle_rad, .. } => [-angle_rad.sin(), angle_rad.cos(), 0.0],
        }
    }
}

/// Whether `tri` is a facet of one of `surfaces`: its vertices on it and its plane
/// within 60° of the surface's (a flat disc whose rim lies on a cylinder has all its
/// vertices on it, and is not a facet of it).
fn facet_of_any(surfaces: &[Surface], tri: &[P3; 3]) -> bool {
    let n = {
        let (u, v) = (sub(tri[1], tri[0]), sub(tri[2], tri[0]));
        let c = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let l = dot(c, c).sqrt();
        if l == 0.0 {
            return false;
        }
        c.map(|x| x / l)
    };
    let centre = [0, 1, 2].map(|k| (tri[0][k] + tri[1][k] + tri[2][k]) / 3.0);
    surfaces
        .iter()
        .any(|s| tri.iter().all(|&p| s.contains(p)) && dot(n, s.normal_at(centre)).abs() >= 0.5)
}

/// What a gap lies between: two parts, or a fiber and the passage around it.
#[derive(Debug, Clone, PartialEq)]
pub enum Between {
    /// A mating part (the convex side: its chords fall away from the gap).
    Part {
        /// Its kind.
        kind: PartKind,
        /// Its surfaces facing the gap.
        surfaces: Vec<Surface>,
    },
    /// A coated fiber of radius `radius_mm` on the vertical line through `axis_xy_mm`.
    Fiber {
        /// Where the fiber's axis meets z = 0, mm.
        axis_xy_mm: (f64, f64),
        /// Radius of the coated fiber, mm.
        radius_mm: f64,
    },
}

/// A designed gap and the surfaces it lies between.
#[derive(Debug, Clone)]
pub struct GapSpec {
    /// Which surfaces, in words.
    pub what: String,
    /// The spec field that sets the gap.
    pub field: String,
    /// The part whose concave surfaces face the gap: its chords cut into it, so it is
    /// the part refined.
    pub outer: PartKind,
    /// Its surfaces facing the gap.
    pub outer_surfaces: Vec<Surface>,
    /// The other side.
    pub inner: Between,
    /// The gap on exact dimensions, mm.
    pub designed_gap_mm: f64,
}

impl GapSpec {
    /// The inner part's kind (None for a fiber).
    pub fn inner_kind(&self) -> Option<PartKind> {
        match &self.inner {
            Between::Part { kind, .. } => Some(*kind),
            Between::Fiber { .. } => None,
        }
    }
}

/// A designed gap as the written meshes have it.
#[derive(Debug, Clone, Serialize)]
pub struct MeshedGap {
    /// The part on the concave side (the one refined).
    pub outer: PartKind,
    /// The part on the other side (None for a fiber).
    pub inner: Option<PartKind>,
    /// Which surfaces, in words.
    pub what: String,
    /// The spec field that sets the gap.
    pub field: String,
    /// The gap on exact dimensions, mm.
    pub designed_gap_mm: f64,
    /// The gap between the written meshes, mm.
    pub meshed_gap_mm: f64,
    /// Meshed over designed, percent (at least 80).
    pub kept_percent: f64,
    /// The chord tolerance the outer part's surfaces facing the gap were meshed at, mm.
    pub surface_tolerance_mm: f64,
}

/// Chord tolerance a gap's surfaces start at: a fifth of the gap (the share the mesh
/// may eat) over 2, since truck's chord error reaches about 1.6 × its tolerance.
pub fn initial_tolerance_mm(gap_mm: f64) -> f64 {
    (1.0 - KEPT_FRACTION) * gap_mm / 2.0
}

/// The triangles of `mesh` lying on any of `surfaces`.
fn select(mesh: &TriMesh, surfaces: &[Surface]) -> Vec<[P3; 3]> {
    mesh.triangles
        .iter()
        .map(|t| t.map(|i| mesh.positions[i as usize]))
        .filter(|tri| facet_of_any(surfaces, tri))
        .collect()
}

/// Measure `spec` on the meshes: the outer part's mesh, and the inner part's (None
/// for a fiber). None when the outer mesh has no triangle on the gap's surfaces.
pub fn measure(spec: &GapSpec, outer: &TriMesh, inner: Option<&TriMesh>) -> Option<f64> {
    let a = select(outer, &spec.outer_surfaces);
    if a.is_empty() {
        return None;
    }
    match (&spec.inner, inner) {
        (
            Between::Fiber {
                axis_xy_mm,
                radius_mm,
            },
            _,
        ) => {
            let r = a
                .iter()
                .map(|t| axis_to_triangle(*axis_xy_mm, t))
                .fold(f64::INFINITY, f64::min);
            Some(r - radius_mm)
        }
        (Between::Part { surfaces, .. }, Some(m)) => {
            let b = select(m, surfaces);
            if b.is_empty() {
                return None;
            }
            Some(set_distance(&a, &b, spec.designed_gap_mm))
        }
        (Between::Part { .. }, None) => None,
    }
}

/// Distance from the vertical line through `axis` to a triangle (nearly vertical: a
/// hole's wall), measured in plan: the nearest of its edges' projections.
fn axis_to_triangle(axis: (f64, f64), t: &[P3; 3]) -> f64 {
    (0..3)
        .map(|k| {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            seg_dist2(axis, (a[0], a[1]), (b[0], b[1])).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Distance between segments pq and rs (Ericson, Real-Time Collision Detection §5.1.9).
fn segment_segment(p: P3, q: P3, r: P3, s: P3) -> f64 {
    let (d1, d2, w) = (sub(q, p), sub(s, r), sub(p, r));
    let (a, e, f) = (dot(d1, d1), dot(d2, d2), dot(d2, w));
    let (mut sc, mut tc);
    if a <= 1e-20 && e <= 1e-20 {
        return dot(w, w).sqrt();
    }
    if a <= 1e-20 {
        sc = 0.0;
        tc = (f / e).clamp(0.0, 1.0);
    } else {
        let c = dot(d1, w);
        if e <= 1e-20 {
            tc = 0.0;
            sc = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = dot(d1, d2);
            let den = a * e - b * b;
            sc = if den > 1e-20 {
                ((b * f - c * e) / den).clamp(0.0, 1.0)
            } else {
                0.0
            };
            tc = (b * sc + f) / e;
            if tc < 0.0 {
                tc = 0.0;
                sc = (-c / a).clamp(0.0, 1.0);
            } else if tc > 1.0 {
                tc = 1.0;
                sc = ((b - c) / a).clamp(0.0, 1.0);
            }
        }
    }
    let c1 = [p[0] + d1[0] * sc, p[1] + d1[1] * sc, p[2] + d1[2] * sc];
    let c2 = [r[0] + d2[0] * tc, r[1] + d2[1] * tc, r[2] + d2[2] * tc];
    let d = sub(c1, c2);
    dot(d, d).sqrt()
}

/// Distance between two triangles that do not cross: the least of the six
/// vertex-to-triangle and nine edge-to-edge distances.
pub(crate) fn triangle_distance(t: &[P3; 3], u: &[P3; 3]) -> f64 {
    let mut best = f64::INFINITY;
    for (x, y) in [(t, u), (u, t)] {
        for &p in x.iter() {
            let c = super::triangle::closest_on_triangle(p, y[0], y[1], y[2]);
            best = best.min(dot(sub(p, c), sub(p, c)).sqrt());
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            best = best.min(segment_segment(t[i], t[(i + 1) % 3], u[j], u[(j + 1) % 3]));
        }
    }
    best
}

/// Least distance between two sets of triangles, looking only at pairs whose boxes
/// come within `reach` (twice the designed gap, at least 0.05 mm) of each other and
/// could still beat the best found: `b` sorted by its boxes' low x, swept per triangle
/// of `a` (the surfaces' strips are long, so a grid of cells would hold each in many).
fn set_distance(a: &[[P3; 3]], b: &[[P3; 3]], designed_gap_mm: f64) -> f64 {
    let reach = (2.0 * designed_gap_mm).max(0.05);
    let bbox = |t: &[P3; 3]| {
        let lo = [0, 1, 2].map(|k| t[0][k].min(t[1][k]).min(t[2][k]));
        let hi = [0, 1, 2].map(|k| t[0][k].max(t[1][k]).max(t[2][k]));
        (lo, hi)
    };
    let mut sorted: Vec<(P3, P3, usize)> = b
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let (lo, hi) = bbox(t);
            (lo, hi, k)
        })
        .collect();
    sorted.sort_by(|x, y| x.0[0].total_cmp(&y.0[0]));
    let mut best = reach;
    let mut found = f64::INFINITY;
    for t in a {
        let (lo, hi) = bbox(t);
        let end = sorted.partition_point(|s| s.0[0] <= hi[0] + best);
        for (lo2, hi2, k) in &sorted[..end] {
            // The boxes' gap is a lower bound of the triangles' distance.
            let gap2: f64 = (0..3)
                .map(|q| (lo2[q] - hi[q]).max(lo[q] - hi2[q]).max(0.0).powi(2))
                .sum();
            if gap2 >= best * best {
                continue;
            }
            let d = triangle_distance(t, &b[*k]);
            if d < found {
                found = d;
                best = best.min(d);
            }
        }
    }
    if found.is_finite() {
        found
    } else {
        // Nothing within reach: the gap is at least that.
        reach
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_distance_is_exact_for_parallel_and_crossing_edges() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        // Parallel, 0.3 above: the vertex-to-face distance.
        let u = t.map(|p| [p[0], p[1], 0.3]);
        assert!((triangle_distance(&t, &u) - 0.3).abs() < 1e-12);
        // Edges crossing at right angles 0.2 apart (no vertex near the other face):
        // only the edge-to-edge distance finds it.
        let a = [[-1.0, 0.5, 0.0], [1.0, 0.5, 0.0], [0.0, 0.5, -5.0]];
        let b = [[0.5, -1.0, 0.2], [0.5, 1.0, 0.2], [0.5, 0.0, 5.0]];
        assert!((triangle_distance(&a, &b) - 0.2).abs() < 1e-12);
    }

    #[test]
    fn a_surface_holds_its_points_and_no_others() {
        let s = Surface::sphere(2.0, 5.0);
        assert!(s.contains([3.0, 0.0, 6.0]));
        assert!(!s.contains([3.0, 0.0, 6.001]));
        let c = Surface::Revolved {
            axis_xy_mm: (1.0, 1.0),
            meridian: Meridian::Segment((0.5, 0.0), (0.5, 10.0)),
        };
        assert!(c.contains([1.5, 1.0, 4.0]));
        assert!(!c.contains([1.5, 1.0, 10.5]));
        let side = Surface::Side {
            angle_rad: std::f64::consts::FRAC_PI_2,
            offset_mm: -0.6,
            r_mm: (9.0, 11.0),
        };
        // At 90°, across = −x: x = 0.6 is offset −0.6; along = y.
        assert!(side.contains([0.6, 10.0, 3.0]));
        assert!(!side.contains([0.6, 12.0, 3.0]));
        assert!(!side.contains([0.6, -10.0, 3.0]));
    }
}
