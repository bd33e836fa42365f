//! The Q model: Q = |K| · R² / Δt_max (pm/(N·s)) predicted from a design, so that the
//! optimiser can rank designs before anything is printed.
//!
//! * K comes from the opto-mechanical model ([`crate::model::predict`]).
//! * Δt_max, the largest lag between a force peak and its wavelength peak, comes from
//!   a standard linear solid (SLS) per material. Cap, core and insert carry the load in
//!   parallel (the model's no-sliding compatibility), so for loads slow against the
//!   relaxation times the assembly's displacement lags the force by
//!   T = Σᵢ (rᵢ − 1)·wᵢ·τᵢ / Σᵢ wᵢ, with wᵢ = Eᵢ·Aᵢ the relaxed axial stiffness of
//!   part i per unit length, rᵢ = E_u/E_r and τᵢ its relaxation time (derivation in
//!   docs/optimize.md). The interrogator resolves a peak only to one sample period,
//!   so Δt_max = max(T, sample period) (SM125 at 2 Hz: 0.5 s).
//! * R² has two losses: the hysteresis loop of the same SLS under cyclic loading of
//!   period P (a phase lag δ = 2πT/P gives R² = cos²δ for an elliptical loop), and the
//!   hyperelastic stiffening of the grating's host, ε ≈ σ/E + 1.5·n·(σ/E)², whose
//!   quadratic term leaves R² ≈ 1 − (1.5·n·ε_max)²/15 for a uniform force sweep.
//!
//! A verifier JSON of a printed prototype calibrates the model ([`Calibration`]).

use super::materials::{MaterialLibrary, ViscoParams};
use crate::model::{GratingPrediction, LoadCase};
use crate::profile::ModuleProfile;
use crate::spec::Design;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::path::Path;

/// Settings of the Q model that are not properties of the design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct QualitySettings {
    /// Interrogator sample period, s (SM125 at 2 Hz: 0.5 s); the floor of Δt_max.
    pub sample_period_s: f64,
    /// Period of the loading cycle used in calibration, s (assumed 20 s: a slow
    /// press-and-release on a force stand).
    pub loading_period_s: f64,
}

impl Default for QualitySettings {
    fn default() -> Self {
        QualitySettings {
            sample_period_s: 0.5,
            loading_period_s: 20.0,
        }
    }
}

/// One part of the load path, for the lag model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub(crate) struct LoadPathPart {
    /// Part name (cap, core, insert).
    pub part: String,
    /// Relaxed Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// Load-carrying cross-section of its cylindrical section, mm².
    pub area_mm2: f64,
    /// Viscoelastic parameters.
    pub visco: ViscoParams,
}

/// Lag T (s) of parallel standard linear solids under slow loading:
/// T = Σ (rᵢ − 1)·Eᵢ·Aᵢ·τᵢ / Σ Eᵢ·Aᵢ.
pub(crate) fn parallel_lag_s(parts: &[LoadPathPart], tau_scale: f64) -> f64 {
    let mut num = 0.0;
    let mut den = 0.0;
    for p in parts {
        let w = p.youngs_modulus_mpa * p.area_mm2;
        num +=
            (p.visco.unrelaxed_to_relaxed_ratio - 1.0) * w * p.visco.relaxation_time_s * tau_scale;
        den += w;
    }
    if den > 0.0 {
        num / den
    } else {
        0.0
    }
}

/// R² lost to the hysteresis loop of a lag `lag_s` under loading of period `period_s`:
/// cos²(2π·lag/period), with the phase clamped at 90° (R² = 0).
pub(crate) fn r_squared_hysteresis(lag_s: f64, period_s: f64) -> f64 {
    let delta = (2.0 * PI * lag_s / period_s).clamp(0.0, PI / 2.0);
    delta.cos().powi(2)
}

