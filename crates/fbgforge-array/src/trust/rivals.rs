//! The rivals of an answer, computed from the frame and the answer alone: every
//! support one cell away from the answer's (a load dropped, added or moved) and the
//! best support of every size by forward selection from the frame. Each is screened
//! by its unconstrained χ² (a lower bound of its bounded one, from incremental
//! Cholesky factors: O(k²n) per base support) and fitted exactly, loads within the
//! rated range, when the screen cannot exclude it.
//!
//! **The rival test.** Each distinct rival r fitted is also fitted to the answer's
//! own prediction ŷ (what the frame would be, noise-free, were the answer true). Its
//! statistic T = [χ²_r(y) − χ²_answer(y)] − χ²_r(ŷ) compares how much better the
//! rival does on the frame than on the answer's prediction. Under the answer (the
//! linear Gaussian model), T = 2⟨v, e⟩ − Q with e the noise, v the part of the
//! rival's misfit to ŷ outside the answer's columns and Q ≤ χ² with |r \ answer|
//! degrees of freedom: its lower tail is bounded by
//! min over θ of Φ(θT / 2‖v‖) + P(χ²_k ≥ −(1 − θ)T). The frame's rival p-value is
//! that bound for the best rival, times the number of rivals considered
//! (Bonferroni), so a true answer is `ambiguous` with probability at most the
//! share of the significance the test is given, whatever the array's size.

use super::Weighted;

use super::chi2_p_value;
use super::OCCAM_CHI2;
use crate::methods::DISTINCT_RATIO;
use nalgebra::DMatrix;
use std::collections::HashSet;

/// What a rival may hold and how far it is looked for.
pub(super) struct Bounds {
    /// Loads of a rival are within [lo, hi], g.
    pub lo: f64,
    pub hi: f64,
    /// Most loads a rival may hold.
    pub max_loads: usize,
    /// Rivals whose penalised χ² cannot be below this are not fitted.
    pub cut: f64,
}

/// A support being grown one cell at a time: the Cholesky factor of its Gram block
/// and, for every cell l, s_l = ‖L⁻¹G_{B,l}‖² and t_l = (L⁻¹G_{B,l})·(L⁻¹c_B), so that
/// adding l lowers the unconstrained χ² by (c_l − t_l)²/(d_l − s_l).
struct Base {
    cells: Vec<usize>,
    /// L row-major, row r holds r + 1 entries.
    l: Vec<Vec<f64>>,
    /// L⁻¹c_B.
    u: Vec<f64>,
    /// Rows of L⁻¹G_{B,·}.
    rows: Vec<Vec<f64>>,
    s: Vec<f64>,
    t: Vec<f64>,
    /// Unconstrained χ² of the support.
    chi2: f64,
}

impl Base {
    fn empty(w: &Weighted) -> Self {
        Base {
            cells: Vec::new(),
            l: Vec::new(),
            u: Vec::new(),
            rows: Vec::new(),
            s: vec![0.0; w.n],
            t: vec![0.0; w.n],
            chi2: w.yty,
        }
    }

    /// Add `cell` (its Gram row `grow`); false (unchanged) when its column depends on
    /// the support's.
    fn push(&mut self, w: &Weighted, cell: usize, grow: &[f64]) -> bool {
        let k = self.cells.len();
        let mut v = vec![0.0; k];
        for r in 0..k {
            let acc: f64 = (0..r).map(|q| self.l[r][q] * v[q]).sum();
            v[r] = (grow[self.cells[r]] - acc) / self.l[r][r];
        }
        let d2 = w.d[cell] - v.iter().map(|a| a * a).sum::<f64>();
        if d2 <= 1e-10 * w.d[cell].max(1e-300) {
            return false;
        }
        let diag = d2.sqrt();
        let un = (w.c[cell] - v.iter().zip(&self.u).map(|(a, b)| a * b).sum::<f64>()) / diag;
        let mut row = Vec::with_capacity(w.n);
        for (l, &g) in grow.iter().enumerate() {
            let acc: f64 = (0..k).map(|r| v[r] * self.rows[r][l]).sum();
            let ml = (g - acc) / diag;
            self.s[l] += ml * ml;
            self.t[l] += ml * un;
            row.push(ml);
        }
        let mut lrow = v;
        lrow.push(diag);
        self.l.push(lrow);
        self.rows.push(row);
        self.u.push(un);
        self.cells.push(cell);
        self.chi2 -= un * un;
        true
    }

    /// How much adding cell l (not in the support) lowers the unconstrained χ² with
    /// a positive load on it (0 when its best load is not positive).
    fn gain(&self, w: &Weighted, l: usize) -> f64 {
        let den = w.d[l] - self.s[l];
        if den <= 1e-10 * w.d[l].max(1e-300) {
            return 0.0;
        }
        let num = w.c[l] - self.t[l];
        if num <= 0.0 {
            0.0
        } else {
            num * num / den
        }
    }
}

