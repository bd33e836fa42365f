//! The model's own uncertainty inside the optimiser: the policy's readings at an
//! anchor design (the design interval's ends, the contact window's and the bounding
//! readings) kept as ratios to the nominal K, with the nominal's stated error, so that
//! the estimate of a candidate carries them along; and the robust numbers of one
//! grating (the |K| scored, the |K| the limits hold for, how far the nominal is from
//! its bounding readings).

use crate::model::{GratingPrediction, LoadCase};
use crate::prediction::{Fidelity, KReadings};
use serde::Serialize;

/// One grating's readings over its nominal K at the anchor.
#[derive(Debug, Clone, PartialEq)]
struct RatioRow {
    grating: String,
    case: LoadCase,
    model: Fidelity,
    error: f64,
    window: Option<[f64; 2]>,
    interval: [f64; 2],
    bonded: f64,
    sliding: f64,
}

/// The policy's readings at an anchor design as ratios to the nominal K, by grating
/// and case (the insert aside, so that the search can carry a start's ratios to other
/// inserts until a candidate is scored exactly).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct UncertaintyRatios {
    rows: Vec<RatioRow>,
}

impl UncertaintyRatios {
    /// The ratios of `readings` (a zero nominal gives NaN ratios, which the band
    /// constraint refuses).
    pub fn from_readings(readings: &[KReadings]) -> Self {
        UncertaintyRatios {
            rows: readings
                .iter()
                .map(|r| {
                    let k = r.nominal_pm_per_n;
                    let ratio = |v: f64| if k != 0.0 { v / k } else { f64::NAN };
                    RatioRow {
                        grating: r.grating.clone(),
                        case: r.configuration.case,
                        model: r.model,
                        error: r.model_error_fraction,
                        window: r.contact_window_pm_per_n.map(|[a, b]| [ratio(a), ratio(b)]),
                        interval: r.design_interval_pm_per_n.map(ratio),
                        bonded: ratio(r.bonded_pillars_pm_per_n),
                        sliding: ratio(r.sliding_apex_patch_pm_per_n),
                    }
                })
                .collect(),
        }
    }

    /// Merge: rows of `other` replace rows of the same grating and case.
    pub fn merged(mut self, other: &UncertaintyRatios) -> Self {
        for o in &other.rows {
            self.rows
                .retain(|r| !(r.grating == o.grating && r.case == o.case));
            self.rows.push(o.clone());
        }
        self
    }

    /// The readings of a predicted row: `p` is the estimate with the trust region's
    /// correction (its K is the nominal, and the design interval's and the contact
    /// window's ends follow it), `trend` the same row without it (the bounding readings
    /// follow the closed form's trend from their anchor values, so that a nominal K
    /// crossing zero moves against them). The nominal alone (no error, no interval)
    /// when the anchor stated nothing for its grating and case.
    pub(crate) fn readings_of(
        &self,
        p: &GratingPrediction,
        trend: &GratingPrediction,
    ) -> KReadings {
        let k = p.sensitivity_pm_per_n;
        let t = trend.sensitivity_pm_per_n;
        let row = self
            .rows
            .iter()
            .find(|r| r.grating == p.grating && r.case == p.case);
        KReadings {
            grating: p.grating.clone(),
            configuration: crate::model::Configuration {
                core: p.core.clone(),
                case: p.case,
                insert: p.insert.clone(),
            },
            model: row.map_or(Fidelity::ClosedForm, |r| r.model),
            nominal_pm_per_n: k,
            model_error_fraction: row.map_or(0.0, |r| r.error),
            contact_window_pm_per_n: row.and_then(|r| r.window).map(|[a, b]| [a * k, b * k]),
            design_interval_pm_per_n: row.map_or([k, k], |r| {
                let (a, b) = (r.interval[0] * k, r.interval[1] * k);
                [a.min(b), a.max(b)]
            }),
            bonded_pillars_pm_per_n: row.map_or(k, |r| r.bonded * t),
            sliding_apex_patch_pm_per_n: row.map_or(k, |r| r.sliding * t),
        }
    }
}

/// A candidate's numbers on the Pareto front's objectives, each for its worst strain
/// grating, under unit-bearing names.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrontObjectives {
    /// |K| as scored under the robustness setting (worst case over the design interval
    /// by default), pm/N.
    pub sensitivity_pm_per_n: f64,
    /// |K| of the nominal contact reading, pm/N.
    pub nominal_sensitivity_pm_per_n: f64,
    /// The largest force before a grating reaches the strain limit (less the required
    /// margin) or leaves its wavelength window, at the far end of its design interval, N.
    pub force_range_n: f64,
    /// Which limit sets the force range: `grating_strain` or `wavelength_window`.
    pub force_range_limited_by: &'static str,
    /// Δt_max at the interrogator's rate, s.
    pub max_lag_s: f64,
    /// R² of the straight line Δλ(F).
    pub r_squared: f64,
    /// Q = |K|·R²/Δt_max with the scored |K|, pm/(N·s).
    pub quality_pm_per_n_s: f64,
}
