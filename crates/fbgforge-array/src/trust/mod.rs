//! Whether a frame's answer can be trusted: one stated test, the same for every
//! method, and the flags it gives ([`FrameFlags`]).
//!
//! **The test.** An *explanation* of a frame is a set of loaded cells with loads in
//! the array's rated range [min_load, ulimit]; its χ² is the least
//! Σ rᵢ²/vᵢ over those loads (exact bounded least squares,
//! [`crate::methods::bounded::box_qp`]), vᵢ the variance of reading i under the
//! problem's [`crate::problem::Uncertainty`] at the answer (interrogator
//! resolution², the matrix's per-entry error times the loads, the additivity error of
//! simultaneous loads), and its penalised χ² adds [`OCCAM_CHI2`] per load (the price
//! the ℓ0 methods put on a load: λ = 16 σ², in units of σ²; the rivals' search
//! screens on it). With the significance α
//! (a setting: [`crate::problem::SensingProblem::with_significance`], default
//! [`DEFAULT_SIGNIFICANCE`]) the answer is trusted when each of three tests, run at
//! α/3 ([`TESTS`]), keeps it, so that a true answer is flagged with probability at
//! most α (the union bound) on an array of any size:
//!
//! 1. its χ² is consistent with the noise model: P(χ²_dof ≥ χ²) ≥ α/3, dof = gratings
//!    − the loads free within the range (− 1 with a common-mode term); else
//!    `inconsistent`;
//! 2. no *rival* explains the frame better than the answer could by chance: for each
//!    rival (an explanation at least 12 dB away from the answer, ‖x′ − x‖ >
//!    10^(−12/20)‖x‖, the recovery criterion), the statistic T = [χ²_rival(y) −
//!    χ²_answer(y)] − χ²_rival(ŷ), ŷ the frame the answer predicts, has a known lower
//!    tail when the answer is true ([`rivals`]); the smallest tail probability times
//!    the number of rivals considered (Bonferroni) below α/3 makes the frame
//!    `ambiguous` (so does a loaded cell whose column another cell repeats);
//! 3. loads pruned below the range were not needed (below, `below_range`).
//!
//! A rival the array cannot separate from the answer at this noise (T near 0 either
//! way) does not flag the frame: no test of this size can, the same data coming as
//! often from a right answer. How close the nearest rival is stays on the frame as
//! [`Reconstruction::rival_margin_chi2`], for information.
//!
//! The rivals are computed from the frame and the answer, never taken from the
//! search that ran, so every method's answer is held to the same test: every
//! support that differs from the answer by one cell (one load dropped, one added,
//! one moved), and the best support of every size up to the load cap by forward
//! selection from the frame ([`rivals`]). Each is screened by its unconstrained
//! χ² (a lower bound) and evaluated exactly when the screen cannot exclude it.
//!
//! **Before the test** loads below the rated range are pruned: the cells that carry
//! less than `min_load_g` are dropped and the smaller support refitted (bounded
//! least squares) until none is left; the answer returned is the pruned one.
//! `below_range` is set when the pruned loads were needed: the likelihood-ratio test
//! of the fit with them against the fit without them rejects the smaller one at α/3.
//!
//! The other flags: `ceiling` (a load at ulimit), `overload` (on some subset of the
//! answer's cells holding a load at the ceiling, the fit without the upper bound has
//! every load positive, one above ulimit, and passes the χ² test at α),
//! `unconverged` (the method did not meet its own convergence test: a note, not
//! part of the test; `bnb` stopped at its work budget is judged like any answer),
//! `unusable` (a
//! wrong length, a non-finite shift or one beyond the interrogator's window: no
//! loads, NaN).
//!
//! Every frame keeps the statistics the α-dependent flags come from
//! ([`Reconstruction::p_value`], [`Reconstruction::rival_p_value`],
//! [`Reconstruction::below_range_p_value`], [`Reconstruction::overload_p_value`]), so
//! [`Reconstruction::flags_at`] gives the flags at another significance without
//! solving again (the studies' ROC curves).

mod chi2;
mod rivals;
pub(crate) mod significance;

