//! Gratings whose residuals break the model over the stream: two channels swapped,
//! or one grating noisier than stated.
//!
//! * **Swapped** (looked for when the frames' χ² is beyond chance: the sum over the
//!   frames spread across the stream against the χ² quantile at 1 − 10⁻³ of the
//!   summed degrees of freedom): every pair of gratings (of the [`SWAP_CANDIDATES`]
//!   with the largest residuals when there are more) is tried with its two readings
//!   exchanged in every frame; the pair that lowers the frames' χ² the most is
//!   swapped when it at least halves it and the drop is beyond the χ² quantile at
//!   1 − 10⁻³ with one degree of freedom per frame. Its readings are exchanged back
//!   in every frame. (A swap spreads its misfit over every grating the fit touches,
//!   so the pair is not necessarily the two worst residuals: all pairs are tried.)
//! * **Noisy**: a grating whose leave-one-out residual scatters far more than the
//!   others' ([`find_noisy`]): left out.

use super::{median, view, Corrections, Solver, StreamSample, SuspectGrating, SuspectReason};
use crate::methods::ReadingSettings;
use crate::problem::SensingProblem;
use crate::trust::chi2_quantile;
use crate::ArrayError;
use nalgebra::DVector;

/// Least scatter of a noisy grating's leave-one-out residual, resolutions.
pub(crate) const NOISY_SIGMAS: f64 = 3.0;

/// A noisy grating's scatter against the median grating's, at least.
pub(crate) const NOISY_RATIO: f64 = 3.0;

/// Largest median scatter of the gratings, resolutions, at which [`NOISY_RATIO`]
/// is enough to name a grating noisy.
pub(crate) const NOISY_MEDIAN_SIGMAS: f64 = 2.0;

/// Least ratio to the median scatter when the median is above
/// [`NOISY_MEDIAN_SIGMAS`] resolutions.
pub(crate) const NOISY_ALONE_RATIO: f64 = 6.0;

/// A frame is quiet for a grating when the answer predicts at most this many
/// resolutions there: its reading is then noise whatever the model's error.
pub(crate) const QUIET_SIGMAS: f64 = 6.0;

/// Fewest quiet frames a grating is judged on.
pub(crate) const MIN_QUIET: usize = 6;

/// Fewest frames before either test is made.
pub(crate) const MIN_FRAMES: usize = 8;

/// Gratings whose pairs are tried for a swap, at most (those with the largest
/// residuals); every pair up to this many gratings.
pub(crate) const SWAP_CANDIDATES: usize = 12;

/// Per frame: χ² and its degrees of freedom, and per grating rᵢ²/vᵢ.
struct Fits {
    chi2: Vec<f64>,
    dof: usize,
    z: Vec<Vec<f64>>,
}

fn fit_all(solver: &Solver, frames: &[Vec<f64>]) -> Fits {
    let p = &solver.problem;
    let mut fits = Fits {
        chi2: Vec::new(),
        dof: 0,
        z: Vec::new(),
    };
    for y in frames {
        let r = solver.solve(y);
        let pred = &p.sensitivity_pm_per_g * DVector::from_column_slice(&r.loads_g);
        let var = p
            .uncertainty
            .reading_variances_pm2(&r.loads_g, pred.as_slice());
        let z = p
            .residual_vector_pm(&r.loads_g, y)
            .iter()
            .zip(&var)
            .map(|(q, v)| q * q / v)
            .collect();
        fits.chi2.push(r.chi2);
        fits.dof += r.dof;
        fits.z.push(z);
    }
    fits
}

/// The frames spread over the stream that no saturated grating clips, as the
/// problem of `corr` sees them.
fn frames_of(sample: &StreamSample, corr: &Corrections) -> Vec<Vec<f64>> {
    sample
        .spread()
        .iter()
        .filter(|(f, y)| {
            let v = corr.corrected(*f, y);
            corr.clipped.iter().all(|&(i, at)| v[i] < at)
        })
        .map(|(f, y)| view(corr, *f, y))
        .collect()
}

