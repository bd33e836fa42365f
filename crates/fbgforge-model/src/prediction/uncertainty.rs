//! The model's own uncertainty about a grating's K, as the policy states it: the
//! nominal reading, the ends of the contact window (the domes' contact radius from 1.30
//! to 1.48 × the apex patch, within which the FE model meets the paper's Case I
//! statements, docs/model.md §5.6) and the two physically bounding contact readings
//! (pillars bonded; cylinders sliding with the domes touching over the apex patch).
//!
//! Every number comes from [`predict`](super::predict), so the FE solves go through the
//! policy's one path. The optimiser scores designs over this uncertainty (worst case or
//! a quantile) and refuses a design whose nominal K lies outside its bounding readings
//! or whose sign is not fixed across them ([`KReadings::band_violation`]).

use super::{predict, Fidelity, FidelityChoice, PredictionRequest};
use crate::fem::{FemOptions, GeometryCache};
use crate::model::{Configuration, LoadCase};
use crate::spec::{Contact, Design};
use anyhow::{Context, Result};
use serde::Serialize;

/// Relative tolerance of the bounding readings around a closed-form nominal: the
/// closed form's largest measured deviation from the FE model in Case II (+3.5 %,
/// docs/model.md §9), since the readings are FE and the nominal is not.
pub const CLOSED_FORM_BAND_TOLERANCE: f64 = 0.035;

/// What one grating's K may be under the model's stated uncertainty, pm/N.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KReadings {
    /// Grating name.
    pub grating: String,
    /// The configuration.
    pub configuration: Configuration,
    /// The model of the nominal K.
    pub model: Fidelity,
    /// The policy's nominal K (the design's contact reading).
    pub nominal_pm_per_n: f64,
    /// K with the domes' contact radius at the low and the high end of the window
    /// ([`Contact::PAPER_WINDOW_TO_PATCH`]); `None` when the row does not rest on the
    /// shipped default radius (Case II, the closed form, or a calibrated contact, whose
    /// radius was measured).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_window_pm_per_n: Option<[f64; 2]>,
    /// FE, pillars bonded to cap and core (most coupled).
    pub bonded_pillars_pm_per_n: f64,
    /// FE, cylinders sliding, domes touching over the apex patch only (least coupled).
    pub sliding_apex_patch_pm_per_n: f64,
}

/// How a design is scored over the model's uncertainty about K.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Robustness {
    /// The nominal K only.
    Nominal,
    /// The smallest |K| over the contact window (the constraints on strain and
    /// wavelength take the largest).
    WorstCase,
    /// The `p`-quantile of |K| with the contact radius uniform over the window (K
    /// piecewise linear in the radius through the window's ends and the nominal); the
    /// constraints take the (1 − p)-quantile.
    Quantile(f64),
}

impl Robustness {
    /// Parse `nominal`, `worst` or `quantile:P` (0 < P < 1).
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "nominal" => Ok(Robustness::Nominal),
            "worst" | "worst-case" => Ok(Robustness::WorstCase),
            _ => {
                let p = s
                    .strip_prefix("quantile:")
                    .and_then(|p| p.parse::<f64>().ok())
                    .with_context(|| {
                        format!("unknown robustness `{s}`; expected nominal, worst or quantile:P (e.g. quantile:0.1)")
                    })?;
                anyhow::ensure!(
                    p > 0.0 && p < 1.0,
                    "robustness quantile:{p}: the quantile must lie strictly between 0 and 1"
                );
                Ok(Robustness::Quantile(p))
            }
        }
    }

    /// In words, for reports.
    pub fn describe(self) -> String {
        let (lo, hi) = Contact::PAPER_WINDOW_TO_PATCH;
        match self {
            Robustness::Nominal => "nominal K (the design's contact reading)".into(),
            Robustness::WorstCase => format!(
                "worst case over the contact window ({lo:.2}–{hi:.2} × the apex patch): smallest |K| scored, largest |K| held to the strain and wavelength limits"
            ),
            Robustness::Quantile(p) => format!(
                "{:.0} % quantile of |K| with the contact radius uniform over {lo:.2}–{hi:.2} × the apex patch (limits at the {:.0} % quantile)",
                100.0 * p,
                100.0 * (1.0 - p)
            ),
        }
    }
}