/// R² left by hyperelastic stiffening of a host with coefficient `nonlinearity` at the
/// peak strain `strain` (dimensionless). The response y = x + b·x² (b = 1.5·n·|ε|) on a
/// uniform sweep x ∈ [0, 1] fitted by a line leaves a residual variance b²/180 out of
/// var(y) = 1/12 + b/6 + 4b²/45, so R² = 1 − (b²/180)/var(y) (≈ 1 − b²/15 for small b).
pub(crate) fn r_squared_linearity(strain: f64, nonlinearity: f64) -> f64 {
    let b = 1.5 * nonlinearity * strain.abs();
    let var_y = 1.0 / 12.0 + b / 6.0 + 4.0 * b * b / 45.0;
    (1.0 - b * b / 180.0 / var_y).clamp(0.0, 1.0)
}

/// The Q model's numbers for one grating in one configuration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct QualityBreakdown {
    /// Grating name.
    pub grating: String,
    /// Predicted sensitivity K, pm/N (signed).
    pub sensitivity_pm_per_n: f64,
    /// Lag of the load path, s.
    pub lag_s: f64,
    /// Δt_max = max(lag, sample period), s.
    pub dt_max_s: f64,
    /// R² from hysteresis.
    pub r_squared_hysteresis: f64,
    /// R² from hyperelastic stiffening.
    pub r_squared_linearity: f64,
    /// Combined R² (product of the two, after calibration).
    pub r_squared: f64,
    /// Q = |K|·R²/Δt_max, pm/(N·s).
    pub quality_pm_per_n_s: f64,
}

/// What a measured prototype tells the Q model: one factor on every relaxation time
/// and one on the R² loss (one measurement cannot separate the parts).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Multiplies every relaxation time.
    pub tau_scale: f64,
    /// Multiplies the predicted R² loss (1 − R²).
    pub r_squared_loss_scale: f64,
    /// Interrogator sample period, s.
    pub sample_period_s: f64,
}

impl Calibration {
    /// No correction, with the given sample period.
    pub fn identity(settings: &QualitySettings) -> Self {
        Calibration {
            tau_scale: 1.0,
            r_squared_loss_scale: 1.0,
            sample_period_s: settings.sample_period_s,
        }
    }
}

/// The load path of a module design in one case: cap and core, plus the insert in
/// Case I. Areas are the cylinder sections' cross-sections from [`ModuleProfile`].
pub(crate) fn load_path(
    design: &Design,
    lib: &MaterialLibrary,
    core_material: &str,
    insert_material: Option<&str>,
) -> anyhow::Result<Vec<LoadPathPart>> {
    let m = design
        .module
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("the design has no [module] section"))?;
    let p = ModuleProfile::from_module(m);
    let part = |name: &str, key: &str, area: f64| -> anyhow::Result<LoadPathPart> {
        let mat = design.material(key, name)?;
        Ok(LoadPathPart {
            part: name.to_string(),
            youngs_modulus_mpa: mat.youngs_modulus_mpa,
            area_mm2: area,
            visco: lib.visco_for(key, mat),
        })
    };
    let ring = |ro: f64, ri: f64| PI * (ro * ro - ri * ri);
    let mut parts = vec![
        part(
            "cap",
            &m.cap_material,
            ring(p.cap_outer_radius_mm, p.cap_inner_radius_mm),
        )?,
        part(
            "core",
            core_material,
            ring(p.core_outer_radius_mm, p.core_inner_radius_mm),
        )?,
    ];
    if let Some(ins) = insert_material {
        parts.push(part(
            "insert",
            ins,
            PI * p.insert_radius_mm * p.insert_radius_mm,
        )?);
    }
    Ok(parts)
}

