//! Linear static solve of an axisymmetric problem: degree-of-freedom map with ties and
//! supports, reverse Cuthill–McKee ordering, sparse assembly and a sparse Cholesky
//! factorisation (nalgebra-sparse `CscCholesky`).
//!
//! Two interchangeable linear solvers sit behind [`LinearSolver`]: nalgebra-sparse's
//! general sparse Cholesky ([`SparseCholesky`]) and a hand-written envelope (skyline)
//! Cholesky ([`EnvelopeCholesky`]) whose rows are contiguous, so its inner loops are
//! plain dot products; after RCM the envelope holds the same fill as the sparse factor.
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
    /// Assemble and solve K u = f with the default solver ([`EnvelopeCholesky`]).
    pub fn solve(&self) -> Result<Solution> {
        self.solve_with(&EnvelopeCholesky)
    }

    /// Assemble and solve K u = f with the given linear solver.
    pub fn solve_with(&self, solver: &dyn LinearSolver) -> Result<Solution> {
        let f = self.factor_with(solver)?;
        f.solve_loads(&self.loads)
    }

    /// Assemble and factorise K once; the factor then solves any number of load cases
    /// (the contact solver needs one solve per contact pair).
    pub fn factor_with(&self, solver: &dyn LinearSolver) -> Result<FactoredProblem> {
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
            let mat = *self.materials.get(e.material).ok_or_else(|| {
                anyhow!(
                    "element refers to material {} which is not defined",
                    e.material
                )
            })?;
            let ke = element::stiffness(&xy, mat, self.formulation)?;
            for (a, da) in d.iter().enumerate() {
                let Some(ia) = da else { continue };
                for (c, dc) in d.iter().enumerate() {
                    let Some(ic) = dc else { continue };
                    coo.push(perm[*ia], perm[*ic], ke[a][c]);
                }
            }
        }
        let k = CscMatrix::from(&coo);
        drop(coo);
        let factor = solver
            .factor(&k)
            .context("the stiffness matrix is not positive definite: a part is not supported (rigid-body motion) or an element is degenerate")?;
        Ok(FactoredProblem {
            map,
            perm,
            unknowns: n,
            nodes: self.mesh.nodes.len(),
            factor,
        })
    }
}

/// An assembled and factorised stiffness matrix with its numbering of the unknowns.
pub struct FactoredProblem {
    map: Vec<Option<usize>>,
    perm: Vec<usize>,
    unknowns: usize,
    nodes: usize,
    factor: Box<dyn Factorization>,
}

impl FactoredProblem {
    /// Number of unknowns.
    pub fn unknowns(&self) -> usize {
        self.unknowns
    }

    /// The position of (node, component) in the solver's vector, `None` when the
    /// component is held at zero.
    pub fn unknown_of(&self, node: usize, component: Component) -> Option<usize> {
        self.map
            .get(2 * node + component)
            .copied()
            .flatten()
            .map(|i| self.perm[i])
    }

    /// Solve for nodal loads (node, component, N); loads on held components are dropped.
    pub fn solve_loads(&self, loads: &[(usize, Component, f64)]) -> Result<Solution> {
        let mut f = vec![0.0; self.unknowns];
        for &(node, c, value) in loads {
            if node >= self.nodes || c > 1 {
                bail!("load ({node}, {c}) refers to a node or component that does not exist");
            }
            if let Some(i) = self.unknown_of(node, c) {
                f[i] += value;
            }
        }
        self.factor.solve_in_place(&mut f);
        self.solution_from(&f)
    }

    /// Nodal displacements from a solution vector in the solver's numbering.
    pub fn solution_from(&self, u: &[f64]) -> Result<Solution> {
        let mut disp = vec![[0.0; 2]; self.nodes];
        for (node, dd) in disp.iter_mut().enumerate() {
            for (c, v) in dd.iter_mut().enumerate() {
                if let Some(i) = self.unknown_of(node, c) {
                    *v = u[i];
                }
            }
        }
        if disp.iter().any(|d| !d[0].is_finite() || !d[1].is_finite()) {
            bail!("the solve produced non-finite displacements");
        }
        Ok(Solution {
            displacement_mm: disp,
            unknowns: self.unknowns,
            factor_nonzeros: self.factor.nonzeros(),
        })
    }
}

