//! The model's own uncertainty about a grating's K, as the policy states it: the
//! nominal reading with its stated error, the design interval the design is held to
//! (in Case I the contact window's ends, 1.30 to 1.48 × the apex patch, within which
//! the FE model meets the paper's statements, docs/model.md §5.6; in Case II the
//! closed form and the FE reading of the stated `cylinders`; every reading widened by
//! its own model's error, §5.8) and the two physically bounding contact readings
//! (pillars bonded; cylinders sliding with the domes touching over the apex patch).
//!
//! Every number comes from [`predict`](super::predict), so the FE solves go through the
//! policy's one path. The optimiser scores designs over the design interval (worst case
//! or a quantile), holds its limits at the interval's far end, and refuses a design
//! whose nominal K lies outside its bounding readings widened by its model error or
//! whose sign is not fixed across them ([`KReadings::band_violation`]).

use super::{predict, Fidelity, FidelityChoice, PredictionRequest};
use crate::fem::{FemOptions, GeometryCache};
use crate::model::{Configuration, LoadCase};
use crate::spec::Design;
use anyhow::{Context, Result};
use serde::Serialize;

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
    /// The nominal's stated error as a fraction of |K| (0 when none is stated).
    pub model_error_fraction: f64,
    /// K with the domes' contact radius at the low and the high end of the window;
    /// `None` when the row does not rest on the shipped default radius.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_window_pm_per_n: Option<[f64; 2]>,
    /// The interval the design is held to (low, high by value): it contains the
    /// nominal widened by its error.
    pub design_interval_pm_per_n: [f64; 2],
    /// FE, pillars bonded to cap and core (most coupled).
    pub bonded_pillars_pm_per_n: f64,
    /// FE, cylinders sliding, domes touching over the apex patch only (least coupled).
    pub sliding_apex_patch_pm_per_n: f64,
}

/// How a design is scored over the model's uncertainty about K.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Robustness {
    /// The nominal K only (the limits still hold at the design interval's far end).
    Nominal,
    /// The smallest |K| over the design interval (the limits hold at its largest).
    WorstCase,
    /// The `p`-quantile of |K| with K uniform over the design interval.
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
        const LIMITS: &str = "limits held at the far end of the design interval";
        match self {
            Robustness::Nominal => format!("nominal K scored; {LIMITS}"),
            Robustness::WorstCase => format!(
                "worst case over the design interval (Case I: the contact window, 1.30–1.48 × the apex patch; Case II: the closed form and the stated cylinders' FE reading; each widened by its model error): smallest |K| scored, {LIMITS}"
            ),
            Robustness::Quantile(p) => format!(
                "{:.0} % quantile of |K| with K uniform over the design interval; {LIMITS}",
                100.0 * p
            ),
        }
    }
}

impl KReadings {
    /// The |K| the row is scored on under `robustness`, and the largest |K| of its
    /// design interval, which the strain and wavelength limits hold for.
    pub fn abs_k_range(&self, robustness: Robustness) -> (f64, f64) {
        let k = self.nominal_pm_per_n.abs();
        let [lo, hi] = self.design_interval_pm_per_n;
        let largest = lo.abs().max(hi.abs()).max(k);
        // |K| over the interval: from its value nearest zero to its largest.
        let smallest = if lo <= 0.0 && hi >= 0.0 {
            0.0
        } else {
            lo.abs().min(hi.abs())
        };
        let scored = match robustness {
            Robustness::Nominal => k,
            Robustness::WorstCase => smallest.min(k),
            Robustness::Quantile(p) => {
                // K uniform over [lo, hi]: the p-quantile of |K|, by bisection on its
                // distribution function.
                let cdf = |a: f64| {
                    let w = hi - lo;
                    if w <= 0.0 {
                        return if a >= k { 1.0 } else { 0.0 };
                    }
                    let covered = (a.min(hi) - (-a).max(lo)).max(0.0);
                    covered / w
                };
                let (mut a, mut b) = (0.0, largest);
                for _ in 0..60 {
                    let c = 0.5 * (a + b);
                    if cdf(c) < p {
                        a = c;
                    } else {
                        b = c;
                    }
                }
                b
            }
        };
        (scored, largest)
    }