use chi2::chi2_1_quantile;
pub(crate) use chi2::{chi2_p_value, chi2_quantile};

use super::methods::bounded::box_qp;
use super::methods::Reconstruction;
use super::problem::SensingProblem;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// The per-frame flags, defined beside the [`Reconstruction`] that carries them.
pub use super::methods::FrameFlags;
pub use significance::{check_significance, DEFAULT_SIGNIFICANCE};

/// The tests a clean frame can fail (`inconsistent`, `ambiguous`, `below_range`):
/// each is run at the significance divided by this, so that a true answer is
/// flagged by one of them with probability at most the significance (the union
/// bound).
pub const TESTS: f64 = 3.0;

/// The price of one load in the penalised χ²: the ℓ0 methods' λ = 16 σ²
/// ([`crate::methods::l0_penalty_for_resolution`]) in units of σ².
pub const OCCAM_CHI2: f64 = 16.0;

/// The rival quantile q(α): the χ²₁ quantile at 1 − α.
pub fn rival_quantile(significance: f64) -> f64 {
    chi2_1_quantile(significance)
}

/// How many frames carry each flag (a frame may carry several).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct FlagCounts {
    /// Frames with no flag.
    pub trusted: usize,
    /// Frames flagged `inconsistent`.
    pub inconsistent: usize,
    /// Frames flagged `ceiling`.
    pub ceiling: usize,
    /// Frames flagged `overload`.
    pub overload: usize,
    /// Frames flagged `below_range`.
    pub below_range: usize,
    /// Frames flagged `ambiguous`.
    pub ambiguous: usize,
    /// Frames flagged `unconverged`.
    pub unconverged: usize,
    /// Frames flagged `unusable`.
    pub unusable: usize,
}

impl FlagCounts {
    /// Count the flags of every frame.
    pub fn of<'a>(frames: impl IntoIterator<Item = &'a Reconstruction>) -> Self {
        let mut c = FlagCounts::default();
        for r in frames {
            c.add(&r.flags);
        }
        c
    }

    /// Count one frame's flags.
    pub fn add(&mut self, f: &FrameFlags) {
        self.trusted += usize::from(f.trusted());
        self.inconsistent += usize::from(f.inconsistent);
        self.ceiling += usize::from(f.ceiling);
        self.overload += usize::from(f.overload);
        self.below_range += usize::from(f.below_range);
        self.ambiguous += usize::from(f.ambiguous);
        self.unconverged += usize::from(f.unconverged);
        self.unusable += usize::from(f.unusable);
    }
}

impl Reconstruction {
    /// The flags this frame's test statistics give at `significance`: the
    /// α-dependent flags (`inconsistent`, `ambiguous`, `below_range`, `overload`)
    /// recomputed, the others (`ceiling`, `unconverged`, `unusable`) as they are.
    /// Exact for a significance at or above the run's (below it, rivals beyond the
    /// run's quantile were not evaluated).
    pub fn flags_at(&self, significance: f64) -> FrameFlags {
        let f = self.flags;
        if f.unusable {
            return f;
        }
        let part = significance / TESTS;
        FrameFlags {
            inconsistent: self.dof > 0 && self.p_value < part,
            ambiguous: self.rival_p_value.is_some_and(|p| p < part),
            below_range: self.below_range_p_value.is_some_and(|p| p < part),
            overload: f.ceiling && self.overload_p_value.is_some_and(|p| p >= significance),
            ..f
        }
    }
}

/// The frame test of one problem, with what depends only on the matrix.
#[derive(Debug, Clone)]
pub struct FrameTest {
    problem: SensingProblem,
    /// Most loads a rival may hold (the load cap; at most gratings − common mode).
    max_loads: usize,
    /// The rival quantile of the problem's significance.
    quantile: f64,
    /// P·A by columns (the common-mode direction projected out), pm/g.
    cols: Vec<f64>,
}

