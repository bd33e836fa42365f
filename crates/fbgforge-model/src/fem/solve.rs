//! Linear static solve of an axisymmetric problem: degree-of-freedom map with ties and
//! supports, sparse assembly and a direct solve by one of the interchangeable sparse
//! Cholesky solvers of [`crate::fem::linear`] (faer's, with an AMD ordering, by default).
//!
//! Ties join two nodes' displacement components into one unknown (bonded parts whose
//! surfaces are a clearance apart, or a frictionless contact when only the normal
//! component is tied). An [`Interpolation`] makes a component follow three others (a
//! node in the middle of a coarser neighbour's quadratic edge: the two meshes then
//! stay conforming across a 2:1 change of element size); it is eliminated, not solved
//! for (K̄ = Tᵀ K T).
//!
//! **Structure apart from values.** What does not depend on the moduli is computed
//! once per problem shape, in a [`ProblemStructure`]: the numbering of the unknowns,
//! the stiffness matrix's pattern, where each element's entries go in it, each
//! element's stiffness per unit shear and bulk modulus
//! ([`element::StiffnessParts`]) and the solver's symbolic analysis (ordering, factor
//! structure). A change of moduli (another core or insert, a sweep over E) is then
//! one pass over the elements to sum μ·shear + κ·bulk and one numeric factorisation
//! ([`ProblemStructure::factor`]); `crate::fem::cache` keeps structures across solves.

use super::element::{self, ElasticConstants, Formulation};
use super::mesh::Mesh;
use anyhow::{anyhow, bail, Context, Result};
use std::sync::Arc;

pub use super::linear::{
    reverse_cuthill_mckee, EnvelopeCholesky, Factorization, LinearSolver, LowerPattern, SparseLlt,
    SymbolicFactorization,
};

/// Displacement component: 0 = radial u_r, 1 = axial u_z.
pub(crate) type Component = usize;
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
    /// Components that follow others (hanging nodes on a coarser edge).
    pub interpolations: Vec<Interpolation>,
    /// Nodal forces (node, component, N), resultants over the full circumference.
    pub loads: Vec<(usize, Component, f64)>,
}

/// A component of one node that follows the same component of three others:
/// u(node) = Σ weight · u(master), e.g. a node at s = ±½ on a quadratic edge whose
/// nodes sit at s = −1, 0, 1 (weights ⅜, ¾, −⅛).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interpolation {
    /// The following node.
    pub node: usize,
    /// Its component that follows (the masters' same component).
    pub component: Component,
    /// (master node, weight).
    pub masters: [(usize, f64); 3],
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

/// The unknowns a following component is made of: (unknown, weight), held masters
/// left out, masters sharing an unknown merged.
type Terms = Vec<(usize, f64)>;

/// The numbering of a problem's unknowns: for each component (index 2·node + c) its
/// unknown (None = fixed at zero, or following others), the number of unknowns, and
/// the following components (by component index) with their terms.
type DofMap = (Vec<Option<usize>>, usize, Vec<(usize, Terms)>);

/// The components that follow others (by component index), the interpolations
/// checked: they name existing nodes and components, finite weights, masters that
/// follow no one, and components neither tied nor held.
fn following_components(p: &Problem) -> Result<Vec<bool>> {
    let n = p.mesh.nodes.len() * 2;
    let mut follows = vec![false; n];
    for f in &p.interpolations {
        let exists = f.node < p.mesh.nodes.len()
            && f.component <= 1
            && f.masters.iter().all(|&(m, _)| m < p.mesh.nodes.len());
        if !exists {
            bail!(
                "interpolation of ({}, {}) refers to a node or component that does not exist",
                f.node,
                f.component
            );
        }
        if f.masters.iter().any(|&(_, w)| !w.is_finite()) {
            bail!(
                "interpolation of ({}, {}): every weight must be a finite number",
                f.node,
                f.component
            );
        }
        follows[2 * f.node + f.component] = true;
    }
    for f in &p.interpolations {
        if f.masters.iter().any(|&(m, _)| follows[2 * m + f.component]) {
            bail!(
                "interpolation of ({}, {}): a master follows others too",
                f.node,
                f.component
            );
        }
    }
    // A following component is eliminated, so it may be neither tied nor held.
    let mut tied_or_held = vec![false; n];
    for &(a, b, c) in &p.ties {
        for i in [2 * a + c, 2 * b + c] {
            if let Some(t) = tied_or_held.get_mut(i) {
                *t = true;
            }
        }
    }
    for &(a, c) in &p.fixed {
        if let Some(t) = tied_or_held.get_mut(2 * a + c) {
            *t = true;
        }
    }
    if let Some(f) = p
        .interpolations
        .iter()
        .find(|f| tied_or_held[2 * f.node + f.component])
    {
        bail!(
            "interpolation of ({}, {}): the component is also tied or held",
            f.node,
            f.component
        );
    }
    Ok(follows)
}

