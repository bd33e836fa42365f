//! Study `spectra` (`cargo run --release -p fbgforge-studies -- spectra [--quick]`):
//! how often does the peak finder give a **confidently wrong** peak — an error larger
//! than 3× its own `std_error_pm` with no flag raised — over a randomised scenario space
//! wider than the cases the finder was designed for?
//!
//! Its own generator draws each scenario independently: SNR 5–5000 (log-uniform), FWHM
//! 0.7–8 samples (log-uniform), the line shape (a Gaussian, a uniform grating's
//! transfer-matrix spectrum with its side lobes, a linearly chirped grating, or a grating
//! split into two lobes 0.8–2.5 FWHM apart), a second grating at 0.8–8 FWHM (in 30 % of
//! scenarios), a baseline tilt of up to 30 % of the peak height across ±3 FWHM, and
//! detector saturation clipping the top at 50–95 % of the peak (15 %). The truth is the
//! midpoint of the noiseless line's half-maximum points (the Bragg centre of a symmetric
//! line; for a split grating, the centre between its lobes). Each scenario is matched to
//! its grating's window, as `fbgforge peaks --design` does, so a split is flagged.
//!
//! Writes `spectra-scenarios.csv` (one line per scenario) and `spectra-summary.json`
//! (confidently wrong counts with their 95 % Wilson intervals, per shape and overall),
//! and prints the table.

use anyhow::{Context, Result};
use clap::Args;
use fbgforge::spectra::{
    find_grating_peaks, grating_spectrum, EstimatorChoice, ExpectedGrating, FindOptions, Grating,
    PowerUnit, Spectrum, StrainProfile,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of the spectra scenario study.
#[derive(Debug, Clone, Args)]
pub struct SpectraStudyArgs {
    /// Number of random scenarios.
    #[arg(long, default_value_t = 4000)]
    pub scenarios: usize,
    /// Seed of the scenario generator.
    #[arg(long, default_value_t = 36)]
    pub seed: u64,
    /// Output directory.
    #[arg(long, default_value = "target/studies/spectra")]
    pub out: PathBuf,
    /// Smoke form: 300 scenarios.
    #[arg(long)]
    pub quick: bool,
}

const PITCH_NM: f64 = 0.008;
const CENTER_NM: f64 = 1550.0;

/// The line shape of a scenario's grating.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LineKind {
    /// A Gaussian.
    Gaussian,
    /// A uniform grating by the transfer-matrix model (sinc²-like, side lobes).
    Grating,
    /// A grating under a linear strain gradient (chirped: flat-topped, broadened).
    Chirped,
    /// Two lobes of one grating (transverse load, strong non-uniform strain).
    Split,
}

impl LineKind {
    const ALL: [LineKind; 4] = [
        LineKind::Gaussian,
        LineKind::Grating,
        LineKind::Chirped,
        LineKind::Split,
    ];
    fn name(self) -> &'static str {
        match self {
            LineKind::Gaussian => "gaussian",
            LineKind::Grating => "grating",
            LineKind::Chirped => "chirped",
            LineKind::Split => "split",
        }
    }
}

/// One drawn scenario.
#[derive(Debug, Clone, Serialize)]
pub struct Scenario {
    /// Line shape.
    pub kind: LineKind,
    /// Peak height over the noise σ.
    pub snr: f64,
    /// Nominal FWHM in samples (of the main lobe / of each lobe).
    pub fwhm_samples: f64,
    /// Distance of a neighbouring grating, FWHM (`None`: alone).
    pub neighbour_fwhm: Option<f64>,
    /// Baseline change across ±3 FWHM, fraction of the peak height.
    pub tilt: f64,
    /// Saturation level, fraction of the peak top (`None`: not saturated).
    pub saturation: Option<f64>,
    /// Sub-sample offset of the line, samples.
    pub offset_samples: f64,
}

/// What the finder said about one scenario.
#[derive(Debug, Clone, Serialize)]
pub struct Outcome {
    /// The scenario.
    #[serde(flatten)]
    pub scenario: Scenario,
    /// Truth, nm (half-maximum midpoint of the noiseless line).
    pub truth_nm: f64,
    /// Peak found in the grating's window.
    pub found: bool,
    /// Error, pm (NaN when not found).
    pub error_pm: f64,
    /// Reported standard error, pm.
    pub std_error_pm: f64,
    /// Flags raised.
    pub flags: String,
    /// Error above 3× the standard error with no flag.
    pub confidently_wrong: bool,
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    (lo.ln() + rng.random::<f64>() * (hi.ln() - lo.ln())).exp()
}