/// The answer, as the rival test sees it.
pub(super) struct Answer<'a> {
    /// Its loads, g.
    pub x: &'a [f64],
    /// Its loaded cells.
    pub support: &'a [usize],
    /// Its χ² on the frame (unpenalised).
    pub chi2: f64,
    /// The frame the answer predicts (noise-free), in the same weighted space.
    pub predicted: &'a Weighted,
}

/// The rivals found: the closest one's penalised χ² and the rival test's p-value.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Found {
    /// Penalised χ² of the closest distinct rival fitted.
    pub closest: Option<f64>,
    /// The rival test's p-value (Bonferroni over the rivals considered).
    pub p_value: Option<f64>,
}

/// The rivals' search state: what was fitted, the answer, the closest rival so far.
struct Search<'a> {
    w: &'a Weighted,
    b: &'a Bounds,
    a: &'a Answer<'a>,
    x_norm2: f64,
    /// Orthonormal basis of the answer's weighted columns.
    q: DMatrix<f64>,
    seen: HashSet<Vec<usize>>,
    best: Option<f64>,
    /// Smallest per-rival tail bound.
    least_p: Option<f64>,
}

/// P(Z ≤ z), Z standard normal.
fn normal_cdf(z: f64) -> f64 {
    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
}

/// Upper bound of P(2⟨v, e⟩ − Q ≤ t) with ‖v‖² = `v2`, e standard normal and
/// Q ≤ χ²_k: the two tails split at θ, the best θ of a grid.
fn lower_tail_bound(t: f64, v2: f64, k: usize) -> f64 {
    if t >= 0.0 {
        return 1.0;
    }
    (0..=20)
        .map(|i| {
            let th = f64::from(i) / 20.0;
            let lin = if v2 > 1e-18 {
                normal_cdf(th * t / (2.0 * v2.sqrt()))
            } else if th > 0.0 {
                0.0
            } else {
                1.0
            };
            let quad = if th < 1.0 {
                if k == 0 {
                    0.0
                } else {
                    chi2_p_value(-(1.0 - th) * t, k)
                }
            } else {
                1.0
            };
            lin + quad
        })
        .fold(1.0, f64::min)
}

impl<'a> Search<'a> {
    /// A search from the answer `a`: nothing fitted yet but the answer's support.
    fn new(w: &'a Weighted, a: &'a Answer<'a>, b: &'a Bounds) -> Self {
        let support = a.support;
        let q = if support.is_empty() {
            DMatrix::zeros(w.m, 0)
        } else {
            let ba = DMatrix::from_fn(w.m, support.len(), |i, c| w.col(support[c])[i]);
            ba.qr().q()
        };
        let mut key = support.to_vec();
        key.sort_unstable();
        Search {
            w,
            b,
            a,
            x_norm2: a.x.iter().map(|v| v * v).sum(),
            q,
            seen: HashSet::from([key]),
            best: None,
            least_p: None,
        }
    }

    /// Fit the support `cells` exactly (loads in [lo, hi]) unless seen; if it is
    /// distinct from the answer keep its penalised χ² when the closest so far, and
    /// its rival-test tail bound when the least so far.
    fn fit(&mut self, cells: &[usize]) {
        let mut key = cells.to_vec();
        key.sort_unstable();
        if !self.seen.insert(key) {
            return;
        }
        let Some((chi2, z)) = self.w.box_fit(cells, self.b.lo, self.b.hi) else {
            return;
        };
        let loads = z.iter().filter(|&&v| v > 0.0).count();
        let cost = chi2 + OCCAM_CHI2 * loads as f64;
        // ‖x′ − x‖² over every cell: the answer's norm, corrected on the rival's cells.
        let x = self.a.x;
        let mut d2 = self.x_norm2;
        for (&j, &v) in cells.iter().zip(&z) {
            d2 += (v - x[j]) * (v - x[j]) - x[j] * x[j];
        }
        let distinct = d2 > DISTINCT_RATIO * DISTINCT_RATIO * self.x_norm2 * (1.0 + 1e-9) + 1e-18;
        if !distinct {
            return;
        }
        if self.best.is_none_or(|b| cost < b) {
            self.best = Some(cost);
        }
        if let Some(p) = self.tail_bound(cells, chi2) {
            if self.least_p.is_none_or(|b| p < b) {
                self.least_p = Some(p);
            }
        }
    }

