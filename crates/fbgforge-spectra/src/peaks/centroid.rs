//! Centroid over a threshold.

use super::{PeakEstimate, PeakEstimator, PeakWindow};
use crate::error::SpectrumError;

/// Centroid of the contiguous samples around the maximum that exceed
/// t = baseline + `threshold_fraction`·(max − baseline), weighted by (y − t) and by the
/// local sample pitch: λc = Σ λᵢ(yᵢ − t)Δᵢ / Σ (yᵢ − t)Δᵢ. `std_error_pm` propagates
/// the noise σ with the threshold held fixed: σ·√(Σ ((λᵢ − λc)Δᵢ)²) / Σ (yᵢ − t)Δᵢ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Centroid {
    /// Threshold as a fraction of the height above the floor (0.5: the half-maximum).
    pub threshold_fraction: f64,
}

impl Default for Centroid {
    fn default() -> Self {
        Centroid {
            threshold_fraction: 0.5,
        }
    }
}

impl PeakEstimator for Centroid {
    fn name(&self) -> &'static str {
        "centroid"
    }

    fn estimate(&self, w: &PeakWindow) -> Result<PeakEstimate, SpectrumError> {
        let (x, y, i) = (w.wavelengths_nm, w.power, w.max_index);
        let height = w.height();
        if !(height > 0.0) {
            return Err(SpectrumError::Estimate {
                estimator: "centroid",
                reason: "the maximum is not above the floor".into(),
            });
        }
        let t = w.baseline + self.threshold_fraction * height;
        let mut lo = i;
        while lo > 0 && y[lo - 1] > t {
            lo -= 1;
        }
        let mut hi = i;
        while hi + 1 < y.len() && y[hi + 1] > t {
            hi += 1;
        }
        let pitch = |k: usize| {
            let left = if k > 0 {
                x[k] - x[k - 1]
            } else {
                x[k + 1] - x[k]
            };
            let right = if k + 1 < x.len() {
                x[k + 1] - x[k]
            } else {
                left
            };
            0.5 * (left + right)
        };
        let (mut sw, mut swx) = (0.0, 0.0);
        for k in lo..=hi {
            let weight = (y[k] - t) * pitch(k);
            sw += weight;
            swx += weight * x[k];
        }
        let c = swx / sw;
        let spread: f64 = (lo..=hi).map(|k| ((x[k] - c) * pitch(k)).powi(2)).sum();
        Ok(PeakEstimate {
            wavelength_nm: c,
            std_error_pm: 1e3 * w.noise_sigma * spread.sqrt() / sw,
            amplitude: height,
            baseline: w.baseline,
            fwhm_nm: w.measured_fwhm_nm(),
        })
    }
}
