//! The `calibrate` study (issue 34): how often `calibrate-array` hands out a wrong
//! matrix as if it were good, misses a fault, or names one that is not there.
//!
//! Its own generator (no code shared with `fbgforge-synth`): the shifts are made here
//! as Σ_c A[g,c]·L_c(t) on a time grid, each load put on and taken off by hand (a
//! linear press of 0–0.8 s, each edge ± 1 s from the schedule's time), the sheet
//! creeping (0–3 % of each change, τ 0.3–1 s), a common temperature drift of up to
//! ± 0.01 pm/s on every grating, white noise 0.2–1.0 pm, 5–20 Hz. The true matrix is
//! the design's power law scaled by 0.6–1.6 (the cast's modulus) with every entry off
//! by 5 % (log-normal). Cells are loaded in a random order (100–300 g, 6–15 s on,
//! 6–15 s off), or as a staircase on a random cell (20–30 g steps to 200–300 g, 2–4
//! cycles, 4–6 s a step). Scenarios (the cases, drawn wider):
//!
//! * `clean`, `staircase`: nothing wrong; no fault may make the matrix unusable;
//! * `late_clock`: the schedule's clock 2–6 s off (either sign): a warning only;
//! * `swapped`: two random gratings exchanged (`swapped_gratings`);
//! * `drift`: one random grating drifting 3–10 pm over the run (`drift`);
//! * `duplicate`: one cell loaded where the schedule says another (`collinear_cells`,
//!   `unloaded_cell` or `schedule_misaligned` naming the cell never loaded);
//! * `missing_step`: a scheduled loading absent from the data (`schedule_misaligned`
//!   or `unloaded_cell` naming its cell);
//! * `negative`: one entry far from its grating −0.03 to −0.08 pm/g (`negative_entry`
//!   naming it).
//!
//! Counted per scenario: **confidently wrong** = the matrix called usable while an
//! entry is off the truth by more than max(4 sd, 2 % of the largest entry); **missed**
//! = a fault scenario called usable, or its fault not named; **false** = a scenario
//! without a fault given an unusable fault; warnings counted apart.

use anyhow::Result;
use fbgforge::array::calibrate::{
    self, analyse, AnalysisInputs, Calibration, FaultKind, Loading, RunData, Severity,
};
use fbgforge::array::kernel::model_matrix;
use fbgforge::output::{write_csv, write_json};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Seeds of this study start here (apart from every seed a test uses).
const SEED_OFFSET: u64 = 3400;
const RESOLUTION_PM: f64 = 0.5;

/// Arguments of `fbgforge-studies calibrate`.
#[derive(Debug, Clone, clap::Args)]
pub struct CalibrateStudyArgs {
    /// The array design.
    #[arg(long, default_value = "designs/tactile-array-60x80.toml")]
    pub design: PathBuf,
    /// Output folder: `calibrate-study.csv` (one row per run), `calibrate-study.json`.
    #[arg(long, default_value = "out/studies/calibrate")]
    pub out: PathBuf,
    /// Runs per scenario.
    #[arg(long, default_value_t = 40)]
    pub runs: usize,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Smoke form: 3 runs per scenario.
    #[arg(long)]
    pub quick: bool,
}

/// The scenarios, in the table's order.
pub const SCENARIOS: [&str; 8] = [
    "clean",
    "staircase",
    "late_clock",
    "swapped",
    "drift",
    "duplicate",
    "missing_step",
    "negative",
];

/// How one run's sheet and hands behave.
struct Hands {
    rate_hz: f64,
    noise_pm: f64,
    press_s: f64,
    jitter_s: f64,
    creep: f64,
    tau_s: f64,
    temp_pm_per_s: f64,
}

impl Hands {
    fn draw(rng: &mut ChaCha8Rng) -> Self {
        Hands {
            rate_hz: [5.0, 10.0, 20.0][rng.random_range(0..3)],
            noise_pm: rng.random_range(0.2..1.0),
            press_s: rng.random_range(0.0..0.8),
            jitter_s: 1.0,
            creep: rng.random_range(0.0..0.03),
            tau_s: rng.random_range(0.3..1.0),
            temp_pm_per_s: rng.random_range(-0.01..0.01),
        }
    }
    /// Fraction of a change at `t0` present at `t`.
    fn edge(&self, t: f64, t0: f64) -> f64 {
        if t < t0 {
            return 0.0;
        }
        let press = if self.press_s > 0.0 {
            ((t - t0) / self.press_s).min(1.0)
        } else {
            1.0
        };
        press * (1.0 - self.creep * (-(t - t0) / self.tau_s).exp())
    }
}

