//! `bnb`: the `support` objective — min ‖Âz − y‖² + λ·|S| over supports of at most
//! K cells, 0 ≤ z ≤ u — solved exactly by depth-first branch and bound instead of
//! enumerating all C(n, ≤ K) supports.
//!
//! * **Order.** Cells are ranked once per frame: the cells of the non-negative least
//!   squares fit of the whole frame (largest load first), then the rest by their
//!   correlation with the frame. A node is a partial support P whose cells appear in
//!   that order; its children add one cell after P's last one. Supports that explain
//!   the frame are met early, so the incumbent is good from the start.
//! * **Node values.** Along a path the Cholesky factor L of ÂₚᵀÂₚ grows by one row
//!   per level, and with it the rows of M = L⁻¹Gₚ,· over every cell (O(n·|P|) per
//!   node). Every child P ∪ {j} then costs O(1): its residual is
//!   R(P) − (b_j − t_j)²/(G_jj − s_j), with s_j = Σ_r M_rj², t_j = Σ_r M_rj w_r,
//!   b = Âᵀy, w = L⁻¹bₚ (incremental Cholesky). A support whose unconstrained loads
//!   are all inside the box has that residual as its exact value; one with a
//!   negative load and none above its bound is a smaller support's solution (valued on
//!   its own); one with a load above its bound gets the exact bounded solve
//!   ([`bounded::box_qp`]), negative loads or not (at the ceiling a negative
//!   unconstrained load can hide a bounded optimum with every load positive).
//! * **Rivals** are not the search's business: the frame test ([`crate::trust`])
//!   computes them from the frame and the answer, the same for every method.
//! * **Bounds.** Every support below the child P ∪ {order[i]} lies within the cells
//!   P ∪ {order[i], order[i+1], …}. The non-negative least-squares residual over those
//!   cells (z ≥ 0 only: a relaxation of the box and of the cardinality) plus λ·|P ∪ c|
//!   is therefore a lower bound of the whole subtree. The bound only grows along the
//!   siblings (each drops one more cell from the set), so the first sibling whose
//!   bound reaches the incumbent ends the loop over siblings. The supports strictly
//!   below a child hold one load more, so their bound is λ higher: once that reaches
//!   the incumbent, the remaining siblings are only valued themselves (O(1) each, as
//!   leaves) and no relaxation is solved for them. Going from one sibling to the next
//!   removes one cell from the relaxation; the Lawson–Hanson solve is warm started
//!   (the factor downdated by Givens rotations, the passive fit one back
//!   substitution, the entering cell chosen from the residual in the gratings'
//!   space), and costs nothing when that cell carried no load.
//! * **Leaves.** At |P| = K − 1 the children are leaves, valued exactly in O(1) each
//!   without any relaxation.
//!
//! The search stops when every node is pruned (the answer is the certified optimum,
//! `converged`) or after a work budget (the best support found so far, not certified:
//! `converged = false`).

use super::*;

/// The registry entry of `bnb`.
pub(super) const ENTRY: MethodEntry = MethodEntry {
    name: "bnb",
    penalty_grid: doubling_grid,
    defaults: |prior| MethodSettings::BranchAndBound(BnbSettings::for_prior(prior)),
};

/// Default work budget of `bnb` per frame (units of [`BnbSettings::node_budget`];
/// 7–35 ms on the reference machine from 32 × 256 down to 8 × 16, see
/// `choice::ns_per_bnb_unit`).
pub const DEFAULT_NODE_BUDGET: u64 = 2_000_000;

/// Settings of `bnb`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BnbSettings {
    /// λ per non-zero load, pm² (the `support` objective).
    pub penalty: f64,
    /// Most simultaneous loads a support may hold (K). Capped at the number of
    /// gratings and cells.
    pub max_loads: usize,
    /// Work the search may do per frame before it stops with the best support found
    /// so far, marked not converged (not certified), in work units: one per support
    /// valued in O(1), and ~8 multiply-adds per unit for the pushes along a path and
    /// the relaxation's steps (what `bnb` reports as its `iterations`).
    pub node_budget: u64,
}

impl BnbSettings {
    /// For readings of this kind: λ from the resolution (as `support`), the load cap
    /// and [`DEFAULT_NODE_BUDGET`].
    pub fn for_prior(prior: &ReadingSettings) -> Self {
        BnbSettings {
            penalty: l0_penalty_for_resolution(prior.resolution_pm),
            max_loads: prior.max_loads,
            node_budget: DEFAULT_NODE_BUDGET,
        }
    }
}