/// Draws one scenario from the generator's space.
pub fn draw(rng: &mut ChaCha8Rng) -> Scenario {
    let kind = LineKind::ALL[rng.random_range(0..LineKind::ALL.len())];
    Scenario {
        kind,
        snr: log_uniform(rng, 5.0, 5000.0),
        fwhm_samples: log_uniform(rng, 0.7, 8.0),
        neighbour_fwhm: (rng.random::<f64>() < 0.3).then(|| rng.random_range(0.8..8.0)),
        tilt: rng.random_range(0.0..0.3),
        saturation: (rng.random::<f64>() < 0.15).then(|| rng.random_range(0.5..0.95)),
        offset_samples: rng.random::<f64>(),
    }
}

/// A uniform grating (κL = 1.5) whose main lobe has `fwhm_nm`: at a fixed κL the
/// whole line scales with 1/L, so one grating of 5 mm is measured and scaled.
fn grating_of_fwhm(center_nm: f64, fwhm_nm: f64) -> Result<Grating> {
    let kl = 1.5;
    let lambda_mm = center_nm * 1e-6;
    let of_length = |length_mm: f64| Grating {
        bragg_wavelength_nm: center_nm,
        length_mm,
        index_modulation: kl / length_mm * lambda_mm / std::f64::consts::PI,
        ..Grating::default()
    };
    let probe = of_length(5.0);
    let fine: Vec<f64> = (0..2001)
        .map(|i| center_nm - 0.5 + i as f64 * 0.0005)
        .collect();
    let y = grating_spectrum(&probe, &StrainProfile::Uniform(0.0), &fine)?.power;
    let fwhm0 = half_max_points(&fine, &y)
        .map(|(l, r)| r - l)
        .unwrap_or(0.2);
    Ok(of_length(5.0 * fwhm0 / fwhm_nm))
}

/// The noiseless line (height 1 at its top) on `x`.
fn line(kind: LineKind, center_nm: f64, fwhm_nm: f64, x: &[f64]) -> Result<Vec<f64>> {
    let gauss = |c: f64, w: f64| -> Vec<f64> {
        x.iter()
            .map(|&l| (-4.0 * std::f64::consts::LN_2 * ((l - c) / w).powi(2)).exp())
            .collect()
    };
    let normalised = |v: Vec<f64>| {
        let m = v.iter().copied().fold(0.0, f64::max);
        v.into_iter().map(|p| p / m).collect::<Vec<f64>>()
    };
    Ok(match kind {
        LineKind::Gaussian => gauss(center_nm, fwhm_nm),
        LineKind::Grating | LineKind::Chirped => {
            let g = grating_of_fwhm(center_nm, fwhm_nm)?;
            // A chirp of 2 FWHM across the grating, centred so the Bragg centre stays.
            let strain = if kind == LineKind::Chirped {
                let e = fwhm_nm / (g.strain_sensitivity_pm_per_microstrain() * 1e-3) * 1e-6;
                StrainProfile::Linear { start: -e, end: e }
            } else {
                StrainProfile::Uniform(0.0)
            };
            normalised(grating_spectrum(&g, &strain, x)?.power)
        }
        LineKind::Split => {
            let a = gauss(center_nm - 0.8 * fwhm_nm, fwhm_nm);
            let b = gauss(center_nm + 0.8 * fwhm_nm, fwhm_nm);
            normalised(a.iter().zip(&b).map(|(p, q)| p + 0.8 * q).collect())
        }
    })
}

/// Midpoint of the half-maximum points around the highest sample of a fine line.
fn half_max_midpoint(x: &[f64], y: &[f64]) -> f64 {
    half_max_points(x, y).map_or(f64::NAN, |(l, r)| 0.5 * (l + r))
}

/// The half-maximum points either side of the highest sample.
fn half_max_points(x: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    if y.is_empty() {
        return None;
    }
    let top = (0..y.len())
        .max_by(|&a, &b| y[a].total_cmp(&y[b]))
        .unwrap_or(0);
    let half = 0.5 * y[top];
    let cross = |range: &mut dyn Iterator<Item = usize>| -> f64 {
        let mut prev = top;
        for i in range {
            if y[i] < half {
                let t = (y[prev] - half) / (y[prev] - y[i]);
                return x[prev] + t * (x[i] - x[prev]);
            }
            prev = i;
        }
        x[prev]
    };
    let left = cross(&mut (0..top).rev());
    let right = cross(&mut (top + 1..y.len()));
    Some((left, right))
}

