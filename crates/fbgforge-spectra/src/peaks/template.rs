//! Cross-correlation with a template: the grating's own unloaded spectrum, shifted.
//!
//! The window is matched to b + a·T(λ − δ), with T the template (a natural cubic spline
//! through its samples, constant beyond them): δ is first located by scanning the
//! normalised cross-correlation (a and b solved linearly for each trial shift, on a
//! grid of a quarter sample), then refined by least squares on (a, δ, b). The peak
//! wavelength is the template's reference wavelength + δ.

use super::lm::{self, Model};
use super::{GaussianLeastSquares, PeakEstimate, PeakEstimator, PeakWindow};
use crate::error::SpectrumError;
use crate::spectrum::Spectrum;

/// Natural cubic spline.
#[derive(Debug, Clone, PartialEq)]
struct Spline {
    x: Vec<f64>,
    y: Vec<f64>,
    m: Vec<f64>,
}

impl Spline {
    fn new(x: Vec<f64>, y: Vec<f64>) -> Self {
        let n = x.len();
        let mut m = vec![0.0; n];
        if n > 2 {
            // Thomas algorithm on the interior second derivatives (natural ends: M = 0).
            let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
            let mut diag = vec![0.0; n];
            let mut rhs = vec![0.0; n];
            for i in 1..n - 1 {
                diag[i] = 2.0 * (h[i - 1] + h[i]);
                rhs[i] = 6.0 * ((y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1]);
            }
            for i in 2..n - 1 {
                let f = h[i - 1] / diag[i - 1];
                diag[i] -= f * h[i - 1];
                rhs[i] -= f * rhs[i - 1];
            }
            for i in (1..n - 1).rev() {
                m[i] = (rhs[i] - h[i] * m[i + 1]) / diag[i];
            }
        }
        Spline { x, y, m }
    }

    /// Value and derivative at `t` (constant beyond the ends).
    fn eval(&self, t: f64) -> (f64, f64) {
        let n = self.x.len();
        if t <= self.x[0] {
            return (self.y[0], 0.0);
        }
        if t >= self.x[n - 1] {
            return (self.y[n - 1], 0.0);
        }
        let j = self
            .x
            .partition_point(|&v| v <= t)
            .saturating_sub(1)
            .min(n - 2);
        let (x0, x1, y0, y1, m0, m1) = (
            self.x[j],
            self.x[j + 1],
            self.y[j],
            self.y[j + 1],
            self.m[j],
            self.m[j + 1],
        );
        let h = x1 - x0;
        let (a, b) = (x1 - t, t - x0);
        let c0 = y0 / h - m0 * h / 6.0;
        let c1 = y1 / h - m1 * h / 6.0;
        let value = m0 * a * a * a / (6.0 * h) + m1 * b * b * b / (6.0 * h) + c0 * a + c1 * b;
        let slope = -m0 * a * a / (2.0 * h) + m1 * b * b / (2.0 * h) - c0 + c1;
        (value, slope)
    }
}

/// A grating's reference spectrum (linear power) and the wavelength it stands for.
#[derive(Debug, Clone, PartialEq)]
pub struct Template {
    /// Reference wavelength, nm: a measured peak shifted by δ is at `reference_nm` + δ.
    pub reference_nm: f64,
    /// FWHM of the template, nm.
    pub fwhm_nm: f64,
    height: f64,
    floor: f64,
    spline: Spline,
}

impl Template {
    /// A template from linear-power samples; its reference wavelength and FWHM are those
    /// of a Gaussian least-squares fit to it (the floor started at its lowest sample).
    pub fn new(wavelengths_nm: Vec<f64>, power: Vec<f64>) -> Result<Self, SpectrumError> {
        let spectrum = Spectrum::new("template", wavelengths_nm, power, crate::PowerUnit::Linear)?;
        let p = &spectrum.power;
        let floor = p.iter().copied().fold(f64::INFINITY, f64::min);
        let i = (0..p.len())
            .max_by(|&a, &b| p[a].total_cmp(&p[b]))
            .unwrap_or(0);
        let window = PeakWindow {
            wavelengths_nm: &spectrum.wavelengths_nm,
            power: p,
            max_index: i,
            baseline: floor,
            noise_sigma: 0.0,
        };
        let c = GaussianLeastSquares.estimate(&window)?;
        Ok(Template {
            reference_nm: c.wavelength_nm,
            fwhm_nm: c.fwhm_nm,
            height: c.amplitude,
            floor: c.baseline,
            spline: Spline::new(spectrum.wavelengths_nm, spectrum.power),
        })
    }

