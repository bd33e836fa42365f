//! The `live-starts` study: how often does `live` show a confidently wrong load after
//! it starts, when it starts at any moment of a load script (issue 37)?
//!
//! Its own generator, wider than the cases (the demo script started 1.3 s in):
//!
//! * **script**: a random script of 2–6 steps after a rest of 0–2.5 s (0: the script
//!   starts loaded), each step held 0.1–2.0 s (so some holds outlast the 1 s tare
//!   window); array steps load 1–2 random cells with 20–250 g, or rest (30 %); module
//!   steps hold 0–10 N, with a ±2 K temperature step in 20 % of them;
//! * **start**: uniform over the script's first pass;
//! * **touch**: in half the scenarios a touch during the first 1.2 s after the start
//!   (0.05–0.6 s; array: one cell, 50–250 g; module: 1–10 N);
//! * **noise**: none, the interrogator's resolution (0.5 pm), or the paper's noise
//!   model (array: hysteresis, linearity, additivity; module: the resolution);
//! * **drift**: a thermal drift common to every grating, 0 in half the scenarios, else
//!   uniform in ±0–2 pm/s from the start.
//!
//! Each scenario is read for 8 s from its start at 1 kHz three ways: **at rest** (the
//! tare as shipped: 50 frames and 1 s within the resolution, re-tare when the sensor
//! settles below the tare), **first 50** (the tare before issue 37: the mean of the
//! first 50 frames, whatever they held) and **oracle** (the true zero-load
//! wavelengths at the start: the floor the model's own error and the drift leave). A
//! reading is *wrong* when an array cell is off by more than 40 g (the paper's noise
//! gives up to ~20 g) or a module grating's force by more than 0.25 N; *confidently
//! wrong* when it is wrong and shown unflagged (array trust flags empty, not below the
//! tare). Gratings are placed at their nominal wavelengths (no fabrication offset), so
//! the oracle tare is the design's nominal.
//!
//! Run with `cargo run --release -p fbgforge-studies -- live-starts [--quick]`.

use anyhow::Result;
use fbgforge::live::interpret::{InterpretOptions, Interpreter, Reading};
use fbgforge::live::source::Frame;
use fbgforge::output::{write_csv, write_json};
use fbgforge::spec::Design;
use fbgforge::synth::stream::{Generator, LoadScript, SynthNoise, SynthRequest};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of the study.
#[derive(Debug, clap::Args)]
pub struct LiveStartsArgs {
    /// The array design.
    #[arg(long, default_value = "designs/tactile-array-60x80.toml")]
    pub array: PathBuf,
    /// The module design.
    #[arg(long, default_value = "designs/clip-on-34mm.toml")]
    pub module: PathBuf,
    /// Scenarios per design.
    #[arg(long, default_value_t = 150)]
    pub scenarios: usize,
    /// Seed of the first scenario.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder.
    #[arg(long, default_value = "out/studies/live-starts")]
    pub out: PathBuf,
    /// A few scenarios, 3 s each (the test suite's form).
    #[arg(long)]
    pub quick: bool,
}

/// Frames per second of every scenario.
const RATE_HZ: f64 = 1000.0;
/// An array reading is wrong when a cell is off by more than this, g.
pub const ARRAY_WRONG_G: f64 = 40.0;
/// A module reading is wrong when a grating's force is off by more than this, N.
pub const MODULE_WRONG_N: f64 = 0.25;

/// One random scenario.
#[derive(Debug, Clone, Serialize)]
pub struct Scenario {
    /// `array` or `module`.
    pub kind: &'static str,
    /// Seed of its draws.
    pub seed: u64,
    /// When `live` starts in the script, s.
    pub start_s: f64,
    /// The script's rest before its first step, s.
    pub first_rest_s: f64,
    /// Whether the script is loaded at the start.
    pub starts_loaded: bool,
    /// Longest hold of a load in the script, s.
    pub longest_load_s: f64,
    /// A touch during the tare: (s after the start, duration s), if any.
    pub touch: Option<(f64, f64)>,
    /// `none`, `resolution` or `paper`.
    pub noise: &'static str,
    /// Common drift, pm/s.
    pub drift_pm_per_s: f64,
}