impl FrameTest {
    /// The test for `problem` (its uncertainty, load range, significance), with
    /// rivals of up to `max_loads` loads.
    pub fn new(problem: &SensingProblem, max_loads: usize) -> Self {
        let (m, n) = (problem.n_gratings(), problem.n_cells());
        let mut cols = Vec::with_capacity(m * n);
        for j in 0..n {
            cols.extend(problem.project_frame(problem.sensitivity_pm_per_g.column(j).as_slice()));
        }
        let free = m.saturating_sub(usize::from(problem.common_mode.is_some()));
        FrameTest {
            max_loads: max_loads.max(1).min(free.max(1)).min(n),
            quantile: rival_quantile(problem.significance),
            problem: problem.clone(),
            cols,
        }
    }

    /// The problem tested.
    pub fn problem(&self) -> &SensingProblem {
        &self.problem
    }

    /// The significance of the test.
    pub fn significance(&self) -> f64 {
        self.problem.significance
    }

    /// Test `r`, a method's answer to frame `shifts_pm`: prune its loads below the
    /// range, then fill its χ², p-value, rival margin and flags (see the module doc).
    pub fn assess(&self, shifts_pm: &[f64], r: &mut Reconstruction) {
        let p = &self.problem;
        if r.flags.unusable || p.check_shifts(shifts_pm).is_err() {
            let iterations = r.iterations;
            *r = Reconstruction::unusable(p.n_cells());
            r.iterations = iterations;
            return;
        }
        let yp = p.project_frame(shifts_pm);
        let unpruned: Vec<usize> = loaded(&r.loads_g);
        let (x, pruned) = self.prune(&yp, &r.loads_g);
        if pruned > 0 {
            r.residual_pm = p.residual_pm(&x, shifts_pm);
            r.common_mode_pm = p.common_offset_pm(&x, shifts_pm);
            r.loads_g = x;
        }
        r.pruned_loads = pruned;
        let x = &r.loads_g;
        let AtAnswer {
            support,
            w,
            wa,
            chi2,
            fitted,
        } = self.at_answer(shifts_pm, x);
        let (lo, hi) = (p.min_load_g, p.ulimit_g);
        let m = p.n_gratings();
        r.chi2 = chi2;
        // A load the refit holds at a bound of the range is not a free parameter: it
        // takes no degree of freedom from the noise.
        let free = fitted.as_ref().map_or(support.len(), |(_, z)| {
            z.iter()
                .filter(|&&v| v > lo + 1e-9 * hi && v < hi * (1.0 - 1e-9))
                .count()
        });
        r.dof = m.saturating_sub(free + usize::from(p.common_mode.is_some()));
        r.p_value = chi2_p_value(chi2, r.dof);
        r.below_range_p_value = (pruned > 0).then(|| {
            let with = w.box_fit(&unpruned, 0.0, hi).map_or(chi2, |(c, _)| c);
            chi2_p_value((chi2 - with).max(0.0), pruned)
        });
        let answer_cost = chi2 + OCCAM_CHI2 * support.len() as f64;
        let bounds = self.bounds(support.len(), answer_cost);
        let answer = rivals::Answer {
            x,
            support: &support,
            chi2,
            predicted: &wa,
        };
        let found = rivals::closest(&w, &answer, &bounds);
        r.rival_margin_chi2 = found.closest.map(|cost| cost - answer_cost);
        // A loaded cell whose column another cell repeats: the twin explains the
        // frame exactly as well at any noise (the rival test's p-value is 0).
        r.rival_p_value = if has_twin(&w, &support) {
            Some(0.0)
        } else {
            found.p_value
        };
        let at_ceiling: Vec<usize> = support
            .iter()
            .copied()
            .filter(|&j| x[j] >= hi * (1.0 - 1e-9))
            .collect();
        r.overload_p_value = if at_ceiling.is_empty() {
            None
        } else {
            self.overload_p_value(shifts_pm, &support, &at_ceiling)
        };
        r.flags = FrameFlags {
            ceiling: !at_ceiling.is_empty(),
            unconverged: !r.converged,
            ..FrameFlags::default()
        };
        r.flags = r.flags_at(p.significance);
    }

