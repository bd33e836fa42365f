//! Triangle meshes of the solids and the checks a printable mesh must pass.
//!
//! truck-meshalgo tessellates each face on its own and re-evaluates boundary points on
//! each face's surface, so the two copies of a shared edge point differ by rounding
//! noise; [`weld`] merges points closer than [`WELD_TOLERANCE_MM`]. A mesh is accepted
//! only if it is closed, consistently oriented, 2-manifold, free of degenerate
//! triangles, one connected piece, and encloses a positive volume.

use std::collections::HashMap;
use truck_meshalgo::prelude::*;
use truck_modeling::{Point3, Solid};

/// Points closer than this are the same mesh vertex, mm. truck's own tolerance is
/// 1e-6; edge points re-evaluated on two surfaces agree far better than the smallest
/// feature (0.13 mm fiber hole) but not bit for bit.
pub(crate) const WELD_TOLERANCE_MM: f64 = 1.0e-5;

/// An indexed triangle mesh, counter-clockwise seen from outside, in mm.
#[derive(Debug, Clone, Default)]
pub struct TriMesh {
    /// Vertex positions, mm.
    pub positions: Vec<[f64; 3]>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

/// A check that a part's mesh failed.
#[derive(Debug, thiserror::Error)]
#[error("part `{part}`: mesh check `{check}` failed: {detail}")]
pub struct MeshError {
    /// Part name.
    pub part: String,
    /// Name of the check (`tessellation`, `closed`, `oriented`, `manifold`,
    /// `degenerate`, `connected`, `volume`).
    pub check: &'static str,
    /// What was found.
    pub detail: String,
}

impl TriMesh {
    /// Signed enclosed volume, mm³ (positive for outward-facing triangles).
    pub fn volume_mm3(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum()
    }

    /// Axis-aligned bounding box (min, max), mm.
    pub fn bbox_mm(&self) -> ([f64; 3], [f64; 3]) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        (lo, hi)
    }

    /// Unit normal of triangle `t` (zero for a degenerate one).
    pub fn normal(&self, t: &[u32; 3]) -> [f64; 3] {
        let [a, b, c] = t.map(|i| self.positions[i as usize]);
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if l > 0.0 {
            n.map(|x| x / l)
        } else {
            [0.0; 3]
        }
    }

    /// Run every check; the first failure names the part and the check.
    pub fn check(&self, part: &str) -> Result<(), MeshError> {
        let fail = |check, detail: String| MeshError {
            part: part.to_string(),
            check,
            detail,
        };
        if self.triangles.is_empty() {
            return Err(fail("closed", "the mesh has no triangles".into()));
        }
        // Degenerate: repeated vertex or (numerically) zero area.
        for t in &self.triangles {
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || self.double_area(t) < 1e-14 {
                let p = self.positions[t[0] as usize];
                return Err(fail("degenerate", format!("zero-area triangle near {p:?}")));
            }
        }
        // Directed edges: each must occur once, and its reverse once.
        let mut directed: HashMap<(u32, u32), u32> =
            HashMap::with_capacity(self.triangles.len() * 3);
        for t in &self.triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &directed {
            let back = directed.get(&(b, a)).copied().unwrap_or(0);
            let p = self.positions[a as usize];
            if n > 1 {
                let check = if back == 0 { "oriented" } else { "manifold" };
                return Err(fail(
                    check,
                    format!("edge near {p:?} is used {n} times in the same direction"),
                ));
            }
            if back == 0 {
                return Err(fail("closed", format!("open edge near {p:?}")));
            }
        }
        // Connected: one piece (union-find over triangle edges).
        let mut parent: Vec<u32> = (0..self.positions.len() as u32).collect();
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        for t in &self.triangles {
            for k in 1..3 {
                let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
                parent[a as usize] = b;
            }
        }
        let mut roots = std::collections::HashSet::new();
        for t in &self.triangles {
            roots.insert(find(&mut parent, t[0]));
        }
        if roots.len() != 1 {
            return Err(fail(
                "connected",
                format!("{} separate pieces", roots.len()),
            ));
        }
        let v = self.volume_mm3();
        if v.is_nan() || v <= 0.0 {
            return Err(fail(
                "volume",
                format!("signed volume {v} mm³ is not positive (inside out)"),
            ));
        }
        Ok(())
    }

    fn double_area(&self, t: &[u32; 3]) -> f64 {
        let [a, b, c] = t.map(|i| self.positions[i as usize]);
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let n = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
    }
}

/// Merge points closer than `tol` (grid hashing with a neighbour search), drop the
/// triangles that collapse, and return the indexed mesh.
pub(crate) fn weld(triangles: &[[Point3; 3]], tol: f64) -> TriMesh {
    weld_indexed(triangles, tol).0
}