/// What one way of taring made of a scenario.
#[derive(Debug, Clone, Serialize)]
pub struct Outcome {
    /// `at_rest`, `first_50` or `oracle`.
    pub policy: &'static str,
    /// Readings shown.
    pub shown: u64,
    /// Readings wrong (flagged or not).
    pub wrong: u64,
    /// Readings wrong and shown unflagged.
    pub confidently_wrong: u64,
    /// Frame time from the start to the first reading, s (None: no reading).
    pub first_reading_s: Option<f64>,
    /// Tare changes (waiting, resting, refused) said.
    pub tare_changes: usize,
}

/// Totals of one policy over the scenarios of one design.
#[derive(Debug, Clone, Serialize)]
pub struct PolicyTotal {
    /// `array` or `module`.
    pub kind: &'static str,
    /// The policy.
    pub policy: &'static str,
    /// Scenarios.
    pub scenarios: usize,
    /// Scenarios with at least one confidently wrong reading.
    pub scenarios_confidently_wrong: usize,
    /// 95 % Wilson interval of that share.
    pub share_interval: (f64, f64),
    /// Readings shown.
    pub shown: u64,
    /// Confidently wrong readings.
    pub confidently_wrong: u64,
    /// Median time to the first reading, s.
    pub median_first_reading_s: f64,
}

/// The study's totals.
#[derive(Debug, Serialize)]
pub struct LiveStartsSummary {
    /// Per design and policy.
    pub totals: Vec<PolicyTotal>,
    /// Criteria.
    pub array_wrong_g: f64,
    /// Criteria.
    pub module_wrong_n: f64,
    /// Seconds the study took.
    pub elapsed_s: f64,
}

/// A scenario's load at time `t` (s of script time): the script plus the touch.
struct Truth {
    script: LoadScript,
    /// (from s, to s, values added).
    touch: Option<(f64, f64, Vec<f64>)>,
}

impl Truth {
    fn at(&self, t: f64) -> Vec<f64> {
        let mut v = self.script.at(t).to_vec();
        if let Some((a, b, add)) = &self.touch {
            if t >= *a && t < *b {
                for (x, y) in v.iter_mut().zip(add) {
                    *x += y;
                }
            }
        }
        v
    }

    /// The same as a plain script (piecewise constant up to `end_s`), for the
    /// generator: every step boundary of the script and the touch.
    fn as_script(&self, end_s: f64) -> LoadScript {
        let period = self.script.period_s();
        let mut cuts = vec![0.0];
        let mut t = 0.0;
        while t < end_s {
            for (h, _) in &self.script.steps {
                t += h;
                cuts.push(t);
            }
            if period <= 0.0 {
                break;
            }
        }
        if let Some((a, b, _)) = &self.touch {
            cuts.extend([*a, *b]);
        }
        cuts.retain(|&c| c <= end_s);
        cuts.push(end_s);
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        let steps = cuts
            .windows(2)
            .map(|w| (w[1] - w[0], self.at(0.5 * (w[0] + w[1]))))
            .collect();
        LoadScript {
            columns: self.script.columns.clone(),
            steps,
        }
    }
}

/// A random base script for `design`.
fn random_script(design: &Design, rng: &mut ChaCha8Rng) -> LoadScript {
    let array = design.array.is_some();
    let cells = design
        .array
        .as_ref()
        .map_or(0, |a| (a.cells_x * a.cells_y) as usize);
    let width = if array { cells } else { 2 };
    let mut steps = Vec::new();
    let rest = if rng.random_bool(0.2) {
        0.0
    } else {
        rng.random_range(0.1..2.5)
    };
    if rest > 0.0 {
        steps.push((rest, vec![0.0; width]));
    }
    for _ in 0..rng.random_range(2..=6) {
        let hold = rng.random_range(0.1..2.0);
        let mut v = vec![0.0; width];
        if array {
            if !rng.random_bool(0.3) {
                for _ in 0..rng.random_range(1..=2) {
                    v[rng.random_range(0..cells)] = rng.random_range(20.0..250.0);
                }
            }
        } else {
            v[0] = rng.random_range(0.0..10.0);
            if rng.random_bool(0.2) {
                v[1] = if rng.random_bool(0.5) { 2.0 } else { -2.0 };
            }
        }
        steps.push((hold, v));
    }
    let columns = if array {
        (0..cells).map(|k| format!("c{k}")).collect()
    } else {
        vec!["force_n".into(), "delta_t_k".into()]
    };
    LoadScript { columns, steps }
}

