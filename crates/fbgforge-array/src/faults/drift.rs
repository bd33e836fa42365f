//! A drifting grating: its reading moves away, slowly, from what the loads explain
//! (a bond that creeps, a grating whose temperature changes alone). Over the frames
//! spread across the stream, each grating's leave-one-out residual (its reading less
//! what the other gratings' loads predict, frames whose fit passed its χ² test) is
//! fitted with a robust line (Theil–Sen slope, intercept and scale by medians). The
//! grating drifts when the line's t-statistic is at least [`DRIFT_T`] and its change
//! over the stream at least [`DRIFT_MIN_SIGMAS`] resolutions. The leave-one-out fits
//! carry the common-mode term when the problem may have one, so that a temperature
//! drift of every grating (a common offset, [`super::offset`]) is predicted for the
//! grating left out and does not read as its own; and when half the gratings or more
//! drift the same way all the same, none is named. A drifting grating's readings are
//! corrected by its line.

use super::{
    leave_one_out, median, view, Corrections, StreamSample, SuspectGrating, SuspectReason,
};
use crate::methods::ReadingSettings;
use crate::problem::SensingProblem;
use crate::ArrayError;

/// Least |t| of the trend (slope over its standard error from the robust scale).
pub(crate) const DRIFT_T: f64 = 6.0;

/// Least change of the trend over the stream, resolutions.
pub(crate) const DRIFT_MIN_SIGMAS: f64 = 4.0;

/// Fewest frames with a usable leave-one-out fit before the test is made.
pub(crate) const MIN_DRIFT_FRAMES: usize = 16;

/// A robust straight line through (frame index, residual) points.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Line {
    pub offset: f64,
    pub slope: f64,
    /// Robust scale of the residuals about the line (not floored), pm.
    pub scale: f64,
    /// Slope over its standard error.
    pub t: f64,
    /// Change over the frames' span, pm.
    pub change: f64,
}

/// Theil–Sen line with a robust t: the slope is the median of the pairwise slopes,
/// the scale 1.4826 × the median absolute residual (at least `floor`).
pub(crate) fn robust_line(points: &[(f64, f64)], floor: f64) -> Option<Line> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let mut slopes = Vec::with_capacity(n * (n - 1) / 2);
    for a in 0..n {
        for b in a + 1..n {
            let dx = points[b].0 - points[a].0;
            if dx != 0.0 {
                slopes.push((points[b].1 - points[a].1) / dx);
            }
        }
    }
    if slopes.is_empty() {
        return None;
    }
    let slope = median(slopes);
    let offset = median(points.iter().map(|(x, y)| y - slope * x).collect());
    let raw = 1.4826
        * median(
            points
                .iter()
                .map(|(x, y)| (y - offset - slope * x).abs())
                .collect(),
        );
    let scale = raw.max(floor);
    let xm = points.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let sxx: f64 = points.iter().map(|p| (p.0 - xm) * (p.0 - xm)).sum();
    let (lo, hi) = points
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), p| (l.min(p.0), h.max(p.0)));
    Some(Line {
        offset,
        slope,
        scale: raw,
        t: slope * sxx.sqrt() / scale,
        change: slope * (hi - lo),
    })
}

/// Each grating's leave-one-out residual history: its row, its robust line and the
/// frames it rests on (gratings with too few frames are left out).
pub(super) type Histories = Vec<(usize, Line, usize)>;