/// Find a swapped pair among the rows `current` keeps of `original` and exchange it
/// back.
pub(super) fn find_swapped(
    original: &SensingProblem,
    current: &SensingProblem,
    prior: &ReadingSettings,
    sample: &StreamSample,
    corr: &mut Corrections,
    suspects: &mut Vec<SuspectGrating>,
) -> Result<(), ArrayError> {
    let kept = corr.kept(original.n_gratings());
    let m = kept.len();
    let frames = frames_of(sample, corr);
    if frames.len() < MIN_FRAMES || m < 3 {
        return Ok(());
    }
    let solver = Solver::new(current.clone(), prior)?;
    let fits = fit_all(&solver, &frames);
    let total: f64 = fits.chi2.iter().sum();
    if fits.dof == 0 || total <= chi2_quantile(1e-3, fits.dof) {
        return Ok(());
    }
    let means: Vec<f64> = (0..m)
        .map(|r| fits.z.iter().map(|z| z[r]).sum::<f64>() / frames.len() as f64)
        .collect();
    let mut rows: Vec<usize> = (0..m).collect();
    rows.sort_by(|&a, &b| means[b].total_cmp(&means[a]));
    rows.truncate(SWAP_CANDIDATES);
    let mut best: Option<(usize, usize, f64)> = None;
    for (k, &a) in rows.iter().enumerate() {
        for &b in &rows[k + 1..] {
            let chi2: f64 = frames
                .iter()
                .map(|y| {
                    let mut v = y.clone();
                    v.swap(a, b);
                    solver.solve(&v).chi2
                })
                .sum();
            if best.is_none_or(|(_, _, c)| chi2 < c) {
                best = Some((a, b, chi2));
            }
        }
    }
    let Some((a, b, chi2)) = best else {
        return Ok(());
    };
    if chi2 > 0.5 * total || total - chi2 <= chi2_quantile(1e-3, frames.len()) {
        return Ok(());
    }
    let (ia, ib) = (kept[a].min(kept[b]), kept[a].max(kept[b]));
    corr.swaps.push((ia, ib));
    for (i, j) in [(ia, ib), (ib, ia)] {
        suspects.push(SuspectGrating {
            index: i,
            name: String::new(),
            reason: SuspectReason::Swapped,
            partner: Some(j),
            partner_name: None,
            evidence: format!(
                "the frames' χ² falls from {total:.0} to {chi2:.0} over {} frames with its readings and its partner's exchanged",
                frames.len()
            ),
            remedy: "its readings exchanged back with its partner's".into(),
            frames: frames.len(),
        });
    }
    Ok(())
}

/// Name and drop the noisy gratings: those whose leave-one-out residual scatter
/// about its trend ([`super::drift`]'s histories; robust, so the frames whose
/// prediction fails do not count) is at least [`NOISY_SIGMAS`] resolutions and
/// [`NOISY_RATIO`] times the median grating's. Gratings found swapped are not judged
/// (their histories were taken before the swap was undone).
pub(super) fn find_noisy(
    sigma: f64,
    histories: &super::drift::Histories,
    corr: &mut Corrections,
    suspects: &mut Vec<SuspectGrating>,
) {
    let judged: Vec<&(usize, super::drift::Line, usize)> = histories
        .iter()
        .filter(|(i, _, _)| !corr.swaps.iter().any(|&(a, b)| a == *i || b == *i))
        .collect();
    if judged.len() < 4 {
        return;
    }
    let med = median(judged.iter().map(|(_, l, _)| l.scale).collect());
    for &&(i, line, count) in &judged {
        // Where the other gratings' own scatter is already well above the noise
        // (a small array whose leave-one-out fits have little to spare, a model
        // error such as additivity), a ratio of 3 happens by chance: only a grating
        // standing out by NOISY_ALONE_RATIO is named there.
        let ratio = line.scale / med.max(1e-300);
        let crowded = med > NOISY_MEDIAN_SIGMAS * sigma;
        if line.scale < NOISY_SIGMAS * sigma
            || ratio < NOISY_RATIO
            || (crowded && ratio < NOISY_ALONE_RATIO)
        {
            continue;
        }
        let evidence = format!(
            "its reading scatters by {:.2} pm (robust sd) about what the other gratings predict, {:.1} times the median grating's, over {count} frames",
            line.scale,
            line.scale / med.max(1e-300)
        );
        name_noisy(i, evidence, count, corr, suspects);
    }
}