/// Draw scenario `seed` for `design`: the scenario, its truth and its noise.
fn draw(design: &Design, seed: u64) -> (Scenario, Truth, SynthNoise) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let script = random_script(design, &mut rng);
    let array = design.array.is_some();
    let start_s = rng.random_range(0.0..script.period_s());
    let touch = rng.random_bool(0.5).then(|| {
        let at = start_s + rng.random_range(0.0..1.2);
        let len = rng.random_range(0.05..0.6);
        let mut add = vec![0.0; script.columns.len()];
        if array {
            let cell = rng.random_range(0..add.len());
            add[cell] = rng.random_range(50.0..250.0);
        } else {
            add[0] = rng.random_range(1.0..10.0);
        }
        (at, at + len, add)
    });
    let (noise, noise_word) = match rng.random_range(0..3) {
        0 => (SynthNoise::None, "none"),
        1 => (SynthNoise::Resolution, "resolution"),
        _ => (SynthNoise::Paper, "paper"),
    };
    let drift = if rng.random_bool(0.5) {
        0.0
    } else {
        rng.random_range(-2.0..2.0)
    };
    let loaded = |v: &[f64]| {
        if array {
            v.iter().any(|&x| x > 0.0)
        } else {
            v[0] > 0.0
        }
    };
    let truth = Truth { script, touch };
    let scenario = Scenario {
        kind: if array { "array" } else { "module" },
        seed,
        start_s,
        first_rest_s: match truth.script.steps.first() {
            Some((h, v)) if !loaded(v) => *h,
            _ => 0.0,
        },
        starts_loaded: loaded(&truth.at(start_s)),
        longest_load_s: truth
            .script
            .steps
            .iter()
            .filter(|(_, v)| loaded(v))
            .map(|s| s.0)
            .fold(0.0, f64::max),
        touch: truth.touch.as_ref().map(|(a, b, _)| (a - start_s, b - a)),
        noise: noise_word,
        drift_pm_per_s: drift,
    };
    (scenario, truth, noise)
}

/// How far a reading is from the truth: the worst cell (g) or grating (N); and
/// whether it is shown unflagged.
fn error_of(reading: &Reading, truth: &[f64]) -> (f64, bool) {
    match reading {
        Reading::Loads { loads_g, flags, .. } => (
            loads_g
                .iter()
                .zip(truth)
                .map(|(e, t)| (e - t).abs())
                .fold(0.0, f64::max),
            flags.words().is_empty(),
        ),
        Reading::Forces { forces_n, .. } => (
            forces_n
                .iter()
                .flatten()
                .map(|f| (f - truth[0]).abs())
                .fold(0.0, f64::max),
            true,
        ),
    }
}

/// The three ways of taring.
const POLICIES: [&str; 3] = ["at_rest", "first_50", "oracle"];

