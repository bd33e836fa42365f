//! A small B-rep assembler: faces described by their boundary curves, joined into a
//! closed shell through a registry that creates every vertex and edge exactly once.
//!
//! Why not sweeps and booleans: the parts join an extruded cross-section (pillars,
//! grooves, fiber holes) to a revolved dome, and truck-shapeops fails or panics on
//! such joins (reference §4). Here every face is built on its own from registry
//! edges, so two faces that meet share the same edge object and the shell closes by
//! construction. Orientation is never assumed: each boundary loop is turned to run
//! counter-clockwise about its surface's own normal (what truck-meshalgo's trimming
//! expects), and each face is inverted when that normal disagrees with the outward
//! direction the caller states.

use std::collections::HashMap;
use std::result::Result;
use truck_modeling::*;

/// Points closer than this are one vertex, mm: far below any feature, far above the
/// rounding noise between two formulas for the same point.
const SAME_POINT_MM: f64 = 1.0e-7;

fn cell(p: Point3) -> [i64; 3] {
    let s = 1.0 / (4.0 * SAME_POINT_MM);
    [
        (p.x * s).floor() as i64,
        (p.y * s).floor() as i64,
        (p.z * s).floor() as i64,
    ]
}

/// Geometry of one edge, given by the caller; the registry makes the truck curve.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Seg {
    /// Straight line from the first to the second point.
    Line(Point3, Point3),
    /// Circle arc from the first point through the second (transit) to the third.
    Arc(Point3, Point3, Point3),
}

impl Seg {
    fn ends(&self) -> (Point3, Point3) {
        match *self {
            Seg::Line(a, b) => (a, b),
            Seg::Arc(a, _, b) => (a, b),
        }
    }

    /// A point in the middle of the edge, used to tell apart two edges that join the
    /// same vertices (e.g. the two halves of a circle).
    fn mid(&self) -> Point3 {
        match *self {
            Seg::Line(a, b) => a.midpoint(b),
            Seg::Arc(_, t, _) => t,
        }
    }

    /// The same edge run the other way.
    pub fn reversed(&self) -> Seg {
        match *self {
            Seg::Line(a, b) => Seg::Line(b, a),
            Seg::Arc(a, t, b) => Seg::Arc(b, t, a),
        }
    }
}

/// Errors while assembling a solid; they name the part and the face.
#[derive(Debug, thiserror::Error)]
pub enum BrepError {
    /// A face could not be created from its boundary.
    #[error("{part}: face `{face}` could not be built: {reason}")]
    Face {
        /// Part name.
        part: String,
        /// Face description.
        face: String,
        /// What went wrong.
        reason: String,
    },
    /// The assembled shell is not closed and oriented.
    #[error("{part}: the B-rep shell is {condition:?}, expected a closed oriented shell")]
    Shell {
        /// Part name.
        part: String,
        /// What truck reports.
        condition: ShellCondition,
    },
}

/// Registry of vertices and edges plus the faces built so far for one part.
#[derive(Debug)]
pub(crate) struct Assembler {
    part: String,
    /// Vertices by grid cell (points within [`SAME_POINT_MM`] are one vertex).
    grid: HashMap<[i64; 3], Vec<usize>>,
    vertices: Vec<Vertex>,
    /// Edges by (front, back) vertex index, told apart by their middle point.
    edges: HashMap<(usize, usize), Vec<(Point3, Edge)>>,
    faces: Vec<Face>,
}

impl Assembler {
    /// Start a part.
    pub fn new(part: &str) -> Self {
        Self {
            part: part.to_string(),
            grid: HashMap::new(),
            vertices: Vec::new(),
            edges: HashMap::new(),
            faces: Vec::new(),
        }
    }