/// Q of one predicted grating, given its load path and the host's nonlinearity.
/// `strain_at_max_force` is the grating strain at the largest force of interest.
pub(crate) fn grating_quality(
    prediction: &GratingPrediction,
    parts: &[LoadPathPart],
    host_nonlinearity: f64,
    strain_at_max_force: f64,
    settings: &QualitySettings,
    cal: &Calibration,
) -> QualityBreakdown {
    let lag = parallel_lag_s(parts, cal.tau_scale);
    let dt_max = lag.max(cal.sample_period_s);
    let r2h = r_squared_hysteresis(lag, settings.loading_period_s);
    let r2l = r_squared_linearity(strain_at_max_force, host_nonlinearity);
    let loss = (1.0 - r2h * r2l) * cal.r_squared_loss_scale;
    let r2 = (1.0 - loss).clamp(0.0, 1.0);
    let k = prediction.sensitivity_pm_per_n;
    QualityBreakdown {
        grating: prediction.grating.clone(),
        sensitivity_pm_per_n: k,
        lag_s: lag,
        dt_max_s: dt_max,
        r_squared_hysteresis: r2h,
        r_squared_linearity: r2l,
        r_squared: r2,
        quality_pm_per_n_s: k.abs() * r2 / dt_max,
    }
}

/// Q of every strain grating of `core` in one case of a design, at `max_force_n`.
pub fn design_quality(
    design: &Design,
    predictions: &[GratingPrediction],
    lib: &MaterialLibrary,
    core: &str,
    insert: Option<&str>,
    settings: &QualitySettings,
    cal: &Calibration,
) -> anyhow::Result<Vec<QualityBreakdown>> {
    let m = design
        .module
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("the design has no [module] section"))?;
    let core_spec = m
        .cores
        .iter()
        .find(|c| c.name == core)
        .ok_or_else(|| anyhow::anyhow!("the design has no core named `{core}`"))?;
    let insert_material = match insert {
        Some(name) => Some(
            m.inserts
                .iter()
                .find(|i| i.name == name)
                .ok_or_else(|| anyhow::anyhow!("the design has no insert named `{name}`"))?
                .material
                .as_str(),
        ),
        None => None,
    };
    let parts = load_path(design, lib, &core_spec.material, insert_material)?;
    let host = lib.visco_for(
        &core_spec.material,
        design.material(&core_spec.material, "core")?,
    );
    let case = if insert.is_some() {
        LoadCase::I
    } else {
        LoadCase::II
    };
    Ok(predictions
        .iter()
        .filter(|p| p.core == core && p.case == case && p.insert.as_deref() == insert)
        .map(|p| grating_quality(p, &parts, host.nonlinearity, p.strain, settings, cal))
        .collect())
}

/// What the verifier measured on a printed prototype, read from the JSON of
/// `fbgforge verify --json`. Mapping from the verifier's fields (averaged over its
/// strain gratings):
///
/// | here | verifier |
/// |---|---|
/// | `dt_max_s` | `gratings[].max_lag_s` (Δt_max, quantised by the sample period) |
/// | `r_squared` | `gratings[].r_squared` (straight line of Δλ on F) |
/// | `sls_lag_s` | (1 − `gratings[].sls_instant_fraction`) · `gratings[].sls_time_constant_s` |
/// | `sample_period_s` | 1 / `wavelength_rate_hz` |
///
/// The verifier's first-order lag fit, Δλ = K·[r·F + (1 − r)·(F low-passed by τ)],
/// lags a slow force by (1 − r)·τ, which is exactly the lag T of this module's SLS
/// model; it resolves lags shorter than a sample period, so it calibrates τ better
/// than Δt_max does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct MeasuredPrototype {
    /// Largest lag between force and wavelength peaks, s.
    pub dt_max_s: Option<f64>,
    /// R² of the linear fit of Δλ on F.
    pub r_squared: Option<f64>,
    /// Lag of the fitted standard linear solid, (1 − r)·τ, s.
    pub sls_lag_s: Option<f64>,
    /// Interrogator sample period, s.
    pub sample_period_s: Option<f64>,
}