impl Default for BnbSettings {
    /// The paper's readings.
    fn default() -> Self {
        Self::for_prior(&ReadingSettings::paper())
    }
}

impl Knobs for BnbSettings {
    fn method(&self) -> Method {
        Method::BranchAndBound
    }
    fn build(&self, common: Common) -> Result<Box<dyn Reconstructor>, ArrayError> {
        if self.max_loads == 0 {
            return Err(ArrayError::Input(
                "max_loads must be at least 1 for `bnb`".into(),
            ));
        }
        let kmax = self
            .max_loads
            .min(common.problem.n_gratings())
            .min(common.n());
        Ok(Box::new(BranchAndBound {
            gram_rows: (0..common.n())
                .map(|i| common.gram.row(i).iter().copied().collect())
                .collect(),
            columns: Columns {
                at: common.problem.working.as_slice().to_vec(), // column-major: column j contiguous
                m: common.problem.n_gratings(),
            },
            common,
            lambda: self.penalty,
            kmax,
            node_budget: self.node_budget,
        }))
    }
    fn penalty_mut(&mut self) -> Option<&mut f64> {
        Some(&mut self.penalty)
    }
    fn max_loads_mut(&mut self) -> Option<&mut usize> {
        Some(&mut self.max_loads)
    }
}

pub(super) struct BranchAndBound {
    pub(super) common: Common,
    pub(super) lambda: f64,
    /// Most loads in a support (K, capped at the number of gratings and cells).
    pub(super) kmax: usize,
    /// Nodes (supports valued plus relaxation updates) before the search gives up
    /// its certificate.
    pub(super) node_budget: u64,
    /// ÂᵀÂ row by row.
    gram_rows: Vec<Vec<f64>>,
    /// Â by columns (the Lawson–Hanson gradient).
    columns: Columns,
}

/// Lawson–Hanson non-negative least squares in Gram form over the allowed cells,
/// warm-startable: min zᵀGz − 2bᵀz, z ≥ 0, z_j = 0 off `allowed`. The Cholesky
/// factor of the passive cells' Gram block grows by one row per added cell.
#[derive(Clone)]
struct Nnls {
    z: Vec<f64>,
    passive: Vec<usize>,
    allowed: Vec<bool>,
    in_passive: Vec<bool>,
    /// Cholesky factor of the passive block, row-major with stride `cap`.
    l: Vec<f64>,
    cap: usize,
    /// Scratch: least-squares solution on the passive set.
    s: Vec<f64>,
    /// Scratch: the residual y − Âz (one entry per grating).
    r: Vec<f64>,
    /// u = L⁻¹bₚ, kept with the factor: the passive least-squares solution is then
    /// one back substitution, and its residual yᵀy − uᵀu.
    u: Vec<f64>,
    /// ‖Âz − y‖² at the optimum of the last `solve`.
    value: f64,
}

/// What the relaxation needs of the matrix and the frame.
struct FrameData<'a> {
    g: &'a [Vec<f64>],
    cols: &'a Columns,
    y: &'a [f64],
    b: &'a [f64],
    yty: f64,
    tol: f64,
}

/// The working matrix Â column by column (cell j's m entries contiguous).
struct Columns {
    at: Vec<f64>,
    m: usize,
}

impl Columns {
    fn col(&self, j: usize) -> &[f64] {
        &self.at[j * self.m..(j + 1) * self.m]
    }
}

impl Nnls {
    fn new(n: usize, m: usize, cap: usize) -> Self {
        Nnls {
            r: vec![0.0; m],
            u: vec![0.0; cap],
            value: f64::INFINITY,
            z: vec![0.0; n],
            passive: Vec::with_capacity(cap),
            allowed: vec![true; n],
            in_passive: vec![false; n],
            l: vec![0.0; cap * cap],
            cap,
            s: vec![0.0; cap],
        }
    }