/// Ties merged (union–find over component indices) and supports marked on their
/// roots: each component's parent and whether each root is held.
fn merged_components(p: &Problem) -> Result<(Vec<usize>, Vec<bool>)> {
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
    Ok((parent, fixed_root))
}

/// The [`DofMap`] of a problem: ties merged, supports held, interpolations resolved.
fn dof_map(p: &Problem) -> Result<DofMap> {
    let n = p.mesh.nodes.len() * 2;
    let follows = following_components(p)?;
    let (mut parent, fixed_root) = merged_components(p)?;
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
        if !used[i] || follows[i] {
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
    let mut following: Vec<(usize, Terms)> = p
        .interpolations
        .iter()
        .map(|f| {
            let mut terms: Terms = Vec::with_capacity(3);
            for &(m, w) in &f.masters {
                if let Some(u) = map[2 * m + f.component] {
                    match terms.iter_mut().find(|t| t.0 == u) {
                        Some(t) => t.1 += w,
                        None => terms.push((u, w)),
                    }
                }
            }
            (2 * f.node + f.component, terms)
        })
        .collect();
    following.sort_by_key(|t| t.0);
    if following.windows(2).any(|w| w[0].0 == w[1].0) {
        bail!("a component follows two interpolations");
    }
    Ok((map, count, following))
}

/// Entries of an element matrix's upper triangle (diagonal included): 18 · 19 / 2.
const ELEMENT_ENTRIES: usize = 171;

/// The part of a problem's solve that does not depend on the moduli (see the module
/// documentation): built once per mesh with its ties and supports, then factorised
/// for any set of materials by [`ProblemStructure::factor`].
pub struct ProblemStructure {
    map: Vec<Option<usize>>,
    /// Components that follow others, by component index, with their terms.
    following: Vec<(usize, Terms)>,
    unknowns: usize,
    nodes: usize,
    pattern: LowerPattern,
    /// Material (region) index of each element.
    element_material: Vec<usize>,
    /// For each element, its [`ELEMENT_ENTRIES`] upper-triangle entries (a ≤ c): the
    /// position in the pattern's values, `u32::MAX` when a component is held.
    slots: Vec<u32>,
    /// Those entries' stiffness per unit shear modulus, doubled where two of the
    /// element's components share one unknown (both (a, c) and (c, a) land on it).
    shear: Vec<f64>,
    /// The same per unit bulk modulus.
    bulk: Vec<f64>,
    /// Entries that involve a following component (held out of `slots`): (slot,
    /// element, stiffness per unit shear and bulk modulus, weights applied).
    spread: Vec<(u32, u32, f64, f64)>,
    symbolic: Box<dyn SymbolicFactorization>,
    solver: &'static str,
}

impl std::fmt::Debug for ProblemStructure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ProblemStructure")
            .field("unknowns", &self.unknowns)
            .field("pattern_nonzeros", &self.pattern.nonzeros())
            .field("elements", &self.element_material.len())
            .field("solver", &self.solver)
            .finish()
    }
}

impl Problem {
    /// Assemble and solve K u = f with the default solver ([`SparseLlt`]).
    pub fn solve(&self) -> Result<Solution> {
        self.solve_with(&SparseLlt::default())
    }

