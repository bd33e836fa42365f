//! The mesh of the solid insert of Case I: a rectangle below the dome seam and an
//! O-grid above it, on the same stations as the walls so that the core's inner wall
//! can be tied to it node by node.

use super::stations::{point, Station, Stations, Surface};
use crate::fem::mesh::Mesh;
use crate::fem::solve::Z;
use crate::profile::ModuleProfile;

/// Mesh the solid insert of Case I: a rectangle below the dome seam, an O-grid (a
/// square and two ray blocks) above it, its base held axially. Returns the node on the
/// insert's surface at each station j (the core's inner wall is tied to them).
pub(super) fn mesh_insert(
    mesh: &mut Mesh,
    fixed: &mut Vec<(usize, usize)>,
    p: &ModuleProfile,
    s: &Stations,
    h: f64,
    zc: f64,
) -> Vec<usize> {
    let ins_surf = Surface {
        r: p.insert_radius_mm,
        rho: p.insert_sphere_radius_mm,
    };
    let sq = 0.5 * p.insert_radius_mm.min(p.insert_sphere_radius_mm);
    let n_rad = (((p.insert_radius_mm - sq) / h).ceil() as usize).max(1);
    let theta = |j: usize| match s.st[j] {
        Station::Theta(t) => t,
        Station::Z(_) => 0.0,
    };
    let n_e = s.j_45 - s.j_seam; // doubled steps along θ ∈ [0, 45°]
    let n_n = s.j_axis - s.j_45; // doubled steps along θ ∈ [45°, 90°]
                                 // Column abscissae of rectangle and square (doubled): square part then ray part.
    let mut xs: Vec<f64> = (0..=n_n)
        .map(|u| sq / theta(s.j_axis - u).tan().max(1e-300))
        .collect();
    xs[0] = 0.0;
    for k in 1..=2 * n_rad {
        xs.push(sq + (p.insert_radius_mm - sq) * k as f64 / (2 * n_rad) as f64);
    }
    let rect: Vec<Vec<usize>> = xs
        .iter()
        .map(|&x| {
            (0..=s.j_seam)
                .map(|j| {
                    let z = match s.st[j] {
                        Station::Z(z) => z,
                        Station::Theta(_) => zc,
                    };
                    mesh.add_node(x, z)
                })
                .collect()
        })
        .collect();
    mesh.add_block(&rect, 5);
    for col in &rect {
        fixed.push((col[0], Z));
    }
    // Square: columns share x with the rectangle, rows at y = sq tan θ.
    let square: Vec<Vec<usize>> = (0..=n_n)
        .map(|c| {
            (0..=n_e)
                .map(|t| {
                    if t == 0 {
                        rect[c][s.j_seam]
                    } else {
                        mesh.add_node(xs[c], zc + sq * theta(s.j_seam + t).tan())
                    }
                })
                .collect()
        })
        .collect();
    mesh.add_block(&square, 5);
    let ray = |mesh: &mut Mesh, inner: [f64; 2], j: usize, k: usize| {
        let o = point(ins_surf, s.st[j], zc);
        let t = k as f64 / (2 * n_rad) as f64;
        mesh.add_node(
            inner[0] + (o[0] - inner[0]) * t,
            inner[1] + (o[1] - inner[1]) * t,
        )
    };
    // East block: rays θ ∈ [0, 45°] from the square's right side to the surface.
    let east: Vec<Vec<usize>> = (0..=2 * n_rad)
        .map(|k| {
            (0..=n_e)
                .map(|t| {
                    if k == 0 {
                        square[n_n][t]
                    } else if t == 0 {
                        rect[n_n + k][s.j_seam]
                    } else {
                        let th = theta(s.j_seam + t);
                        ray(mesh, [sq, zc + sq * th.tan()], s.j_seam + t, k)
                    }
                })
                .collect()
        })
        .collect();
    mesh.add_block(&east, 5);
    // North block: rays θ ∈ [45°, 90°] from the square's top side to the surface.
    let north: Vec<Vec<usize>> = (0..=2 * n_rad)
        .map(|k| {
            (0..=n_n)
                .map(|u| {
                    if k == 0 {
                        square[n_n - u][n_e]
                    } else if u == 0 {
                        east[k][n_e]
                    } else {
                        ray(mesh, [xs[n_n - u], zc + sq], s.j_45 + u, k)
                    }
                })
                .collect()
        })
        .collect();
    mesh.add_block(&north, 5);
    (0..=s.j_axis)
        .map(|j| {
            if j <= s.j_seam {
                rect[xs.len() - 1][j]
            } else if j <= s.j_45 {
                east[2 * n_rad][j - s.j_seam]
            } else {
                north[2 * n_rad][j - s.j_45]
            }
        })
        .collect()
}
