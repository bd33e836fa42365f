//! Clock skew between the force stand and the interrogator, read from the per-segment
//! lags.
//!
//! Two recorders' clocks rarely tick at exactly the same rate. A force stand whose
//! clock runs ε fast stamps a force applied t s after its start at (1 + ε)·t, so with
//! one constant offset the force drifts against the shift by ε per second: the
//! per-segment lags fall (ε > 0) or rise linearly over the run — at +1000 ppm by 1.2 s
//! over 20 min, down to lags below zero, which a passive part cannot have. The
//! weighted straight line of the lags against time gives the skew (ε = −slope); its
//! uncertainty is the slope's, widened by the Birge ratio √(χ²/(n − 2)) when the lags
//! scatter more than their own uncertainties allow (segments the lag model describes
//! unequally must not pass for a skew). The force clock is then warped linearly about a
//! pivot, u' = pivot + (u − pivot)/(1 + ε): the force log's start when the clock offset
//! was given (the offset holds there), the lags' weighted mean time when it was
//! estimated (the estimate is the run's average alignment).

use serde::Serialize;

/// A skew is corrected when it exceeds this many standard uncertainties.
pub(crate) const SIGNIFICANCE: f64 = 3.0;
/// Fewest segment lags a skew is fitted to.
pub(crate) const MIN_SEGMENTS: usize = 3;

/// The straight line of the segment lags against time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(crate) struct SkewFit {
    /// How much faster the force clock runs than the wavelength clock, s/s (1e-6 =
    /// 1 ppm); positive when the lags fall over the run.
    pub skew: f64,
    /// Its standard uncertainty, s/s.
    pub skew_uncertainty: f64,
    /// The fitted lag at the pivot, s.
    pub lag_at_pivot_s: f64,
    /// The time the warp leaves unchanged, s (wavelength clock).
    pub pivot_s: f64,
    /// Segment lags fitted.
    pub segments: usize,
    /// How far the lags' line drifts over the segments' time span, s.
    pub drift_over_run_s: f64,
}

impl SkewFit {
    /// The skew in parts per million.
    pub fn ppm(&self) -> f64 {
        1e6 * self.skew
    }

    /// Its uncertainty in parts per million.
    pub(crate) fn uncertainty_ppm(&self) -> f64 {
        1e6 * self.skew_uncertainty
    }

    /// Whether the skew stands out of its uncertainty ([`SIGNIFICANCE`]).
    pub fn significant(&self) -> bool {
        self.skew.abs() > SIGNIFICANCE * self.skew_uncertainty && self.skew.abs() < 0.5
    }

    /// A force time on the wavelength clock, skew removed.
    pub fn warp(&self, u: f64) -> f64 {
        self.pivot_s + (u - self.pivot_s) / (1.0 + self.skew)
    }
}

/// Fit the skew to segment lags `(time s, lag s, standard uncertainty s)`; `pivot_s`
/// is where the warp holds the clocks together (None: the lags' weighted mean time).
/// None with fewer than [`MIN_SEGMENTS`] usable lags or no spread in time.
pub(crate) fn fit_skew(points: &[(f64, f64, f64)], pivot_s: Option<f64>) -> Option<SkewFit> {
    let p: Vec<(f64, f64, f64)> = points
        .iter()
        .copied()
        .filter(|(t, l, u)| t.is_finite() && l.is_finite() && u.is_finite() && *u > 0.0)
        .collect();
    if p.len() < MIN_SEGMENTS {
        return None;
    }
    let w: Vec<f64> = p.iter().map(|(_, _, u)| 1.0 / (u * u)).collect();
    let sw: f64 = w.iter().sum();
    let tm = p.iter().zip(&w).map(|((t, _, _), w)| w * t).sum::<f64>() / sw;
    let lm = p.iter().zip(&w).map(|((_, l, _), w)| w * l).sum::<f64>() / sw;
    let stt: f64 = p
        .iter()
        .zip(&w)
        .map(|((t, _, _), w)| w * (t - tm).powi(2))
        .sum();
    if stt.is_nan() || stt <= 0.0 {
        return None;
    }
    let slope = p
        .iter()
        .zip(&w)
        .map(|((t, l, _), w)| w * (t - tm) * (l - lm))
        .sum::<f64>()
        / stt;
    let chi2: f64 = p
        .iter()
        .zip(&w)
        .map(|((t, l, _), w)| w * (l - lm - slope * (t - tm)).powi(2))
        .sum();
    let birge = (chi2 / (p.len() - 2) as f64).sqrt().max(1.0);
    let se = birge / stt.sqrt();
    let pivot = pivot_s.filter(|x| x.is_finite()).unwrap_or(tm);
    let (t0, t1) = p
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (t, _, _)| {
            (a.min(*t), b.max(*t))
        });
    Some(SkewFit {
        skew: -slope,
        skew_uncertainty: se,
        lag_at_pivot_s: lm + slope * (pivot - tm),
        pivot_s: pivot,
        segments: p.len(),
        drift_over_run_s: slope * (t1 - t0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_drift_of_the_lags_is_the_skew_and_the_warp_removes_it() {
        // +1000 ppm over 20 min: a true lag of 0.3 s read as 0.3 − 1e-3 (t − 60).
        let pts: Vec<(f64, f64, f64)> = (0..24)
            .map(|k| {
                let t = 60.0 + 50.0 * k as f64;
                let wiggle = 0.004 * if k % 2 == 0 { 1.0 } else { -1.0 };
                (t, 0.3 - 1e-3 * (t - 60.0) + wiggle, 0.005)
            })
            .collect();
        let s = fit_skew(&pts, Some(60.0)).unwrap();
        assert!(
            (s.ppm() - 1000.0).abs() < 3.0 * s.uncertainty_ppm(),
            "{s:?}"
        );
        assert!(s.uncertainty_ppm() < 10.0 && s.significant());
        assert!((s.lag_at_pivot_s - 0.3).abs() < 0.01, "{s:?}");
        // The force stamp of an event at T is pivot + (1 + ε)(T − pivot): the warp
        // gives T back.
        let stamped = 60.0 + (1.0 + s.skew) * (900.0 - 60.0);
        assert!((s.warp(stamped) - 900.0).abs() < 1e-9);
        // Lags that only scatter (alternating ±0.02 s around 0.3 s, stated ±0.005 s)
        // give no significant skew: the Birge ratio widens the slope's uncertainty.
        let flat: Vec<(f64, f64, f64)> = (0..24)
            .map(|k| {
                let e = if (k / 3) % 2 == 0 { 0.02 } else { -0.02 };
                (60.0 + 50.0 * k as f64, 0.3 + e, 0.005)
            })
            .collect();
        let s = fit_skew(&flat, None).unwrap();
        assert!(!s.significant(), "{s:?}");
        // Too few lags: no fit.
        assert!(fit_skew(&pts[..2], None).is_none());
    }
}