    /// Assemble and solve K u = f with the given linear solver.
    pub(crate) fn solve_with(&self, solver: &dyn LinearSolver) -> Result<Solution> {
        let f = self.factor_with(solver)?;
        f.solve_loads(&self.loads)
    }

    /// Assemble and factorise K once; the factor then solves any number of load cases
    /// (the contact solver needs one solve per contact pair).
    pub fn factor_with(&self, solver: &dyn LinearSolver) -> Result<FactoredProblem> {
        Arc::new(self.structure(solver)?).factor(&self.materials)
    }

    /// Everything of this problem's solve that does not depend on the moduli, with
    /// `solver`'s symbolic analysis.
    pub fn structure(&self, solver: &dyn LinearSolver) -> Result<ProblemStructure> {
        let (map, n, following) = dof_map(self)?;
        if n == 0 {
            bail!("the problem has no free unknowns");
        }
        let numbering = Numbering {
            map: &map,
            following: &following,
        };
        let elem_dofs = numbering.element_dofs(&self.mesh);
        let elem_unknowns = numbering.element_unknowns(&self.mesh, &elem_dofs);
        let pattern = LowerPattern::from_elements(n, &elem_unknowns);
        if pattern.nonzeros() >= u32::MAX as usize {
            bail!(
                "the stiffness matrix has {} stored entries, more than this solver addresses",
                pattern.nonzeros()
            );
        }
        let entries = self.element_entries(&numbering, &elem_dofs, &pattern)?;
        let symbolic = solver.analyse(&pattern)?;
        Ok(ProblemStructure {
            map,
            following,
            spread: entries.spread,
            unknowns: n,
            nodes: self.mesh.nodes.len(),
            pattern,
            element_material: self.mesh.elements.iter().map(|e| e.material).collect(),
            slots: entries.slots,
            shear: entries.shear,
            bulk: entries.bulk,
            symbolic,
            solver: solver.name(),
        })
    }

    /// Where each element's upper-triangle entries land in `pattern`, with their
    /// stiffness per unit shear and bulk modulus; entries that involve a following
    /// component spread over its masters' unknowns.
    fn element_entries(
        &self,
        numbering: &Numbering,
        elem_dofs: &[[Option<usize>; 18]],
        pattern: &LowerPattern,
    ) -> Result<ElementEntries> {
        let ne = self.mesh.elements.len();
        let mut out = ElementEntries {
            slots: Vec::with_capacity(ne * ELEMENT_ENTRIES),
            shear: Vec::with_capacity(ne * ELEMENT_ENTRIES),
            bulk: Vec::with_capacity(ne * ELEMENT_ENTRIES),
            spread: Vec::new(),
        };
        let slot_of = |p: usize, q: usize| -> u32 {
            pattern
                .position(p.max(q), p.min(q))
                .expect("every element entry is in the pattern") as u32
        };
        for (ei, (e, d)) in self.mesh.elements.iter().zip(elem_dofs).enumerate() {
            let parts = element::stiffness_parts(&self.mesh.element_coords(e), self.formulation)?;
            // Each local component as terms (a plain unknown is one term of weight 1).
            // (An array of references: no allocation for the elements without one.)
            let local_terms: [Option<&Terms>; 18] = std::array::from_fn(|k| match d[k] {
                Some(_) => None,
                None => numbering.terms_of(2 * e.nodes[k / 2] + k % 2),
            });
            for a in 0..18 {
                for c in a..18 {
                    if local_terms[a].is_some() || local_terms[c].is_some() {
                        // K̄ = Tᵀ K T over this entry (and its transpose when a < c).
                        let one = |k: usize| -> Terms {
                            match (local_terms[k], d[k]) {
                                (Some(t), _) => t.clone(),
                                (None, Some(i)) => vec![(i, 1.0)],
                                (None, None) => vec![],
                            }
                        };
                        let (ta, tc) = (one(a), one(c));
                        for (x, &(p, wp)) in ta.iter().enumerate() {
                            let partners = if a == c { &tc[x..] } else { &tc[..] };
                            for &(q, wq) in partners {
                                let m = if a != c && p == q { 2.0 } else { 1.0 };
                                out.spread.push((
                                    slot_of(p, q),
                                    ei as u32,
                                    m * wp * wq * parts.shear[a][c],
                                    m * wp * wq * parts.bulk[a][c],
                                ));
                            }
                        }
                        out.slots.push(u32::MAX);
                        out.shear.push(0.0);
                        out.bulk.push(0.0);
                        continue;
                    }
                    let (slot, twice) = match (d[a], d[c]) {
                        (Some(i), Some(j)) => (slot_of(i, j), a != c && i == j),
                        _ => (u32::MAX, false),
                    };
                    let m = if twice { 2.0 } else { 1.0 };
                    out.slots.push(slot);
                    out.shear.push(m * parts.shear[a][c]);
                    out.bulk.push(m * parts.bulk[a][c]);
                }
            }
        }
        Ok(out)
    }
}

