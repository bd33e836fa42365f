//! Linear static solve of an axisymmetric problem: degree-of-freedom map with ties and
//! supports, reverse Cuthill–McKee ordering, sparse assembly and a sparse Cholesky
//! factorisation (nalgebra-sparse `CscCholesky`).
//!
//! Ties join two nodes' displacement components into one unknown (bonded parts whose
//! surfaces are a clearance apart, or a frictionless contact when only the normal
//! component is tied). `CscCholesky` does no fill-reducing reordering of its own, so
//! the unknowns are numbered by reverse Cuthill–McKee first: on the structured meshes
//! used here the fill then stays inside a narrow band.

use super::element::{self, ElasticConstants, Formulation};
use super::mesh::Mesh;
use anyhow::{anyhow, bail, Context, Result};
use nalgebra::DVector;
use nalgebra_sparse::factorization::CscCholesky;
use nalgebra_sparse::{CooMatrix, CscMatrix};
use std::collections::VecDeque;

/// Displacement component: 0 = radial u_r, 1 = axial u_z.
pub type Component = usize;
/// Radial component.
pub const R: Component = 0;
/// Axial component.
pub const Z: Component = 1;

/// A linear-elastic axisymmetric boundary-value problem on a mesh.
#[derive(Debug, Clone)]
pub struct Problem {
    /// The mesh (node coordinates and Q9 elements).
    pub mesh: Mesh,
    /// Material of each region (indexed by `Element::material`).
    pub materials: Vec<ElasticConstants>,
    /// Element formulation.
    pub formulation: Formulation,
    /// Zero displacements: (node, component).
    pub fixed: Vec<(usize, Component)>,
    /// Tied components: (node a, node b, component) share one unknown.
    pub ties: Vec<(usize, usize, Component)>,
    /// Nodal forces (node, component, N), resultants over the full circumference.
    pub loads: Vec<(usize, Component, f64)>,
}

/// The solved displacement field.
#[derive(Debug, Clone)]
pub struct Solution {
    /// (u_r, u_z) of every node, mm.
    pub displacement_mm: Vec<[f64; 2]>,
    /// Number of unknowns solved for.
    pub unknowns: usize,
    /// Non-zeros of the Cholesky factor.
    pub factor_nonzeros: usize,
}