/// Read one scenario with one policy.
fn read(
    design: &Design,
    frames: &[(f64, Vec<f64>)],
    truth: &Truth,
    policy: &'static str,
) -> Result<Outcome> {
    let array = design.array.is_some();
    let opts = InterpretOptions {
        tare_frames: if policy == "at_rest" { 50 } else { 0 },
        ..InterpretOptions::default()
    };
    let mut interp = Interpreter::new(design, &opts)?;
    // First 50: the mean of the first 50 frames' peaks is the zero (the rest is the
    // nominal wavelength, which the interpreter without a tare subtracts).
    let rest = &frames_rest(design)?;
    let offset: Vec<f64> = if policy == "first_50" {
        let n = frames.len().min(50);
        (0..rest.len())
            .map(|i| frames[..n].iter().map(|f| f.1[i]).sum::<f64>() / n as f64 - rest[i])
            .collect()
    } else {
        vec![0.0; rest.len()]
    };
    let wrong_at = if array { ARRAY_WRONG_G } else { MODULE_WRONG_N };
    let t0 = frames.first().map_or(0.0, |f| f.0);
    let mut out = Outcome {
        policy,
        shown: 0,
        wrong: 0,
        confidently_wrong: 0,
        first_reading_s: None,
        tare_changes: 0,
    };
    let now = Instant::now();
    for (k, (t, peaks)) in frames.iter().enumerate() {
        if policy == "first_50" && k < 50 {
            // Those frames were the tare: not read.
            continue;
        }
        let frame = Frame {
            serial: Some(k as u64),
            time_s: Some(*t),
            wall_clock: false,
            peaks_nm: peaks.iter().zip(&offset).map(|(p, o)| p - o).collect(),
            received: now,
            origin: String::new(),
        };
        let a = interp.prepare(&frame);
        out.tare_changes += interp.take_tare_changes().len();
        let Ok(p) = a.result else { continue };
        let r = interp.solve(std::slice::from_ref(&p));
        let (err, unflagged) = error_of(&r[0], &truth.at(*t));
        out.shown += 1;
        out.first_reading_s.get_or_insert(t - t0);
        if err > wrong_at {
            out.wrong += 1;
            out.confidently_wrong += u64::from(unflagged && !p.below_tare);
        }
    }
    Ok(out)
}

/// The peaks of the design at rest, in the order the generator sends them.
fn frames_rest(design: &Design) -> Result<Vec<f64>> {
    let mut req = SynthRequest::new(PathBuf::new());
    req.noise = SynthNoise::None;
    req.offset_pm = 0.0;
    let mut script = fbgforge::synth::stream::default_script(design)?;
    for s in &mut script.steps {
        s.1.iter_mut().for_each(|v| *v = 0.0);
    }
    let mut g = Generator::with_script(design, script, &req)?;
    Ok(g.frame(0, 0.0).0.peaks_nm)
}

/// Make the frames of a scenario: (script time s, peaks nm), `run_s` from its start.
fn frames_of(
    design: &Design,
    truth: &Truth,
    noise: SynthNoise,
    s: &Scenario,
    run_s: f64,
) -> Result<Vec<(f64, Vec<f64>)>> {
    let mut req = SynthRequest::new(PathBuf::new());
    req.noise = noise;
    req.offset_pm = 0.0;
    req.seed = s.seed;
    req.rate_hz = RATE_HZ;
    let end = s.start_s + run_s;
    let mut g = Generator::with_script(design, truth.as_script(end + 1.0), &req)?;
    let first = (s.start_s * RATE_HZ).ceil() as u64;
    let last = (end * RATE_HZ) as u64;
    Ok((first..last)
        .map(|k| {
            let t = k as f64 / RATE_HZ;
            let drift_nm = s.drift_pm_per_s * (t - s.start_s) * 1e-3;
            let peaks = g
                .frame(k, t)
                .0
                .peaks_nm
                .iter()
                .map(|p| p + drift_nm)
                .collect();
            (t, peaks)
        })
        .collect())
}

/// One scenario, every policy.
fn run_scenario(design: &Design, seed: u64, run_s: f64) -> Result<(Scenario, Vec<Outcome>)> {
    let (s, truth, noise) = draw(design, seed);
    let frames = frames_of(design, &truth, noise, &s, run_s)?;
    let outcomes = POLICIES
        .iter()
        .map(|p| read(design, &frames, &truth, p))
        .collect::<Result<Vec<_>>>()?;
    Ok((s, outcomes))
}

/// 95 % Wilson interval of k successes in n.
pub fn wilson(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let (k, n, z) = (k as f64, n as f64, 1.96_f64);
    let p = k / n;
    let d = 1.0 + z * z / n;
    let c = (p + z * z / (2.0 * n)) / d;
    let h = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / d;
    ((c - h).max(0.0), (c + h).min(1.0))
}

