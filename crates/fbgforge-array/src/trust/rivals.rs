//! The rivals of an answer, computed from the frame and the answer alone: every
//! support one cell away from the answer's (a load dropped, added or moved) and the
//! best support of every size by forward selection from the frame. Each is screened
//! by its unconstrained χ² (a lower bound of its bounded one, from incremental
//! Cholesky factors: O(k²n) per base support) and fitted exactly, loads within the
//! rated range, when the screen cannot exclude it.

use super::Weighted;

use super::OCCAM_CHI2;
use crate::methods::DISTINCT_RATIO;
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

/// The rivals' search state: what was fitted, the answer, the closest rival so far.
struct Search<'a> {
    w: &'a Weighted,
    b: &'a Bounds,
    /// The answer's loads, g.
    x: &'a [f64],
    x_norm2: f64,
    seen: HashSet<Vec<usize>>,
    best: Option<f64>,
}

impl Search<'_> {
    /// Fit the support `cells` exactly (loads in [lo, hi]) unless seen, and keep its
    /// penalised χ² if it is distinct from the answer and the closest so far.
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
        if self.best.is_some_and(|b| b <= cost) {
            return;
        }
        // ‖x′ − x‖² over every cell: the answer's norm, corrected on the rival's cells.
        let mut d2 = self.x_norm2;
        for (&j, &v) in cells.iter().zip(&z) {
            d2 += (v - self.x[j]) * (v - self.x[j]) - self.x[j] * self.x[j];
        }
        let distinct = d2 > DISTINCT_RATIO * DISTINCT_RATIO * self.x_norm2 * (1.0 + 1e-9) + 1e-18;
        if distinct {
            self.best = Some(cost);
        }
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

/// The penalised χ² of the closest rival of the answer `x` (support `support`) found
/// below `bounds.cut`, or the closest fitted if none is; None if no distinct rival
/// was fitted.
pub(super) fn closest(w: &Weighted, support: &[usize], x: &[f64], b: &Bounds) -> Option<f64> {
    let mut s = Search {
        w,
        b,
        x,
        x_norm2: x.iter().map(|v| v * v).sum(),
        seen: HashSet::new(),
        best: None,
    };
    let mut key = support.to_vec();
    key.sort_unstable();
    s.seen.insert(key);
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
    s.best
}