    /// Append factor row `r` for cell `j` (the cells before it already factored);
    /// false when its column is numerically dependent on theirs.
    fn factor_row(&mut self, g: &[Vec<f64>], b: &[f64], r: usize, j: usize) -> bool {
        let cap = self.cap;
        let gj = &g[j];
        let mut d2 = gj[j];
        for q in 0..r {
            let mut v = gj[self.passive[q]];
            for t in 0..q {
                v -= self.l[r * cap + t] * self.l[q * cap + t];
            }
            let lv = v / self.l[q * cap + q];
            self.l[r * cap + q] = lv;
            d2 -= lv * lv;
        }
        if d2 <= 1e-12 * gj[j] {
            return false;
        }
        let d = d2.sqrt();
        self.l[r * cap + r] = d;
        let mut v = b[j];
        for t in 0..r {
            v -= self.l[r * cap + t] * self.u[t];
        }
        self.u[r] = v / d;
        true
    }

    /// Take the passive cell at `pos` out of the set and out of the factor: its row
    /// is deleted and the later rows, now one entry past the diagonal, are restored to
    /// triangular form by Givens rotations of adjacent columns — O((p − pos)²)
    /// instead of refactoring them (O((p − pos)·p²)), which the relaxation's updates
    /// did on nearly every sibling.
    fn drop_passive(&mut self, pos: usize) {
        let (p, cap) = (self.passive.len(), self.cap);
        let j = self.passive.remove(pos);
        self.in_passive[j] = false;
        self.z[j] = 0.0;
        let (l, u) = (&mut self.l, &mut self.u);
        for r in pos + 1..p {
            l.copy_within(r * cap..r * cap + r + 1, (r - 1) * cap);
        }
        for k in pos..p - 1 {
            let (a, b) = (l[k * cap + k], l[k * cap + k + 1]);
            let h = (a * a + b * b).sqrt(); // libm's hypot costs more than the rest
            let (c, s) = (a / h, b / h);
            for r in k..p - 1 {
                let (x, y) = (l[r * cap + k], l[r * cap + k + 1]);
                l[r * cap + k] = c * x + s * y;
                l[r * cap + k + 1] = c * y - s * x;
            }
            l[k * cap + k + 1] = 0.0;
            let (x, y) = (u[k], u[k + 1]);
            u[k] = c * x + s * y;
            u[k + 1] = c * y - s * x;
        }
    }

    /// Least squares on the passive set into `self.s`: Lᵀs = u.
    fn passive_solve(&mut self) {
        let (p, cap) = (self.passive.len(), self.cap);
        self.s[..p].copy_from_slice(&self.u[..p]);
        for r in (0..p).rev() {
            let mut v = self.s[r];
            for t in r + 1..p {
                v -= self.l[t * cap + r] * self.s[t];
            }
            self.s[r] = v / self.l[r * cap + r];
        }
    }