fn totals(kind: &'static str, rows: &[(Scenario, Vec<Outcome>)]) -> Vec<PolicyTotal> {
    (0..POLICIES.len())
        .map(|p| {
            let of = |r: &(Scenario, Vec<Outcome>)| r.1[p].clone();
            let bad = rows.iter().filter(|r| of(r).confidently_wrong > 0).count();
            let mut first: Vec<f64> = rows.iter().filter_map(|r| of(r).first_reading_s).collect();
            first.sort_by(f64::total_cmp);
            PolicyTotal {
                kind,
                policy: POLICIES[p],
                scenarios: rows.len(),
                scenarios_confidently_wrong: bad,
                share_interval: wilson(bad, rows.len()),
                shown: rows.iter().map(|r| of(r).shown).sum(),
                confidently_wrong: rows.iter().map(|r| of(r).confidently_wrong).sum(),
                median_first_reading_s: first.get(first.len() / 2).copied().unwrap_or(f64::NAN),
            }
        })
        .collect()
}

fn csv_rows(rows: &[(Scenario, Vec<Outcome>)]) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for (s, outcomes) in rows {
        for o in outcomes {
            out.push(vec![
                s.kind.to_string(),
                s.seed.to_string(),
                format!("{:.3}", s.start_s),
                s.starts_loaded.to_string(),
                format!("{:.3}", s.longest_load_s),
                s.touch
                    .map_or(String::new(), |t| format!("{:.3}+{:.3}", t.0, t.1)),
                s.noise.to_string(),
                format!("{:.3}", s.drift_pm_per_s),
                o.policy.to_string(),
                o.shown.to_string(),
                o.wrong.to_string(),
                o.confidently_wrong.to_string(),
                o.first_reading_s
                    .map_or(String::new(), |t| format!("{t:.3}")),
            ]);
        }
    }
    out
}

const HEADER: [&str; 13] = [
    "kind",
    "seed",
    "start_s",
    "starts_loaded",
    "longest_load_s",
    "touch_s",
    "noise",
    "drift_pm_per_s",
    "policy",
    "shown",
    "wrong",
    "confidently_wrong",
    "first_reading_s",
];

/// Run the study: `scenarios.csv`, `summary.json`, and the table on stdout.
pub fn run(a: &LiveStartsArgs) -> Result<()> {
    let t0 = Instant::now();
    let (n, run_s) = if a.quick {
        (4, 3.0)
    } else {
        (a.scenarios, 8.0)
    };
    let mut all = Vec::new();
    let mut totals_all = Vec::new();
    for (kind, path) in [("array", &a.array), ("module", &a.module)] {
        let design = fbgforge::design::load(Path::new(path))?;
        let rows = (0..n as u64)
            .into_par_iter()
            .map(|k| run_scenario(&design, a.seed + k, run_s))
            .collect::<Result<Vec<_>>>()?;
        totals_all.extend(totals(kind, &rows));
        all.extend(rows);
    }
    fbgforge::output::ensure_dir(&a.out)?;
    write_csv(&a.out.join("scenarios.csv"), &HEADER, &csv_rows(&all))?;
    let summary = LiveStartsSummary {
        totals: totals_all,
        array_wrong_g: ARRAY_WRONG_G,
        module_wrong_n: MODULE_WRONG_N,
        elapsed_s: t0.elapsed().as_secs_f64(),
    };
    write_json(&a.out.join("summary.json"), &summary)?;
    println!("live starts: {n} scenarios per design, {run_s} s each; confidently wrong = off by > {ARRAY_WRONG_G} g / {MODULE_WRONG_N} N and shown unflagged");
    println!(
        "{:<7} {:<9} {:>22} {:>9} {:>13} {:>14}",
        "design", "policy", "scenarios conf. wrong", "shown", "conf. wrong", "first read s"
    );
    for t in &summary.totals {
        println!(
            "{:<7} {:<9} {:>4} of {:<4} [{:.2}, {:.2}] {:>9} {:>13} {:>14.2}",
            t.kind,
            t.policy,
            t.scenarios_confidently_wrong,
            t.scenarios,
            t.share_interval.0,
            t.share_interval.1,
            t.shown,
            t.confidently_wrong,
            t.median_first_reading_s
        );
    }
    println!("wrote {}", a.out.display());
    Ok(())
}