/// Name and drop the gratings noisy where no load acts near them: over the frames
/// quiet for a grating (the answer predicts at most [`QUIET_SIGMAS`] resolutions
/// there), its residual's robust scatter is at least [`NOISY_SIGMAS`] resolutions and
/// [`NOISY_RATIO`] times the median of the other gratings judged (at least two). On those frames the reading is noise
/// whatever the model's error (additivity, calibration), so the stated resolution is
/// the yardstick even where the leave-one-out fits of a small array have too few
/// gratings to spare ([`find_noisy`]'s test, which names none there).
pub(super) fn find_noisy_quiet(
    original: &SensingProblem,
    current: &SensingProblem,
    prior: &ReadingSettings,
    sample: &StreamSample,
    corr: &mut Corrections,
    suspects: &mut Vec<SuspectGrating>,
) -> Result<(), ArrayError> {
    let kept = corr.kept(original.n_gratings());
    let frames = frames_of(sample, corr);
    if frames.len() < MIN_FRAMES || kept.len() < 4 {
        return Ok(());
    }
    let sigma = original.uncertainty.resolution_pm;
    let solver = Solver::new(current.clone(), prior)?;
    let mut quiet: Vec<Vec<f64>> = vec![Vec::new(); kept.len()];
    for y in &frames {
        let r = solver.solve(y);
        if r.flags.unusable {
            continue;
        }
        let pred = &current.sensitivity_pm_per_g * DVector::from_column_slice(&r.loads_g);
        let res = current.residual_vector_pm(&r.loads_g, y);
        for (q, z) in quiet.iter_mut().enumerate() {
            if pred[q].abs() <= QUIET_SIGMAS * sigma {
                z.push(res[q] / sigma);
            }
        }
    }
    let scales: Vec<(usize, f64, usize)> = quiet
        .iter()
        .enumerate()
        .filter(|(_, z)| z.len() >= MIN_QUIET)
        .map(|(q, z)| {
            let mid = median(z.clone());
            let mad = median(z.iter().map(|v| (v - mid).abs()).collect());
            (q, 1.4826 * mad, z.len())
        })
        .collect();
    if scales.len() < 3 {
        return Ok(());
    }
    for &(q, scale, count) in &scales {
        let i = kept[q];
        // The yardstick is the other judged gratings' median: a noisy grating does
        // not raise it, and on a small array two others are enough.
        let med = median(
            scales
                .iter()
                .filter(|(p, _, _)| *p != q)
                .map(|(_, s, _)| *s)
                .collect(),
        );
        let swapped = corr.swaps.iter().any(|&(a, b)| a == i || b == i);
        if swapped || scale < NOISY_SIGMAS || scale < NOISY_RATIO * med {
            continue;
        }
        let evidence = format!(
            "where no load acts near it ({count} frames) its reading scatters by {:.2} pm (robust sd), {scale:.1} resolutions, {:.1} times the median grating's",
            scale * sigma,
            scale / med.max(1e-300)
        );
        name_noisy(i, evidence, count, corr, suspects);
    }
    Ok(())
}

/// Name grating `i` noisy with its evidence and leave it out of every frame (both
/// noise tests end the same way).
fn name_noisy(
    i: usize,
    evidence: String,
    frames: usize,
    corr: &mut Corrections,
    suspects: &mut Vec<SuspectGrating>,
) {
    suspects.push(SuspectGrating {
        index: i,
        name: String::new(),
        reason: SuspectReason::Noisy,
        partner: None,
        partner_name: None,
        evidence,
        remedy: "left out of every frame".into(),
        frames,
    });
    corr.dropped.push(i);
}