fn mean_field(gratings: &[serde_json::Value], key: &str) -> Option<f64> {
    let v: Vec<f64> = gratings
        .iter()
        .filter_map(|g| g.get(key).and_then(|x| x.as_f64()))
        .filter(|x| x.is_finite())
        .collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

impl MeasuredPrototype {
    /// Read a verifier JSON, naming the file on error.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            anyhow::anyhow!("{}: cannot read the verifier JSON: {e}", path.display())
        })?;
        Self::parse(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
    }

    /// Parse verifier JSON text: either the verifier's own output (a `gratings`
    /// array, possibly nested under a `measurement` object) or a flat object with
    /// the fields of this struct.
    pub fn parse(text: &str) -> anyhow::Result<Self> {
        let v: serde_json::Value = serde_json::from_str(text)
            .map_err(|e| anyhow::anyhow!("line {}: not JSON: {e}", e.line()))?;
        let root = v.get("measurement").unwrap_or(&v);
        let m = if let Some(gr) = root.get("gratings").and_then(|g| g.as_array()) {
            let tau = mean_field(gr, "sls_time_constant_s");
            let r = mean_field(gr, "sls_instant_fraction");
            MeasuredPrototype {
                dt_max_s: mean_field(gr, "max_lag_s"),
                r_squared: mean_field(gr, "r_squared"),
                sls_lag_s: tau.zip(r).map(|(t, r)| (1.0 - r) * t),
                sample_period_s: root
                    .get("wavelength_rate_hz")
                    .and_then(|x| x.as_f64())
                    .filter(|x| *x > 0.0)
                    .map(|hz| 1.0 / hz),
            }
        } else {
            serde_json::from_value(root.clone()).map_err(|e| {
                anyhow::anyhow!("expected the JSON of `fbgforge verify --json` (a `gratings` array) or fields dt_max_s, r_squared, sls_lag_s, sample_period_s: {e}")
            })?
        };
        if m.dt_max_s.is_none() && m.r_squared.is_none() && m.sls_lag_s.is_none() {
            anyhow::bail!(
                "no measured lag (gratings[].max_lag_s, gratings[].sls_time_constant_s) or R² (gratings[].r_squared) found; expected the JSON of `fbgforge verify --json`"
            );
        }
        for (name, v) in [
            ("dt_max_s", m.dt_max_s),
            ("r_squared", m.r_squared),
            ("sls_lag_s", m.sls_lag_s),
            ("sample_period_s", m.sample_period_s),
        ] {
            if let Some(x) = v {
                if !x.is_finite() || x < 0.0 {
                    anyhow::bail!("field `{name}`: expected a finite non-negative number, got {x}");
                }
            }
        }
        if let Some(r2) = m.r_squared {
            if r2 > 1.0 {
                anyhow::bail!("field `r_squared`: {r2} is above 1");
            }
        }
        Ok(m)
    }

    /// Calibrate the Q model against this measurement of a prototype whose model lag
    /// is `model_lag_s` and whose model R² from stiffening is `model_r_squared_linearity`.
    ///
    /// The fitted SLS lag, when present, fixes the τ scale (T is linear in every τ).
    /// Otherwise Δt_max does when it exceeds the sample period; a Δt_max at the sample
    /// period only bounds T, so the scale shrinks if the model predicted more than one
    /// sample period, else it stays 1. The R² loss scale is then set so that the model,
    /// with the calibrated lag, reproduces the measured R².
    pub fn calibrate(
        &self,
        model_lag_s: f64,
        model_r_squared_linearity: f64,
        settings: &QualitySettings,
    ) -> Calibration {
        let sample = self
            .sample_period_s
            .filter(|s| *s > 0.0)
            .unwrap_or(settings.sample_period_s);
        let mut cal = Calibration {
            tau_scale: 1.0,
            r_squared_loss_scale: 1.0,
            sample_period_s: sample,
        };
        if model_lag_s > 0.0 {
            if let Some(t) = self.sls_lag_s {
                cal.tau_scale = t / model_lag_s;
            } else if let Some(dt) = self.dt_max_s {
                if dt > sample {
                    cal.tau_scale = dt / model_lag_s;
                } else if model_lag_s > sample {
                    cal.tau_scale = sample / model_lag_s;
                }
            }
        }
        if let Some(r2) = self.r_squared {
            let model_r2 =
                r_squared_hysteresis(model_lag_s * cal.tau_scale, settings.loading_period_s)
                    * model_r_squared_linearity;
            let model_loss = 1.0 - model_r2;
            if model_loss > 1e-9 {
                cal.r_squared_loss_scale = (1.0 - r2) / model_loss;
            }
        }
        cal
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(e: f64, a: f64, tau: f64, r: f64) -> LoadPathPart {
        LoadPathPart {
            part: "p".into(),
            youngs_modulus_mpa: e,
            area_mm2: a,
            visco: ViscoParams {
                relaxation_time_s: tau,
                unrelaxed_to_relaxed_ratio: r,
                nonlinearity: 0.0,
            },
        }
    }

    /// The closed-form lag of one SLS equals the delay of its numerically integrated
    /// response to a slow half-sine force pulse (peak-to-peak).
    #[test]
    fn single_sls_lag_matches_a_time_domain_simulation() {
        let (er, ratio, tau) = (2.0, 1.5, 0.8);
        let eu = er * ratio;
        let lag = parallel_lag_s(&[part(er, 1.0, tau, ratio)], 1.0);
        assert!((lag - (ratio - 1.0) * tau).abs() < 1e-12);
        // SLS (Zener) in relaxation form: σ = E_r ε + q, dq/dt = (E_u − E_r) dε/dt − q/τ.
        // Drive with stress σ(t) = sin(πt/T) and integrate for ε.
        let period = 60.0;
        let dt = 1e-3;
        let (mut eps, mut q) = (0.0f64, 0.0f64);
        let (mut best_t, mut best_eps) = (0.0, f64::MIN);
        let mut t = 0.0;
        while t < period {
            let sigma_next = (PI * (t + dt) / period).sin();
            // Implicit step for q and ε together: σ = E_r ε + q, q' = (E_u−E_r)(ε'−...)
            // Solve q_{n+1} = (q_n + (eu−er)(ε_{n+1}−ε_n)) / (1 + dt/τ) with
            // σ_{n+1} = er ε_{n+1} + q_{n+1}.
            let a = 1.0 / (1.0 + dt / tau);
            let eps_next = (sigma_next - a * (q - (eu - er) * eps)) / (er + a * (eu - er));
            q = a * (q + (eu - er) * (eps_next - eps));
            eps = eps_next;
            t += dt;
            if eps > best_eps {
                best_eps = eps;
                best_t = t;
            }
        }
        let measured_lag = best_t - period / 2.0;
        assert!(
            (measured_lag - lag).abs() < 0.03 * lag + 2e-3,
            "model {lag} s, simulated {measured_lag} s"
        );
    }

    #[test]
    fn parallel_lag_is_the_stiffness_weighted_mean() {
        let parts = [part(10.0, 1.0, 1.0, 2.0), part(30.0, 1.0, 2.0, 1.0)];
        // Only the first part relaxes: (2−1)·10·1 / 40.
        assert!((parallel_lag_s(&parts, 1.0) - 0.25).abs() < 1e-12);
        assert!((parallel_lag_s(&parts, 2.0) - 0.5).abs() < 1e-12);
    }

    /// R² of an elliptical loop y = sin(θ − δ) against x = sin θ, fitted numerically,
    /// equals cos²δ.
    #[test]
    fn hysteresis_r_squared_matches_a_least_squares_fit() {
        let (lag, period) = (1.2, 20.0);
        let delta = 2.0 * PI * lag / period;
        let n = 10_000;
        let xs: Vec<f64> = (0..n)
            .map(|i| (2.0 * PI * i as f64 / n as f64).sin())
            .collect();
        let ys: Vec<f64> = (0..n)
            .map(|i| (2.0 * PI * i as f64 / n as f64 - delta).sin())
            .collect();
        let r2 = fit_r2(&xs, &ys);
        assert!(
            (r2 - r_squared_hysteresis(lag, period)).abs() < 1e-6,
            "{r2}"
        );
    }

    /// R² of y = x + b x² on a uniform sweep, fitted numerically, equals the closed form.
    #[test]
    fn linearity_r_squared_matches_a_least_squares_fit() {
        let (strain, n_coef) = (0.2, 1.0);
        let b = 1.5 * n_coef * strain;
        let n = 10_001;
        let xs: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
        let ys: Vec<f64> = xs.iter().map(|x| x + b * x * x).collect();
        let r2 = fit_r2(&xs, &ys);
        assert!(
            (r2 - r_squared_linearity(strain, n_coef)).abs() < 1e-6,
            "{r2}"
        );
        assert_eq!(r_squared_linearity(0.5, 0.0), 1.0);
    }

    fn fit_r2(xs: &[f64], ys: &[f64]) -> f64 {
        let n = xs.len() as f64;
        let mx = xs.iter().sum::<f64>() / n;
        let my = ys.iter().sum::<f64>() / n;
        let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| (x - mx) * (y - my)).sum();
        let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
        let syy: f64 = ys.iter().map(|y| (y - my).powi(2)).sum();
        sxy * sxy / (sxx * syy)
    }

    #[test]
    fn calibration_reproduces_the_measurement() {
        let s = QualitySettings::default();
        // The verifier's own layout: per-grating fits and the wavelength log's rate.
        let json = r#"{"wavelength_rate_hz": 2.0, "gratings": [
            {"grating": "a", "max_lag_s": 1.5, "r_squared": 0.96, "sls_time_constant_s": 2.0, "sls_instant_fraction": 0.4},
            {"grating": "b", "max_lag_s": 1.5, "r_squared": 0.96, "sls_time_constant_s": 2.0, "sls_instant_fraction": 0.4}]}"#;
        let m = MeasuredPrototype::parse(json).unwrap();
        assert_eq!(m.sample_period_s, Some(0.5));
        assert!((m.sls_lag_s.unwrap() - 1.2).abs() < 1e-12);
        let cal = m.calibrate(0.6, 0.99, &s);
        // The calibrated model reproduces the fitted lag and the measured R².
        let lag = 0.6 * cal.tau_scale;
        assert!((lag - 1.2).abs() < 1e-12);
        let model_r2 = r_squared_hysteresis(lag, s.loading_period_s) * 0.99;
        assert!((1.0 - (1.0 - model_r2) * cal.r_squared_loss_scale - 0.96).abs() < 1e-12);
        // Without the SLS fit, a Δt_max above one sample period sets the scale ...
        let m = MeasuredPrototype::parse(r#"{"dt_max_s": 1.5}"#).unwrap();
        assert!((0.6 * m.calibrate(0.6, 0.99, &s).tau_scale - 1.5).abs() < 1e-12);
        // ... and one at the floor cannot raise it.
        let m = MeasuredPrototype::parse(r#"{"dt_max_s": 0.5}"#).unwrap();
        assert_eq!(m.calibrate(0.2, 0.99, &s).tau_scale, 1.0);
        let e = MeasuredPrototype::parse(r#"{"gratings": [{"k": 1}]}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("no measured lag"), "{e}");
        assert!(MeasuredPrototype::parse(r#"{"r_squared": 1.5}"#).is_err());
        assert!(MeasuredPrototype::parse(r#"{"speed": 3}"#).is_err());
        assert!(MeasuredPrototype::parse("{oops")
            .unwrap_err()
            .to_string()
            .contains("line 1"));
    }
}
