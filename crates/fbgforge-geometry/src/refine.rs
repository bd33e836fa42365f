//! Meshing with a finer chord tolerance on chosen surfaces only (the surfaces facing a
//! designed gap, [`crate::gaps`]), the rest at the part's tolerance.
//!
//! truck tessellates a shell face by face on edge polylines it divides once per
//! shell. Its division of a curve is recursive bisection at the parameter's midpoint,
//! stopped where the chord is within the tolerance, so the division at a finer
//! tolerance contains every point of the coarser one. The faces to refine are
//! therefore tessellated together as a shell of their own at their tolerance, the rest
//! as the whole solid at the part's; on an edge between a fine face and a coarse one the
//! fine side has extra points on the coarse side's chord (T-junctions), and each coarse
//! triangle along it is split into a fan through those points. The result must pass
//! every check of [`TriMesh::check`]; if the stitching cannot be made (a fan would fold)
//! the whole part is meshed at the finest tolerance instead.

use super::gaps::Surface;
use super::mesh::{mesh_solid, weld_indexed, MeshError, TriMesh, WELD_TOLERANCE_MM};
use std::collections::HashMap;
use truck_meshalgo::prelude::*;
use truck_modeling::{Point3, Shell, Solid};

/// A shell as truck meshes it: polyline edges, a polygon mesh per face.
type MeshedShell = truck_topology::Shell<Point3, PolylineCurve<Point3>, Option<PolygonMesh>>;

/// A surface group and the chord tolerance its faces need, mm.
#[derive(Debug, Clone)]
pub struct SurfaceNeed {
    /// Faces lying wholly on one of these surfaces are refined.
    pub surfaces: Vec<Surface>,
    /// Their chord tolerance, mm.
    pub tolerance_mm: f64,
}

/// Each face's triangles (positions, outward winding) from a meshed shell; None for a
/// face that could not be tessellated.
fn face_triangles(meshed: &MeshedShell) -> Vec<Option<Vec<[Point3; 3]>>> {
    meshed
        .face_iter()
        .map(|face| {
            let poly = face.surface()?;
            let pos = poly.positions();
            Some(
                poly.faces()
                    .triangle_iter()
                    .map(|tri| {
                        let t = [pos[tri[0].pos], pos[tri[1].pos], pos[tri[2].pos]];
                        if face.orientation() {
                            t
                        } else {
                            [t[0], t[2], t[1]]
                        }
                    })
                    .collect(),
            )
        })
        .collect()
}

/// Mesh `solid` at `tol_mm`, with every face that lies wholly on a surface of a need
/// at that need's tolerance (the finest that applies). Checked like [`mesh_solid`].
pub fn mesh_solid_graded(
    part: &str,
    solid: &Solid,
    tol_mm: f64,
    needs: &[SurfaceNeed],
) -> Result<TriMesh, MeshError> {
    let finer: Vec<&SurfaceNeed> = needs.iter().filter(|n| n.tolerance_mm < tol_mm).collect();
    if finer.is_empty() {
        return mesh_solid(part, solid, tol_mm);
    }
    let shell = &solid.boundaries()[0];
    let coarse = face_triangles(&shell.triangulation(tol_mm));
    let fail = |k: usize| MeshError {
        part: part.to_string(),
        check: "tessellation",
        detail: format!("face {k} could not be tessellated"),
    };
    // Each face's tolerance: the finest need whose surfaces hold all its vertices.
    let level: Vec<f64> = coarse
        .iter()
        .enumerate()
        .map(|(k, tris)| {
            let tris = tris.as_ref().ok_or_else(|| fail(k))?;
            Ok(finer
                .iter()
                .filter(|n| {
                    n.surfaces.iter().any(|s| {
                        tris.iter()
                            .all(|t| t.iter().all(|p| s.contains([p.x, p.y, p.z])))
                    })
                })
                .map(|n| n.tolerance_mm)
                .fold(tol_mm, f64::min))
        })
        .collect::<Result<_, MeshError>>()?;
    let mut tols: Vec<f64> = level.iter().copied().filter(|&t| t < tol_mm).collect();
    tols.sort_by(f64::total_cmp);
    tols.dedup();
    if tols.is_empty() {
        return mesh_solid(part, solid, tol_mm);
    }
    // Fine faces, tessellated per tolerance as shells of their own.
    let faces: Vec<_> = shell.face_iter().collect();
    let mut tagged: Vec<([Point3; 3], f64)> = Vec::new();
    for (k, tris) in coarse.iter().enumerate() {
        if level[k] >= tol_mm {
            let tris = tris.as_ref().ok_or_else(|| fail(k))?;
            tagged.extend(tris.iter().map(|t| (*t, tol_mm)));
        }
    }
    for &t in &tols {
        let idx: Vec<usize> = (0..faces.len()).filter(|&k| level[k] == t).collect();
        let sub: Shell = idx.iter().map(|&k| faces[k].clone()).collect();
        for (j, tris) in face_triangles(&sub.triangulation(t))
            .into_iter()
            .enumerate()
        {
            let tris = tris.ok_or_else(|| fail(idx[j]))?;
            tagged.extend(tris.into_iter().map(|tri| (tri, t)));
        }
    }
    let tris: Vec<[Point3; 3]> = tagged.iter().map(|(t, _)| *t).collect();
    let levels: Vec<f64> = tagged.iter().map(|(_, l)| *l).collect();
    let (mesh, kept) = weld_indexed(&tris, WELD_TOLERANCE_MM);
    let kept: Vec<f64> = kept.into_iter().map(|k| levels[k]).collect();
    match stitch(mesh, &kept) {
        Some(m) if m.check(part).is_ok() => Ok(m),
        // The fans could not be made: the whole part at the finest tolerance.
        _ => mesh_solid(part, solid, tols[0]),
    }
}