/// The robust line of each of `rows` ((row of `current`, row of the original)):
/// its leave-one-out residual history over the spread frames as `corr` corrects
/// them; rows with too few usable frames are left out.
fn lines(
    with_offset: &SensingProblem,
    prior: &ReadingSettings,
    sample: &StreamSample,
    corr: &Corrections,
    rows: &[(usize, usize)],
    floor: f64,
) -> Result<Histories, ArrayError> {
    let frames: Vec<(usize, Vec<f64>)> = sample
        .spread()
        .iter()
        .map(|(f, y)| (*f, view(corr, *f, y)))
        .collect();
    let ys: Vec<&[f64]> = frames.iter().map(|(_, y)| y.as_slice()).collect();
    let mut out = Histories::new();
    for &(r, i) in rows {
        let preds = leave_one_out(with_offset, prior, r, &ys)?;
        let points: Vec<(f64, f64)> = frames
            .iter()
            .zip(&preds)
            .filter_map(|((f, y), p)| match p {
                Some((pred, true)) => Some((*f as f64, y[r] - pred)),
                _ => None,
            })
            .collect();
        if points.len() < MIN_DRIFT_FRAMES {
            continue;
        }
        if let Some(line) = robust_line(&points, floor) {
            out.push((i, line, points.len()));
        }
    }
    Ok(out)
}

/// Find the drifting gratings among the rows `current` keeps of `original`, and
/// correct them; return every grating's residual history (for [`super::noisy`]).
///
/// One drifting grating leaks into its neighbours' leave-one-out residuals (it is
/// in their fits), so they can show a smaller trend of their own: the strongest
/// trend is taken first, corrected, and the others tested again on the corrected
/// frames, until none is left.
pub(super) fn find(
    original: &SensingProblem,
    current: &SensingProblem,
    common_weights: Option<&[f64]>,
    prior: &ReadingSettings,
    sample: &StreamSample,
    corr: &mut Corrections,
    suspects: &mut Vec<SuspectGrating>,
) -> Result<Histories, ArrayError> {
    let sigma = original.uncertainty.resolution_pm;
    let kept = corr.kept(original.n_gratings());
    if sample.spread().len() < MIN_DRIFT_FRAMES {
        return Ok(Histories::new());
    }
    let with_offset = match common_weights {
        Some(w) if current.common_mode.is_none() => current
            .clone()
            .with_common_mode(w)
            .unwrap_or_else(|_| current.clone()),
        _ => current.clone(),
    };
    let rows: Vec<(usize, usize)> = kept.iter().copied().enumerate().collect();
    let histories = lines(&with_offset, prior, sample, corr, &rows, 0.5 * sigma)?;
    let drifts = |h: &Histories| -> Histories {
        h.iter()
            .copied()
            .filter(|(_, l, _)| l.t.abs() >= DRIFT_T && l.change.abs() >= DRIFT_MIN_SIGMAS * sigma)
            .collect()
    };
    let mut found = drifts(&histories);
    // Half the gratings or more drifting the same way: the temperature of all.
    let m = kept.len();
    let up = found.iter().filter(|(_, l, _)| l.slope > 0.0).count();
    let down = found.len() - up;
    if up.max(down) >= 3.max(m.div_ceil(2)) {
        return Ok(histories);
    }
    while let Some(k) =
        (0..found.len()).max_by(|&a, &b| found[a].1.t.abs().total_cmp(&found[b].1.t.abs()))
    {
        let (i, line, count) = found.swap_remove(k);
        corr.trends.push((i, line.offset, line.slope));
        suspects.push(SuspectGrating {
            index: i,
            name: String::new(),
            reason: SuspectReason::Drifting,
            partner: None,
            partner_name: None,
            evidence: format!(
                "its reading drifts by {:+.1} pm over the stream against what the other gratings predict (robust trend, t = {:.0}, {count} frames)",
                line.change, line.t
            ),
            remedy: "its readings corrected by that trend".into(),
            frames: count,
        });
        if found.is_empty() {
            break;
        }
        let again: Vec<(usize, usize)> = rows
            .iter()
            .copied()
            .filter(|(_, q)| found.iter().any(|(f, _, _)| f == q))
            .collect();
        found = drifts(&lines(
            &with_offset,
            prior,
            sample,
            corr,
            &again,
            0.5 * sigma,
        )?);
    }
    Ok(histories)
}
