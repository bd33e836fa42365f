//! A common offset: every grating moving together (a temperature change since the
//! tare). Over the frames spread across the stream, each is reconstructed without
//! and with the common-mode term; the term is called for when it lowers the frames'
//! χ² by more than chance would (the sum of the per-frame drops against the χ²
//! quantile at 1 − [`OFFSET_ALARM`] with one degree of freedom per frame), in most
//! frames (the median drop at least [`MEDIAN_DROP`]: an error the model does not
//! hold in some frames, say the additivity of several loads or a pair of swapped
//! channels, lowers a few frames' χ² a lot, an offset lowers every frame's), and
//! not through one grating alone (no grating gives more than [`MAX_SHARE`] of the
//! drop: a single faulty grating also lowers χ² when an offset absorbs part of it).

use super::{median, view, Corrections, Solver, StreamSample};
use crate::methods::ReadingSettings;
use crate::problem::SensingProblem;
use crate::trust::{chi2_p_value, chi2_quantile};
use crate::ArrayError;
use nalgebra::DVector;

/// Probability with which the common mode is turned on for frames without an offset.
pub(crate) const OFFSET_ALARM: f64 = 1e-3;

/// Largest share of the χ² drop one grating may give.
pub(crate) const MAX_SHARE: f64 = 0.5;

/// Least median drop of χ² per frame (P(χ²₁ ≥ 2) = 0.16: the median of many frames
/// without an offset stays well below).
pub(crate) const MEDIAN_DROP: f64 = 2.0;

/// Fewest frames before the common mode is decided from the data.
pub(crate) const MIN_OFFSET_FRAMES: usize = 8;

/// Per grating, rᵢ²/vᵢ of an answer.
fn standardised(problem: &SensingProblem, y: &[f64], loads: &[f64]) -> Vec<f64> {
    let pred = &problem.sensitivity_pm_per_g * DVector::from_column_slice(loads);
    let var = problem
        .uncertainty
        .reading_variances_pm2(loads, pred.as_slice());
    problem
        .residual_vector_pm(loads, y)
        .iter()
        .zip(&var)
        .map(|(r, v)| r * r / v)
        .collect()
}

/// Whether the frames call for a common offset with weights `weights` (one per row
/// of `current`), and why.
pub(super) fn called_for(
    current: &SensingProblem,
    weights: &[f64],
    prior: &ReadingSettings,
    sample: &StreamSample,
    corr: &Corrections,
) -> Result<(bool, String), ArrayError> {
    let frames: Vec<Vec<f64>> = sample
        .spread()
        .iter()
        .map(|(f, y)| view(corr, *f, y))
        .collect();
    let f = frames.len();
    if f < MIN_OFFSET_FRAMES {
        return Ok((
            false,
            format!("no common offset: {f} usable frames, too few to tell (at least {MIN_OFFSET_FRAMES})"),
        ));
    }
    let Ok(with) = current.clone().with_common_mode(weights) else {
        return Ok((
            false,
            "no common offset: a cell's load cannot be told from it".into(),
        ));
    };
    let (s0, s1) = (
        Solver::new(current.clone(), prior)?,
        Solver::new(with, prior)?,
    );
    let m = current.n_gratings();
    let mut drop = 0.0;
    let mut drops = Vec::with_capacity(f);
    let mut by_grating = vec![0.0; m];
    let mut offsets = Vec::with_capacity(f);
    for y in &frames {
        let (r0, r1) = (s0.solve(y), s1.solve(y));
        drop += r0.chi2 - r1.chi2;
        drops.push(r0.chi2 - r1.chi2);
        let (z0, z1) = (
            standardised(&s0.problem, y, &r0.loads_g),
            standardised(&s1.problem, y, &r1.loads_g),
        );
        for i in 0..m {
            by_grating[i] += z0[i] - z1[i];
        }
        offsets.push(r1.common_mode_pm.unwrap_or(0.0).abs());
    }
    let positive: f64 = by_grating.iter().map(|d| d.max(0.0)).sum();
    let (top, share) = by_grating
        .iter()
        .enumerate()
        .map(|(i, d)| (i, d.max(0.0) / positive.max(1e-300)))
        .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
    let p = chi2_p_value(drop.max(0.0), f);
    let median_drop = median(drops);
    let significant = drop > chi2_quantile(OFFSET_ALARM, f);
    let spread_out = m < 4 || share <= MAX_SHARE;
    let numbers = format!(
        "fitting it lowers χ² by {drop:.0} over {f} frames spread over the stream (p = {p:.1e}), by {median_drop:.1} in the median frame, at most {:.0} % of it from one grating (row {}); median |offset| {:.2} pm",
        100.0 * share,
        top + 1,
        median(offsets)
    );
    Ok(if significant && spread_out && median_drop >= MEDIAN_DROP {
        (
            true,
            format!("common offset fitted: the frames call for it ({numbers})"),
        )
    } else if significant && !spread_out {
        (
            false,
            format!("no common offset: one grating gives most of the drop ({numbers})"),
        )
    } else if significant {
        (
            false,
            format!("no common offset: the drop comes from a few frames ({numbers})"),
        )
    } else {
        (
            false,
            format!("no common offset: the frames do not call for it ({numbers})"),
        )
    })
}