/// Split every triangle with an edge that a finer neighbour divides into a fan through
/// the neighbour's points on it. None when a fan would fold.
fn stitch(mut mesh: TriMesh, levels: &[f64]) -> Option<TriMesh> {
    if levels.len() != mesh.triangles.len() {
        return None;
    }
    let mut tris: Vec<([u32; 3], f64)> = mesh
        .triangles
        .iter()
        .copied()
        .zip(levels.iter().copied())
        .collect();
    for _round in 0..64 {
        let mut directed: HashMap<(u32, u32), f64> = HashMap::with_capacity(tris.len() * 3);
        for (t, l) in &tris {
            for k in 0..3 {
                directed.insert((t[k], t[(k + 1) % 3]), *l);
            }
        }
        // Unmatched edges of finer triangles, by their start.
        let mut open_from: HashMap<u32, Vec<(u32, f64)>> = HashMap::new();
        for (&(a, b), &l) in &directed {
            if !directed.contains_key(&(b, a)) {
                open_from.entry(a).or_default().push((b, l));
            }
        }
        let mut changed = false;
        let mut out = Vec::with_capacity(tris.len());
        for &(t, l) in &tris {
            let split = (0..3).find_map(|k| {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if directed.contains_key(&(b, a)) {
                    return None;
                }
                chain(&mesh, &open_from, (b, a), l).map(|c| (k, c))
            });
            let Some((k, chain)) = split else {
                out.push((t, l));
                continue;
            };
            changed = true;
            // t = (a, b, c) with a→b divided: a → chain reversed → b, fanned from c.
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let mut path = vec![a];
            path.extend(chain.iter().rev());
            path.push(b);
            let n0 = mesh.normal(&t);
            for w in path.windows(2) {
                let nt = [w[0], w[1], c];
                if dot3(mesh.normal(&nt), n0) <= 0.0 {
                    return None;
                }
                out.push((nt, l));
            }
        }
        tris = out;
        if !changed {
            mesh.triangles = tris.into_iter().map(|(t, _)| t).collect();
            return Some(mesh);
        }
    }
    None
}

fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The points strictly between `from` and `to` along unmatched edges of triangles finer
/// than `level` (the finer neighbour's side of a divided edge), in order from `from`.
/// Where two such edges leave a point (a corner shared by two refined faces), the one
/// nearer the chord `from`–`to` is taken; every point must lie within a few of the
/// coarse side's chord tolerances of that chord.
fn chain(
    mesh: &TriMesh,
    open_from: &HashMap<u32, Vec<(u32, f64)>>,
    (from, to): (u32, u32),
    level: f64,
) -> Option<Vec<u32>> {
    let (p, q) = (mesh.positions[from as usize], mesh.positions[to as usize]);
    let off_chord = |v: u32| point_segment(mesh.positions[v as usize], p, q);
    let reach = 4.0 * level + 1e-6;
    let mut out = Vec::new();
    let mut at = from;
    for _ in 0..100_000 {
        let next = open_from
            .get(&at)?
            .iter()
            .filter(|(_, l)| *l < level)
            .map(|(v, _)| *v)
            .filter(|&v| v == to || off_chord(v) <= reach)
            .min_by(|&a, &b| {
                let d = |v: u32| if v == to { -1.0 } else { off_chord(v) };
                d(a).total_cmp(&d(b))
            })?;
        if next == to {
            return (!out.is_empty()).then_some(out);
        }
        if out.contains(&next) {
            return None;
        }
        out.push(next);
        at = next;
    }
    None
}

/// Distance from `x` to the segment pq.
fn point_segment(x: [f64; 3], p: [f64; 3], q: [f64; 3]) -> f64 {
    let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
    let w = [x[0] - p[0], x[1] - p[1], x[2] - p[2]];
    let l = dot3(d, d);
    let t = if l > 0.0 {
        (dot3(w, d) / l).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let e = [w[0] - t * d[0], w[1] - t * d[1], w[2] - t * d[2]];
    dot3(e, e).sqrt()
}
