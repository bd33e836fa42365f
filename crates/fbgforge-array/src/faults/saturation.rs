//! A saturated grating: its reading stops at a ceiling (the peak leaves the part of
//! the spectrum the interrogator reads, or the channel clips). Its largest readings
//! then sit on a flat top: at least [`MIN_AT_TOP`] of them within two resolutions of
//! the largest, while the loads the other gratings give predict more there, by at
//! least [`EXCESS_SIGMAS`] resolutions and [`EXCESS_FRAC`] of the top (median over
//! those frames). On a small array the other gratings' leave-one-out prediction is
//! too loose for that median (five gratings, up to four loads: many explanations),
//! so a flat top is also named when the whole fit is pulled down there: in most of
//! those frames the fit with the grating predicts more than it reads (a sign test at
//! [`CENSORED_P`]) or leaving it out lowers their χ² beyond chance (the χ² quantile
//! at 1 − [`CENSORED_P`], a degree of freedom per frame); a healthy grating's
//! residual at its largest readings has either sign, and a reading made too large
//! (additivity) pushes the other way. Frames where it reads at its top are
//! reconstructed without it.

use super::{
    leave_one_out, median, view, Corrections, Solver, StreamSample, SuspectGrating, SuspectReason,
};
use crate::methods::ReadingSettings;
use crate::problem::SensingProblem;
use crate::trust::chi2_quantile;
use crate::ArrayError;

/// Fewest readings on the flat top.
pub(crate) const MIN_AT_TOP: usize = 3;

/// Least median excess of the prediction over the top, resolutions.
pub(crate) const EXCESS_SIGMAS: f64 = 5.0;

/// Least median excess of the prediction over the top, as a fraction of the top.
pub(crate) const EXCESS_FRAC: f64 = 0.1;

/// A reading is at the top when within this many resolutions of it.
pub(crate) const TOP_SIGMAS: f64 = 2.0;

/// Size of each of the two tests on the frames at the top (the sign test and the χ²
/// drop) when the other gratings' leave-one-out prediction is too loose to tell.
pub(crate) const CENSORED_P: f64 = 1e-3;

/// P(at least `k` of `n` fair coin tosses come up heads).
fn sign_test_p(k: usize, n: usize) -> f64 {
    let mut term = 0.5f64.powi(n as i32); // C(n, 0) / 2^n
    let mut tail = 0.0;
    for j in 0..=n {
        if j >= k {
            tail += term;
        }
        term *= (n - j) as f64 / (j + 1) as f64;
    }
    tail.min(1.0)
}

/// Find the saturated gratings among the rows `current` keeps of `original`.
pub(super) fn find(
    original: &SensingProblem,
    current: &SensingProblem,
    prior: &ReadingSettings,
    sample: &StreamSample,
    corr: &mut Corrections,
    suspects: &mut Vec<SuspectGrating>,
) -> Result<(), ArrayError> {
    let sigma = original.uncertainty.resolution_pm;
    let kept = corr.kept(original.n_gratings());
    let full = Solver::new(current.clone(), prior)?;
    let mut found = Vec::new();
    for (r, &i) in kept.iter().enumerate() {
        let tops: Vec<(usize, Vec<f64>)> = sample
            .tops(i)
            .into_iter()
            .map(|(_, (f, y))| (*f, corr.corrected(*f, y)))
            .collect();
        let Some(top) = tops.iter().map(|(_, y)| y[i]).reduce(f64::max) else {
            continue;
        };
        if top <= TOP_SIGMAS * sigma {
            continue;
        }
        let at_top: Vec<&(usize, Vec<f64>)> = tops
            .iter()
            .filter(|(_, y)| y[i] >= top - TOP_SIGMAS * sigma)
            .collect();
        if at_top.len() < MIN_AT_TOP {
            continue;
        }
        let views: Vec<Vec<f64>> = at_top.iter().map(|(f, y)| view(corr, *f, y)).collect();
        let ys: Vec<&[f64]> = views.iter().map(Vec::as_slice).collect();
        let preds: Vec<f64> = leave_one_out(current, prior, r, &ys)?
            .into_iter()
            .flatten()
            .map(|(p, _)| p)
            .collect();
        if preds.len() < MIN_AT_TOP {
            continue;
        }
        let predicted = median(preds.clone());
        let (drop, below) = censored(&full, current, prior, r, &ys)?;
        let n = ys.len();
        let pulled_down = 2 * below > n
            && (sign_test_p(below, n) <= CENSORED_P || drop > chi2_quantile(CENSORED_P, n));
        if predicted - top >= (EXCESS_SIGMAS * sigma).max(EXCESS_FRAC * top) || pulled_down {
            found.push((i, top, predicted, at_top.len(), below, drop));
        }
    }
    for (i, top, predicted, count, below, drop) in found {
        corr.clipped.push((i, top - TOP_SIGMAS * sigma));
        suspects.push(SuspectGrating {
            index: i,
            name: String::new(),
            reason: SuspectReason::Saturated,
            partner: None,
            partner_name: None,
            evidence: format!(
                "{count} of its largest readings sit on a flat top at {top:.1} pm where the other gratings predict {predicted:.1} pm (median); on {below} of them the fit with it predicts more than it reads, and leaving it out lowers their χ² by {drop:.0}"
            ),
            remedy: format!(
                "left out of the frames where it reads {:.1} pm or more",
                top - TOP_SIGMAS * sigma
            ),
            frames: count,
        });
    }
    Ok(())
}

/// Over the frames `ys` (rows of `current`) where row `r` reads at its top: how much
/// the frames' χ² falls when the row is left out (the sum over the frames), and in
/// how many frames the fit with it predicts more than it reads.
fn censored(
    full: &Solver,
    current: &SensingProblem,
    prior: &ReadingSettings,
    r: usize,
    ys: &[&[f64]],
) -> Result<(f64, usize), ArrayError> {
    let Ok(reduced) = current.without_gratings(&[r]) else {
        return Ok((0.0, 0));
    };
    let loo = Solver::new(reduced, prior)?;
    let mut drop = 0.0;
    let mut below = 0;
    for y in ys {
        let with = full.solve(y);
        let yr: Vec<f64> = (0..y.len()).filter(|&q| q != r).map(|q| y[q]).collect();
        let without = loo.solve(&yr);
        if with.flags.unusable || without.flags.unusable {
            continue;
        }
        drop += with.chi2 - without.chi2;
        below += usize::from(current.residual_vector_pm(&with.loads_g, y)[r] < 0.0);
    }
    Ok((drop, below))
}