    /// The rival test's tail bound for rival `cells` with χ² `chi2` on the frame.
    fn tail_bound(&self, cells: &[usize], chi2: f64) -> Option<f64> {
        let wa = self.a.predicted;
        let (chi2_hat, zh) = wa.box_fit(cells, self.b.lo, self.b.hi)?;
        let t = (chi2 - self.a.chi2) - chi2_hat;
        // The rival's misfit to the prediction, outside the answer's columns.
        let mut res = wa.yb.clone();
        for (&j, &v) in cells.iter().zip(&zh) {
            for (r, b) in res.iter_mut().zip(wa.col(j)) {
                *r -= v * b;
            }
        }
        let mut v2: f64 = res.iter().map(|r| r * r).sum();
        for c in 0..self.q.ncols() {
            let dot: f64 = self.q.column(c).iter().zip(&res).map(|(q, r)| q * r).sum();
            v2 -= dot * dot;
        }
        // Q's degrees of freedom: the rival's cells outside the answer, at least one
        // (the bounded refits move with the noise even where the supports nest).
        let new = cells.iter().filter(|j| !self.a.support.contains(j)).count();
        Some(lower_tail_bound(t, v2.max(0.0), new.max(1)))
    }

    /// Fit base ∪ {l} for every cell l outside `skip` whose screen passes.
    fn grow(&mut self, base: &Base, skip: &[usize]) {
        if base.cells.len() + 1 > self.b.max_loads {
            return;
        }
        let floor = OCCAM_CHI2 * (base.cells.len() + 1) as f64;
        for l in 0..self.w.n {
            if skip.contains(&l) {
                continue;
            }
            if base.chi2 - base.gain(self.w, l) + floor <= self.b.cut {
                let mut cells = base.cells.clone();
                cells.push(l);
                self.fit(&cells);
            }
        }
    }
}

/// How many rivals the search considers for an answer of `k` loads among `n` cells
/// with rivals of at most `max_loads` loads: one added, one dropped, one moved, and
/// the forward-selection path (the Bonferroni count of the rival test).
fn considered(n: usize, k: usize, max_loads: usize) -> usize {
    let add = if k < max_loads { n - k } else { 0 };
    add + k + k * (n - k) + max_loads
}

/// The rivals of the answer `a` found below `bounds.cut`: the closest one's
/// penalised χ² and the rival test's p-value (see the module doc).
pub(super) fn closest(w: &Weighted, a: &Answer<'_>, b: &Bounds) -> Found {
    let support = a.support;
    let mut s = Search::new(w, a, b);
    let grows: Vec<Vec<f64>> = support.iter().map(|&j| w.gram_row(j)).collect();
    // One load added.
    let mut full = Base::empty(w);
    for (&j, g) in support.iter().zip(&grows) {
        full.push(w, j, g);
    }
    s.grow(&full, support);
    // One load dropped, and one moved (dropped, another added).
    for a in 0..support.len() {
        let mut base = Base::empty(w);
        for (q, (&j, g)) in support.iter().zip(&grows).enumerate() {
            if q != a {
                base.push(w, j, g);
            }
        }
        if base.chi2 + OCCAM_CHI2 * base.cells.len() as f64 <= b.cut {
            let cells = base.cells.clone();
            s.fit(&cells);
        }
        s.grow(&base, support);
    }
    // The best support of each size by forward selection from the frame.
    let mut path = Base::empty(w);
    while path.cells.len() < b.max_loads.min(w.n) {
        let pick = (0..w.n)
            .filter(|l| !path.cells.contains(l))
            .map(|l| (l, path.gain(w, l)))
            .filter(|&(_, g)| g > 0.0)
            .max_by(|p, q| p.1.total_cmp(&q.1));
        let Some((l, _)) = pick else { break };
        if !path.push(w, l, &w.gram_row(l)) {
            break;
        }
        if path.chi2 + OCCAM_CHI2 * path.cells.len() as f64 <= b.cut {
            let cells = path.cells.clone();
            s.fit(&cells);
        }
    }
    let count = considered(w.n, support.len(), b.max_loads) as f64;
    Found {
        closest: s.best,
        p_value: s.least_p.map(|p| (p * count).min(1.0)),
    }
}

/// One explanation on `cells` held against the answer `a`, as the rival test would
/// hold it were it found: its penalised χ² (loads refitted within the range) and,
/// when it is a rival (≥ 12 dB from the answer, not the answer's own cells), the
/// frame's rival p-value it would give (its tail bound times the Bonferroni count).
/// None: dependent columns.
pub(super) fn hold(
    w: &Weighted,
    a: &Answer<'_>,
    b: &Bounds,
    cells: &[usize],
) -> Option<(f64, Option<f64>)> {
    let (chi2, z) = w.box_fit(cells, b.lo, b.hi)?;
    let cost = chi2 + OCCAM_CHI2 * z.iter().filter(|&&v| v > 0.0).count() as f64;
    // The answer's own cells are no rival of it (seeded as seen, as in the search).
    let mut s = Search::new(w, a, b);
    s.fit(cells);
    let count = considered(w.n, a.support.len(), b.max_loads) as f64;
    Some((cost, s.least_p.map(|p| (p * count).min(1.0))))
}