    /// The rivals' bounds for an answer of `k` loads and penalised χ² `answer_cost`.
    fn bounds(&self, k: usize, answer_cost: f64) -> rivals::Bounds {
        rivals::Bounds {
            lo: self.problem.min_load_g,
            hi: self.problem.ulimit_g,
            max_loads: self.max_loads.max(k),
            cut: answer_cost + self.quantile,
        }
    }

    /// The frame seen from the answer `x` (pruned): the test's weights are the
    /// reading variances at `x`.
    fn at_answer(&self, shifts_pm: &[f64], x: &[f64]) -> AtAnswer {
        let p = &self.problem;
        let yp = p.project_frame(shifts_pm);
        let support = loaded(x);
        let predicted = &p.sensitivity_pm_per_g * DVector::from_column_slice(x);
        let var = p.uncertainty.reading_variances_pm2(x, predicted.as_slice());
        let w = Weighted::new(&self.cols, &yp, &var);
        let fitted = w.box_fit(&support, p.min_load_g, p.ulimit_g);
        let chi2 = fitted.as_ref().map(|(c, _)| *c).unwrap_or_else(|| {
            let res = p.residual_vector_pm(x, shifts_pm);
            res.iter().zip(&var).map(|(r, v)| r * r / v).sum()
        });
        // What the frame would be were the answer's support true, its loads refitted
        // with the test's weights (the rival test's null).
        let m = p.n_gratings();
        let mut yhat = vec![0.0; m];
        match &fitted {
            Some((_, z)) => {
                for (&j, &v) in support.iter().zip(z) {
                    for (h, c) in yhat.iter_mut().zip(&self.cols[j * m..(j + 1) * m]) {
                        *h += v * c;
                    }
                }
            }
            None => yhat = p.project_frame(predicted.as_slice()),
        }
        let wa = Weighted::new(&self.cols, &yhat, &var);
        AtAnswer {
            support,
            w,
            wa,
            chi2,
            fitted,
        }
    }

    /// Hold the explanation with loads on `cells` against `r`, an answer to frame
    /// `shifts_pm` this test has assessed ([`FrameTest::assess`]), under the test's
    /// weights (the answer's): whether the truth of a synthetic frame would have
    /// beaten the answer had the rivals' search found it (the flag study's
    /// classification of wrong answers, issue 35). None for an unusable frame or
    /// dependent columns.
    pub fn hold_against(
        &self,
        shifts_pm: &[f64],
        r: &Reconstruction,
        cells: &[usize],
    ) -> Option<HeldAgainst> {
        if r.flags.unusable
            || shifts_pm.len() != self.problem.n_gratings()
            || cells.iter().any(|&j| j >= self.problem.n_cells())
        {
            return None;
        }
        let at = self.at_answer(shifts_pm, &r.loads_g);
        let answer_cost = at.chi2 + OCCAM_CHI2 * at.support.len() as f64;
        let bounds = self.bounds(at.support.len(), answer_cost);
        let answer = rivals::Answer {
            x: &r.loads_g,
            support: &at.support,
            chi2: at.chi2,
            predicted: &at.wa,
        };
        let (cost, rival_p_value) = rivals::hold(&at.w, &answer, &bounds, cells)?;
        Some(HeldAgainst {
            penalised_chi2: cost,
            answer_penalised_chi2: answer_cost,
            rival_p_value,
        })
    }

    /// The answer with its loads below the rated range removed, the smaller support
    /// refitted (unweighted bounded least squares, as the methods fit) until none is
    /// left; and how many loads were removed.
    fn prune(&self, yp: &[f64], loads_g: &[f64]) -> (Vec<f64>, usize) {
        let p = &self.problem;
        let (lo, hi) = (p.min_load_g, p.ulimit_g);
        let mut x = loads_g.to_vec();
        let mut pruned = 0;
        if lo <= 0.0 {
            return (x, 0);
        }
        let unit = vec![1.0; p.n_gratings()];
        let w = Weighted::new(&self.cols, yp, &unit);
        loop {
            let low: Vec<usize> = (0..x.len()).filter(|&j| x[j] > 0.0 && x[j] < lo).collect();
            if low.is_empty() {
                break;
            }
            pruned += low.len();
            low.iter().for_each(|&j| x[j] = 0.0);
            let s = loaded(&x);
            if let Some((_, z)) = w.box_fit(&s, 0.0, hi) {
                for (&j, v) in s.iter().zip(z) {
                    x[j] = v;
                }
            }
        }
        (x, pruned)
    }