    /// Run Lawson–Hanson from the current feasible point (passive loads > 0, the
    /// factor up to date) to the optimum. Returns its work in units of ~8
    /// multiply-adds: each passive solve p²/8, each search for an entering cell n·m/8.
    fn solve(&mut self, f: &FrameData) -> u64 {
        let (g, cols, y, b, tol) = (f.g, f.cols, f.y, f.b, f.tol);
        let n = self.z.len();
        let mut solves = 0u64;
        let mut restore_only = true;
        // Whether z is the least-squares fit of the passive set (then its residual
        // is yᵀy − uᵀu).
        let mut at_fit = true;
        for _outer in 0..(3 * n + 10) {
            if !restore_only {
                // Most promising cell: largest b_j − (Gz)_j = Â_jᵀ(y − Âz) among the
                // others, from the residual in the gratings' space: contiguous
                // m-long dot products instead of gathers from the Gram rows.
                let m = cols.m;
                solves += 1 + (n * m / 8) as u64;
                self.r.copy_from_slice(y);
                for &q in &self.passive {
                    let (zq, aq) = (self.z[q], cols.col(q));
                    for (ri, &a) in self.r.iter_mut().zip(aq) {
                        *ri -= zq * a;
                    }
                }
                let mut best: Option<(usize, f64)> = None;
                for j in 0..n {
                    if !self.allowed[j] || self.in_passive[j] {
                        continue;
                    }
                    let aj = &cols.at[j * m..(j + 1) * m];
                    let w: f64 = aj.iter().zip(&self.r).map(|(a, r)| a * r).sum();
                    if w > tol && best.is_none_or(|(_, bw)| w > bw) {
                        best = Some((j, w));
                    }
                }
                let Some((j, _)) = best else {
                    self.set_value(f, at_fit);
                    return solves;
                };
                let r = self.passive.len();
                if r == self.cap || {
                    self.passive.push(j);
                    !self.factor_row(g, b, r, j)
                } {
                    // Full rank already, or a dependent column: the optimum is reached
                    // up to round-off.
                    if self.passive.len() > r {
                        self.passive.pop();
                    }
                    self.set_value(f, at_fit);
                    return solves;
                }
                self.in_passive[j] = true;
            }
            restore_only = false;
            // Inner loop: keep every passive load positive.
            for _inner in 0..(n + 5) {
                self.passive_solve();
                let p = self.passive.len();
                solves += 1 + (p * p / 8) as u64;
                at_fit = false;
                if self.s[..p].iter().all(|&v| v > 0.0) {
                    for a in 0..p {
                        self.z[self.passive[a]] = self.s[a];
                    }
                    at_fit = true;
                    break;
                }
                // Step towards s until the first load reaches zero; it leaves.
                let mut alpha = 1.0f64;
                let mut hit = None;
                for a in 0..p {
                    let q = self.passive[a];
                    if self.s[a] <= 0.0 {
                        let d = self.z[q] - self.s[a];
                        if d > 0.0 && self.z[q] / d < alpha {
                            alpha = self.z[q] / d;
                            hit = Some(q);
                        }
                    }
                }
                for a in 0..p {
                    let q = self.passive[a];
                    self.z[q] += alpha * (self.s[a] - self.z[q]);
                }
                if let Some(q) = hit {
                    self.z[q] = 0.0;
                }
                for a in (0..self.passive.len()).rev() {
                    if self.z[self.passive[a]] <= 0.0 {
                        self.drop_passive(a);
                    }
                }
            }
        }
        self.set_value(f, at_fit);
        solves
    }

    /// Cache ‖Âz − y‖² at the current point.
    fn set_value(&mut self, f: &FrameData, at_fit: bool) {
        self.value = if at_fit {
            let p = self.passive.len();
            (f.yty - self.u[..p].iter().map(|v| v * v).sum::<f64>()).max(0.0)
        } else {
            self.residual_at_z(f.g, f.b, f.yty)
        };
    }

    /// Forbid cell `c`; returns whether the optimum may have changed (it carried a
    /// load), in which case the factor is already updated and `solve` must run.
    fn remove(&mut self, c: usize) -> bool {
        self.allowed[c] = false;
        if let Some(pos) = self.passive.iter().position(|&q| q == c) {
            self.drop_passive(pos);
            true
        } else {
            false
        }
    }

    /// ‖Âz − y‖² at the current point: yᵀy − 2bᵀz + zᵀGz.
    fn residual_at_z(&self, g: &[Vec<f64>], b: &[f64], yty: f64) -> f64 {
        let mut quad = 0.0;
        let mut lin = 0.0;
        for &r in &self.passive {
            lin += b[r] * self.z[r];
            let gr = &g[r];
            let mut v = 0.0;
            for &q in &self.passive {
                v += gr[q] * self.z[q];
            }
            quad += self.z[r] * v;
        }
        (yty - 2.0 * lin + quad).max(0.0)
    }
}

/// The partial support of a node, with what makes its children cheap: row r of
/// M = L⁻¹Gₚ,· for every cell (L the Cholesky factor of the path's Gram block), and
/// per depth the running sums s_j = Σ_r M_rj² and t_j = Σ_r M_rj w_r (w = L⁻¹bₚ).
/// Then a child P ∪ {j} has pivot² G_jj − s_j and residual
/// R(P) − (b_j − t_j)² / (G_jj − s_j): O(1) per child after O(n·|P|) per node.
struct Path {
    n: usize,
    cells: Vec<usize>,
    /// Rows of M, K × n.
    m: Vec<f64>,
    /// Pivot (diagonal of L) per depth.
    d: Vec<f64>,
    w: Vec<f64>,
    /// s and t per depth, (K + 1) × n.
    s: Vec<f64>,
    t: Vec<f64>,
    /// Unconstrained residual per depth.
    residual: Vec<f64>,
    /// Work of the pushes so far (units of ~8 multiply-adds: n·(|P| + 1)/8 each).
    work: u64,
}

