//! Faults seen only across frames: a dead or stuck grating, and the temperature
//! weights of the common-mode term.
//!
//! **Dead or stuck grating.** A grating whose shift stays at the noise level while
//! the matrix predicts large responses. Over the strongest frames of a stream (at
//! most [`ACTIVE_FRAMES`]), grating i is suspect when its reading hardly varies
//! (standard deviation ≤ [`STILL_SIGMAS`] × the resolution) while the loads
//! reconstructed *without it* predict readings that vary with a standard deviation
//! of at least [`PREDICTED_SIGMAS`] × the resolution: the others say it should move
//! a lot, and it does not. (Variation, not level: a grating whose matrix entries are
//! merely off still moves with the loads, and a stuck one may sit at any value.) Leaving the grating out is what
//! makes the test fair: with it, the fit is pulled towards its flat reading. Only
//! gratings that pass the first (cheap) test are reconstructed without; the
//! reconstruction then drops the suspects ([`crate::reconstruct()`]).

use super::methods::{build, MethodSettings};
use super::problem::SensingProblem;
use super::ArrayError;
use serde::Serialize;

/// Strongest frames (largest ‖y‖) the dead-grating test looks at, at most.
pub(crate) const ACTIVE_FRAMES: usize = 48;

/// A reading "at the noise level": its standard deviation over the active frames
/// is at most this many resolutions.
pub(crate) const STILL_SIGMAS: f64 = 3.0;

/// "Large responses": the readings predicted without the grating vary with a
/// standard deviation of at least this many resolutions.
pub(crate) const PREDICTED_SIGMAS: f64 = 10.0;

/// Fewest usable frames with a signal before the test is made.
pub(crate) const MIN_ACTIVE_FRAMES: usize = 4;

/// A grating found dead or stuck.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuspectGrating {
    /// Row of the grating in the sensing matrix.
    pub index: usize,
    /// Its name (filled by the caller that knows the names; else empty).
    pub name: String,
    /// Standard deviation of its reading over the active frames, pm.
    pub measured_sd_pm: f64,
    /// Standard deviation of the readings predicted without it, pm.
    pub predicted_sd_pm: f64,
    /// Active frames the test used.
    pub frames: usize,
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// The dead or stuck gratings of a stream, found with the method `settings` on
/// `problem` (see the module doc). None are sought with fewer than three gratings or
/// [`MIN_ACTIVE_FRAMES`] frames with a signal.
pub fn suspect_gratings(
    problem: &SensingProblem,
    settings: &MethodSettings,
    frames: &[Vec<f64>],
) -> Result<Vec<SuspectGrating>, ArrayError> {
    let m = problem.n_gratings();
    let sigma = problem.uncertainty.resolution_pm;
    if m < 3 {
        return Ok(Vec::new());
    }
    // The strongest usable frames, with a signal well above the noise.
    let mut active: Vec<(f64, &Vec<f64>)> = frames
        .iter()
        .filter(|y| problem.check_shifts(y).is_ok())
        .map(|y| (y.iter().map(|v| v * v).sum::<f64>().sqrt(), y))
        .filter(|(norm, _)| *norm > PREDICTED_SIGMAS * sigma)
        .collect();
    if active.len() < MIN_ACTIVE_FRAMES {
        return Ok(Vec::new());
    }
    active.sort_by(|a, b| b.0.total_cmp(&a.0));
    active.truncate(ACTIVE_FRAMES);
    let mut out = Vec::new();
    for i in 0..m {
        let reads: Vec<f64> = active.iter().map(|(_, y)| y[i]).collect();
        let mu = mean(&reads);
        let sd =
            (reads.iter().map(|v| (v - mu) * (v - mu)).sum::<f64>() / reads.len() as f64).sqrt();
        if sd > STILL_SIGMAS * sigma {
            continue;
        }
        let Ok(reduced) = problem.without_gratings(&[i]) else {
            continue;
        };
        let r = build(&reduced, settings)?;
        let keep: Vec<usize> = (0..m).filter(|&q| q != i).collect();
        let w_i = problem.common_mode_weight(i, &keep);
        let mut preds = Vec::with_capacity(active.len());
        for (_, y) in &active {
            let yr: Vec<f64> = keep.iter().map(|&q| y[q]).collect();
            let rec = r.reconstruct(&yr);
            let mut pred: f64 = (0..problem.n_cells())
                .map(|j| problem.sensitivity_pm_per_g[(i, j)] * rec.loads_g[j])
                .sum();
            if let (Some(w), Some(t)) = (w_i, rec.common_mode_pm) {
                pred += w * t;
            }
            preds.push(pred);
        }
        let pm = mean(&preds);
        let psd =
            (preds.iter().map(|v| (v - pm) * (v - pm)).sum::<f64>() / preds.len() as f64).sqrt();
        if psd >= PREDICTED_SIGMAS * sigma {
            out.push(SuspectGrating {
                index: i,
                name: String::new(),
                measured_sd_pm: sd,
                predicted_sd_pm: psd,
                frames: active.len(),
            });
        }
    }
    Ok(out)
}

/// Temperature weights of an array's gratings for the common-mode term: each
/// grating's temperature sensitivity (bare fiber, ∝ its Bragg wavelength:
/// [`crate::grating::FiberOptics::temperature_sensitivity_pm_per_k`]), scaled to a
/// mean of 1.
pub(crate) fn temperature_weights(bragg_wavelengths_nm: &[f64]) -> Vec<f64> {
    let optics = crate::grating::FiberOptics::default();
    let s: Vec<f64> = bragg_wavelengths_nm
        .iter()
        .map(|&l| optics.temperature_sensitivity_pm_per_k(l))
        .collect();
    let mu = mean(&s);
    s.iter().map(|v| v / mu).collect()
}