fn find(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// Map from (node, component) to unknown index (None = fixed at zero).
fn dof_map(p: &Problem) -> Result<(Vec<Option<usize>>, usize)> {
    let n = p.mesh.nodes.len() * 2;
    let mut parent: Vec<usize> = (0..n).collect();
    for &(a, b, c) in &p.ties {
        if a >= p.mesh.nodes.len() || b >= p.mesh.nodes.len() || c > 1 {
            bail!("tie ({a}, {b}, {c}) refers to a node or component that does not exist");
        }
        let (ra, rb) = (find(&mut parent, 2 * a + c), find(&mut parent, 2 * b + c));
        if ra != rb {
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let mut fixed_root = vec![false; n];
    for &(node, c) in &p.fixed {
        if node >= p.mesh.nodes.len() || c > 1 {
            bail!("support ({node}, {c}) refers to a node or component that does not exist");
        }
        let r = find(&mut parent, 2 * node + c);
        fixed_root[r] = true;
    }
    // Only unknowns that some element touches get a number (unused nodes stay out).
    let mut used = vec![false; n];
    for e in &p.mesh.elements {
        for &nd in &e.nodes {
            used[2 * nd] = true;
            used[2 * nd + 1] = true;
        }
    }
    let mut root_index = vec![usize::MAX; n];
    let mut map = vec![None; n];
    let mut count = 0;
    for i in 0..n {
        if !used[i] {
            continue;
        }
        let r = find(&mut parent, i);
        if fixed_root[r] {
            continue;
        }
        if root_index[r] == usize::MAX {
            root_index[r] = count;
            count += 1;
        }
        map[i] = Some(root_index[r]);
    }
    Ok((map, count))
}

/// Reverse Cuthill–McKee permutation of a graph given by adjacency lists:
/// returns new index of each old vertex.
pub fn reverse_cuthill_mckee(adj: &[Vec<usize>]) -> Vec<usize> {
    let n = adj.len();
    let mut order = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let degree: Vec<usize> = adj.iter().map(|a| a.len()).collect();
    let mut by_degree: Vec<usize> = (0..n).collect();
    by_degree.sort_by_key(|&v| degree[v]);
    for &start in &by_degree {
        if seen[start] {
            continue;
        }
        // A pseudo-peripheral start: the last vertex reached by a BFS from `start`.
        let mut root = start;
        for _ in 0..2 {
            let mut level = vec![usize::MAX; n];
            let mut q = VecDeque::from([root]);
            level[root] = 0;
            let mut last = root;
            while let Some(v) = q.pop_front() {
                last = v;
                for &w in &adj[v] {
                    if level[w] == usize::MAX {
                        level[w] = level[v] + 1;
                        q.push_back(w);
                    }
                }
            }
            root = last;
        }
        let mut q = VecDeque::from([root]);
        seen[root] = true;
        while let Some(v) = q.pop_front() {
            order.push(v);
            let mut next: Vec<usize> = adj[v].iter().copied().filter(|&w| !seen[w]).collect();
            next.sort_by_key(|&w| degree[w]);
            for w in next {
                if !seen[w] {
                    seen[w] = true;
                    q.push_back(w);
                }
            }
        }
    }
    let mut new_index = vec![0; n];
    for (k, &v) in order.iter().rev().enumerate() {
        new_index[v] = k;
    }
    new_index
}

impl Problem {
    /// Assemble and solve K u = f.
    pub fn solve(&self) -> Result<Solution> {
        let (map, n) = dof_map(self)?;
        if n == 0 {
            bail!("the problem has no free unknowns");
        }
        // Element dof lists and the unknowns' graph for the ordering.
        let elem_dofs: Vec<[Option<usize>; 18]> = self
            .mesh
            .elements
            .iter()
            .map(|e| {
                let mut d = [None; 18];
                for (k, &nd) in e.nodes.iter().enumerate() {
                    d[2 * k] = map[2 * nd];
                    d[2 * k + 1] = map[2 * nd + 1];
                }
                d
            })
            .collect();
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
        for d in &elem_dofs {
            for a in d.iter().flatten() {
                for b in d.iter().flatten() {
                    if a != b {
                        adj[*a].push(*b);
                    }
                }
            }
        }
        for a in adj.iter_mut() {
            a.sort_unstable();
            a.dedup();
        }
        let perm = reverse_cuthill_mckee(&adj);
        drop(adj);

        let mut coo = CooMatrix::new(n, n);
        for (e, d) in self.mesh.elements.iter().zip(&elem_dofs) {
            let xy = self.mesh.element_coords(e);
            let mat = *self
                .materials
                .get(e.material)
                .ok_or_else(|| anyhow!("element refers to material {} which is not defined", e.material))?;
            let ke = element::stiffness(&xy, mat, self.formulation)?;
            for (a, da) in d.iter().enumerate() {
                let Some(ia) = da else { continue };
                for (c, dc) in d.iter().enumerate() {
                    let Some(ic) = dc else { continue };
                    coo.push(perm[*ia], perm[*ic], ke[a][c]);
                }
            }
        }
        let mut f = DVector::zeros(n);
        for &(node, c, value) in &self.loads {
            if let Some(Some(i)) = map.get(2 * node + c) {
                f[perm[*i]] += value;
            }
        }
        let k = CscMatrix::from(&coo);
        drop(coo);
        let chol = CscCholesky::factor(&k)
            .map_err(|e| anyhow!("{e:?}"))
            .context("the stiffness matrix is not positive definite: a part is not supported (rigid-body motion) or an element is degenerate")?;
        let factor_nonzeros = chol.l().nnz();
        let u = chol.solve(&f);
        let mut disp = vec![[0.0; 2]; self.mesh.nodes.len()];
        for (node, dd) in disp.iter_mut().enumerate() {
            for c in 0..2 {
                if let Some(i) = map[2 * node + c] {
                    dd[c] = u[(perm[i], 0)];
                }
            }
        }
        if disp.iter().any(|d| !d[0].is_finite() || !d[1].is_finite()) {
            bail!("the solve produced non-finite displacements");
        }
        Ok(Solution {
            displacement_mm: disp,
            unknowns: n,
            factor_nonzeros,
        })
    }
}

impl Solution {
    /// Strain [ε_rr, ε_zz, ε_θθ, γ_rz] at (r, z), searching the given elements
    /// (all when `elements` is None). None when the point is outside them.
    pub fn strain_at(&self, mesh: &Mesh, elements: Option<&[usize]>, r: f64, z: f64) -> Option<[f64; 4]> {
        let all: Vec<usize>;
        let list = match elements {
            Some(l) => l,
            None => {
                all = (0..mesh.elements.len()).collect();
                &all
            }
        };
        for &ei in list {
            let e = &mesh.elements[ei];
            let xy = mesh.element_coords(e);
            let (mut r0, mut r1, mut z0, mut z1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
            for p in &xy {
                r0 = r0.min(p[0]);
                r1 = r1.max(p[0]);
                z0 = z0.min(p[1]);
                z1 = z1.max(p[1]);
            }
            let pad = 1e-9 * (1.0 + r1.abs() + z1.abs());
            if r < r0 - pad || r > r1 + pad || z < z0 - pad || z > z1 + pad {
                continue;
            }
            if let Some((xi, eta)) = element::locate(&xy, r, z) {
                let mut u = [[0.0; 2]; 9];
                for k in 0..9 {
                    u[k] = self.displacement_mm[e.nodes[k]];
                }
                return Some(element::strain_at(&xy, &u, xi, eta));
            }
        }
        None
    }
}