/// A factorised symmetric positive definite matrix.
pub trait Factorization: Send + Sync {
    /// Overwrite `b` with the solution of K x = b.
    fn solve_in_place(&self, b: &mut [f64]);
    /// Non-zeros of the factor.
    fn nonzeros(&self) -> usize;
}

/// A direct solver for a symmetric positive definite system K u = f.
pub trait LinearSolver {
    /// Short name for tables.
    fn name(&self) -> &'static str;
    /// Factorise K.
    fn factor(&self, k: &CscMatrix<f64>) -> Result<Box<dyn Factorization>>;
    /// Solve; returns u and the number of non-zeros of the factor.
    fn solve(&self, k: &CscMatrix<f64>, f: &DVector<f64>) -> Result<(DVector<f64>, usize)> {
        let factor = self.factor(k)?;
        let mut u = f.clone();
        factor.solve_in_place(u.as_mut_slice());
        Ok((u, factor.nonzeros()))
    }
}

/// nalgebra-sparse's `CscCholesky` (up-looking sparse Cholesky, no reordering of its own).
#[derive(Debug, Clone, Copy, Default)]
pub struct SparseCholesky;

struct SparseFactor(CscCholesky<f64>);

impl Factorization for SparseFactor {
    fn solve_in_place(&self, b: &mut [f64]) {
        let u = self.0.solve(&DVector::from_column_slice(b));
        b.copy_from_slice(u.column(0).as_slice());
    }
    fn nonzeros(&self) -> usize {
        self.0.l().nnz()
    }
}

impl LinearSolver for SparseCholesky {
    fn name(&self) -> &'static str {
        "sparse Cholesky (nalgebra-sparse)"
    }
    fn factor(&self, k: &CscMatrix<f64>) -> Result<Box<dyn Factorization>> {
        let chol = CscCholesky::factor(k).map_err(|e| anyhow!("sparse Cholesky failed: {e:?}"))?;
        Ok(Box::new(SparseFactor(chol)))
    }
}

/// Dot product with eight independent partial sums, so the compiler can vectorise it
/// (a single running sum fixes the order of the additions and cannot be).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s: f64 = acc.iter().sum();
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// Envelope (skyline) Cholesky: row i of L is stored densely from its first non-zero
/// column to the diagonal; fill stays inside that envelope.
#[derive(Debug, Clone, Copy, Default)]
pub struct EnvelopeCholesky;

/// The envelope factor: row i of L from column `first[i]` to the diagonal, stored
/// contiguously from `start[i]`.
struct EnvelopeFactor {
    first: Vec<usize>,
    start: Vec<usize>,
    l: Vec<f64>,
}

impl Factorization for EnvelopeFactor {
    fn solve_in_place(&self, y: &mut [f64]) {
        let (first, start, l) = (&self.first, &self.start, &self.l);
        let n = first.len();
        // Forward L y = f, then backward Lᵀ u = y.
        for i in 0..n {
            let row = &l[start[i]..start[i + 1]];
            let fi = first[i];
            let dot = dot(&row[..i - fi], &y[fi..i]);
            y[i] = (y[i] - dot) / row[i - fi];
        }
        for i in (0..n).rev() {
            let row = &l[start[i]..start[i + 1]];
            let fi = first[i];
            y[i] /= row[i - fi];
            let yi = y[i];
            for (k, &lik) in row[..i - fi].iter().enumerate() {
                y[fi + k] -= lik * yi;
            }
        }
    }
    fn nonzeros(&self) -> usize {
        self.l.len()
    }
}