/// A problem's numbering of its unknowns, as the elements read it.
struct Numbering<'a> {
    /// Each component's unknown.
    map: &'a [Option<usize>],
    /// The following components with their terms, by component index.
    following: &'a [(usize, Terms)],
}

impl Numbering<'_> {
    /// The terms of a following component.
    fn terms_of(&self, i: usize) -> Option<&Terms> {
        self.following
            .binary_search_by_key(&i, |t| t.0)
            .ok()
            .map(|k| &self.following[k].1)
    }

    /// Each element's 18 components' unknowns.
    fn element_dofs(&self, mesh: &Mesh) -> Vec<[Option<usize>; 18]> {
        mesh.elements
            .iter()
            .map(|e| {
                let mut d = [None; 18];
                for (k, &nd) in e.nodes.iter().enumerate() {
                    d[2 * k] = self.map[2 * nd];
                    d[2 * k + 1] = self.map[2 * nd + 1];
                }
                d
            })
            .collect()
    }

    /// Every unknown an element couples, a following component's masters included
    /// (at most 3 per component).
    fn element_unknowns(
        &self,
        mesh: &Mesh,
        elem_dofs: &[[Option<usize>; 18]],
    ) -> Vec<[Option<usize>; 54]> {
        mesh.elements
            .iter()
            .zip(elem_dofs)
            .map(|(e, d)| {
                let mut u = [None; 54];
                let mut k = 0;
                for (local, &nd) in e.nodes.iter().enumerate() {
                    for c in 0..2 {
                        if let Some(i) = d[2 * local + c] {
                            u[k] = Some(i);
                            k += 1;
                        } else if let Some(terms) = self.terms_of(2 * nd + c) {
                            for &(i, _) in terms {
                                u[k] = Some(i);
                                k += 1;
                            }
                        }
                    }
                }
                u
            })
            .collect()
    }
}

/// Each element's upper-triangle entries: where they land, their stiffness per unit
/// moduli, and those spread over a following component's masters.
struct ElementEntries {
    slots: Vec<u32>,
    shear: Vec<f64>,
    bulk: Vec<f64>,
    spread: Vec<(u32, u32, f64, f64)>,
}

impl ProblemStructure {
    /// Number of unknowns.
    pub fn unknowns(&self) -> usize {
        self.unknowns
    }

    /// The lower triangle's pattern of the stiffness matrix, in the numbering of the
    /// unknowns.
    pub fn pattern(&self) -> &LowerPattern {
        &self.pattern
    }

    /// Bytes this structure holds (without the solver's symbolic analysis), for the
    /// cache's budget.
    pub(crate) fn approximate_bytes(&self) -> usize {
        self.map.len() * 16
            + self.pattern.nonzeros() * 8
            + self.element_material.len() * 8
            + self.slots.len() * (4 + 8 + 8)
            + self.spread.len() * 24
            + self.following.len() * 64
    }