    fn vertex(&mut self, p: Point3) -> usize {
        let c = cell(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = self.grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        for &i in list {
                            if self.vertices[i].point().distance(p) <= SAME_POINT_MM {
                                return i;
                            }
                        }
                    }
                }
            }
        }
        self.vertices.push(Vertex::new(p));
        let i = self.vertices.len() - 1;
        self.grid.entry(c).or_default().push(i);
        i
    }

    /// The edge for `seg`, created on first request; asked the other way round it
    /// comes back inverted, so adjacent faces share one edge object.
    pub fn edge(&mut self, seg: Seg) -> Edge {
        let (a, b) = seg.ends();
        let (ia, ib) = (self.vertex(a), self.vertex(b));
        let m = seg.mid();
        // Same vertices and the same middle point: the same edge (the two halves of a
        // circle share their end vertices but not their middle).
        let tol = 1.0e3 * SAME_POINT_MM;
        if let Some(list) = self.edges.get(&(ia, ib)) {
            if let Some((_, e)) = list.iter().find(|(q, _)| q.distance(m) <= tol) {
                return e.clone();
            }
        }
        if let Some(list) = self.edges.get(&(ib, ia)) {
            if let Some((_, e)) = list.iter().find(|(q, _)| q.distance(m) <= tol) {
                return e.inverse();
            }
        }
        let (va, vb) = (self.vertices[ia].clone(), self.vertices[ib].clone());
        let e = match seg {
            Seg::Line(..) => builder::line(&va, &vb),
            Seg::Arc(_, t, _) => builder::circle_arc(&va, &vb, t),
        };
        self.edges.entry((ia, ib)).or_default().push((m, e.clone()));
        e
    }

    fn wire(&mut self, segs: &[Seg]) -> Wire {
        segs.iter().map(|s| self.edge(*s)).collect()
    }

    /// Add a face on `surface` bounded by `loops` (the first is the outer boundary,
    /// the others holes). `probe` is the surface parameter inside the face where the
    /// surface normal is compared with the stated `outward` direction.
    pub fn face(
        &mut self,
        name: &str,
        loops: &[Vec<Seg>],
        surface: Surface,
        probe: (f64, f64),
        outward: Vector3,
    ) -> Result<(), BrepError> {
        let n_surf = surface.normal(probe.0, probe.1);
        let mut wires = Vec::with_capacity(loops.len());
        for (i, l) in loops.iter().enumerate() {
            let mut w = self.wire(l);
            let area = newell(&w);
            // Outer loop counter-clockwise about the surface normal, holes clockwise.
            if (area.dot(n_surf) > 0.0) != (i == 0) {
                w.invert();
            }
            wires.push(w);
        }
        let mut f = Face::try_new(wires, surface).map_err(|e| BrepError::Face {
            part: self.part.clone(),
            face: name.to_string(),
            reason: e.to_string(),
        })?;
        if n_surf.dot(outward) < 0.0 {
            f.invert();
        }
        self.faces.push(f);
        Ok(())
    }

    /// A planar face with outward normal `outward` (constant over the face).
    pub fn plane(
        &mut self,
        name: &str,
        loops: &[Vec<Seg>],
        outward: Vector3,
    ) -> Result<(), BrepError> {
        // Three well-spread points of the outer loop span the plane.
        let pts: Vec<Point3> = loops[0].iter().map(|s| s.ends().0).collect();
        let o = pts[0];
        let far = *pts
            .iter()
            .max_by(|a, b| a.distance2(o).total_cmp(&b.distance2(o)))
            .expect("a loop has points");
        let u = (far - o).normalize();
        let v = outward.normalize().cross(u);
        let plane = Plane::new(o, o + u, o + v);
        // Every boundary point must lie in that plane: a wrong `outward` or a
        // non-planar loop is a construction bug, reported rather than meshed.
        let n = outward.normalize();
        for l in loops {
            for s in l {
                let (a, _) = s.ends();
                if (a - o).dot(n).abs() > 1e-9 {
                    return Err(BrepError::Face {
                        part: self.part.clone(),
                        face: name.to_string(),
                        reason: format!("boundary point {a:?} is off the face's plane"),
                    });
                }
            }
        }
        self.face(name, loops, Surface::Plane(plane), (0.0, 0.0), outward)
    }

    /// A patch of the surface swept by revolving a meridian (a line or arc in a
    /// half-plane bounded by the vertical axis through `axis_point`) about that axis.
    /// The patch spans `theta0..theta1` (radians, less than π apart); `meridian_at`
    /// returns the meridian placed at a given angle. The surface is built from the
    /// meridian placed opposite the patch, so the patch sits in the middle of the
    /// surface's angular parameter, far from its seam.
    ///
    /// The outward normal is `outward_sign` × (point − centre), where the centre is
    /// `sphere_center` for a spherical patch and the axis (at the point's height)
    /// for a cylindrical one.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn revolved(
        &mut self,
        name: &str,
        loops: &[Vec<Seg>],
        axis_point: Point3,
        (theta0, theta1): (f64, f64),
        meridian_at: &dyn Fn(f64) -> Seg,
        sphere_center: Option<Point3>,
        outward_sign: f64,
    ) -> Result<(), BrepError> {
        let mid = 0.5 * (theta0 + theta1);
        let seed = meridian_at(mid + std::f64::consts::PI);
        let curve: Curve = match seed {
            Seg::Line(a, b) => Curve::Line(Line(a, b)),
            Seg::Arc(a, t, b) => {
                builder::circle_arc(&Vertex::new(a), &Vertex::new(b), t).oriented_curve()
            }
        };
        let (t0, t1) = curve.range_tuple();
        let surface = Surface::RevolutedCurve(Processor::new(RevolutedCurve::by_revolution(
            curve,
            axis_point,
            Vector3::unit_z(),
        )));
        // Probe: middle of the meridian, half a turn from the seed = patch middle.
        let probe = (0.5 * (t0 + t1), std::f64::consts::PI);
        let p = surface.subs(probe.0, probe.1);
        let c = sphere_center.unwrap_or(Point3::new(axis_point.x, axis_point.y, p.z));
        let outward = (p - c) * outward_sign;
        self.face(name, loops, surface, probe, outward)
    }

    /// Close the part: the faces must form one closed, oriented shell.
    pub fn solid(self) -> Result<Solid, BrepError> {
        let shell: Shell = self.faces.into_iter().collect();
        let cond = shell.shell_condition();
        if cond != ShellCondition::Closed {
            return Err(BrepError::Shell {
                part: self.part,
                condition: cond,
            });
        }
        Ok(Solid::new_unchecked(vec![shell]))
    }
}

/// Vector area of a closed wire (Newell's formula over points sampled along its edges).
fn newell(w: &Wire) -> Vector3 {
    let mut pts = Vec::new();
    for e in w.edge_iter() {
        let c = e.oriented_curve();
        let (t0, t1) = c.range_tuple();
        const N: usize = 16;
        for i in 0..N {
            pts.push(c.subs(t0 + (t1 - t0) * i as f64 / N as f64));
        }
    }
    let mut n = Vector3::zero();
    for i in 0..pts.len() {
        let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
        n += a.to_vec().cross(b.to_vec());
    }
    n * 0.5
}
