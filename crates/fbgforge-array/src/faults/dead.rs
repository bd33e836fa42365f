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

/// Fewest usable frames with a signal before the test is made.
pub(crate) const MIN_ACTIVE_FRAMES: usize = 4;

fn sd(v: &[f64]) -> f64 {
    let mu = mean(v);
    (v.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / v.len().max(1) as f64).sqrt()
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
    let active: Vec<&[f64]> = sample
        .strongest()
        .into_iter()
        .map(|(_, y)| y.as_slice())
        .filter(|y| y.iter().map(|v| v * v).sum::<f64>().sqrt() > PREDICTED_SIGMAS * sigma)
        .collect();
    if active.len() < MIN_ACTIVE_FRAMES {
        return Ok(());
    }
    for i in 0..m {
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
                    "its shift varies by {measured:.2} pm (sd) over the {} strongest frames, where the other gratings predict {predicted:.1} pm",
                    active.len()
                ),
                remedy: "left out of every frame".into(),
                frames: active.len(),
            });
        }
    }
    Ok(())
}
