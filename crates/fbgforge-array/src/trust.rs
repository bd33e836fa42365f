//! Whether a frame's answer can be trusted: the per-frame flags every reconstruction
//! carries ([`FrameFlags`]), and the test behind each.
//!
//! * `inconsistent`: the residual is larger than the problem's [`Uncertainty`]
//!   explains (interrogator noise, the matrix's own per-entry error, the additivity
//!   error of simultaneous loads): no loads on the answer's cells (within
//!   [0, ulimit]) bring χ² = Σ r_i²/v_i, with v_i the variances at the answer, below
//!   the χ² quantile at 1 − [`FALSE_ALARM`] with dof = gratings − loads (− 1 with a
//!   common-mode term). The loads are refitted with the weights 1/v_i for the test:
//!   the methods fit unweighted, and a grating with a large stated matrix error
//!   would otherwise spread its misfit over the others. A fault the model does not hold (a temperature offset, a
//!   dead grating, a matrix worse than stated) shows here.
//! * `ceiling`: a load sits at the upper bound (ulimit): the true load may be larger.
//! * `overload`: the frame is consistent with a load above ulimit: on some subset of
//!   the answer's cells that holds a load at the ceiling, the fit without the upper
//!   bound has every load positive, one above ulimit, and passes the χ² test.
//! * `below_range`: a loaded cell carries less than the array's rated minimum
//!   (`min_load_g`, the paper's 25 g): a load the array is not rated to read,
//!   typically one a fault (temperature offset, dead grating, additivity error)
//!   made up to absorb a misfit.
//! * `ambiguous`: another answer at least 12 dB away from this one fits the frame
//!   about as well (the support searches' contenders, [`Reconstruction::rival_fits`]),
//!   or a loaded cell's column is identical to another cell's (any method).
//! * `unconverged`: the method did not meet its convergence test (`bnb`: stopped at
//!   its work budget, best support found, not certified).
//! * `unusable`: the frame had a wrong length or a non-finite shift (zero loads).
//!
//! [`Checker::assess`] fills the flags, the χ² and its degrees of freedom; it is
//! called for every frame by [`crate::reconstruct()`], so the CLI, Python and
//! live get the same flags.

use super::methods::Reconstruction;
use super::problem::SensingProblem;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// The per-frame flags, defined beside the [`Reconstruction`] that carries them.
pub use super::methods::FrameFlags;

/// Probability with which a frame whose errors are as stated is still flagged
/// `inconsistent` (and with which `overload` is raised on a touching bound).
pub(crate) const FALSE_ALARM: f64 = 1e-3;

/// Columns whose cosine is at least this are identical for `ambiguous`.
pub(crate) const IDENTICAL_COLUMNS_COS: f64 = 1.0 - 1e-6;

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
            let f = &r.flags;
            c.trusted += usize::from(f.trusted());
            c.inconsistent += usize::from(f.inconsistent);
            c.ceiling += usize::from(f.ceiling);
            c.overload += usize::from(f.overload);
            c.below_range += usize::from(f.below_range);
            c.ambiguous += usize::from(f.ambiguous);
            c.unconverged += usize::from(f.unconverged);
            c.unusable += usize::from(f.unusable);
        }
        c
    }
}

/// ln Γ(a) for a > 0 (Lanczos, g = 7, 9 terms: ~15 digits).
fn ln_gamma(a: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if a < 0.5 {
        // Reflection: Γ(a)Γ(1 − a) = π / sin(πa).
        let pi = std::f64::consts::PI;
        return (pi / (pi * a).sin()).ln() - ln_gamma(1.0 - a);
    }
    let x = a - 1.0;
    let mut s = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        s += c / (x + i as f64);
    }
    let t = x + 7.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// The upper regularised incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a): by its
/// series for x < a + 1, else by its continued fraction (modified Lentz).
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let ln_pre = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * ln_pre.exp()).clamp(0.0, 1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (ln_pre.exp() * h).clamp(0.0, 1.0)
    }
}

/// P(χ²_dof ≥ x): the p-value of a χ² statistic with `dof` degrees of freedom.
pub(crate) fn chi2_p_value(x: f64, dof: usize) -> f64 {
    if dof == 0 {
        return 1.0;
    }
    gamma_q(0.5 * dof as f64, 0.5 * x.max(0.0))
}

/// The per-frame tests of one problem, with what depends only on the matrix.
#[derive(Debug, Clone)]
pub(crate) struct Checker {
    problem: SensingProblem,
    /// For each cell, whether another cell's column is identical to its own.
    has_twin: Vec<bool>,
}

impl Checker {
    /// Prepare the tests for `problem` (finds identical columns once).
    pub fn new(problem: &SensingProblem) -> Self {
        let a = &problem.working;
        let n = a.ncols();
        let norms: Vec<f64> = (0..n).map(|j| a.column(j).norm().max(1e-300)).collect();
        let mut has_twin = vec![false; n];
        for j in 0..n {
            for k in j + 1..n {
                let cos = a.column(j).dot(&a.column(k)) / (norms[j] * norms[k]);
                if cos >= IDENTICAL_COLUMNS_COS {
                    has_twin[j] = true;
                    has_twin[k] = true;
                }
            }
        }
        Checker {
            problem: problem.clone(),
            has_twin,
        }
    }

    /// The problem tested.
    pub fn problem(&self) -> &SensingProblem {
        &self.problem
    }

