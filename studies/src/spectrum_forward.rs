//! Study `spectrum-forward` (`cargo run --release -p fbgforge-studies -- spectrum-forward
//! [--quick]`): how often is `predict`'s "one clean peak over the force range" verdict
//! **confidently wrong** — it says clean where a dense scan of the same FE profile
//! finds the reflection unclean inside the range, or it names a force where it stops
//! that is off by more than 5 % (or one dense step)?
//!
//! Its own generator draws, on the 34 mm module, a strain grating of either core and
//! either case (Case I on a random insert) made 2–30 mm long (log-uniform) and centred
//! 20–40 mm up its core (the spec's range), Δn 1·10⁻⁵–3·10⁻⁴ (log-uniform), apodisation
//! uniform, Gaussian (W = 0.5 L) or raised cosine, and a force range of 1–50 N
//! (log-uniform), far wider than the shipped 5 mm gratings. The truth is
//! `clean_peak_limit` on the same FE profile with 64 equal force steps (8× predict's).
//! What it tests is predict's sampling of the range and its bisection, not the FE.
//!
//! Writes `spectrum-forward-scenarios.csv` and `spectrum-forward-summary.json`.

use anyhow::Result;
use clap::Args;
use fbgforge::fem::{
    solve_configuration, Configuration, ContactReading, FemOptions, GeometryCache,
};
use fbgforge::model::LoadCase;
use fbgforge::prediction::{predict, FidelityChoice, PredictionRequest};
use fbgforge::spec::{Design, Limits};
use fbgforge::spectra::grating::{
    clean_peak_limit, Apodisation, CleanPeakCriteria, LoadCase as SpectrumLoad, StrainProfile,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of the study.
#[derive(Debug, Clone, Args)]
pub struct SpectrumForwardArgs {
    /// Number of random scenarios.
    #[arg(long, default_value_t = 200)]
    pub scenarios: usize,
    /// Seed of the scenario generator.
    #[arg(long, default_value_t = 36)]
    pub seed: u64,
    /// Output directory.
    #[arg(long, default_value = "target/studies/spectrum-forward")]
    pub out: PathBuf,
    /// Smoke form: 8 scenarios.
    #[arg(long)]
    pub quick: bool,
}

/// One scenario and what predict and the dense scan said.
#[derive(Debug, Clone, Serialize)]
pub struct Scenario {
    /// Core, case and insert.
    pub configuration: String,
    /// Grating length, mm.
    pub length_mm: f64,
    /// Grating centre above the core's base, mm.
    pub center_height_mm: f64,
    /// Index modulation.
    pub index_modulation: f64,
    /// Apodisation name.
    pub apodisation: &'static str,
    /// Top of the force range, N.
    pub force_range_n: f64,
    /// Strain span along the grating, µε/N.
    pub strain_span_microstrain_per_n: f64,
    /// Predict's limit, N (`None`: clean over the range).
    pub predicted_limit_n: Option<f64>,
    /// The dense scan's limit, N.
    pub dense_limit_n: Option<f64>,
    /// `agree`, `missed` (predict clean, truth not), `false_alarm`, `force_off`, or
    /// `refused` (predict failed: the error text).
    pub outcome: String,
}

/// Counts of the outcomes.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Scenarios run.
    pub scenarios: usize,
    /// Scenarios predict refused.
    pub refused: usize,
    /// Scenarios the dense scan finds unclean inside the range.
    pub unclean: usize,
    /// Missed warnings plus forces off: confidently wrong.
    pub confidently_wrong: usize,
    /// Warnings the dense scan does not confirm.
    pub false_alarms: usize,
    /// 95 % Wilson interval of the confidently wrong fraction of answered scenarios.
    pub interval: (f64, f64),
}

fn wilson(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let (k, n, z) = (k as f64, n as f64, 1.96);
    let p = k / n;
    let c = (p + z * z / (2.0 * n)) / (1.0 + z * z / n);
    let h = z / (1.0 + z * z / n) * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt();
    ((c - h).max(0.0), (c + h).min(1.0))
}