    /// The largest p-value of a fit, on a subset of the support holding a load at
    /// the ceiling, without the upper bound (weights 1/vᵢ at that fit), with every
    /// load positive and one above ulimit; None when no subset gives one.
    fn overload_p_value(&self, y: &[f64], support: &[usize], at_ceiling: &[usize]) -> Option<f64> {
        let p = &self.problem;
        let m = p.n_gratings();
        let k = support.len();
        if k > 12 {
            return None;
        }
        let yp = p.project_frame(y);
        let col = |j: usize| &self.cols[j * m..(j + 1) * m];
        let mut best: Option<f64> = None;
        for mask in 1u32..(1 << k) {
            let t: Vec<usize> = (0..k).filter(|a| mask & (1 << a) != 0).collect();
            if !t.iter().any(|&a| at_ceiling.contains(&support[a])) {
                continue;
            }
            let dof = m.saturating_sub(t.len() + usize::from(p.common_mode.is_some()));
            // Two passes: ordinary least squares, then weighted by the variances at
            // that fit.
            let mut x = vec![0.0; p.n_cells()];
            let mut var = vec![1.0f64; m];
            let mut ok = false;
            for _ in 0..2 {
                let a = DMatrix::from_fn(m, t.len(), |i, c| col(support[t[c]])[i] / var[i].sqrt());
                let yw = DVector::from_fn(m, |i, _| yp[i] / var[i].sqrt());
                let Some(sol) = (a.transpose() * &a)
                    .cholesky()
                    .map(|ch| ch.solve(&(a.transpose() * &yw)))
                else {
                    break;
                };
                x.iter_mut().for_each(|v| *v = 0.0);
                for (c, &q) in t.iter().enumerate() {
                    x[support[q]] = sol[c];
                }
                let pred = &p.sensitivity_pm_per_g * DVector::from_column_slice(&x);
                var = p.uncertainty.reading_variances_pm2(&x, pred.as_slice());
                ok = true;
            }
            if !ok || t.iter().any(|&q| x[support[q]] <= 0.0) {
                continue;
            }
            if !t.iter().any(|&q| x[support[q]] > p.ulimit_g) {
                continue;
            }
            let res = p.residual_vector_pm(&x, y);
            let chi2: f64 = res.iter().zip(&var).map(|(r, v)| r * r / v).sum();
            let pv = chi2_p_value(chi2, dof);
            best = Some(best.map_or(pv, |b: f64| b.max(pv)));
        }
        best
    }
}

/// The frame seen from an answer: its loaded cells, the weighted frame and the
/// weighted prediction, the answer's χ² and its refit.
struct AtAnswer {
    support: Vec<usize>,
    w: Weighted,
    wa: Weighted,
    chi2: f64,
    fitted: Option<(f64, Vec<f64>)>,
}

/// An explanation of a frame held against the answer under the test's weights
/// ([`FrameTest::hold_against`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldAgainst {
    /// Its penalised χ²: the least χ² over loads on its cells within the rated
    /// range, plus [`OCCAM_CHI2`] per load.
    pub penalised_chi2: f64,
    /// The answer's penalised χ² (its χ² plus [`OCCAM_CHI2`] per load).
    pub answer_penalised_chi2: f64,
    /// The frame's rival p-value, had the rivals' search found it (its tail bound
    /// times the Bonferroni count): the frame is `ambiguous` with it below a third
    /// of the significance. None when it is not a rival (under 12 dB from the
    /// answer once refitted, or the answer's own cells).
    pub rival_p_value: Option<f64>,
}

