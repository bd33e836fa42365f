//! A saturated grating: its reading stops at a ceiling (the peak leaves the part of
//! the spectrum the interrogator reads, or the channel clips). Its largest readings
//! then sit on a flat top: at least [`MIN_AT_TOP`] of them within two resolutions of
//! the largest, while the loads the other gratings give predict more there, by at
//! least [`EXCESS_SIGMAS`] resolutions and [`EXCESS_FRAC`] of the top (median over
//! those frames). Frames where it reads at its top are reconstructed without it.

use super::{
    leave_one_out, median, view, Corrections, StreamSample, SuspectGrating, SuspectReason,
};
use crate::methods::ReadingSettings;
use crate::problem::SensingProblem;
use crate::ArrayError;

/// Fewest readings on the flat top.
pub(crate) const MIN_AT_TOP: usize = 3;

/// Least median excess of the prediction over the top, resolutions.
pub(crate) const EXCESS_SIGMAS: f64 = 5.0;

/// Least median excess of the prediction over the top, as a fraction of the top.
pub(crate) const EXCESS_FRAC: f64 = 0.1;

/// A reading is at the top when within this many resolutions of it.
pub(crate) const TOP_SIGMAS: f64 = 2.0;

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
            if std::env::var("I35_DEBUG").is_ok() {
                eprintln!(
                    "sat g{i} top {top:.2} at_top {} only; next {:?}",
                    at_top.len(),
                    tops.iter().take(5).map(|(_, y)| y[i]).collect::<Vec<_>>()
                );
            }
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
        if std::env::var("I35_DEBUG").is_ok() {
            eprintln!(
                "sat g{i} top {top:.2} at_top {} preds {:?}",
                at_top.len(),
                preds
                    .iter()
                    .map(|p| (p * 10.0).round() / 10.0)
                    .collect::<Vec<_>>()
            );
        }
        if predicted - top >= (EXCESS_SIGMAS * sigma).max(EXCESS_FRAC * top) {
            found.push((i, top, predicted, at_top.len()));
        }
    }
    for (i, top, predicted, count) in found {
        corr.clipped.push((i, top - TOP_SIGMAS * sigma));
        suspects.push(SuspectGrating {
            index: i,
            name: String::new(),
            reason: SuspectReason::Saturated,
            partner: None,
            partner_name: None,
            evidence: format!(
                "{count} of its largest readings sit on a flat top at {top:.1} pm where the other gratings predict {predicted:.1} pm (median)"
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