impl KReadings {
    /// |K| at the contact ratio `r` (× patch), piecewise linear through the window's
    /// ends and the nominal (at `nominal_ratio`).
    fn abs_k_at(&self, nominal_ratio: f64, r: f64) -> f64 {
        let Some([k_lo, k_hi]) = self.contact_window_pm_per_n else {
            return self.nominal_pm_per_n.abs();
        };
        let (r_lo, r_hi) = Contact::PAPER_WINDOW_TO_PATCH;
        let mut pts = vec![(r_lo, k_lo), (r_hi, k_hi)];
        if nominal_ratio > r_lo && nominal_ratio < r_hi {
            pts.insert(1, (nominal_ratio, self.nominal_pm_per_n));
        }
        let i = pts
            .windows(2)
            .position(|w| r <= w[1].0)
            .unwrap_or(pts.len() - 2);
        let ((x0, y0), (x1, y1)) = (pts[i], pts[i + 1]);
        (y0 + (y1 - y0) * (r - x0) / (x1 - x0)).abs()
    }

    /// The smallest and largest |K| the row may have under `robustness`: the value the
    /// design is scored on and the one the strain and wavelength limits must hold for.
    pub fn abs_k_range(&self, robustness: Robustness) -> (f64, f64) {
        let k = self.nominal_pm_per_n.abs();
        let Some([lo, hi]) = self.contact_window_pm_per_n else {
            return (k, k);
        };
        match robustness {
            Robustness::Nominal => (k, k),
            Robustness::WorstCase => (k.min(lo.abs()).min(hi.abs()), k.max(lo.abs()).max(hi.abs())),
            Robustness::Quantile(p) => {
                // The nominal ratio only shapes the interpolation; the default's.
                let nominal = Contact::DEFAULT_CONTACT_TO_PATCH;
                let (r_lo, r_hi) = Contact::PAPER_WINDOW_TO_PATCH;
                let n = 401;
                let mut v: Vec<f64> = (0..n)
                    .map(|i| {
                        let r = r_lo + (r_hi - r_lo) * i as f64 / (n - 1) as f64;
                        self.abs_k_at(nominal, r)
                    })
                    .collect();
                v.sort_by(f64::total_cmp);
                let q = |p: f64| v[((n - 1) as f64 * p).round() as usize];
                (q(p), q(1.0 - p))
            }
        }
    }

    /// How far the row is from a K the bounding readings support, 0 when it is: the
    /// nominal's distance outside the readings' range (less the closed form's own
    /// tolerance when the nominal is the closed form's), plus every reading on the wrong
    /// side of zero, each over the largest |K| of the row. With the reason in words.
    pub fn band_violation(&self) -> (f64, String) {
        let k = self.nominal_pm_per_n;
        let (b, s) = (
            self.bonded_pillars_pm_per_n,
            self.sliding_apex_patch_pm_per_n,
        );
        let scale = k.abs().max(b.abs()).max(s.abs());
        if !(scale > 0.0 && scale.is_finite()) {
            return (
                1.0,
                format!("grating `{}`: K is zero or undefined", self.grating),
            );
        }
        let tol = match self.model {
            Fidelity::ClosedForm => CLOSED_FORM_BAND_TOLERANCE * k.abs(),
            Fidelity::Fem => 0.0,
        };
        let (lo, hi) = (b.min(s) - tol, b.max(s) + tol);
        let outside = (lo - k).max(k - hi).max(0.0);
        let sign = k.signum();
        let wrong: f64 = [b, s].iter().map(|r| (-sign * r).max(0.0)).sum();
        let v = (outside + wrong) / scale;
        let why = if wrong > 0.0 {
            format!(
                "grating `{}`: the sign of K is not fixed across the bounding readings (nominal {k:+.1}, bonded pillars {b:+.1}, sliding apex patch {s:+.1} pm/N)",
                self.grating
            )
        } else if outside > 0.0 {
            format!(
                "grating `{}`: nominal K {k:+.1} pm/N lies outside its bounding readings {:+.1} … {:+.1} pm/N",
                self.grating,
                b.min(s),
                b.max(s)
            )
        } else {
            format!(
                "grating `{}`: nominal K {k:+.1} pm/N within its bounding readings {:+.1} … {:+.1} pm/N",
                self.grating,
                b.min(s),
                b.max(s)
            )
        };
        (v, why)
    }
}