/// One standard normal draw (Box–Muller).
fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = 1.0 - rng.random::<f64>();
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// Runs one scenario: its spectrum, the finder, the verdict.
pub fn run_scenario(s: &Scenario, seed: u64) -> Result<Outcome> {
    let fwhm_nm = s.fwhm_samples * PITCH_NM;
    let center = CENTER_NM + s.offset_samples * PITCH_NM;
    let half = (40.0 * fwhm_nm).max(60.0 * PITCH_NM);
    let n = (2.0 * half / PITCH_NM) as usize;
    let x: Vec<f64> = (0..n)
        .map(|i| CENTER_NM - half + i as f64 * PITCH_NM)
        .collect();
    // The truth on a fine grid (0.01 sample).
    let fine: Vec<f64> = (0..4001)
        .map(|i| center - 4.0 * fwhm_nm + 8.0 * fwhm_nm * i as f64 / 4000.0)
        .collect();
    let truth_nm = half_max_midpoint(&fine, &line(s.kind, center, fwhm_nm, &fine)?);
    let mut y = line(s.kind, center, fwhm_nm, &x)?;
    if let Some(d) = s.neighbour_fwhm {
        let other = line(LineKind::Gaussian, center + d * fwhm_nm, fwhm_nm, &x)?;
        y.iter_mut().zip(other).for_each(|(p, q)| *p += 0.7 * q);
    }
    let sigma = 1.0 / s.snr;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let floor = 10.0 * sigma + 0.05;
    for (p, &l) in y.iter_mut().zip(&x) {
        let tilt = s.tilt * (l - center) / (6.0 * fwhm_nm);
        *p += floor + tilt + sigma * standard_normal(&mut rng);
        if let Some(sat) = s.saturation {
            *p = p.min(floor + sat);
        }
    }
    let spectrum = Spectrum::new("CH 1", x, y, PowerUnit::Mw)?;
    let expected = [ExpectedGrating {
        name: "g".into(),
        nominal_nm: CENTER_NM,
        window_nm: (3.0 * fwhm_nm).max(0.05),
    }];
    let options = FindOptions {
        estimator: EstimatorChoice::default(),
        ..FindOptions::default()
    };
    let matched = find_grating_peaks(&spectrum, &expected, &options)?;
    let peak = matched.into_iter().next().and_then(|m| m.peak);
    Ok(match peak {
        None => Outcome {
            scenario: s.clone(),
            truth_nm,
            found: false,
            error_pm: f64::NAN,
            std_error_pm: f64::NAN,
            flags: String::new(),
            confidently_wrong: false,
        },
        Some(p) => {
            let error_pm = 1e3 * (p.wavelength_nm - truth_nm);
            let flags = p.flags.names().join("|");
            // NaN standard errors count as wrong: `within` is false for them.
            let within = error_pm.abs() <= 3.0 * p.std_error_pm;
            Outcome {
                scenario: s.clone(),
                truth_nm,
                found: true,
                error_pm,
                std_error_pm: p.std_error_pm,
                confidently_wrong: p.flags.is_clean() && !within,
                flags,
            }
        }
    })
}

/// Wilson 95 % interval of k successes in n, as fractions.
fn wilson(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let (z, nf, p) = (1.96_f64, n as f64, k as f64 / n as f64);
    let c = (p + z * z / (2.0 * nf)) / (1.0 + z * z / nf);
    let h = z * (p * (1.0 - p) / nf + z * z / (4.0 * nf * nf)).sqrt() / (1.0 + z * z / nf);
    ((c - h).max(0.0), (c + h).min(1.0))
}

/// One line of the summary.
#[derive(Debug, Clone, Serialize)]
pub struct SummaryLine {
    /// Group (a line shape, `clean` for the scenarios with no tilt, neighbour or
    /// saturation, or `all`).
    pub group: String,
    /// Scenarios.
    pub scenarios: usize,
    /// Peaks found.
    pub found: usize,
    /// Peaks with at least one flag.
    pub flagged: usize,
    /// Confidently wrong peaks.
    pub confidently_wrong: usize,
    /// Their fraction of the scenarios, with its 95 % Wilson interval.
    pub confidently_wrong_fraction: f64,
    /// Lower end of the interval.
    pub interval_low: f64,
    /// Upper end of the interval.
    pub interval_high: f64,
}