/// Loads that really happened (each edge moved by the hand) → shifts.
fn shifts(
    truth: &DMatrix<f64>,
    events: &[Loading],
    h: &Hands,
    drift: Option<(usize, f64)>,
    rng: &mut ChaCha8Rng,
) -> RunData {
    let end = events.iter().map(|e| e.end_s).fold(0.0, f64::max) + 10.0;
    let n = (end * h.rate_hz) as usize;
    let time_s: Vec<f64> = (0..n).map(|k| k as f64 / h.rate_hz).collect();
    let normal = rand_distr_normal;
    let mut shifts_pm = vec![Vec::with_capacity(n); truth.nrows()];
    for &t in &time_s {
        let mut load = vec![0.0; truth.ncols()];
        for e in events {
            load[e.cell] += e.load_g * (h.edge(t, e.start_s) - h.edge(t, e.end_s));
        }
        for (g, row) in shifts_pm.iter_mut().enumerate() {
            let mut y: f64 = (0..truth.ncols()).map(|c| truth[(g, c)] * load[c]).sum();
            y += h.temp_pm_per_s * t + h.noise_pm * normal(rng);
            if let Some((dg, pm)) = drift {
                if dg == g {
                    y += pm * t / end;
                }
            }
            row.push(y);
        }
    }
    RunData { time_s, shifts_pm }
}

/// A standard normal draw (Box–Muller).
fn rand_distr_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// The schedule: every cell once in a random order, or a staircase on one cell.
fn schedule(rng: &mut ChaCha8Rng, n_cells: usize, staircase: bool) -> Vec<Loading> {
    let mut out = Vec::new();
    let mut t = 10.0;
    if staircase {
        let cell = rng.random_range(0..n_cells);
        let step = rng.random_range(20.0..30.0f64).round();
        let top = (rng.random_range(200.0..300.0) / step).round() as usize;
        let step_s = rng.random_range(4.0..6.0);
        for _ in 0..rng.random_range(2..=4) {
            for k in (1..=top).chain((1..top).rev()) {
                out.push(Loading {
                    start_s: t,
                    end_s: t + step_s,
                    cell,
                    load_g: step * k as f64,
                });
                t += step_s;
            }
            t += 2.0 * step_s;
        }
        return out;
    }
    let mut order: Vec<usize> = (0..n_cells).collect();
    for i in (1..n_cells).rev() {
        order.swap(i, rng.random_range(0..=i));
    }
    let load_g = rng.random_range(100.0..300.0f64).round();
    for cell in order {
        let on = rng.random_range(6.0..15.0);
        out.push(Loading {
            start_s: t,
            end_s: t + on,
            cell,
            load_g,
        });
        t += on + rng.random_range(6.0..15.0);
    }
    out
}

/// One run's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct RunRow {
    /// Scenario.
    pub scenario: String,
    /// Run index.
    pub run: usize,
    /// The matrix was called usable.
    pub usable: bool,
    /// Largest |measured − true| over the measured entries, in units of max(4 sd, 2 % of
    /// the largest entry).
    pub worst_error_ratio: f64,
    /// Usable but wrong.
    pub confidently_wrong: bool,
    /// A fault scenario whose fault was not named, or was called usable.
    pub missed: bool,
    /// An unusable fault in a scenario without one.
    pub false_fault: bool,
    /// Warnings (severity warning) named.
    pub warnings: usize,
    /// The unusable kinds named, `;`-joined.
    pub kinds: String,
    /// The first unusable fault's reason (empty when none).
    pub first_reason: String,
}

/// What the run's fault must look like to count as named.
struct Expect {
    kinds: Vec<FaultKind>,
    grating: Option<String>,
    cell: Option<String>,
}