impl Path {
    fn new(n: usize, cap: usize, yty: f64) -> Self {
        let mut residual = vec![0.0; cap + 1];
        residual[0] = yty;
        Path {
            n,
            cells: Vec::with_capacity(cap),
            m: vec![0.0; cap * n],
            d: vec![0.0; cap],
            w: vec![0.0; cap],
            s: vec![0.0; (cap + 1) * n],
            t: vec![0.0; (cap + 1) * n],
            residual,
            work: 0,
        }
    }

    fn depth(&self) -> usize {
        self.cells.len()
    }

    fn residual(&self) -> f64 {
        self.residual[self.depth()]
    }

    /// Residual of the child P ∪ {j}, or None when j's column is (numerically) in the
    /// span of the path's.
    #[inline]
    fn child_residual(&self, g: &[Vec<f64>], b: &[f64], j: usize) -> Option<f64> {
        let p = self.depth();
        let den = g[j][j] - self.s[p * self.n + j];
        if den <= 1e-10 * g[j][j] {
            return None;
        }
        let num = b[j] - self.t[p * self.n + j];
        Some((self.residual[p] - num * num / den).max(0.0))
    }

    /// Whether the child P ∪ {j} gives j a positive load in its unconstrained fit
    /// (w_j > 0: the last load of the factor, before the others are corrected).
    #[inline]
    fn child_pushes_up(&self, b: &[f64], j: usize) -> bool {
        b[j] - self.t[self.depth() * self.n + j] > 0.0
    }

    /// Descend to the child P ∪ {c}; false (and no change) when c is dependent.
    fn push(&mut self, g: &[Vec<f64>], b: &[f64], c: usize) -> bool {
        let (p, n) = (self.depth(), self.n);
        let den = g[c][c] - self.s[p * n + c];
        if den <= 1e-10 * g[c][c] {
            return false;
        }
        self.work += 1 + (n * (p + 1) / 8) as u64;
        let d = den.sqrt();
        let w = (b[c] - self.t[p * n + c]) / d;
        let (before, row) = self.m.split_at_mut(p * n);
        let row = &mut row[..n];
        row.copy_from_slice(&g[c]);
        for r in 0..p {
            let mr = &before[r * n..(r + 1) * n];
            let f = mr[c];
            for (x, &v) in row.iter_mut().zip(mr) {
                *x -= f * v;
            }
        }
        let inv = 1.0 / d;
        let (s_old, s_new) = self.s.split_at_mut((p + 1) * n);
        let (t_old, t_new) = self.t.split_at_mut((p + 1) * n);
        let (s_old, t_old) = (&s_old[p * n..], &t_old[p * n..]);
        for j in 0..n {
            let v = row[j] * inv;
            row[j] = v;
            s_new[j] = s_old[j] + v * v;
            t_new[j] = t_old[j] + v * w;
        }
        self.d[p] = d;
        self.w[p] = w;
        self.cells.push(c);
        self.residual[p + 1] = (self.residual[p] - w * w).max(0.0);
        true
    }

    fn pop(&mut self) {
        self.cells.pop();
    }

    /// Unconstrained loads z = L⁻ᵀw of the path (in path order), L_rt = M_t,c_r.
    fn loads(&self) -> Vec<f64> {
        let p = self.depth();
        let mut z = self.w[..p].to_vec();
        for r in (0..p).rev() {
            let row = &self.m[r * self.n..(r + 1) * self.n];
            let later: f64 = self.cells[r + 1..p]
                .iter()
                .zip(&z[r + 1..p])
                .map(|(&c, &zt)| row[c] * zt)
                .sum();
            z[r] = (z[r] - later) / self.d[r];
        }
        z
    }
}

/// Search state of one frame.
struct Search<'a> {
    bb: &'a BranchAndBound,
    /// The frame (working units).
    y: &'a [f64],
    b: Vec<f64>,
    yty: f64,
    order: Vec<usize>,
    best_cost: f64,
    best: Vec<(usize, f64)>,
    nodes: u64,
    exhausted: bool,
    tol: f64,
    /// Slack on comparisons against the incumbent (round-off only).
    slack: f64,
}