    /// How far the row is from a K the bounding readings support, 0 when it is: the
    /// nominal's distance outside the readings' range widened by its model error,
    /// plus every reading on the wrong side of zero, each over the largest |K| of the
    /// row. With the reason in words.
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
        let f = self.model_error_fraction;
        let (lo, hi) = (b.min(s), b.max(s));
        let (lo, hi) = (lo - f * lo.abs(), hi + f * hi.abs());
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
                "grating `{}`: nominal K {k:+.1} pm/N lies outside its bounding readings widened by its model error {:.1} % ({lo:+.1} … {hi:+.1} pm/N)",
                self.grating,
                100.0 * f
            )
        } else {
            format!(
                "grating `{}`: nominal K {k:+.1} pm/N within its bounding readings widened by its model error {:.1} % ({lo:+.1} … {hi:+.1} pm/N)",
                self.grating,
                100.0 * f
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
/// its stated error, its band and its design interval (one policy prediction: the
/// window's ends share the nominal's factorisation).
pub fn readings(design: &Design, request: &ReadingsRequest) -> Result<Vec<KReadings>> {
    let rows = predict(
        design,
        &PredictionRequest {
            case: request.case,
            insert: request.insert.clone(),
            core: request.core.clone(),
            fidelity: request.fidelity,
            fem_options: request.fem_options,
            cache: request.cache.clone(),
            band: true,
            design_interval: true,
            ..PredictionRequest::default()
        },
    )?;
    rows.iter()
        .map(|r| {
            let p = &r.detail.prediction;
            let band = r
                .band_readings
                .context("internal: the band was asked for")?;
            let k = p.sensitivity_pm_per_n;
            Ok(KReadings {
                grating: p.grating.clone(),
                configuration: Configuration {
                    core: p.core.clone(),
                    case: p.case,
                    insert: p.insert.clone(),
                },
                model: r.model,
                nominal_pm_per_n: k,
                model_error_fraction: r.model_error_fraction.unwrap_or(0.0),
                contact_window_pm_per_n: r
                    .design_interval_readings
                    .and_then(|i| i.contact_window_pm_per_n),
                design_interval_pm_per_n: r.design_interval_pm_per_n.unwrap_or([k, k]),
                bonded_pillars_pm_per_n: band.bonded_pillars_pm_per_n,
                sliding_apex_patch_pm_per_n: band.sliding_apex_patch_pm_per_n,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(nominal: f64, interval: [f64; 2], b: f64, s: f64) -> KReadings {
        KReadings {
            grating: "g".into(),
            configuration: Configuration {
                core: "c".into(),
                case: LoadCase::I,
                insert: Some("i".into()),
            },
            model: Fidelity::Fem,
            nominal_pm_per_n: nominal,
            model_error_fraction: 0.1,
            contact_window_pm_per_n: None,
            design_interval_pm_per_n: interval,
            bonded_pillars_pm_per_n: b,
            sliding_apex_patch_pm_per_n: s,
        }
    }

    #[test]
    fn worst_case_and_quantiles_follow_the_design_interval() {
        let r = row(100.0, [80.0, 130.0], 10.0, 220.0);
        assert_eq!(r.abs_k_range(Robustness::WorstCase), (80.0, 130.0));
        // The limits hold at the far end whatever is scored.
        assert_eq!(r.abs_k_range(Robustness::Nominal), (100.0, 130.0));
        // K uniform over 80…130: the p-quantile is 80 + 50 p.
        let (q10, hi) = r.abs_k_range(Robustness::Quantile(0.1));
        assert!((q10 - 85.0).abs() < 1e-9, "{q10}");
        assert_eq!(hi, 130.0);
        // A blue shift: |K| of −190…−160 runs 160…190.
        let b = row(-170.0, [-190.0, -160.0], -180.0, -100.0);
        assert_eq!(b.abs_k_range(Robustness::WorstCase), (160.0, 190.0));
        let (q50, _) = b.abs_k_range(Robustness::Quantile(0.5));
        assert!((q50 - 175.0).abs() < 1e-9, "{q50}");
        // An interval across zero scores zero in the worst case.
        let z = row(5.0, [-2.0, 9.0], 1.0, 9.0);
        assert_eq!(z.abs_k_range(Robustness::WorstCase).0, 0.0);
    }

    #[test]
    fn the_band_violation_measures_a_nominal_outside_the_widened_readings_and_a_sign_not_fixed() {
        assert_eq!(
            row(100.0, [90.0, 110.0], 10.0, 220.0).band_violation().0,
            0.0
        );
        // The 16 mm case: nominal −180.5, readings +42.6 and +1520.
        let (v, why) = row(-180.5, [-200.0, -160.0], 42.6, 1520.0).band_violation();
        assert!(v > 1.0, "{v}");
        assert!(why.contains("sign"), "{why}");
        // Further outside costs more, so a solver can move away from it.
        let (v2, _) = row(-90.0, [-100.0, -80.0], 42.6, 1520.0).band_violation();
        assert!(v2 < v, "{v2} vs {v}");
        // One sign, nominal above both readings widened by 10 %: 220 × 1.1 = 242.
        let (v, why) = row(300.0, [270.0, 330.0], 10.0, 220.0).band_violation();
        assert!((v - 58.0 / 300.0).abs() < 1e-12, "{v}");
        assert!(why.contains("outside"), "{why}");
        // Within the widening: a nominal 8 % beyond the readings is supported.
        assert_eq!(
            row(237.6, [200.0, 260.0], 10.0, 220.0).band_violation().0,
            0.0
        );
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