/// Make and analyse one run of `scenario`.
fn one_run(
    scenario: &str,
    base: &DMatrix<f64>,
    inputs: &Fixed,
    rng: &mut ChaCha8Rng,
) -> Result<(Calibration, DMatrix<f64>, Option<Expect>)> {
    let (n_g, n_c) = base.shape();
    let scale = rng.random_range(0.6..1.6);
    let mut truth = base.map(|v| v * scale * (0.05 * rand_distr_normal(rng)).exp());
    let h = Hands::draw(rng);
    let sched = schedule(rng, n_c, scenario == "staircase");
    let mut events: Vec<Loading> = sched.clone();
    for e in &mut events {
        e.start_s += rng.random_range(-h.jitter_s..h.jitter_s);
        e.end_s += rng.random_range(-h.jitter_s..h.jitter_s);
    }
    // Contiguous staircase steps share their edges: one hand, one time.
    for k in 1..events.len() {
        if (sched[k].start_s - sched[k - 1].end_s).abs() < 1e-9
            && sched[k].cell == sched[k - 1].cell
        {
            events[k].start_s = events[k - 1].end_s;
        }
    }
    let mut told = sched.clone();
    let mut drift = None;
    let mut expect = None;
    let label = fbgforge::profile::cell_label;
    match scenario {
        "late_clock" => {
            let off = rng.random_range(2.0..6.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            for l in &mut told {
                l.start_s -= off;
                l.end_s -= off;
            }
        }
        "swapped" => {
            let a = rng.random_range(0..n_g);
            let b = (a + rng.random_range(1..n_g)) % n_g;
            truth.swap_rows(a, b);
            expect = Some(Expect {
                kinds: vec![FaultKind::SwappedGratings],
                grating: Some(inputs.gratings[a].clone()),
                cell: None,
            });
        }
        "drift" => {
            let g = rng.random_range(0..n_g);
            drift = Some((
                g,
                rng.random_range(3.0..10.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 },
            ));
            expect = Some(Expect {
                kinds: vec![FaultKind::Drift],
                grating: Some(inputs.gratings[g].clone()),
                cell: None,
            });
        }
        "duplicate" => {
            let k = rng.random_range(1..events.len());
            let never = events[k].cell;
            events[k].cell = events[k - 1].cell;
            expect = Some(Expect {
                kinds: vec![
                    FaultKind::CollinearCells,
                    FaultKind::UnloadedCell,
                    FaultKind::ScheduleMisaligned,
                ],
                grating: None,
                cell: Some(label(never)),
            });
        }
        "missing_step" => {
            let k = rng.random_range(0..events.len());
            let gone = events.remove(k).cell;
            expect = Some(Expect {
                kinds: vec![FaultKind::ScheduleMisaligned, FaultKind::UnloadedCell],
                grating: None,
                cell: Some(label(gone)),
            });
        }
        "negative" => {
            // The entry whose cell is farthest from the grating (the smallest).
            let g = rng.random_range(0..n_g);
            let c = (0..n_c)
                .min_by(|&x, &y| base[(g, x)].total_cmp(&base[(g, y)]))
                .unwrap_or(0);
            truth[(g, c)] = -rng.random_range(0.03..0.08);
            expect = Some(Expect {
                kinds: vec![FaultKind::NegativeEntry],
                grating: Some(inputs.gratings[g].clone()),
                cell: Some(label(c)),
            });
        }
        _ => {}
    }
    let data = shifts(&truth, &events, &h, drift, rng);
    let c = analyse(&AnalysisInputs {
        gratings: &inputs.gratings,
        cells: &inputs.cells,
        data: &data,
        schedule: &told,
        predicted: &inputs.predicted,
        model: &inputs.model,
        resolution_pm: RESOLUTION_PM,
        tolerance: calibrate::compare::DEFAULT_MODEL_TOLERANCE,
    })?;
    Ok((c, truth, expect))
}

/// What every run shares.
struct Fixed {
    gratings: Vec<String>,
    cells: Vec<String>,
    predicted: DMatrix<f64>,
    model: String,
}

/// Judge one run.
fn judge(
    scenario: &str,
    run: usize,
    c: &Calibration,
    truth: &DMatrix<f64>,
    expect: Option<&Expect>,
) -> RunRow {
    let top = truth.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let mut worst: f64 = 0.0;
    for (g, row) in c.matrix_pm_per_g.iter().enumerate() {
        for (k, v) in row.iter().enumerate() {
            if let (Some(v), Some(sd)) = (v, c.matrix_sd_pm_per_g[g][k]) {
                worst = worst.max((v - truth[(g, k)]).abs() / (4.0 * sd).max(0.02 * top));
            }
        }
    }
    let unusable: Vec<&calibrate::Fault> = c
        .faults
        .iter()
        .filter(|f| f.severity == Severity::Unusable)
        .collect();
    let named = expect.is_some_and(|e| {
        c.faults.iter().any(|f| {
            e.kinds.contains(&f.kind)
                && e.grating.as_ref().is_none_or(|g| f.gratings.contains(g))
                && e.cell.as_ref().is_none_or(|x| f.cells.contains(x))
        })
    });
    RunRow {
        scenario: scenario.to_string(),
        run,
        usable: c.usable,
        worst_error_ratio: worst,
        confidently_wrong: c.usable && worst > 1.0,
        missed: expect.is_some() && (c.usable || !named),
        false_fault: expect.is_none() && !unusable.is_empty(),
        warnings: c.faults.len() - unusable.len(),
        kinds: unusable
            .iter()
            .map(|f| f.kind.name())
            .collect::<Vec<_>>()
            .join(";"),
        first_reason: unusable
            .first()
            .map_or_else(String::new, |f| f.reason.clone()),
    }
}

/// One scenario's counts.
#[derive(Debug, Clone, Serialize)]
pub struct ScenarioCounts {
    /// Scenario.
    pub scenario: String,
    /// Runs.
    pub runs: usize,
    /// Usable but wrong.
    pub confidently_wrong: usize,
    /// Fault not named (fault scenarios).
    pub missed: usize,
    /// Unusable fault where there is none.
    pub false_faults: usize,
    /// Runs with at least one warning.
    pub warned: usize,
}

/// Run the study: the table on standard output, the rows and counts in `out`.
pub fn run(a: &CalibrateStudyArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    let base = calibrate::power_law_matrix(&design)?;
    let p = model_matrix(&design, None)?;
    let fixed = Fixed {
        gratings: base.gratings.clone(),
        cells: base.cells.clone(),
        predicted: p.matrix.sensitivity_pm_per_g.clone(),
        model: p.description.clone(),
    };
    let runs = if a.quick { 3 } else { a.runs };
    let mut rows = Vec::new();
    for (s, scenario) in SCENARIOS.iter().enumerate() {
        for r in 0..runs {
            let mut rng =
                ChaCha8Rng::seed_from_u64(SEED_OFFSET + a.seed * 100_000 + (s * 10_000 + r) as u64);
            let (c, truth, expect) =
                one_run(scenario, &base.sensitivity_pm_per_g, &fixed, &mut rng)?;
            rows.push(judge(scenario, r, &c, &truth, expect.as_ref()));
        }
    }
    let counts = summarise(&rows);
    println!("{}", table(&counts));
    write_outputs(&a.out, &rows, &counts)
}

/// Counts per scenario.
pub fn summarise(rows: &[RunRow]) -> Vec<ScenarioCounts> {
    SCENARIOS
        .iter()
        .map(|s| {
            let r: Vec<&RunRow> = rows.iter().filter(|x| x.scenario == *s).collect();
            ScenarioCounts {
                scenario: s.to_string(),
                runs: r.len(),
                confidently_wrong: r.iter().filter(|x| x.confidently_wrong).count(),
                missed: r.iter().filter(|x| x.missed).count(),
                false_faults: r.iter().filter(|x| x.false_fault).count(),
                warned: r.iter().filter(|x| x.warnings > 0).count(),
            }
        })
        .collect()
}

/// The counts as a markdown table.
fn table(counts: &[ScenarioCounts]) -> String {
    let mut t = String::from("| scenario | runs | confidently wrong | missed fault | false fault | warned |\n|---|---|---|---|---|---|\n");
    for c in counts {
        t.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            c.scenario, c.runs, c.confidently_wrong, c.missed, c.false_faults, c.warned
        ));
    }
    t
}

fn write_outputs(out: &Path, rows: &[RunRow], counts: &[ScenarioCounts]) -> Result<()> {
    std::fs::create_dir_all(out)?;
    let header = [
        "scenario",
        "run",
        "usable",
        "worst_error_ratio",
        "confidently_wrong",
        "missed",
        "false_fault",
        "warnings",
        "kinds",
        "first_reason",
    ];
    let body: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.scenario.clone(),
                r.run.to_string(),
                r.usable.to_string(),
                format!("{:.3}", r.worst_error_ratio),
                r.confidently_wrong.to_string(),
                r.missed.to_string(),
                r.false_fault.to_string(),
                r.warnings.to_string(),
                r.kinds.clone(),
                r.first_reason.clone(),
            ]
        })
        .collect();
    write_csv(&out.join("calibrate-study.csv"), &header, &body)?;
    write_json(&out.join("calibrate-study.json"), &counts)
}