/// What [`readings`] predicts.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadingsRequest {
    /// One load case only.
    pub case: Option<LoadCase>,
    /// Case I with this insert only.
    pub insert: Option<String>,
    /// Gratings of this core only.
    pub core: Option<String>,
    /// Which model gives the nominal.
    pub fidelity: FidelityChoice,
    /// Mesh and solver of the FE solves.
    pub fem_options: FemOptions,
    /// Where the FE solves' structures come from and go (see
    /// [`super::PredictionRequest::cache`]).
    pub cache: GeometryCache,
}

impl Default for ReadingsRequest {
    fn default() -> Self {
        ReadingsRequest {
            case: None,
            insert: None,
            core: None,
            fidelity: FidelityChoice::Auto,
            fem_options: FemOptions::default(),
            cache: GeometryCache::default(),
        }
    }
}

/// `design` with the domes' contact radius set to `ratio` × the apex patch.
pub fn with_contact_ratio(design: &Design, ratio: f64) -> Design {
    let mut d = design.clone();
    if let Some(m) = d.module.as_mut() {
        m.contact.dome_contact_radius_mm = None;
        m.contact.dome_contact_radius_to_patch = Some(ratio);
    }
    d
}

/// Every strain grating's K under the model's uncertainty: the policy's nominal with
/// its band, and, for rows that rest on the shipped default contact radius, K at both
/// ends of the contact window (two more policy predictions of the configurations).
pub fn readings(design: &Design, request: &ReadingsRequest) -> Result<Vec<KReadings>> {
    let base = PredictionRequest {
        case: request.case,
        insert: request.insert.clone(),
        core: request.core.clone(),
        fidelity: request.fidelity,
        fem_options: request.fem_options,
        cache: request.cache.clone(),
        ..PredictionRequest::default()
    };
    let rows = predict(
        design,
        &PredictionRequest {
            band: true,
            ..base.clone()
        },
    )?;
    let m = design
        .module
        .as_ref()
        .context("the design has no [module] section")?;
    // The window applies where the nominal rests on the default contact radius: Case I
    // rows the FE model answers with the design's contact.
    let windowed = |r: &super::ModelledPrediction| {
        r.detail.prediction.case == LoadCase::I
            && r.model == Fidelity::Fem
            && m.contact_radius_is_default()
    };
    let window = if rows.iter().any(windowed) {
        let at = |ratio: f64| {
            predict(
                &with_contact_ratio(design, ratio),
                &PredictionRequest {
                    case: Some(LoadCase::I),
                    ..base.clone()
                },
            )
        };
        let (lo, hi) = Contact::PAPER_WINDOW_TO_PATCH;
        let (a, b) = rayon::join(|| at(lo), || at(hi));
        Some((a?, b?))
    } else {
        None
    };
    rows.iter()
        .map(|r| {
            let p = &r.detail.prediction;
            let band = r
                .band_readings
                .context("internal: the band was asked for")?;
            let find = |rows: &[super::ModelledPrediction]| {
                rows.iter()
                    .find(|w| {
                        let q = &w.detail.prediction;
                        q.grating == p.grating && q.case == p.case && q.insert == p.insert
                    })
                    .map(|w| w.detail.prediction.sensitivity_pm_per_n)
            };
            let contact_window_pm_per_n = match (&window, windowed(r)) {
                (Some((lo, hi)), true) => Some([
                    find(lo).context("internal: no window row")?,
                    find(hi).context("internal: no window row")?,
                ]),
                _ => None,
            };
            Ok(KReadings {
                grating: p.grating.clone(),
                configuration: Configuration {
                    core: p.core.clone(),
                    case: p.case,
                    insert: p.insert.clone(),
                },
                model: r.model,
                nominal_pm_per_n: p.sensitivity_pm_per_n,
                contact_window_pm_per_n,
                bonded_pillars_pm_per_n: band.bonded_pillars_pm_per_n,
                sliding_apex_patch_pm_per_n: band.sliding_apex_patch_pm_per_n,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(nominal: f64, window: Option<[f64; 2]>, b: f64, s: f64) -> KReadings {
        KReadings {
            grating: "g".into(),
            configuration: Configuration {
                core: "c".into(),
                case: LoadCase::I,
                insert: Some("i".into()),
            },
            model: Fidelity::Fem,
            nominal_pm_per_n: nominal,
            contact_window_pm_per_n: window,
            bonded_pillars_pm_per_n: b,
            sliding_apex_patch_pm_per_n: s,
        }
    }

    #[test]
    fn worst_case_and_quantiles_follow_the_window() {
        // K falls linearly with the radius: 120 at 1.30, 100 at 1.376 (nominal), and
        // 120 − 20/0.076 × 0.18 at 1.48 on the same line.
        let slope = -20.0 / 0.076;
        let k_hi = 120.0 + slope * 0.18;
        let r = row(100.0, Some([120.0, k_hi]), 10.0, 220.0);
        let (lo, hi) = r.abs_k_range(Robustness::WorstCase);
        assert!((lo - k_hi).abs() < 1e-12 && (hi - 120.0).abs() < 1e-12);
        assert_eq!(r.abs_k_range(Robustness::Nominal), (100.0, 100.0));
        // On a straight line with the radius uniform, the p-quantile of K is the line at
        // the matching radius: exact up to the 401-point grid (step 0.18/400).
        let (q10, q90) = r.abs_k_range(Robustness::Quantile(0.1));
        let exact = |p: f64| k_hi + (120.0 - k_hi) * p;
        let grid = (120.0 - k_hi) / 400.0;
        assert!((q10 - exact(0.1)).abs() <= grid, "{q10} vs {}", exact(0.1));
        assert!((q90 - exact(0.9)).abs() <= grid, "{q90} vs {}", exact(0.9));
        // No window (Case II or a measured contact): the nominal in every sense.
        let n = row(-170.0, None, -190.0, -165.0);
        assert_eq!(n.abs_k_range(Robustness::WorstCase), (170.0, 170.0));
    }

    #[test]
    fn the_band_violation_measures_a_nominal_outside_and_a_sign_not_fixed() {
        assert_eq!(row(100.0, None, 10.0, 220.0).band_violation().0, 0.0);
        // The 16 mm case: nominal −180.5, readings +42.6 and +1520.
        let (v, why) = row(-180.5, None, 42.6, 1520.0).band_violation();
        assert!(v > 1.0, "{v}");
        assert!(why.contains("sign"), "{why}");
        // Further outside costs more, so a solver can move away from it.
        let (v2, _) = row(-90.0, None, 42.6, 1520.0).band_violation();
        assert!(v2 < v, "{v2} vs {v}");
        // One sign, nominal above both readings: the distance over the largest |K|.
        let (v, why) = row(300.0, None, 10.0, 220.0).band_violation();
        assert!((v - 80.0 / 300.0).abs() < 1e-12, "{v}");
        assert!(why.contains("outside"), "{why}");
        // A closed-form nominal gets the closed form's measured tolerance.
        let mut c = row(-171.0, None, -193.0, -169.9);
        c.model = Fidelity::ClosedForm;
        assert_eq!(c.band_violation().0, 0.0);
        c.nominal_pm_per_n = -160.0;
        assert!(c.band_violation().0 > 0.0);
    }

    #[test]
    fn robustness_parses_and_refuses_bad_quantiles() {
        assert_eq!(Robustness::parse("worst").unwrap(), Robustness::WorstCase);
        assert_eq!(
            Robustness::parse("quantile:0.1").unwrap(),
            Robustness::Quantile(0.1)
        );
        assert!(Robustness::parse("quantile:1.5").is_err());
        assert!(Robustness::parse("best").is_err());
    }
}
