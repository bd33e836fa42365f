//! Peak estimation: the problem (one peak's window of a linear-power spectrum,
//! [`PeakWindow`]) kept apart from the method ([`PeakEstimator`]: Gaussian least
//! squares, 3-point parabola, centroid over a threshold, template cross-correlation),
//! each peak with its standard error, Cramér–Rao bound, FWHM, SNR and flags.

mod centroid;
pub mod crb;
mod finder;
mod gaussian;
pub(crate) mod lm;
mod matching;
mod parabola;
mod template;

use serde::{Deserialize, Serialize};

use crate::error::SpectrumError;

pub use centroid::Centroid;
pub use crb::{
    gaussian_position_crb_closed_form_pm, gaussian_position_crb_joint_pm, gaussian_position_crb_pm,
    FWHM_PER_SIGMA,
};
pub use finder::{find_peaks, find_peaks_in, EstimatorChoice, FindOptions};
pub use gaussian::{fit_gaussians, GaussianComponent, GaussianFit, GaussianLeastSquares};
pub use matching::{
    find_grating_peaks, match_gratings, ExpectedGrating, MatchedPeak, SPLIT_LOBE_FRACTION,
};
pub use parabola::Parabola;
pub use template::{Template, TemplateMatch};

/// One peak's window: wavelengths and linear power around a candidate maximum, with the
/// floor and noise the finder estimated. This is the problem every estimator solves.
#[derive(Debug, Clone, Copy)]
pub struct PeakWindow<'a> {
    /// Wavelengths, nm, strictly increasing.
    pub wavelengths_nm: &'a [f64],
    /// Linear power (mW, ratio or counts) at each wavelength.
    pub power: &'a [f64],
    /// Index (into the two slices) of the candidate's highest sample.
    pub max_index: usize,
    /// Estimated floor under the peak, power units.
    pub baseline: f64,
    /// Standard deviation of the white noise on each sample, power units.
    pub noise_sigma: f64,
}

impl<'a> PeakWindow<'a> {
    /// A window of `wavelengths_nm[lo..hi]` around `max_index` (an index into the full
    /// arrays); the baseline is the median of the samples more than `core_nm` from the
    /// maximum when there are at least 4 of them, else `fallback_baseline`.
    pub fn new(
        wavelengths_nm: &'a [f64],
        power: &'a [f64],
        range: std::ops::Range<usize>,
        max_index: usize,
        core_nm: f64,
        fallback_baseline: f64,
        noise_sigma: f64,
    ) -> Result<Self, SpectrumError> {
        if range.end > wavelengths_nm.len()
            || power.len() != wavelengths_nm.len()
            || !range.contains(&max_index)
        {
            return Err(SpectrumError::Invalid(format!(
                "peak window {range:?} with maximum {max_index} does not fit {} samples",
                wavelengths_nm.len()
            )));
        }
        let w = &wavelengths_nm[range.clone()];
        let p = &power[range.clone()];
        let k = max_index - range.start;
        let mut outer: Vec<f64> = w
            .iter()
            .zip(p)
            .filter(|(x, _)| (*x - w[k]).abs() > core_nm)
            .map(|(_, y)| *y)
            .collect();
        let baseline = if outer.len() >= 4 {
            crate::stats::median(&mut outer)
        } else {
            fallback_baseline
        };
        Ok(PeakWindow {
            wavelengths_nm: w,
            power: p,
            max_index: k,
            baseline,
            noise_sigma,
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.wavelengths_nm.len()
    }

    /// True for an empty window.
    pub fn is_empty(&self) -> bool {
        self.wavelengths_nm.is_empty()
    }

    /// Local sample pitch at the maximum, nm.
    pub fn pitch_nm(&self) -> f64 {
        let i = self.max_index;
        let w = self.wavelengths_nm;
        match (i.checked_sub(1), w.get(i + 1)) {
            (Some(a), Some(&b)) => 0.5 * (b - w[a]),
            (Some(a), None) => w[i] - w[a],
            (None, Some(&b)) => b - w[i],
            (None, None) => f64::NAN,
        }
    }

    /// Height of the highest sample above the baseline.
    pub fn height(&self) -> f64 {
        self.power[self.max_index] - self.baseline
    }

    /// Full width at half maximum from the samples: the half level between baseline and
    /// highest sample, crossings interpolated linearly (the window edge if not crossed).
    pub fn measured_fwhm_nm(&self) -> f64 {
        let (w, p, i) = (self.wavelengths_nm, self.power, self.max_index);
        let half = self.baseline + 0.5 * self.height();
        let cross = |a: usize, b: usize| w[a] + (half - p[a]) / (p[b] - p[a]) * (w[b] - w[a]);
        let left = (0..i)
            .rev()
            .find(|&j| p[j] < half)
            .map(|j| cross(j, j + 1))
            .unwrap_or(w[0]);
        let right = (i + 1..w.len())
            .find(|&j| p[j] < half)
            .map(|j| cross(j - 1, j))
            .unwrap_or(w[w.len() - 1]);
        right - left
    }
}

/// What an estimator returns for one window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PeakEstimate {
    /// Peak (centre) wavelength, nm.
    pub wavelength_nm: f64,
    /// Standard error of `wavelength_nm`, pm: from the fit's residuals (least-squares
    /// estimators) or the noise propagated through the estimator (parabola, centroid).
    pub std_error_pm: f64,
    /// Peak height above the baseline, linear power units.
    pub amplitude: f64,
    /// Baseline (floor) used, linear power units.
    pub baseline: f64,
    /// Full width at half maximum, nm.
    pub fwhm_nm: f64,
}

/// A method that estimates a peak's wavelength from its window.
pub trait PeakEstimator {
    /// Short name (`gaussian`, `parabola`, `centroid`, `xcorr`).
    fn name(&self) -> &'static str;
    /// The estimate for one window.
    fn estimate(&self, window: &PeakWindow) -> Result<PeakEstimate, SpectrumError>;
}

/// Quality flags of a peak.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PeakFlags {
    /// FWHM below `FindOptions::undersampled_samples` (1.2) samples: pixel-locking sets in
    /// and the bound depends on where the peak sits on the grid.
    pub undersampled: bool,
    /// The estimator and a second one differ by more than 3× the bound (see
    /// `FindOptions::disagreement_factor`).
    pub estimator_disagreement: bool,
    /// Another peak lies within `FindOptions::overlap_fwhm` FWHM: both come from a joint
    /// multi-peak Gaussian fit.
    pub overlap: bool,
    /// SNR below `FindOptions::low_snr`.
    pub low_snr: bool,
    /// More than one lobe in one grating's window (set by [`match_gratings`]).
    pub split: bool,
}