impl Search<'_> {
    /// What a support must stay below to be valued: the incumbent.
    fn cut(&self) -> f64 {
        self.best_cost
    }

    /// Value the support of `path` (its unconstrained fit is known) and keep it if it
    /// beats the incumbent.
    fn consider(&mut self, path: &Path) {
        let k = path.depth();
        let floor = self.bb.lambda * k as f64;
        if path.residual() + floor >= self.best_cost {
            return; // the bounded residual is at least the unconstrained one
        }
        let z = path.loads();
        let upper = &self.bb.common.problem.upper;
        let above = bounded::needs_bounded_solve(&z, |a| upper[path.cells[a]]);
        if !above && z.iter().any(|&v| v < 0.0) {
            return; // a smaller support's solution, valued on its own
        }
        let (z, residual) = if !above {
            (z, path.residual())
        } else {
            let g = DMatrix::from_fn(k, k, |a, q| self.bb.gram_rows[path.cells[a]][path.cells[q]]);
            let bs = DVector::from_fn(k, |a, _| self.b[path.cells[a]]);
            let u = DVector::from_fn(k, |a, _| upper[path.cells[a]]);
            let Some(zb) = bounded::box_qp(&g, &bs, &DVector::zeros(k), &u) else {
                return;
            };
            if zb.iter().any(|&v| v <= 0.0) {
                return; // a smaller support's solution, valued on its own
            }
            let quad = zb.dot(&(&g * &zb)) - 2.0 * bs.dot(&zb);
            (zb.iter().copied().collect(), (self.yty + quad).max(0.0))
        };
        let cost = residual + floor;
        let answer: Vec<(usize, f64)> = path.cells.iter().copied().zip(z).collect();
        if cost < self.best_cost {
            self.best = answer;
            self.best_cost = cost;
        }
    }

    /// Greedy forward selection up to K cells: a first incumbent.
    fn greedy(&mut self, path: &mut Path) {
        let (g, n) = (&self.bb.gram_rows, self.order.len());
        while path.depth() < self.bb.kmax {
            let mut pick: Option<(usize, f64)> = None;
            for c in 0..n {
                if path.cells.contains(&c) {
                    continue;
                }
                // Only cells that would carry a positive load: a path through a
                // negative one is rejected whole, and the incumbent would stay empty.
                if !path.child_pushes_up(&self.b, c) {
                    continue;
                }
                if let Some(r) = path.child_residual(g, &self.b, c) {
                    if pick.is_none_or(|(_, br)| r < br) {
                        pick = Some((c, r));
                    }
                }
            }
            self.nodes += n as u64;
            let Some((c, _)) = pick else { break };
            if !path.push(g, &self.b, c) {
                break;
            }
            self.consider(path);
        }
        while path.depth() > 0 {
            path.pop();
        }
    }

    /// Swap local search around the incumbent: replace one of its cells by any other
    /// cell (or add one while it has fewer than K), keep any improvement, repeat
    /// until none. A better incumbent before the search prunes more, and it is the
    /// answer when the work budget ends the search.
    fn local_search(&mut self, path: &mut Path) {
        let (g, n) = (&self.bb.gram_rows, self.order.len());
        for _pass in 0..8 {
            let current: Vec<usize> = self.best.iter().map(|&(c, _)| c).collect();
            if current.is_empty() {
                return;
            }
            let before = self.best_cost;
            let k = current.len();
            // Drop position a (a = k: drop none, i.e. grow when below K).
            for a in 0..=k {
                if a == k && k >= self.bb.kmax {
                    break;
                }
                while path.depth() > 0 {
                    path.pop();
                }
                if !current
                    .iter()
                    .enumerate()
                    .filter(|&(q, _)| q != a)
                    .all(|(_, &c)| path.push(g, &self.b, c))
                {
                    continue;
                }
                let floor = self.bb.lambda * (path.depth() + 1) as f64;
                for j in 0..n {
                    if current.contains(&j) {
                        continue;
                    }
                    self.nodes += 1;
                    let Some(r) = path.child_residual(g, &self.b, j) else {
                        continue;
                    };
                    if r + floor < self.cut() && path.push(g, &self.b, j) {
                        self.consider(path);
                        path.pop();
                    }
                }
            }
            if self.best_cost >= before {
                break;
            }
        }
        while path.depth() > 0 {
            path.pop();
        }
    }

    /// Children of `path` that are leaves (size K): valued in O(1) each.
    fn leaves(&mut self, path: &mut Path, start: usize) {
        let g = &self.bb.gram_rows;
        let floor = self.bb.lambda * (path.depth() + 1) as f64;
        for i in start..self.order.len() {
            let j = self.order[i];
            self.nodes += 1;
            let Some(r) = path.child_residual(g, &self.b, j) else {
                continue;
            };
            if r + floor < self.cut() && path.push(g, &self.b, j) {
                self.consider(path);
                path.pop();
            }
        }
    }

    /// Explore the children of `path`, whose candidates are `order[start..]`;
    /// `relax` is the non-negative fit over path ∪ order[start..].
    fn explore(&mut self, path: &mut Path, start: usize, relax: &mut Nnls) {
        let n = self.order.len();
        let depth = path.depth() + 1; // size of the children
        let floor = self.bb.lambda * depth as f64;
        if floor >= self.cut() {
            return;
        }
        if depth == self.bb.kmax {
            self.leaves(path, start);
            return;
        }
        let g = &self.bb.gram_rows;
        let mut child_relax = relax.clone();
        for i in start..n {
            if self.nodes + path.work >= self.bb.node_budget {
                self.exhausted = true;
                return;
            }
            let c = self.order[i];
            // Bound of every support below this child: the relaxation over
            // path ∪ order[i..]; it only grows along the siblings.
            if i > start && relax.remove(self.order[i - 1]) {
                self.nodes += relax.solve(&FrameData {
                    g,
                    cols: &self.bb.columns,
                    y: self.y,
                    b: &self.b,
                    yty: self.yty,
                    tol: self.tol,
                });
            }
            let bound = relax.value + floor;
            if bound >= self.cut() + self.slack {
                return;
            }
            // The supports strictly below this child hold one more load: once even
            // that λ more reaches the incumbent, no sibling from here on needs its
            // subtree, only its own value (an O(1) scan, no more relaxations).
            if bound + self.bb.lambda >= self.cut() + self.slack {
                self.leaves(path, i);
                return;
            }
            if !path.push(g, &self.b, c) {
                continue; // dependent: every superset is too
            }
            self.consider(path);
            if depth + 1 == self.bb.kmax {
                self.leaves(path, i + 1);
            } else {
                child_relax.clone_from(relax);
                self.explore(path, i + 1, &mut child_relax);
            }
            path.pop();
            if self.exhausted {
                return;
            }
        }
    }
}

