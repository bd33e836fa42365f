//! Matching found peaks to a design's gratings.

use serde::{Deserialize, Serialize};

use super::{find_peaks, FindOptions, Peak};
use crate::error::SpectrumError;
use crate::spectrum::Spectrum;

/// A grating the design expects: its name, nominal wavelength and search half-window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExpectedGrating {
    /// Grating name (`FBG1`, `λ11`, …).
    pub name: String,
    /// Nominal (unloaded) Bragg wavelength, nm.
    pub nominal_nm: f64,
    /// A peak belongs to this grating if it lies within ± this many nm.
    pub window_nm: f64,
}

/// A grating and the peak assigned to it (`None` when none lies in its window).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MatchedPeak {
    /// The grating's name.
    pub grating: String,
    /// Its peak.
    pub peak: Option<Peak>,
}

/// A second lobe in a grating's window counts when its amplitude is at least this
/// fraction of the strongest (0.25: −6 dB, as `CleanPeakCriteria::side_lobe_margin_db`).
pub const SPLIT_LOBE_FRACTION: f64 = 0.25;

/// Assigns each peak to the nearest grating whose window holds it; in a window, peaks
/// below [`SPLIT_LOBE_FRACTION`] of the strongest one there are ignored (side lobes). A
/// grating with one peak left gets it; with several (a grating split into lobes, e.g. by
/// transverse stress or a strong chirp) it gets one peak flagged `split`: the amplitude-weighted mean
/// wavelength of the lobes, their standard errors and bounds combined with the same
/// weights (amplitudes taken as exact), the FWHM spanning the outer lobes' half-maximum
/// points, the highest SNR and the union of the flags. Such a merged peak keeps
/// `overlap` only if its joint fit also held another grating's peak.
pub fn match_gratings(peaks: &[Peak], expected: &[ExpectedGrating]) -> Vec<MatchedPeak> {
    let mut assigned: Vec<Vec<&Peak>> = vec![Vec::new(); expected.len()];
    for p in peaks {
        let nearest = expected
            .iter()
            .enumerate()
            .filter(|(_, g)| (p.wavelength_nm - g.nominal_nm).abs() <= g.window_nm)
            .min_by(|(_, a), (_, b)| {
                (p.wavelength_nm - a.nominal_nm)
                    .abs()
                    .total_cmp(&(p.wavelength_nm - b.nominal_nm).abs())
            });
        if let Some((k, _)) = nearest {
            assigned[k].push(p);
        }
    }
    for lobes in assigned.iter_mut() {
        let strongest = lobes.iter().map(|p| p.amplitude).fold(0.0, f64::max);
        lobes.retain(|p| p.amplitude >= SPLIT_LOBE_FRACTION * strongest);
    }
    expected
        .iter()
        .zip(&assigned)
        .map(|(g, lobes)| {
            let peak = match lobes.as_slice() {
                [] => None,
                [one] => Some((*one).clone()),
                many => {
                    let mut merged = merge_lobes(many);
                    // Another peak (another grating's) in one of the lobes' joint fits?
                    let shared = many.iter().filter_map(|p| p.overlap_group).any(|group| {
                        peaks
                            .iter()
                            .filter(|p| p.overlap_group == Some(group))
                            .count()
                            > many
                                .iter()
                                .filter(|p| p.overlap_group == Some(group))
                                .count()
                    });
                    merged.flags.overlap = shared;
                    Some(merged)
                }
            };
            MatchedPeak {
                grating: g.name.clone(),
                peak,
            }
        })
        .collect()
}

fn merge_lobes(lobes: &[&Peak]) -> Peak {
    let total: f64 = lobes.iter().map(|p| p.amplitude).sum();
    let weights: Vec<f64> = lobes.iter().map(|p| p.amplitude / total).collect();
    let combine = |f: &dyn Fn(&Peak) -> f64| {
        lobes
            .iter()
            .zip(&weights)
            .map(|(p, w)| (w * f(p)).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let lo = lobes
        .iter()
        .map(|p| p.wavelength_nm - 0.5e-3 * p.fwhm_pm)
        .fold(f64::INFINITY, f64::min);
    let hi = lobes
        .iter()
        .map(|p| p.wavelength_nm + 0.5e-3 * p.fwhm_pm)
        .fold(f64::NEG_INFINITY, f64::max);
    let strongest = lobes
        .iter()
        .max_by(|a, b| a.amplitude.total_cmp(&b.amplitude))
        .expect("two or more lobes");
    let mut flags = lobes
        .iter()
        .fold(Default::default(), |f: super::PeakFlags, p| {
            f.union(p.flags)
        });
    flags.split = true;
    Peak {
        wavelength_nm: lobes
            .iter()
            .zip(&weights)
            .map(|(p, w)| w * p.wavelength_nm)
            .sum(),
        std_error_pm: combine(&|p| p.std_error_pm),
        crb_pm: combine(&|p| p.crb_pm),
        fwhm_pm: 1e3 * (hi - lo),
        snr: lobes.iter().map(|p| p.snr).fold(0.0, f64::max),
        amplitude: strongest.amplitude,
        baseline: strongest.baseline,
        estimator: format!("{} (split: {} lobes)", strongest.estimator, lobes.len()),
        flags,
        overlap_group: strongest.overlap_group,
    }
}

/// [`find_peaks`] then [`match_gratings`].
pub fn find_grating_peaks(
    spectrum: &Spectrum,
    expected: &[ExpectedGrating],
    options: &FindOptions,
) -> Result<Vec<MatchedPeak>, SpectrumError> {
    Ok(match_gratings(&find_peaks(spectrum, options)?, expected))
}