impl PeakFlags {
    const NAMES: [&'static str; 5] = [
        "undersampled",
        "estimator_disagreement",
        "overlap",
        "low_snr",
        "split",
    ];

    fn values(&self) -> [bool; 5] {
        [
            self.undersampled,
            self.estimator_disagreement,
            self.overlap,
            self.low_snr,
            self.split,
        ]
    }

    /// Names of the flags that are set.
    pub fn names(&self) -> Vec<&'static str> {
        Self::NAMES
            .iter()
            .zip(self.values())
            .filter(|(_, v)| *v)
            .map(|(n, _)| *n)
            .collect()
    }

    /// True when no flag is set.
    pub fn is_clean(&self) -> bool {
        !self.values().iter().any(|v| *v)
    }

    /// Flags set in either.
    pub fn union(self, other: PeakFlags) -> PeakFlags {
        PeakFlags {
            undersampled: self.undersampled || other.undersampled,
            estimator_disagreement: self.estimator_disagreement || other.estimator_disagreement,
            overlap: self.overlap || other.overlap,
            low_snr: self.low_snr || other.low_snr,
            split: self.split || other.split,
        }
    }
}

impl Serialize for PeakFlags {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.names().serialize(serializer)
    }
}

impl<'de> Deserialize<'de> for PeakFlags {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let names = Vec::<String>::deserialize(deserializer)?;
        let mut f = PeakFlags::default();
        for n in names {
            match n.as_str() {
                "undersampled" => f.undersampled = true,
                "estimator_disagreement" => f.estimator_disagreement = true,
                "overlap" => f.overlap = true,
                "low_snr" => f.low_snr = true,
                "split" => f.split = true,
                other => {
                    return Err(serde::de::Error::custom(format!(
                        "unknown peak flag `{other}`"
                    )))
                }
            }
        }
        Ok(f)
    }
}

/// A peak found in a spectrum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Peak {
    /// Peak wavelength, nm.
    pub wavelength_nm: f64,
    /// Standard error of the wavelength, pm (see [`PeakEstimate::std_error_pm`]).
    pub std_error_pm: f64,
    /// Cramér–Rao bound of the wavelength for this peak's width, amplitude, noise and
    /// sampling grid, pm (see [`crb`]).
    pub crb_pm: f64,
    /// Full width at half maximum, pm.
    pub fwhm_pm: f64,
    /// Peak height above the floor divided by the noise standard deviation.
    pub snr: f64,
    /// Peak height above the floor, linear power units.
    pub amplitude: f64,
    /// Floor under the peak, linear power units.
    pub baseline: f64,
    /// The estimator that produced `wavelength_nm` (`gaussian`, `gaussian-joint`, …).
    pub estimator: String,
    /// Quality flags.
    pub flags: PeakFlags,
    /// Peaks decomposed by one joint fit share this number; `None` for a lone peak.
    pub overlap_group: Option<usize>,
}