/// [`weld`], with the index in `triangles` of each triangle kept.
pub(crate) fn weld_indexed(triangles: &[[Point3; 3]], tol: f64) -> (TriMesh, Vec<usize>) {
    let cell = tol * 4.0;
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut index_of = |p: Point3, positions: &mut Vec<[f64; 3]>| -> u32 {
        let c = [
            (p.x / cell).floor() as i64,
            (p.y / cell).floor() as i64,
            (p.z / cell).floor() as i64,
        ];
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        for &i in list {
                            let q = positions[i as usize];
                            let d2 =
                                (q[0] - p.x).powi(2) + (q[1] - p.y).powi(2) + (q[2] - p.z).powi(2);
                            if d2 <= tol * tol {
                                return i;
                            }
                        }
                    }
                }
            }
        }
        let i = positions.len() as u32;
        positions.push([p.x, p.y, p.z]);
        grid.entry(c).or_default().push(i);
        i
    };
    let mut tris = Vec::with_capacity(triangles.len());
    let mut kept = Vec::with_capacity(triangles.len());
    for (k, t) in triangles.iter().enumerate() {
        let idx = [
            index_of(t[0], &mut positions),
            index_of(t[1], &mut positions),
            index_of(t[2], &mut positions),
        ];
        if idx[0] != idx[1] && idx[1] != idx[2] && idx[0] != idx[2] {
            tris.push(idx);
            kept.push(k);
        }
    }
    (
        TriMesh {
            positions,
            triangles: tris,
        },
        kept,
    )
}

/// Tessellate a solid at chord tolerance `tol_mm`, weld it and check it.
pub fn mesh_solid(part: &str, solid: &Solid, tol_mm: f64) -> Result<TriMesh, MeshError> {
    let meshed = solid.triangulation(tol_mm);
    let mut triangles = Vec::new();
    for (k, face) in meshed.boundaries()[0].face_iter().enumerate() {
        let Some(poly) = face.surface() else {
            return Err(MeshError {
                part: part.to_string(),
                check: "tessellation",
                detail: format!("face {k} could not be tessellated"),
            });
        };
        let pos = poly.positions();
        for tri in poly.faces().triangle_iter() {
            let t = [pos[tri[0].pos], pos[tri[1].pos], pos[tri[2].pos]];
            // truck orients each face's triangles by that face's orientation.
            triangles.push(if face.orientation() {
                t
            } else {
                [t[0], t[2], t[1]]
            });
        }
    }
    let mesh = weld(&triangles, WELD_TOLERANCE_MM);
    mesh.check(part)?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit right tetrahedron, outward-facing: volume 1/6.
    fn tetra(offset: f64) -> TriMesh {
        TriMesh {
            positions: vec![
                [offset, 0.0, 0.0],
                [offset + 1.0, 0.0, 0.0],
                [offset, 1.0, 0.0],
                [offset, 0.0, 1.0],
            ],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        }
    }

    fn check_name(m: &TriMesh) -> Option<&'static str> {
        m.check("t").err().map(|e| e.check)
    }

    #[test]
    fn a_good_tetrahedron_passes_with_its_exact_volume() {
        let m = tetra(0.0);
        assert_eq!(check_name(&m), None);
        assert!((m.volume_mm3() - 1.0 / 6.0).abs() < 1e-15);
    }

    #[test]
    fn each_defect_is_named() {
        let mut open = tetra(0.0);
        open.triangles.pop();
        assert_eq!(check_name(&open), Some("closed"));

        let mut flipped = tetra(0.0);
        flipped.triangles[3] = [1, 3, 2];
        assert_eq!(check_name(&flipped), Some("oriented"));

        let mut inside_out = tetra(0.0);
        inside_out.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        assert_eq!(check_name(&inside_out), Some("volume"));

        let mut two = tetra(0.0);
        let other = tetra(5.0);
        two.positions.extend(other.positions);
        two.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + 4)));
        assert_eq!(check_name(&two), Some("connected"));

        let mut flat = tetra(0.0);
        flat.positions[3] = [0.5, 0.5, 0.0];
        assert_eq!(check_name(&flat), Some("degenerate"));

        // Two tetrahedra sharing one edge: that edge has four triangles.
        let mut bow = tetra(0.0);
        bow.positions.push([-1.0, 0.0, 0.0]);
        bow.positions.push([0.0, -1.0, 0.0]);
        // Second tetra on vertices 0, 3 (shared edge 0–3) and 4, 5.
        bow.triangles
            .extend([[0, 4, 5], [0, 5, 3], [0, 3, 4], [4, 3, 5]]);
        assert!(matches!(
            check_name(&bow),
            Some("manifold") | Some("oriented")
        ));
    }

    #[test]
    fn welding_merges_near_points_and_drops_collapsed_triangles() {
        let a = Point3::new(0.0, 0.0, 0.0);
        let b = Point3::new(1.0, 0.0, 0.0);
        let c = Point3::new(0.0, 1.0, 0.0);
        let b2 = Point3::new(1.0 + 1e-7, 0.0, 0.0);
        let m = weld(
            &[[a, b, c], [a, b2, c], [a, Point3::new(1e-7, 0.0, 0.0), c]],
            WELD_TOLERANCE_MM,
        );
        assert_eq!(m.positions.len(), 3);
        assert_eq!(m.triangles.len(), 2);
    }
}
