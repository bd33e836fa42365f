//! A dead or stuck grating: its shift stays at one level while the matrix predicts
//! large responses. Over the strongest frames of the stream (at most
//! [`super::sample::STRONGEST_FRAMES`]), grating i is suspect when its reading hardly
//! varies (standard deviation ≤ [`STILL_SIGMAS`] × the resolution) while the loads
//! reconstructed *without it* predict readings that vary with a standard deviation
//! of at least [`PREDICTED_SIGMAS`] × the resolution: the others say it should move
//! a lot, and it does not. (Variation, not level: a grating whose matrix entries are
//! merely off still moves with the loads, and a stuck one may sit at any value.)
//! Leaving the grating out is what makes the test fair: with it, the fit is pulled
//! towards its flat reading. Only gratings that pass the first (cheap) test are
//! reconstructed without. Suspects are left out of every frame.
//!
//! The frames: the stream's strongest, the frames spread over it, and the largest
//! readings of the [`NEIGHBOURS`] gratings whose rows of the matrix most resemble
//! grating i's (the frames loaded near it). On a large array the strongest frames
//! alone may load nowhere near a grating, and its death then goes unseen or reads as
//! noise (the 16 × 64 grid of the flag study, issue 35).

use super::{leave_one_out, mean, Corrections, StreamSample, SuspectGrating, SuspectReason};
use crate::methods::ReadingSettings;
use crate::problem::SensingProblem;
use crate::ArrayError;

/// A reading "at one level": its standard deviation over the strong frames is at
/// most this many resolutions.
pub(crate) const STILL_SIGMAS: f64 = 3.0;

/// "Large responses": the readings predicted without the grating vary with a
/// standard deviation of at least this many resolutions.
pub(crate) const PREDICTED_SIGMAS: f64 = 10.0;

/// Gratings whose largest readings are added to the strongest frames when grating
/// i is tested: the ones whose matrix rows are most like i's.
pub(crate) const NEIGHBOURS: usize = 2;

/// Fewest usable frames with a signal before the test is made.
pub(crate) const MIN_ACTIVE_FRAMES: usize = 4;

fn sd(v: &[f64]) -> f64 {
    let mu = mean(v);
    (v.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// The frames grating `i` is tested on: the strongest, the spread ones and its
/// [`NEIGHBOURS`]' largest readings (each frame once), those with a signal.
fn frames_for<'s>(problem: &SensingProblem, sample: &'s StreamSample, i: usize) -> Vec<&'s [f64]> {
    let a = &problem.sensitivity_pm_per_g;
    let sigma = problem.uncertainty.resolution_pm;
    let row_i = a.row(i);
    let mut near: Vec<(f64, usize)> = (0..a.nrows())
        .filter(|&j| j != i)
        .map(|j| {
            let row_j = a.row(j);
            let cos = row_i.dot(&row_j) / (row_i.norm() * row_j.norm()).max(1e-300);
            (cos, j)
        })
        .collect();
    near.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    let mut seen = std::collections::HashSet::new();
    let mut frames = Vec::new();
    let tops = near
        .iter()
        .take(NEIGHBOURS)
        .flat_map(|&(_, j)| sample.tops(j).into_iter().map(|(_, f)| f));
    let spread = sample.spread().iter();
    for (index, y) in sample.strongest().into_iter().chain(spread).chain(tops) {
        let strong = y.iter().map(|v| v * v).sum::<f64>().sqrt() > PREDICTED_SIGMAS * sigma;
        if strong && seen.insert(*index) {
            frames.push(y.as_slice());
        }
    }
    frames
}

/// Find the dead or stuck gratings of `problem` (all the stream's rows) and drop them.
pub(super) fn find(
    problem: &SensingProblem,
    prior: &ReadingSettings,
    sample: &StreamSample,
    corr: &mut Corrections,
    suspects: &mut Vec<SuspectGrating>,
) -> Result<(), ArrayError> {
    let m = problem.n_gratings();
    let sigma = problem.uncertainty.resolution_pm;
    for i in 0..m {
        let active = frames_for(problem, sample, i);
        if active.len() < MIN_ACTIVE_FRAMES {
            continue;
        }
        let reads: Vec<f64> = active.iter().map(|y| y[i]).collect();
        let measured = sd(&reads);
        if measured > STILL_SIGMAS * sigma {
            continue;
        }
        let preds: Vec<f64> = leave_one_out(problem, prior, i, &active)?
            .into_iter()
            .flatten()
            .map(|(p, _)| p)
            .collect();
        if preds.len() < MIN_ACTIVE_FRAMES {
            continue;
        }
        let predicted = sd(&preds);
        if predicted >= PREDICTED_SIGMAS * sigma {
            corr.dropped.push(i);
            suspects.push(SuspectGrating {
                index: i,
                name: String::new(),
                reason: SuspectReason::DeadOrStuck,
                partner: None,
                partner_name: None,
                evidence: format!(
                    "its shift varies by {measured:.2} pm (sd) over {} strong frames (the strongest, those spread over the stream and those loaded near it), where the other gratings predict {predicted:.1} pm",
                    active.len()
                ),
                remedy: "left out of every frame".into(),
                frames: active.len(),
            });
        }
    }
    Ok(())
}