    /// The part of a spectrum within `half_width_nm` of `center_nm` (converted to linear
    /// power) as a template.
    pub fn from_spectrum(
        spectrum: &Spectrum,
        center_nm: f64,
        half_width_nm: f64,
    ) -> Result<Self, SpectrumError> {
        let linear = spectrum.linear_power();
        let (w, p): (Vec<f64>, Vec<f64>) = spectrum
            .wavelengths_nm
            .iter()
            .zip(linear)
            .filter(|(w, _)| (**w - center_nm).abs() <= half_width_nm)
            .unzip();
        if w.len() < 5 {
            return Err(SpectrumError::Invalid(format!(
                "template around {center_nm} nm: fewer than 5 samples"
            )));
        }
        Self::new(w, p)
    }

    fn value(&self, t: f64) -> (f64, f64) {
        self.spline.eval(t)
    }
}

struct Shifted<'a> {
    template: &'a Template,
}

impl Model for Shifted<'_> {
    fn n_params(&self) -> usize {
        3
    }
    // [a, δ, b]
    fn eval(&self, x: f64, p: &[f64], grad: &mut [f64]) -> f64 {
        let (t, slope) = self.template.value(x - p[1]);
        grad[0] = t;
        grad[1] = -p[0] * slope;
        grad[2] = 1.0;
        p[0] * t + p[2]
    }
}

/// Linear least squares of y ≈ a·t + b: (a, b, residual sum of squares).
fn linear_fit(t: &[f64], y: &[f64]) -> (f64, f64, f64) {
    let n = t.len() as f64;
    let (st, sy) = (t.iter().sum::<f64>(), y.iter().sum::<f64>());
    let (mt, my) = (st / n, sy / n);
    let stt: f64 = t.iter().map(|v| (v - mt).powi(2)).sum();
    let sty: f64 = t.iter().zip(y).map(|(a, b)| (a - mt) * (b - my)).sum();
    let a = if stt > 0.0 { sty / stt } else { 0.0 };
    let b = my - a * mt;
    let rss = t
        .iter()
        .zip(y)
        .map(|(tv, yv)| (yv - a * tv - b).powi(2))
        .sum();
    (a, b, rss)
}

/// Cross-correlation with templates (one per grating: the nearest reference is used).
/// `std_error_pm` from the residuals of the (a, δ, b) least squares.
#[derive(Debug, Clone, PartialEq)]
pub struct TemplateMatch {
    /// One template per grating.
    pub templates: Vec<Template>,
}

impl PeakEstimator for TemplateMatch {
    fn name(&self) -> &'static str {
        "xcorr"
    }

    fn estimate(&self, w: &PeakWindow) -> Result<PeakEstimate, SpectrumError> {
        let fail = |reason: &str| SpectrumError::Estimate {
            estimator: "xcorr",
            reason: reason.to_string(),
        };
        let x_max = w.wavelengths_nm[w.max_index];
        let template = self
            .templates
            .iter()
            .min_by(|a, b| {
                (a.reference_nm - x_max)
                    .abs()
                    .total_cmp(&(b.reference_nm - x_max).abs())
            })
            .ok_or_else(|| fail("no template"))?;
        let pitch = w.pitch_nm();
        let step = 0.25 * pitch;
        let span = template.fwhm_nm.max(2.0 * pitch);
        let trials = (2.0 * span / step).ceil() as usize + 1;
        let mut best = (f64::INFINITY, 0.0, 0.0, 0.0);
        let mut t = vec![0.0; w.len()];
        for k in 0..trials {
            let delta = x_max - template.reference_nm - span + k as f64 * step;
            for (ti, &x) in t.iter_mut().zip(w.wavelengths_nm) {
                *ti = template.value(x - delta).0;
            }
            let (a, b, rss) = linear_fit(&t, w.power);
            if a > 0.0 && rss < best.0 {
                best = (rss, a, delta, b);
            }
        }
        if !best.0.is_finite() {
            return Err(fail("the window does not correlate with the template"));
        }
        let fit = lm::fit(
            &Shifted { template },
            w.wavelengths_nm,
            w.power,
            vec![best.1, best.2, best.3],
        )
        .ok_or_else(|| fail("least squares did not converge"))?;
        let (a, delta, b) = (fit.params[0], fit.params[1], fit.params[2]);
        Ok(PeakEstimate {
            wavelength_nm: template.reference_nm + delta,
            std_error_pm: 1e3 * fit.std_error(1),
            amplitude: a * template.height,
            baseline: b + a * template.floor,
            fwhm_nm: template.fwhm_nm,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spline_reproduces_a_cubic_interior_and_its_slope() {
        // A natural spline is exact for straight lines; for sin it converges as h⁴ inside.
        let x: Vec<f64> = (0..41).map(|i| 0.1 * i as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| v.sin()).collect();
        let s = Spline::new(x, y);
        for t in [1.03, 2.17, 3.0] {
            let (v, d) = s.eval(t);
            assert!((v - f64::sin(t)).abs() < 1e-5, "{t}");
            assert!((d - f64::cos(t)).abs() < 1e-3, "{t}");
        }
    }
}