/// Whether a loaded cell's weighted column is repeated by another cell's (within
/// 1e-9 of its norm).
fn has_twin(w: &Weighted, support: &[usize]) -> bool {
    support.iter().any(|&j| {
        (0..w.n).any(|l| {
            l != j && {
                let d2: f64 = w
                    .col(j)
                    .iter()
                    .zip(w.col(l))
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum();
                d2 <= 1e-18 * w.d[j]
            }
        })
    })
}

/// The loaded cells of an answer.
fn loaded(x: &[f64]) -> Vec<usize> {
    (0..x.len()).filter(|&j| x[j] > 0.0).collect()
}

/// One frame in the test's weighted space: B = diag(1/√v)·P·A and b = y/√v, with
/// c = Bᵀb and the squared column norms.
pub(crate) struct Weighted {
    m: usize,
    n: usize,
    /// B by columns.
    b: Vec<f64>,
    /// Bᵀ(weighted frame).
    c: Vec<f64>,
    /// ‖B_j‖².
    d: Vec<f64>,
    /// The weighted frame.
    yb: Vec<f64>,
    /// ‖weighted frame‖².
    yty: f64,
}

impl Weighted {
    fn new(cols: &[f64], yp: &[f64], var: &[f64]) -> Self {
        let m = yp.len();
        let n = cols.len() / m.max(1);
        let sw: Vec<f64> = var.iter().map(|v| 1.0 / v.max(1e-300).sqrt()).collect();
        let yb: Vec<f64> = yp.iter().zip(&sw).map(|(y, s)| y * s).collect();
        let mut b = Vec::with_capacity(m * n);
        let (mut c, mut d) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for j in 0..n {
            let col = &cols[j * m..(j + 1) * m];
            let (mut cj, mut dj) = (0.0, 0.0);
            for i in 0..m {
                let v = col[i] * sw[i];
                b.push(v);
                cj += v * yb[i];
                dj += v * v;
            }
            c.push(cj);
            d.push(dj);
        }
        Weighted {
            m,
            n,
            b,
            c,
            d,
            yty: yb.iter().map(|v| v * v).sum(),
            yb,
        }
    }

    fn col(&self, j: usize) -> &[f64] {
        &self.b[j * self.m..(j + 1) * self.m]
    }

    fn dot(&self, j: usize, l: usize) -> f64 {
        self.col(j)
            .iter()
            .zip(self.col(l))
            .map(|(a, b)| a * b)
            .sum()
    }

    /// B_jᵀB: the Gram row of cell j.
    fn gram_row(&self, j: usize) -> Vec<f64> {
        (0..self.n).map(|l| self.dot(j, l)).collect()
    }