/// Draw one scenario's design, configuration and grating name.
fn draw(rng: &mut ChaCha8Rng, base: &Design) -> (Design, Configuration, &'static str) {
    let mut d = base.clone();
    let log =
        |rng: &mut ChaCha8Rng, a: f64, b: f64| (a.ln() + rng.random::<f64>() * (b / a).ln()).exp();
    d.fiber.index_modulation = log(rng, 1e-5, 3e-4);
    d.fiber.apodisation = match rng.random_range(0..3) {
        0 => Apodisation::Uniform,
        1 => Apodisation::Gaussian { fwhm_fraction: 0.5 },
        _ => Apodisation::RaisedCosine,
    };
    let (core, name) = if rng.random::<bool>() {
        ("psc1", "lambda_11")
    } else {
        ("psc2", "lambda_21")
    };
    let length = log(rng, 2.0, 30.0);
    let center = rng.random_range(20.0..40.0);
    let range = log(rng, 1.0, 50.0);
    let m = d.module.as_mut().expect("a module design");
    let inserts: Vec<String> = m.inserts.iter().map(|i| i.name.clone()).collect();
    let g = m
        .gratings
        .iter_mut()
        .find(|g| g.name == name)
        .expect("the shipped grating");
    g.length_mm = length;
    g.center_height_mm = Some(center);
    m.limits = Some(Limits {
        max_force_n: range,
        max_grating_strain_microstrain: 3000.0,
    });
    let (case, insert) = if rng.random::<bool>() {
        (LoadCase::II, None)
    } else {
        (
            LoadCase::I,
            Some(inserts[rng.random_range(0..inserts.len())].clone()),
        )
    };
    let config = Configuration {
        core: core.into(),
        case,
        insert,
    };
    (d, config, name)
}

fn apodisation_name(a: Apodisation) -> &'static str {
    match a {
        Apodisation::Uniform => "uniform",
        Apodisation::Gaussian { .. } => "gaussian",
        Apodisation::RaisedCosine => "raised_cosine",
    }
}

/// The dense scan's limit: `clean_peak_limit` on 64 steps of the FE profile.
fn dense_limit(
    d: &Design,
    config: &Configuration,
    name: &str,
    range: f64,
    cache: &GeometryCache,
) -> Result<(Option<f64>, f64)> {
    let m = d.module.as_ref().expect("a module design");
    let r = solve_configuration(
        d,
        config,
        &FemOptions::default().with_reading(m, ContactReading::Design, config.case),
        cache,
    )?;
    let i = r
        .strain_per_n
        .iter()
        .position(|(n, _, _)| n == name)
        .ok_or_else(|| anyhow::anyhow!("no grating {name}"))?;
    let p = &r.strain_profile_per_n[i];
    let span = p.strain.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - p.strain.iter().copied().fold(f64::INFINITY, f64::min);
    let grating = d.bragg_grating(name).expect("the grating");
    let cases = (1..=64)
        .map(|k| {
            let f = range * f64::from(k) / 64.0;
            Ok(SpectrumLoad {
                force_n: f,
                strain: StrainProfile::samples(
                    p.z_mm.clone(),
                    p.strain.iter().map(|e| e * f).collect(),
                )?,
            })
        })
        .collect::<Result<Vec<_>, fbgforge::spectra::SpectrumError>>()?;
    let limit = clean_peak_limit(&grating, &cases, &CleanPeakCriteria::default())?;
    Ok((limit.force_n, 1e6 * span))
}