    /// The values of K's lower triangle (in [`Self::pattern`]'s order) for these
    /// materials (indexed by the elements' region numbers).
    pub fn assemble(&self, materials: &[ElasticConstants]) -> Result<Vec<f64>> {
        let mut values = vec![0.0; self.pattern.nonzeros()];
        for (e, &m) in self.element_material.iter().enumerate() {
            let mat = materials
                .get(m)
                .ok_or_else(|| anyhow!("element refers to material {m} which is not defined"))?;
            let (mu, kappa) = (mat.shear_modulus_mpa(), mat.bulk_modulus_mpa());
            let range = e * ELEMENT_ENTRIES..(e + 1) * ELEMENT_ENTRIES;
            for ((&s, &a), &b) in self.slots[range.clone()]
                .iter()
                .zip(&self.shear[range.clone()])
                .zip(&self.bulk[range])
            {
                if s != u32::MAX {
                    values[s as usize] += mu * a + kappa * b;
                }
            }
        }
        for &(s, e, a, b) in &self.spread {
            let mat = &materials[self.element_material[e as usize]];
            values[s as usize] += mat.shear_modulus_mpa() * a + mat.bulk_modulus_mpa() * b;
        }
        Ok(values)
    }

    /// Assemble K for these materials and factorise it (numeric phase only).
    pub fn factor(self: &Arc<Self>, materials: &[ElasticConstants]) -> Result<FactoredProblem> {
        let values = self.assemble(materials)?;
        let factor = self
            .symbolic
            .factor(&values)
            .context("the stiffness matrix is not positive definite: a part is not supported (rigid-body motion) or an element is degenerate")?;
        Ok(FactoredProblem {
            structure: Arc::clone(self),
            factor,
        })
    }
}

/// An assembled and factorised stiffness matrix with its numbering of the unknowns.
pub struct FactoredProblem {
    structure: Arc<ProblemStructure>,
    factor: Box<dyn Factorization>,
}

impl FactoredProblem {
    /// Number of unknowns.
    pub fn unknowns(&self) -> usize {
        self.structure.unknowns
    }

    /// The position of (node, component) in the solver's vector, `None` when the
    /// component is held at zero or follows others ([`Interpolation`]).
    pub(crate) fn unknown_of(&self, node: usize, component: Component) -> Option<usize> {
        self.structure
            .map
            .get(2 * node + component)
            .copied()
            .flatten()
    }

    /// The terms of a following component, `None` for any other.
    fn following(&self, node: usize, component: Component) -> Option<&Terms> {
        let f = &self.structure.following;
        f.binary_search_by_key(&(2 * node + component), |t| t.0)
            .ok()
            .map(|k| &f[k].1)
    }

    /// The load vector of nodal loads (node, component, N); loads on held components
    /// are dropped.
    fn load_vector(&self, loads: &[(usize, Component, f64)], f: &mut [f64]) -> Result<()> {
        for &(node, c, value) in loads {
            if node >= self.structure.nodes || c > 1 {
                bail!("load ({node}, {c}) refers to a node or component that does not exist");
            }
            if let Some(i) = self.unknown_of(node, c) {
                f[i] += value;
            } else if let Some(terms) = self.following(node, c) {
                for &(i, w) in terms {
                    f[i] += w * value;
                }
            }
        }
        Ok(())
    }

    /// Solve for nodal loads (node, component, N); loads on held components are dropped.
    pub fn solve_loads(&self, loads: &[(usize, Component, f64)]) -> Result<Solution> {
        let mut f = vec![0.0; self.unknowns()];
        self.load_vector(loads, &mut f)?;
        self.factor.solve_in_place(&mut f);
        self.solution_from(&f)
    }

    /// Solve several load cases at once (one blocked solve: faster than one at a time
    /// with the supernodal solver).
    pub fn solve_load_cases(
        &self,
        cases: &[Vec<(usize, Component, f64)>],
    ) -> Result<Vec<Solution>> {
        let n = self.unknowns();
        let mut out = Vec::with_capacity(cases.len());
        // Blocks of 32 right-hand sides keep the workspace small.
        for block in cases.chunks(32) {
            let mut f = vec![0.0; n * block.len()];
            for (loads, col) in block.iter().zip(f.chunks_exact_mut(n)) {
                self.load_vector(loads, col)?;
            }
            self.factor.solve_columns_in_place(&mut f, block.len());
            for col in f.chunks_exact(n) {
                out.push(self.solution_from(col)?);
            }
        }
        Ok(out)
    }

