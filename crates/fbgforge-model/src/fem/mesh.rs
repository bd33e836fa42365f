//! Meshes of Q9 elements in the (r, z) half-plane, and consistent edge loads.
//!
//! Blocks are built on a "doubled" logical grid: element (a, b) of a block owns nodes
//! (2a .. 2a+2, 2b .. 2b+2), so the mid-side and centre nodes of the quadratic
//! elements come from the same parametric map as the corners and curved boundaries
//! (the domes' spheres) are followed to third order.

use super::element::{lagrange3, lagrange3_d};
use std::f64::consts::PI;

/// A 9-node quadrilateral; node k = a + 3 b (a along the block's first index).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Element {
    /// Node indices.
    pub nodes: [usize; 9],
    /// Material (region) index.
    pub material: usize,
}

/// Nodes (r, z) in mm and Q9 elements.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    /// Node coordinates (r, z), mm.
    pub nodes: Vec<[f64; 2]>,
    /// Elements.
    pub elements: Vec<Element>,
}

impl Mesh {
    /// The nine node coordinates of an element.
    pub(crate) fn element_coords(&self, e: &Element) -> [[f64; 2]; 9] {
        e.nodes.map(|n| self.nodes[n])
    }

    /// Add a node, returning its index.
    pub fn add_node(&mut self, r: f64, z: f64) -> usize {
        self.nodes.push([r, z]);
        self.nodes.len() - 1
    }

    /// Add the elements of a block whose doubled node grid is `ids[i][j]`
    /// (i in 0..=2 n_i, j in 0..=2 n_j); returns the element indices.
    pub fn add_block(&mut self, ids: &[Vec<usize>], material: usize) -> std::ops::Range<usize> {
        let start = self.elements.len();
        let ni = (ids.len() - 1) / 2;
        let nj = (ids[0].len() - 1) / 2;
        for a in 0..ni {
            for b in 0..nj {
                let mut nodes = [0; 9];
                for beta in 0..3 {
                    for alpha in 0..3 {
                        nodes[alpha + 3 * beta] = ids[2 * a + alpha][2 * b + beta];
                    }
                }
                self.elements.push(Element { nodes, material });
            }
        }
        start..self.elements.len()
    }

    /// A structured rectangle r ∈ [r0, r1], z ∈ [z0, z1] with `nr` × `nz` elements;
    /// returns the mesh and its doubled node grid `[i][j]` (i along r, j along z).
    pub fn rectangle(
        r0: f64,
        r1: f64,
        z0: f64,
        z1: f64,
        nr: usize,
        nz: usize,
    ) -> (Mesh, Vec<Vec<usize>>) {
        let mut m = Mesh::default();
        let ids: Vec<Vec<usize>> = (0..=2 * nr)
            .map(|i| {
                (0..=2 * nz)
                    .map(|j| {
                        m.add_node(
                            r0 + (r1 - r0) * i as f64 / (2 * nr) as f64,
                            z0 + (z1 - z0) * j as f64 / (2 * nz) as f64,
                        )
                    })
                    .collect()
            })
            .collect();
        m.add_block(&ids, 0);
        (m, ids)
    }
}

/// Consistent nodal forces (N, over the full circumference) of a traction on a
/// quadratic element edge through nodes `xy[0..3]`, applied on the part s ∈ [s0, s1]
/// of its parameter range [-1, 1]. `traction(r, z, dr/ds, dz/ds)` returns the force
/// per unit parameter length per radian divided by r, i.e. the integrand is
/// N_i · traction · 2π r ds.
pub fn edge_forces(
    xy: [[f64; 2]; 3],
    s0: f64,
    s1: f64,
    traction: impl Fn(f64, f64, f64, f64) -> [f64; 2],
) -> [[f64; 2]; 3] {
    // 4-point Gauss: exact for the polynomial integrands of straight or quadratic edges
    // under constant traction per projected area.
    let gp = [
        -0.861_136_311_594_052_6,
        -0.339_981_043_584_856_3,
        0.339_981_043_584_856_3,
        0.861_136_311_594_052_6,
    ];
    let gw = [
        0.347_854_845_137_453_9,
        0.652_145_154_862_546_1,
        0.652_145_154_862_546_1,
        0.347_854_845_137_453_9,
    ];
    let mut f = [[0.0; 2]; 3];
    let half = 0.5 * (s1 - s0);
    for (p, w) in gp.iter().zip(gw) {
        let s = 0.5 * (s0 + s1) + half * p;
        let (n, dn) = (lagrange3(s), lagrange3_d(s));
        let (mut r, mut z, mut dr, mut dz) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..3 {
            r += n[k] * xy[k][0];
            z += n[k] * xy[k][1];
            dr += dn[k] * xy[k][0];
            dz += dn[k] * xy[k][1];
        }
        let t = traction(r, z, dr, dz);
        for k in 0..3 {
            for c in 0..2 {
                f[k][c] += n[k] * t[c] * 2.0 * PI * r * w * half;
            }
        }
    }
    f
}

/// Parameter s ∈ [-1, 1] on a quadratic edge where r(s) = `r_target`, by bisection
/// (r must be monotone along the edge).
pub(crate) fn edge_param_at_radius(xy: [[f64; 2]; 3], r_target: f64) -> f64 {
    let r_of = |s: f64| {
        let n = lagrange3(s);
        n[0] * xy[0][0] + n[1] * xy[1][0] + n[2] * xy[2][0]
    };
    let (mut lo, mut hi) = (-1.0, 1.0);
    let rising = r_of(hi) > r_of(lo);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if (r_of(mid) < r_target) == rising {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
