//! Q = |K|·R²/Δt_max of one grating: defined only when Δt_max is resolved from zero,
//! with its uncertainty; a warning (with a lower bound when there is one) when not.

use super::lags::LagFigures;
use super::results::GratingResult;
use crate::logs::LogWarnings;

/// Q = |K|·R²/Δt_max and its uncertainty, when Δt_max is clearly above zero.
pub(super) fn quality_q(
    k: f64,
    se_k: f64,
    r_squared: f64,
    lags: &LagFigures,
) -> (Option<f64>, Option<f64>) {
    let (max_lag, max_lag_u) = (lags.max_lag_s, lags.max_lag_uncertainty_s);
    if max_lag > 2.0 * max_lag_u && max_lag > 0.0 {
        let q = k.abs() * r_squared / max_lag;
        (
            Some(q),
            Some(q * (max_lag_u / max_lag).hypot(se_k / k.abs())),
        )
    } else {
        (None, None)
    }
}

/// Warn when a grating's Q is undefined (Δt_max not resolved from zero), with the
/// bound on Q at 2σ when Δt_max is positive.
pub(super) fn warn_q_undefined(res: &GratingResult, warnings: &mut LogWarnings) {
    if res.quality_q_pm_per_n_s.is_none() {
        warnings.add("q_undefined", || {
            format!(
                "grating `{}`: Δt_max = {:.4} ± {:.4} s is not resolved from zero (it must exceed twice its uncertainty): Q = |K|R²/Δt_max is undefined{}",
                res.grating,
                res.max_lag_s,
                res.max_lag_uncertainty_s,
                if res.max_lag_s > 0.0 {
                    format!(
                        "; Q > {:.3} pm/(N·s) at 2σ",
                        res.sensitivity_pm_per_n.abs() * res.r_squared
                            / (res.max_lag_s + 2.0 * res.max_lag_uncertainty_s)
                    )
                } else {
                    String::new()
                }
            )
        });
    }
}