    /// Solve several load cases and leave the solutions in the solver's numbering
    /// (column-major, unknowns × cases): for a caller that reads a few components of
    /// each ([`Self::component_value`]) and combines columns before building one
    /// [`Solution`] ([`Self::solution_from`]), instead of a full [`Solution`] per case.
    pub(crate) fn solve_load_columns(
        &self,
        cases: &[Vec<(usize, Component, f64)>],
    ) -> Result<Vec<f64>> {
        let n = self.unknowns();
        let mut f = vec![0.0; n * cases.len()];
        for (loads, col) in cases.iter().zip(f.chunks_exact_mut(n)) {
            self.load_vector(loads, col)?;
        }
        // Blocks of 32 right-hand sides keep the workspace small.
        for block in f.chunks_mut(n * 32) {
            let columns = block.len() / n;
            self.factor.solve_columns_in_place(block, columns);
        }
        Ok(f)
    }

    /// The value of (node, component) in a solution vector in the solver's numbering
    /// (zero where the component is held).
    pub(crate) fn component_value(&self, u: &[f64], node: usize, component: Component) -> f64 {
        if let Some(i) = self.unknown_of(node, component) {
            u[i]
        } else if let Some(terms) = self.following(node, component) {
            terms.iter().map(|&(i, w)| w * u[i]).sum()
        } else {
            0.0
        }
    }

    /// Stored entries of the factor.
    pub(crate) fn factor_nonzeros(&self) -> usize {
        self.factor.nonzeros()
    }

    /// The structure this factor was made on.
    pub(crate) fn structure(&self) -> &Arc<ProblemStructure> {
        &self.structure
    }

    /// Nodal displacements from a solution vector in the solver's numbering.
    pub(crate) fn solution_from(&self, u: &[f64]) -> Result<Solution> {
        self.structure.solution_from(u, self.factor.nonzeros())
    }
}

