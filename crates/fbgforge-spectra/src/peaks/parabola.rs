//! 3-point parabola through the highest sample and its two neighbours.
//!
//! On log power (ln(y − baseline)) by default: a Gaussian's logarithm is exactly a
//! parabola, so for a Gaussian on a known floor the vertex is the centre whatever the
//! sampling (Caruana's Gaussian interpolation). When one of the three samples is not
//! above the floor the parabola is fitted to the linear power instead.

use super::crb::FWHM_PER_SIGMA;
use super::{PeakEstimate, PeakEstimator, PeakWindow};
use crate::error::SpectrumError;

/// The parabola through three points: (vertex x, leading coefficient, vertex y).
fn vertex(x: [f64; 3], y: [f64; 3]) -> Option<(f64, f64, f64)> {
    let d01 = (y[1] - y[0]) / (x[1] - x[0]);
    let d12 = (y[2] - y[1]) / (x[2] - x[1]);
    let a = (d12 - d01) / (x[2] - x[0]);
    if !(a < 0.0) {
        return None;
    }
    let xv = 0.5 * (x[0] + x[1]) - d01 / (2.0 * a);
    let yv = y[0] + d01 * (xv - x[0]) + a * (xv - x[0]) * (xv - x[1]);
    Some((xv, a, yv))
}

/// The three samples around the maximum; `None` at a window edge.
fn three(w: &PeakWindow) -> Option<([f64; 3], [f64; 3])> {
    let i = w.max_index;
    if i == 0 || i + 1 >= w.len() {
        return None;
    }
    Some((
        [
            w.wavelengths_nm[i - 1],
            w.wavelengths_nm[i],
            w.wavelengths_nm[i + 1],
        ],
        [w.power[i - 1], w.power[i], w.power[i + 1]],
    ))
}

fn log_values(y: [f64; 3], baseline: f64) -> Option<[f64; 3]> {
    let z = y.map(|v| v - baseline);
    if z.iter().all(|&v| v > 0.0) {
        Some(z.map(f64::ln))
    } else {
        None
    }
}

/// Centre (nm) and FWHM (nm) of the Gaussian through the three samples around the
/// maximum, on ln(y − baseline); `None` when a sample is not above the floor.
pub(crate) fn log_parabola_vertex(w: &PeakWindow) -> Option<(f64, f64)> {
    let (x, y) = three(w)?;
    let (xv, a, _) = vertex(x, log_values(y, w.baseline)?)?;
    Some((xv, FWHM_PER_SIGMA * (-0.5 / a).sqrt()))
}

/// 3-point parabola estimator (see the module notes); `std_error_pm` propagates the
/// window's noise σ through the vertex formula: σ·√(Σₖ (∂λv/∂yₖ)²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parabola {
    /// Fit ln(y − baseline) (a Gaussian's exact form) instead of y.
    pub log_power: bool,
}

impl Default for Parabola {
    fn default() -> Self {
        Parabola { log_power: true }
    }
}

impl Parabola {
    fn vertex_of(&self, x: [f64; 3], y: [f64; 3], baseline: f64) -> Option<(f64, f64, f64, bool)> {
        if self.log_power {
            if let Some(z) = log_values(y, baseline) {
                return vertex(x, z).map(|(xv, a, yv)| (xv, a, yv, true));
            }
        }
        vertex(x, y).map(|(xv, a, yv)| (xv, a, yv, false))
    }
}

impl PeakEstimator for Parabola {
    fn name(&self) -> &'static str {
        "parabola"
    }

    fn estimate(&self, w: &PeakWindow) -> Result<PeakEstimate, SpectrumError> {
        let fail = |reason: &str| SpectrumError::Estimate {
            estimator: "parabola",
            reason: reason.to_string(),
        };
        let (x, y) = three(w).ok_or_else(|| fail("the highest sample is at the window's edge"))?;
        let (xv, a, yv, logarithmic) = self
            .vertex_of(x, y, w.baseline)
            .ok_or_else(|| fail("the three samples are not concave"))?;
        // Noise propagation by central differences of the vertex in each sample.
        let mut var = 0.0;
        for k in 0..3 {
            let h = 1e-3 * w.noise_sigma.max(1e-9 * y[k].abs()).max(f64::MIN_POSITIVE);
            let mut up = y;
            let mut down = y;
            up[k] += h;
            down[k] -= h;
            match (
                self.vertex_of(x, up, w.baseline),
                self.vertex_of(x, down, w.baseline),
            ) {
                (Some(u), Some(d)) => var += ((u.0 - d.0) / (2.0 * h)).powi(2),
                _ => return Err(fail("the vertex is unstable at this noise level")),
            }
        }
        let (amplitude, fwhm_nm) = if logarithmic {
            (yv.exp(), FWHM_PER_SIGMA * (-0.5 / a).sqrt())
        } else {
            (yv - w.baseline, w.measured_fwhm_nm())
        };
        Ok(PeakEstimate {
            wavelength_nm: xv,
            std_error_pm: 1e3 * w.noise_sigma * var.sqrt(),
            amplitude,
            baseline: w.baseline,
            fwhm_nm,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_parabola_is_exact_for_a_gaussian_on_a_known_floor() {
        let x: Vec<f64> = (0..9).map(|i| 1550.0 + 0.1 * i as f64).collect();
        let (c, s, b) = (1550.4137, 0.08, 2.0);
        let y: Vec<f64> = x
            .iter()
            .map(|v| b + 5.0 * (-0.5 * ((v - c) / s).powi(2)).exp())
            .collect();
        let w = PeakWindow {
            wavelengths_nm: &x,
            power: &y,
            max_index: 4,
            baseline: b,
            noise_sigma: 0.0,
        };
        let e = Parabola::default().estimate(&w).unwrap();
        assert!((e.wavelength_nm - c).abs() < 1e-10);
        assert!((e.fwhm_nm - FWHM_PER_SIGMA * s).abs() < 1e-10);
        assert!((e.amplitude - 5.0).abs() < 1e-9);
        // On linear power the same samples give a biased vertex.
        let lin = Parabola { log_power: false }.estimate(&w).unwrap();
        assert!((lin.wavelength_nm - c).abs() > 1e-3);
    }
}
