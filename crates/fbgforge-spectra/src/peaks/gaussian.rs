//! Gaussian least squares: A·exp(−(λ−λ0)²/(2s²)) + b fitted by Levenberg–Marquardt on
//! (A, λ0, s, b); the joint form fits k Gaussians on one shared floor.

use serde::{Deserialize, Serialize};

use super::crb::FWHM_PER_SIGMA;
use super::lm::{self, Model};
use super::parabola::log_parabola_vertex;
use super::{PeakEstimate, PeakEstimator, PeakWindow};
use crate::error::SpectrumError;

/// k Gaussians on a constant floor; parameters [A1, λ1, s1, …, Ak, λk, sk, b].
struct MultiGaussian {
    k: usize,
}

impl Model for MultiGaussian {
    fn n_params(&self) -> usize {
        3 * self.k + 1
    }

    fn eval(&self, x: f64, p: &[f64], grad: &mut [f64]) -> f64 {
        let mut value = p[3 * self.k];
        for j in 0..self.k {
            let (a, mu, s) = (p[3 * j], p[3 * j + 1], p[3 * j + 2]);
            let u = (x - mu) / s;
            let g = (-0.5 * u * u).exp();
            value += a * g;
            grad[3 * j] = g;
            grad[3 * j + 1] = a * g * u / s;
            grad[3 * j + 2] = a * g * u * u / s;
        }
        grad[3 * self.k] = 1.0;
        value
    }

    fn valid(&self, p: &[f64]) -> bool {
        (0..self.k).all(|j| p[3 * j] > 0.0 && p[3 * j + 2] > 0.0) && p.iter().all(|v| v.is_finite())
    }
}

/// One Gaussian of a fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GaussianComponent {
    /// Height above the floor, power units.
    pub amplitude: f64,
    /// Centre, nm.
    pub center_nm: f64,
    /// FWHM = 2√(2 ln 2)·s, nm.
    pub fwhm_nm: f64,
    /// Standard error of the centre from the residuals, nm: √(σ̂²·[(JᵀJ)⁻¹]_λλ).
    pub center_std_error_nm: f64,
    /// √([(JᵀJ)⁻¹]_λλ), nm per unit noise: times σ it is the joint Cramér–Rao bound of the
    /// centre with every other parameter unknown.
    pub center_bound_per_sigma_nm: f64,
}

/// A joint least-squares fit of Gaussians on one floor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GaussianFit {
    /// The Gaussians in the order given.
    pub components: Vec<GaussianComponent>,
    /// Shared floor, power units.
    pub baseline: f64,
    /// Residual standard deviation √(RSS/(n − p)).
    pub residual_sigma: f64,
}

/// Fits Gaussians from initial (amplitude, centre nm, FWHM nm) guesses and a floor guess.
pub fn fit_gaussians(
    wavelengths_nm: &[f64],
    power: &[f64],
    initial: &[(f64, f64, f64)],
    baseline: f64,
) -> Result<GaussianFit, SpectrumError> {
    let fail = |reason: &str| SpectrumError::Estimate {
        estimator: "gaussian",
        reason: reason.to_string(),
    };
    if initial.is_empty() {
        return Err(fail("no peak to fit"));
    }
    let mut p0 = Vec::with_capacity(3 * initial.len() + 1);
    for &(a, mu, fwhm) in initial {
        p0.extend([a, mu, fwhm / FWHM_PER_SIGMA]);
    }
    p0.push(baseline);
    let model = MultiGaussian { k: initial.len() };
    let fit = lm::fit(&model, wavelengths_nm, power, p0).ok_or_else(|| {
        fail("least squares did not converge (too few samples or a singular fit)")
    })?;
    let (lo, hi) = (wavelengths_nm[0], wavelengths_nm[wavelengths_nm.len() - 1]);
    let mut components = Vec::with_capacity(initial.len());
    for j in 0..initial.len() {
        let (a, mu, s) = (
            fit.params[3 * j],
            fit.params[3 * j + 1],
            fit.params[3 * j + 2],
        );
        if !(lo..=hi).contains(&mu) || s > hi - lo {
            return Err(fail(
                "the fitted centre left the window or the width exceeds it",
            ));
        }
        components.push(GaussianComponent {
            amplitude: a,
            center_nm: mu,
            fwhm_nm: s * FWHM_PER_SIGMA,
            center_std_error_nm: fit.std_error(3 * j + 1),
            center_bound_per_sigma_nm: fit.jtj_inverse[(3 * j + 1, 3 * j + 1)].max(0.0).sqrt(),
        });
    }
    Ok(GaussianFit {
        components,
        baseline: fit.params[3 * initial.len()],
        residual_sigma: (fit.rss / fit.dof as f64).sqrt(),
    })
}

/// Gaussian least squares (Levenberg–Marquardt on amplitude, centre, width and a
/// constant floor). Started from the 3-point log-parabola; `std_error_pm` from the
/// residuals: √(σ̂²·[(JᵀJ)⁻¹]_λλ), σ̂² = RSS/(n − 4).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GaussianLeastSquares;

impl PeakEstimator for GaussianLeastSquares {
    fn name(&self) -> &'static str {
        "gaussian"
    }

    fn estimate(&self, w: &PeakWindow) -> Result<PeakEstimate, SpectrumError> {
        let height = w.height();
        let pitch = w.pitch_nm();
        let fwhm0 = w.measured_fwhm_nm().max(0.8 * pitch);
        let center0 = log_parabola_vertex(w)
            .map(|(c, _)| c)
            .unwrap_or(w.wavelengths_nm[w.max_index]);
        let fit = fit_gaussians(
            w.wavelengths_nm,
            w.power,
            &[(height.max(f64::MIN_POSITIVE), center0, fwhm0)],
            w.baseline,
        )?;
        let c = fit.components[0];
        Ok(PeakEstimate {
            wavelength_nm: c.center_nm,
            std_error_pm: 1e3 * c.center_std_error_nm,
            amplitude: c.amplitude,
            baseline: fit.baseline,
            fwhm_nm: c.fwhm_nm,
        })
    }
}