impl ProblemStructure {
    /// Nodal displacements from a solution vector in the numbering of the unknowns,
    /// solved with a factor of `factor_nonzeros` entries.
    pub(crate) fn solution_from(&self, u: &[f64], factor_nonzeros: usize) -> Result<Solution> {
        let mut disp = vec![[0.0; 2]; self.nodes];
        for (node, dd) in disp.iter_mut().enumerate() {
            for (c, v) in dd.iter_mut().enumerate() {
                let i = 2 * node + c;
                if let Some(k) = self.map[i] {
                    *v = u[k];
                } else if let Ok(k) = self.following.binary_search_by_key(&i, |t| t.0) {
                    *v = self.following[k].1.iter().map(|&(j, w)| w * u[j]).sum();
                }
            }
        }
        if disp.iter().any(|d| !d[0].is_finite() || !d[1].is_finite()) {
            bail!("the solve produced non-finite displacements");
        }
        Ok(Solution {
            displacement_mm: disp,
            unknowns: self.unknowns,
            factor_nonzeros,
        })
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

    /// Two stacked Q9 elements of a ring (r 2..4 mm, z 0..2 mm), base held in z, a tie
    /// between two nodes and a load on top.
    fn ring() -> Problem {
        let mut mesh = Mesh::default();
        let mut ids = vec![vec![0; 5]; 5];
        for (i, row) in ids.iter_mut().enumerate() {
            for (j, id) in row.iter_mut().enumerate() {
                *id = mesh.add_node(2.0 + 0.5 * i as f64, 0.5 * j as f64);
            }
        }
        mesh.add_block(
            &[
                ids[0][..3].to_vec(),
                ids[1][..3].to_vec(),
                ids[2][..3].to_vec(),
            ],
            0,
        );
        mesh.add_block(
            &[
                ids[2][..3].to_vec(),
                ids[3][..3].to_vec(),
                ids[4][..3].to_vec(),
            ],
            1,
        );
        Problem {
            mesh,
            materials: vec![
                ElasticConstants {
                    youngs_modulus_mpa: 10.0,
                    poisson_ratio: 0.3,
                },
                ElasticConstants {
                    youngs_modulus_mpa: 3.0,
                    poisson_ratio: 0.49,
                },
            ],
            formulation: Formulation::MixedQ9P1,
            fixed: (0..5)
                .map(|i| (ids[i][0], Z))
                .chain([(ids[0][0], R)])
                .collect(),
            ties: vec![],
            interpolations: vec![],
            loads: (0..5).map(|i| (ids[i][2], Z, -0.1)).collect(),
        }
    }

    #[test]
    fn one_structure_serves_other_moduli_as_a_fresh_factorisation_would() {
        let p = ring();
        let structure = Arc::new(p.structure(&SparseLlt::default()).unwrap());
        let mut q = p.clone();
        q.materials[0].youngs_modulus_mpa = 70.0;
        q.materials[1].poisson_ratio = 0.45;
        for problem in [&p, &q] {
            let reused = structure
                .factor(&problem.materials)
                .unwrap()
                .solve_loads(&problem.loads)
                .unwrap();
            for solver in [
                &EnvelopeCholesky as &dyn LinearSolver,
                &SparseLlt::default(),
            ] {
                let fresh = problem.solve_with(solver).unwrap();
                let scale = fresh
                    .displacement_mm
                    .iter()
                    .map(|d| d[0].abs().max(d[1].abs()))
                    .fold(0.0, f64::max);
                assert!(scale > 0.0);
                for (a, b) in reused.displacement_mm.iter().zip(&fresh.displacement_mm) {
                    assert!((a[0] - b[0]).abs() < 1e-12 * scale);
                    assert!((a[1] - b[1]).abs() < 1e-12 * scale);
                }
            }
        }
        // The moduli moved the answer (so the comparison above could fail).
        let a = p.solve().unwrap().displacement_mm[22][1];
        let b = q.solve().unwrap().displacement_mm[22][1];
        assert!((a - b).abs() > 1e-3 * a.abs());
    }

    #[test]
    fn a_bad_interpolation_is_an_error_not_a_panic() {
        let p = ring();
        let held = p.fixed[0];
        let cases = [
            // Onto a held component.
            (
                held.0,
                held.1,
                [(1, 0.5), (2, 0.5), (3, 0.0)],
                "tied or held",
            ),
            // A master that does not exist.
            (7, R, [(1, 0.5), (999, 0.5), (3, 0.0)], "does not exist"),
            // A weight that is not a number.
            (7, R, [(1, f64::NAN), (2, 0.5), (3, 0.0)], "finite number"),
            // A master that follows others itself.
            (7, R, [(7, 1.0), (2, 0.0), (3, 0.0)], "a master follows"),
        ];
        for (node, component, masters, want) in cases {
            let mut q = p.clone();
            q.interpolations.push(Interpolation {
                node,
                component,
                masters,
            });
            let err = q.structure(&SparseLlt::default()).err().unwrap();
            assert!(err.to_string().contains(want), "{err}");
        }
    }

    #[test]
    fn a_missing_material_is_an_error_not_a_panic() {
        let p = ring();
        let s = Arc::new(p.structure(&SparseLlt::default()).unwrap());
        let err = s.factor(&p.materials[..1]).err().unwrap();
        assert!(err.to_string().contains("material 1"), "{err}");
    }

    #[test]
    fn blocked_solves_equal_single_solves() {
        let p = ring();
        let f = p.factor_with(&SparseLlt::default()).unwrap();
        let cases: Vec<Vec<(usize, Component, f64)>> = (0..40)
            .map(|k| vec![(k % 25, k % 2, 1.0 + k as f64)])
            .collect();
        let all = f.solve_load_cases(&cases).unwrap();
        for (c, s) in cases.iter().zip(&all) {
            let one = f.solve_loads(c).unwrap();
            assert_eq!(one.displacement_mm.len(), s.displacement_mm.len());
            for (a, b) in one.displacement_mm.iter().zip(&s.displacement_mm) {
                assert!((a[0] - b[0]).abs() <= 1e-12 * (1.0 + a[0].abs()));
                assert!((a[1] - b[1]).abs() <= 1e-12 * (1.0 + a[1].abs()));
            }
        }
    }
}
