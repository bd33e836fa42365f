//! Q = |K|·R²/Δt_max of one grating: given only when the lags are absolute (a known
//! clock offset) and Δt_max is resolved from zero, with its uncertainty; otherwise a
//! bound or nothing, always with the reason (and a warning).
//!
//! With an estimated clock offset the lags are relative: the estimate absorbs any pure
//! delay between force and shift, and a passive part's shift never leads its force,
//! so the true Δt_max is at least the relative one and the relative Q is only an upper
//! bound (it read 10–90× the truth on a log with a 0.3 s delay). With absolute lags
//! and Δt_max not resolved from zero, Q is only bounded below.

use super::results::{BoundKind, GratingResult, QualityBound};
use super::LagFigures;
use crate::logs::LogWarnings;

/// Q of one grating: the value, its uncertainty, or a bound and why.
pub(super) struct Quality {
    pub(super) value: Option<f64>,
    pub(super) uncertainty: Option<f64>,
    pub(super) bound: Option<QualityBound>,
    pub(super) note: Option<String>,
}

/// Q = |K|·R²/Δt_max and its uncertainty when the lags are absolute (`relative`
/// false) and Δt_max is clearly above zero; a bound and the reason otherwise.
pub(super) fn quality_q(
    k: f64,
    se_k: f64,
    r_squared: f64,
    lags: &LagFigures,
    relative: bool,
) -> Quality {
    let (dt, u) = (lags.max_lag_s, lags.max_lag_uncertainty_s);
    let gain = k.abs() * r_squared;
    let bound = |kind: BoundKind, lag: f64| {
        (lag > 0.0 && gain.is_finite() && gain > 0.0).then(|| QualityBound {
            kind,
            value_pm_per_n_s: gain / lag,
        })
    };
    if !dt.is_finite() || !u.is_finite() {
        return Quality {
            value: None,
            uncertainty: None,
            bound: None,
            note: Some("no segment lag could be measured, so Δt_max and Q are undefined".into()),
        };
    }
    if relative {
        let b = bound(BoundKind::Upper, dt - 2.0 * u);
        let note = format!(
            "the clock offset was estimated, and an estimate absorbs any pure delay between force and shift: the true Δt_max is at least the relative {dt:.4} ± {u:.4} s, so {}; give the offset between the recorders' clocks (AnalysisOptions.clock_offset_s or VerifyRequest.force_start) for Q",
            match b {
                Some(b) => format!("Q ≤ {:.3} pm/(N·s) at 2σ", b.value_pm_per_n_s),
                None => "Q has no upper bound from this data".to_string(),
            }
        );
        return Quality {
            value: None,
            uncertainty: None,
            bound: b,
            note: Some(note),
        };
    }
    if dt > 2.0 * u && dt > 0.0 {
        let q = gain / dt;
        return Quality {
            value: Some(q),
            uncertainty: Some(q * (u / dt).hypot(se_k / k.abs())),
            bound: None,
            note: None,
        };
    }
    let b = bound(BoundKind::Lower, dt + 2.0 * u);
    let note = format!(
        "Δt_max = {dt:.4} ± {u:.4} s is not resolved from zero (it must exceed twice its uncertainty): Q = |K|R²/Δt_max is undefined{}",
        b.map(|b| format!("; Q ≥ {:.3} pm/(N·s) at 2σ", b.value_pm_per_n_s))
            .unwrap_or_default()
    );
    Quality {
        value: None,
        uncertainty: None,
        bound: b,
        note: Some(note),
    }
}

/// Warn when a grating's Q is not given, with the reason and the bound.
pub(super) fn warn_q_undefined(res: &GratingResult, warnings: &mut LogWarnings) {
    if res.quality_q_pm_per_n_s.is_none() {
        warnings.add("q_undefined", || {
            format!(
                "grating `{}`: {}",
                res.grating,
                res.quality_q_note.as_deref().unwrap_or("Q is undefined")
            )
        });
    }
}