impl LinearSolver for EnvelopeCholesky {
    fn name(&self) -> &'static str {
        "envelope Cholesky"
    }
    fn factor(&self, k: &CscMatrix<f64>) -> Result<Box<dyn Factorization>> {
        let n = k.nrows();
        // First column of each row in the lower triangle (K is symmetric: use columns).
        let mut first: Vec<usize> = (0..n).collect();
        for (j, col) in k.col_iter().enumerate() {
            for &i in col.row_indices() {
                if i > j {
                    first[i] = first[i].min(j);
                }
            }
        }
        let mut start = vec![0usize; n + 1];
        for i in 0..n {
            start[i + 1] = start[i] + (i - first[i] + 1);
        }
        let mut l = vec![0.0; start[n]];
        for (j, col) in k.col_iter().enumerate() {
            for (&i, &v) in col.row_indices().iter().zip(col.values()) {
                if i >= j {
                    l[start[i] + (j - first[i])] += v;
                }
            }
        }
        for i in 0..n {
            let fi = first[i];
            for j in fi..i {
                let fj = first[j];
                let lo = fi.max(fj);
                let (head, row_i) = l.split_at_mut(start[i]);
                let row_j = &head[start[j]..start[j] + (j - fj + 1)];
                let a = &row_i[lo - fi..j - fi];
                let b = &row_j[lo - fj..j - fj];
                let dot = dot(a, b);
                let d = row_j[j - fj];
                row_i[j - fi] = (row_i[j - fi] - dot) / d;
            }
            let row_i = &mut l[start[i]..start[i + 1]];
            let (off, diag) = row_i.split_at_mut(i - fi);
            let s = diag[0] - off.iter().map(|x| x * x).sum::<f64>();
            if s.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !s.is_finite() {
                bail!("envelope Cholesky: pivot {i} is not positive ({s:.3e})");
            }
            diag[0] = s.sqrt();
        }
        Ok(Box::new(EnvelopeFactor { first, start, l }))
    }
}

impl Solution {
    /// Strain [ε_rr, ε_zz, ε_θθ, γ_rz] at (r, z), searching the given elements
    /// (all when `elements` is None). None when the point is outside them.
    pub fn strain_at(
        &self,
        mesh: &Mesh,
        elements: Option<&[usize]>,
        r: f64,
        z: f64,
    ) -> Option<[f64; 4]> {
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
                let u = e.nodes.map(|n| self.displacement_mm[n]);
                return Some(element::strain_at(&xy, &u, xi, eta));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn envelope_and_sparse_cholesky_agree_on_a_banded_spd_matrix() {
        // 1D Laplacian plus a long-range coupling: SPD, with a ragged envelope.
        let n = 40;
        let mut coo = CooMatrix::new(n, n);
        for i in 0..n {
            coo.push(i, i, 4.0);
            if i + 1 < n {
                coo.push(i, i + 1, -1.0);
                coo.push(i + 1, i, -1.0);
            }
            if i + 7 < n && i % 3 == 0 {
                coo.push(i, i + 7, -0.5);
                coo.push(i + 7, i, -0.5);
            }
        }
        let k = CscMatrix::from(&coo);
        let f = DVector::from_fn(n, |i, _| (i as f64).sin() + 1.0);
        let (a, _) = EnvelopeCholesky.solve(&k, &f).unwrap();
        let (b, _) = SparseCholesky.solve(&k, &f).unwrap();
        assert!((&a - &b).norm() < 1e-12 * b.norm());
        // And the residual is small.
        let r = &k * &a - &f;
        assert!(r.norm() < 1e-12 * f.norm());
    }

    #[test]
    fn envelope_cholesky_rejects_an_indefinite_matrix() {
        let mut coo = CooMatrix::new(2, 2);
        coo.push(0, 0, 1.0);
        coo.push(0, 1, 2.0);
        coo.push(1, 0, 2.0);
        coo.push(1, 1, 1.0);
        let k = CscMatrix::from(&coo);
        assert!(EnvelopeCholesky
            .solve(&k, &DVector::from_element(2, 1.0))
            .is_err());
    }

    #[test]
    fn rcm_is_a_permutation() {
        let adj = vec![vec![3], vec![2], vec![1, 3], vec![0, 2]];
        let mut p = reverse_cuthill_mckee(&adj);
        p.sort_unstable();
        assert_eq!(p, vec![0, 1, 2, 3]);
    }
}