    /// The least χ² over loads on `cells` within [lo, hi] and those loads (exact);
    /// None when the cells' columns are dependent.
    fn box_fit(&self, cells: &[usize], lo: f64, hi: f64) -> Option<(f64, Vec<f64>)> {
        let k = cells.len();
        if k == 0 {
            return Some((self.yty, Vec::new()));
        }
        let g = DMatrix::from_fn(k, k, |a, q| self.dot(cells[a], cells[q]));
        let b = DVector::from_fn(k, |a, _| self.c[cells[a]]);
        let z = box_qp(
            &g,
            &b,
            &DVector::from_element(k, lo),
            &DVector::from_element(k, hi),
        )?;
        let quad = z.dot(&(&g * &z)) - 2.0 * b.dot(&z);
        Some(((self.yty + quad).max(0.0), z.iter().copied().collect()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_p_values_match_closed_forms_and_tables() {
        // dof 2: P = exp(−x/2); dof 1: P = erfc(√(x/2)), 3.841 → 0.05; dof 4: tables.
        for x in [0.1, 1.0, 5.0, 20.0] {
            let want = (-x / 2.0f64).exp();
            assert!(
                (chi2_p_value(x, 2) - want).abs() < 1e-12 * (1.0 + want),
                "{x}"
            );
        }
        assert!((chi2_p_value(3.841_458_820_694_124, 1) - 0.05).abs() < 1e-10);
        assert!((chi2_p_value(10.827_566_170_662_733, 1) - 1e-3).abs() < 1e-10);
        assert!((chi2_p_value(9.487_729_036_781_154, 4) - 0.05).abs() < 1e-10);
        assert!((chi2_p_value(29.588_298_445_074_4, 10) - 0.001).abs() < 1e-10);
        assert_eq!(chi2_p_value(0.0, 3), 1.0);
        assert_eq!(chi2_p_value(5.0, 0), 1.0);
        // The quantiles invert them: Φ⁻¹(1 − α/2)² for one degree of freedom.
        assert!((rival_quantile(0.05) - 3.841_458_820_694_124).abs() < 1e-9);
        assert!((rival_quantile(0.01) - 6.634_896_601_021_214).abs() < 1e-9);
        assert!((chi2_quantile(0.001, 10) - 29.588_298_445_074_4).abs() < 1e-8);
        // The closed form agrees with the bisection, deep in the tails too.
        for a in [1e-8, 1e-4, 0.003, 0.2, 0.5] {
            let (q1, qb) = (rival_quantile(a), chi2_quantile(a, 1));
            assert!((q1 - qb).abs() < 1e-9 * (1.0 + qb), "{a}: {q1} {qb}");
        }
    }

    #[test]
    fn the_truth_held_against_a_wrong_answer_costs_exactly_its_price_per_load_without_noise() {
        use crate::kernel::{matrix_from_positions, paper_layout, DistanceKernel};
        let (c, g) = paper_layout();
        let a = matrix_from_positions(&c, &g, &DistanceKernel::paper());
        let p = SensingProblem::new(a.clone(), 250.0, true).unwrap();
        let test = FrameTest::new(&p, 4);
        // 120 g on cell 1 and 60 g on cell 6, read without noise.
        let truth = [0.0, 120.0, 0.0, 0.0, 0.0, 0.0, 60.0, 0.0];
        let y: Vec<f64> = (&a * DVector::from_column_slice(&truth))
            .iter()
            .copied()
            .collect();
        // The answer moved the 60 g load to cell 3.
        let mut r = Reconstruction::answer(vec![0.0, 120.0, 0.0, 60.0, 0.0, 0.0, 0.0, 0.0]);
        test.assess(&y, &mut r);
        let held = test.hold_against(&y, &r, &[1, 6]).unwrap();
        // The truth fits the noise-free frame exactly: χ² 0, two loads at 16 each.
        assert!(
            (held.penalised_chi2 - 2.0 * OCCAM_CHI2).abs() < 1e-6,
            "{held:?}"
        );
        // The answer is priced as the test priced it.
        assert!((held.answer_penalised_chi2 - (r.chi2 + 2.0 * OCCAM_CHI2)).abs() < 1e-9);
        assert!(r.chi2 > chi2_1_quantile(1e-6), "{}", r.chi2);
        // Found as a rival, the truth would make the frame ambiguous.
        assert!(
            held.rival_p_value.unwrap() < DEFAULT_SIGNIFICANCE / TESTS,
            "{held:?}"
        );
        // The answer's own support is no rival and costs what the answer costs.
        let own = test.hold_against(&y, &r, &[1, 3]).unwrap();
        assert_eq!(own.rival_p_value, None);
        assert!((own.penalised_chi2 - own.answer_penalised_chi2).abs() < 1e-9);
        // A frame of the wrong length is not held.
        assert!(test.hold_against(&y[..5], &r, &[1, 6]).is_none());
    }

    #[test]
    fn flags_read_as_words_and_count() {
        let f = FrameFlags {
            inconsistent: true,
            ambiguous: true,
            ..FrameFlags::default()
        };
        assert_eq!(f.field(), "inconsistent;ambiguous");
        assert!(!f.trusted() && FrameFlags::default().trusted());
        assert_eq!(
            serde_json::to_value(f).unwrap(),
            serde_json::json!(["inconsistent", "ambiguous"])
        );
    }

    #[test]
    fn the_significance_is_a_probability_up_to_one_half() {
        for bad in [0.0, -0.1, 0.6, f64::NAN] {
            assert!(check_significance(bad).is_err(), "{bad}");
        }
        assert!(check_significance(0.01).is_ok() && check_significance(0.5).is_ok());
    }
}