fn summarise(group: &str, o: &[&Outcome]) -> SummaryLine {
    let wrong = o.iter().filter(|o| o.confidently_wrong).count();
    let (lo, hi) = wilson(wrong, o.len());
    SummaryLine {
        group: group.to_string(),
        scenarios: o.len(),
        found: o.iter().filter(|o| o.found).count(),
        flagged: o.iter().filter(|o| !o.flags.is_empty()).count(),
        confidently_wrong: wrong,
        confidently_wrong_fraction: wrong as f64 / o.len().max(1) as f64,
        interval_low: lo,
        interval_high: hi,
    }
}

/// The summary lines: per shape, the clean scenarios, all.
pub fn summary(outcomes: &[Outcome]) -> Vec<SummaryLine> {
    let mut lines: Vec<SummaryLine> = LineKind::ALL
        .iter()
        .map(|k| {
            let o: Vec<&Outcome> = outcomes.iter().filter(|o| o.scenario.kind == *k).collect();
            summarise(k.name(), &o)
        })
        .collect();
    let clean: Vec<&Outcome> = outcomes
        .iter()
        .filter(|o| {
            o.scenario.kind == LineKind::Gaussian
                && o.scenario.neighbour_fwhm.is_none()
                && o.scenario.saturation.is_none()
        })
        .collect();
    lines.push(summarise("gaussian, alone, unsaturated", &clean));
    lines.push(summarise("all", &outcomes.iter().collect::<Vec<_>>()));
    lines
}

fn csv(outcomes: &[Outcome]) -> String {
    let mut s = String::from(
        "kind,snr,fwhm_samples,neighbour_fwhm,tilt,saturation,offset_samples,truth_nm,found,error_pm,std_error_pm,flags,confidently_wrong\n",
    );
    for o in outcomes {
        let c = &o.scenario;
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.4}"));
        let _ = writeln!(
            s,
            "{},{:.2},{:.3},{},{:.4},{},{:.4},{:.6},{},{:.4},{:.4},{},{}",
            c.kind.name(),
            c.snr,
            c.fwhm_samples,
            opt(c.neighbour_fwhm),
            c.tilt,
            opt(c.saturation),
            c.offset_samples,
            o.truth_nm,
            o.found,
            o.error_pm,
            o.std_error_pm,
            o.flags,
            o.confidently_wrong
        );
    }
    s
}

/// Runs the study and writes its outputs; returns the summary.
pub fn run_study(a: &SpectraStudyArgs) -> Result<Vec<SummaryLine>> {
    let n = if a.quick { 300 } else { a.scenarios };
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
    let scenarios: Vec<Scenario> = (0..n).map(|_| draw(&mut rng)).collect();
    let outcomes = scenarios
        .iter()
        .enumerate()
        .map(|(i, s)| run_scenario(s, a.seed.wrapping_mul(1_000_003) + i as u64))
        .collect::<Result<Vec<_>>>()?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let lines = summary(&outcomes);
    fbgforge::output::write_atomic(
        &a.out.join("spectra-scenarios.csv"),
        csv(&outcomes).as_bytes(),
    )?;
    fbgforge::output::write_atomic(
        &a.out.join("spectra-summary.json"),
        serde_json::to_string_pretty(&lines)?.as_bytes(),
    )?;
    Ok(lines)
}

/// Runs the study and prints its table.
pub fn run(a: &SpectraStudyArgs) -> Result<()> {
    let lines = run_study(a)?;
    println!("| group | scenarios | found | flagged | confidently wrong | 95 % interval |");
    println!("|---|---|---|---|---|---|");
    for l in &lines {
        println!(
            "| {} | {} | {} | {} | {} ({:.1} %) | {:.1}–{:.1} % |",
            l.group,
            l.scenarios,
            l.found,
            l.flagged,
            l.confidently_wrong,
            100.0 * l.confidently_wrong_fraction,
            100.0 * l.interval_low,
            100.0 * l.interval_high
        );
    }
    println!("wrote {}", a.out.display());
    Ok(())
}