/// Run one scenario.
fn scenario(rng: &mut ChaCha8Rng, base: &Design, cache: &GeometryCache) -> Scenario {
    let (d, config, name) = draw(rng, base);
    let m = d.module.as_ref().expect("a module design");
    let g = m.gratings.iter().find(|g| g.name == name).expect("drawn");
    let range = m.limits.expect("drawn").max_force_n;
    let mut s = Scenario {
        configuration: config.label(),
        length_mm: g.length_mm,
        center_height_mm: g.center_height_mm.unwrap_or(f64::NAN),
        index_modulation: d.fiber.index_modulation,
        apodisation: apodisation_name(d.fiber.apodisation),
        force_range_n: range,
        strain_span_microstrain_per_n: f64::NAN,
        predicted_limit_n: None,
        dense_limit_n: None,
        outcome: String::new(),
    };
    let request = PredictionRequest {
        force_n: range,
        case: Some(config.case),
        insert: config.insert.clone(),
        core: Some(config.core.clone()),
        fidelity: FidelityChoice::Fem,
        spectrum: true,
        cache: cache.clone(),
        ..PredictionRequest::default()
    };
    let answered = predict(&d, &request).and_then(|rows| {
        let row = rows
            .into_iter()
            .find(|r| r.detail.prediction.grating == name)
            .ok_or_else(|| anyhow::anyhow!("no row for {name}"))?;
        let dense = dense_limit(&d, &config, name, range, cache)?;
        Ok((row.spectrum.expect("asked").clean_limit_force_n, dense))
    });
    match answered {
        Err(e) => s.outcome = format!("refused: {e:#}").replace(',', ";"),
        Ok((predicted, (dense, span))) => {
            s.predicted_limit_n = predicted;
            s.dense_limit_n = dense;
            s.strain_span_microstrain_per_n = span;
            s.outcome = match (predicted, dense) {
                (None, None) => "agree",
                (None, Some(_)) => "missed",
                (Some(_), None) => "false_alarm",
                (Some(p), Some(t)) if (p - t).abs() <= (0.05 * t).max(range / 64.0) => "agree",
                (Some(_), Some(_)) => "force_off",
            }
            .into();
        }
    }
    s
}

/// Run the study and write its files; returns the scenarios and the summary.
pub fn run_study(a: &SpectrumForwardArgs) -> Result<(Vec<Scenario>, Summary)> {
    let n = if a.quick { 8 } else { a.scenarios };
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let base = fbgforge::design::load(&root.join("designs/clip-on-34mm.toml"))?;
    let cache = GeometryCache::default();
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
    let rows: Vec<Scenario> = (0..n).map(|_| scenario(&mut rng, &base, &cache)).collect();
    let count = |o: &str| rows.iter().filter(|r| r.outcome.starts_with(o)).count();
    let refused = count("refused");
    let wrong = count("missed") + count("force_off");
    let summary = Summary {
        scenarios: n,
        refused,
        unclean: rows.iter().filter(|r| r.dense_limit_n.is_some()).count(),
        confidently_wrong: wrong,
        false_alarms: count("false_alarm"),
        interval: wilson(wrong, n - refused),
    };
    std::fs::create_dir_all(&a.out)?;
    let mut csv = String::from("configuration,length_mm,center_height_mm,index_modulation,apodisation,force_range_n,strain_span_microstrain_per_n,predicted_limit_n,dense_limit_n,outcome\n");
    let opt = |v: Option<f64>| v.map_or(String::new(), |f| format!("{f:.4}"));
    for r in &rows {
        writeln!(
            csv,
            "{},{:.3},{:.3},{:.3e},{},{:.3},{:.4},{},{},{}",
            r.configuration,
            r.length_mm,
            r.center_height_mm,
            r.index_modulation,
            r.apodisation,
            r.force_range_n,
            r.strain_span_microstrain_per_n,
            opt(r.predicted_limit_n),
            opt(r.dense_limit_n),
            r.outcome
        )?;
    }
    fbgforge::output::write_atomic(
        &a.out.join("spectrum-forward-scenarios.csv"),
        csv.as_bytes(),
    )?;
    fbgforge::output::write_atomic(
        &a.out.join("spectrum-forward-summary.json"),
        serde_json::to_string_pretty(&summary)?.as_bytes(),
    )?;
    Ok((rows, summary))
}

/// Run the study and print its summary.
pub fn run(a: &SpectrumForwardArgs) -> Result<()> {
    let (_, s) = run_study(a)?;
    println!(
        "{} scenarios: {} refused, {} unclean inside their range by the dense scan; confidently wrong {} ({:.1}–{:.1} %), false alarms {}",
        s.scenarios,
        s.refused,
        s.unclean,
        s.confidently_wrong,
        100.0 * s.interval.0,
        100.0 * s.interval.1,
        s.false_alarms
    );
    println!("wrote {}", a.out.display());
    Ok(())
}