impl Reconstructor for BranchAndBound {
    fn method(&self) -> Method {
        Method::BranchAndBound
    }

    /// ‖Âz − y‖² + λ·|S|, as `support`.
    fn objective(&self, y: &[f64], loads_g: &[f64]) -> Option<f64> {
        let (misfit, _) = self.common.misfit_of(y, loads_g)?;
        Some(misfit + self.lambda * loads_g.iter().filter(|&&x| x > 0.0).count() as f64)
    }

    fn reconstruct(&self, y: &[f64]) -> Reconstruction {
        let Some(aty) = self.common.aty(y) else {
            return self.common.unusable();
        };
        let n = self.common.n();
        let b: Vec<f64> = aty.iter().copied().collect();
        let yty: f64 = y.iter().map(|v| v * v).sum();
        let tol = 1e-12 * b.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-300);
        // Root relaxation: non-negative fit over every cell; its cells (largest load
        // first), then the others by correlation, give the search order.
        let cap = self.common.problem.n_gratings().min(n);
        let mut root = Nnls::new(n, self.columns.m, cap);
        let mut nodes = root.solve(&FrameData {
            g: &self.gram_rows,
            cols: &self.columns,
            y,
            b: &b,
            yty,
            tol,
        });
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&p, &q| root.z[q].total_cmp(&root.z[p]).then(b[q].total_cmp(&b[p])));
        nodes += 1;
        let mut search = Search {
            bb: self,
            y,
            b,
            yty,
            order,
            best_cost: yty,
            best: Vec::new(),
            nodes,
            exhausted: false,
            tol,
            slack: 1e-9 * (1.0 + yty),
        };
        let mut path = Path::new(n, self.kmax, yty);
        // The first incumbent: greedy, improved by swaps.
        search.greedy(&mut path);
        search.local_search(&mut path);
        search.explore(&mut path, 0, &mut root);
        let mut full = vec![0.0; n];
        for &(c, v) in &search.best {
            full[c] = v;
        }
        let mut r = self
            .common
            .finish(&full, y, !search.exhausted, search.nodes + path.work);
        r.certified = !search.exhausted;
        r
    }
}