    /// Fill `r`'s χ², degrees of freedom and flags for frame `shifts_pm`.
    pub(crate) fn assess(&self, shifts_pm: &[f64], r: &mut Reconstruction) {
        let p = &self.problem;
        if r.flags.unusable || p.check_shifts(shifts_pm).is_err() {
            r.flags = FrameFlags {
                unusable: true,
                ..FrameFlags::default()
            };
            return;
        }
        let x = &r.loads_g;
        let support: Vec<usize> = (0..x.len()).filter(|&j| x[j] > 0.0).collect();
        let predicted = &p.sensitivity_pm_per_g * DVector::from_column_slice(x);
        let var = p.uncertainty.reading_variances_pm2(x, predicted.as_slice());
        let chi2 = self
            .weighted_chi2(shifts_pm, &support, &var)
            .unwrap_or_else(|| {
                let res = p.residual_vector_pm(x, shifts_pm);
                res.iter().zip(&var).map(|(r, v)| r * r / v).sum()
            });
        let m = p.n_gratings();
        let dof = m.saturating_sub(support.len() + usize::from(p.common_mode.is_some()));
        let at_ceiling: Vec<usize> = support
            .iter()
            .copied()
            .filter(|&j| x[j] >= p.ulimit_g * (1.0 - 1e-9))
            .collect();
        r.chi2 = chi2;
        r.dof = dof;
        r.flags = FrameFlags {
            inconsistent: dof > 0 && chi2_p_value(chi2, dof) < FALSE_ALARM,
            ceiling: !at_ceiling.is_empty(),
            overload: !at_ceiling.is_empty() && self.overload(shifts_pm, &support, &at_ceiling),
            below_range: p.min_load_g > 0.0 && support.iter().any(|&j| x[j] < p.min_load_g),
            ambiguous: r.rival_fits == Some(true) || support.iter().any(|&j| self.has_twin[j]),
            unconverged: !r.converged,
            unusable: false,
        };
    }

    /// The least χ² (weights 1/v_i) over loads on `support` within [0, ulimit]
    /// (exact, [`crate::methods::bounded::box_qp`]); None if the support's
    /// columns are dependent.
    fn weighted_chi2(&self, y: &[f64], support: &[usize], var: &[f64]) -> Option<f64> {
        let p = &self.problem;
        let m = p.n_gratings();
        let k = support.len();
        let yp = p.project_frame(y);
        let yw = DVector::from_fn(m, |i, _| yp[i] / var[i].sqrt());
        if k == 0 {
            return Some(yw.norm_squared());
        }
        let cols: Vec<Vec<f64>> = support
            .iter()
            .map(|&j| p.project_frame(p.sensitivity_pm_per_g.column(j).as_slice()))
            .collect();
        let a = DMatrix::from_fn(m, k, |i, c| cols[c][i] / var[i].sqrt());
        let g = a.transpose() * &a;
        let b = a.transpose() * &yw;
        let z = crate::methods::bounded::box_qp(
            &g,
            &b,
            &DVector::zeros(k),
            &DVector::from_element(k, p.ulimit_g),
        )?;
        Some((&a * z - yw).norm_squared())
    }

    /// Whether some subset of the support holding a load at the ceiling, fitted
    /// without the upper bound (weights 1/v_i at that fit), has every load positive,
    /// one above ulimit, and passes the χ² test.
    fn overload(&self, y: &[f64], support: &[usize], at_ceiling: &[usize]) -> bool {
        let p = &self.problem;
        let m = p.n_gratings();
        let k = support.len();
        if k > 12 {
            return false;
        }
        let yp = p.project_frame(y);
        let cols: Vec<Vec<f64>> = support
            .iter()
            .map(|&j| p.project_frame(p.sensitivity_pm_per_g.column(j).as_slice()))
            .collect();
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
                let a = DMatrix::from_fn(m, t.len(), |i, c| cols[t[c]][i] / var[i].sqrt());
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
            if dof == 0 || chi2_p_value(chi2, dof) >= FALSE_ALARM {
                return true;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_p_values_match_closed_forms_and_tables() {
        // The 1-dof χ² quantile at 1 − FALSE_ALARM (Φ⁻¹(1 − α/2)² = 3.2905²).
        const CHI2_1DOF_AT_FALSE_ALARM: f64 = 10.827_566_170_662_733;
        // dof 2: P = exp(−x/2); dof 1: P = erfc(√(x/2)), 3.841 → 0.05; dof 4: tables.
        for x in [0.1, 1.0, 5.0, 20.0] {
            let want = (-x / 2.0f64).exp();
            assert!(
                (chi2_p_value(x, 2) - want).abs() < 1e-12 * (1.0 + want),
                "{x}"
            );
        }
        assert!((chi2_p_value(3.841_458_820_694_124, 1) - 0.05).abs() < 1e-10);
        assert!((chi2_p_value(CHI2_1DOF_AT_FALSE_ALARM, 1) - FALSE_ALARM).abs() < 1e-10);
        assert!((chi2_p_value(9.487_729_036_781_154, 4) - 0.05).abs() < 1e-10);
        assert!((chi2_p_value(29.588_298_445_074_4, 10) - 0.001).abs() < 1e-10);
        assert_eq!(chi2_p_value(0.0, 3), 1.0);
        assert_eq!(chi2_p_value(5.0, 0), 1.0);
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
}
