//! The `reconstruct` study's fault part (`-- reconstruct --part faults`): RR, flag
//! recall and false-flag rate of every method when the readings break the model in
//! the ways the paper itself reports (issue 24).
//!
//! Its own generator, on seeds no method was tuned on (the study's `--seed`, default
//! 1, offset by 1000). Two arrays: the paper's 6 × 8 layout (`DistanceKernel::paper`)
//! and a 10 × 20 grid (`fiber_grid_layout(5, 4, 2, 5)`, Table 1's power law with a
//! 3 mm core). Frames: 1–4 loads on distinct random cells, masses 50/100/200 g
//! (≤ ulimit 250 g), 0.5 pm Gaussian interrogator noise, the paper's ± 4 % additivity
//! error (uniform, per grating) whenever two or more loads act. Scenarios:
//!
//! * `clean`: the above; the methods see the true matrix.
//! * `calibration`: the methods see a calibrated matrix, every entry off by 2 %
//!   (Gaussian, relative), and every load is placed up to ± 0.1 mm (uniform, x and
//!   y) off the point its column was calibrated at.
//! * `additivity`: ± 30 % additivity error (uniform, per grating) instead of ± 4 %.
//! * `offset`: a common offset of 1–3 pm (either sign) on every grating of a frame
//!   (a temperature change since the tare).
//! * `dead`: one grating (random per stream) reads noise only.
//! * `all`: the four together.
//!
//! Each stream of frames is reconstructed as `fbgforge reconstruct` does it
//! (`array::reconstruct`: flags, dead-grating check across the stream), with the
//! uncertainty stated as a user would: 0.5 pm resolution, the paper's additivity
//! term, and the matrix's per-entry error at 2 % wherever the scenario calibrates
//! (what `calibrate-array`'s repeat scatter gives), else one 200 g reading per
//! column. Penalties follow the resolution (not tuned). A frame is recovered when
//! its SNR is ≥ 12 dB; flag recall is the share of missed frames carrying a flag,
//! the false-flag rate the share of recovered frames carrying one. `de` is left out
//! (a stochastic search at 1500 generations; too slow for this many frames).

use anyhow::Result;
use fbgforge::array::kernel::{
    fiber_grid_layout, matrix_from_positions, paper_layout, DistanceKernel,
};
use fbgforge::array::methods::{Method, ReadingSettings, DEFAULT_MAX_LOADS};
use fbgforge::array::problem::{SensingProblem, Uncertainty, PAPER_MIN_LOAD_G};
use fbgforge::array::protocol::{snr_db, RECOVERY_THRESHOLD_DB};
use fbgforge::array::reconstruct::{reconstruct, Frames, MethodRequest, DEFAULT_BUDGET_US};
use fbgforge::output::{write_csv, write_json};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::progress::{Progress, Quiet};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

const ULIMIT_G: f64 = 250.0;
const RESOLUTION_PM: f64 = 0.5;
const BASE_ADDITIVITY: f64 = 0.04;
const FAULT_ADDITIVITY: f64 = 0.30;
const CALIBRATION_SD: f64 = 0.02;
const PLACEMENT_MM: f64 = 0.1;
const OFFSET_PM: (f64, f64) = (1.0, 3.0);
/// Seeds of this study start here (apart from every seed a method was tuned on).
const SEED_OFFSET: u64 = 1000;

/// One fault scenario.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Scenario {
    /// Name in the tables.
    pub name: &'static str,
    /// 2 % calibration noise and ± 0.1 mm load placement.
    pub calibration: bool,
    /// ± 30 % additivity error.
    pub additivity: bool,
    /// A common offset of 1–3 pm per frame.
    pub offset: bool,
    /// One dead grating.
    pub dead: bool,
}

/// The scenarios, in table order.
pub const SCENARIOS: [Scenario; 6] = [
    Scenario {
        name: "clean",
        calibration: false,
        additivity: false,
        offset: false,
        dead: false,
    },
    Scenario {
        name: "calibration",
        calibration: true,
        additivity: false,
        offset: false,
        dead: false,
    },
    Scenario {
        name: "additivity",
        calibration: false,
        additivity: true,
        offset: false,
        dead: false,
    },
    Scenario {
        name: "offset",
        calibration: false,
        additivity: false,
        offset: true,
        dead: false,
    },
    Scenario {
        name: "dead",
        calibration: false,
        additivity: false,
        offset: false,
        dead: true,
    },
    Scenario {
        name: "all",
        calibration: true,
        additivity: true,
        offset: true,
        dead: true,
    },
];

/// One row: one method (or the default choice, or a method with the common-mode
/// term) on one array under one scenario, pooled over the streams.
#[derive(Debug, Clone, Serialize)]
pub struct FaultRow {
    /// Array (`6x8 paper`, `10x20 grid`).
    pub array: String,
    /// Scenario name.
    pub scenario: &'static str,
    /// Method (`default → <picked>`, picks of several streams joined by `/`; `+cm`:
    /// with `--common-mode`).
    pub method: String,
    /// Frames.
    pub frames: usize,
    /// RR (SNR ≥ 12 dB), %.
    pub rr_pct: f64,
    /// Mean SNR, dB.
    pub mean_snr_db: f64,
    /// Frames below 12 dB.
    pub missed: usize,
    /// Share of missed frames that carry a flag, % (None: no frame missed).
    pub flag_recall_pct: Option<f64>,
    /// Share of recovered frames that carry a flag, % (None: none recovered).
    pub false_flag_pct: Option<f64>,
    /// Share of frames flagged `inconsistent`, %.
    pub inconsistent_pct: f64,
    /// Share of frames flagged `below_range`, %.
    pub below_range_pct: f64,
    /// Share of frames flagged `ambiguous`, %.
    pub ambiguous_pct: f64,
    /// Streams in which the dead grating was named (dead scenarios), of `streams`.
    pub dead_named: usize,
    /// Gratings named suspect that were not dead, over all streams.
    pub false_suspects: usize,
    /// Streams.
    pub streams: usize,
}

struct Array {
    name: String,
    cells: Vec<(f64, f64)>,
    gratings: Vec<(f64, f64)>,
    kernel: DistanceKernel,
}

fn arrays() -> Vec<Array> {
    let (c, g) = paper_layout();
    let (c2, g2) = fiber_grid_layout(5, 4, 2, 5);
    vec![
        Array {
            name: "6x8 paper".into(),
            cells: c,
            gratings: g,
            kernel: DistanceKernel::paper(),
        },
        Array {
            name: "10x20 grid".into(),
            cells: c2,
            gratings: g2,
            kernel: DistanceKernel::table1_power_law(3.0),
        },
    ]
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    // Box–Muller: one draw.
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// One stream: the matrix the methods see, true loads, shifts, the dead grating.
struct Stream {
    matrix: DMatrix<f64>,
    truth_g: Vec<Vec<f64>>,
    shifts_pm: Vec<Vec<f64>>,
    dead: Option<usize>,
}

fn stream(arr: &Array, sc: &Scenario, per_load: usize, rng: &mut ChaCha8Rng) -> Stream {
    let a_true = matrix_from_positions(&arr.cells, &arr.gratings, &arr.kernel);
    let (m, n) = a_true.shape();
    let matrix = if sc.calibration {
        a_true.map(|v| v * (1.0 + CALIBRATION_SD * normal(rng)))
    } else {
        a_true.clone()
    };
    let dead = sc.dead.then(|| rng.random_range(0..m));
    let mut s = Stream {
        matrix,
        truth_g: Vec::new(),
        shifts_pm: Vec::new(),
        dead,
    };
    for k in 1..=4usize {
        for _ in 0..per_load {
            let (cells, x) = crate::reconstruct_scaling::random_loads(n, k, rng);
            // The columns the loads really act through (placed off their point).
            let cols: Vec<(usize, DMatrix<f64>)> = cells
                .iter()
                .map(|&c| {
                    let mut at = arr.cells[c];
                    if sc.calibration {
                        at.0 += PLACEMENT_MM * rng.random_range(-1.0..=1.0);
                        at.1 += PLACEMENT_MM * rng.random_range(-1.0..=1.0);
                    }
                    (c, matrix_from_positions(&[at], &arr.gratings, &arr.kernel))
                })
                .collect();
            let additivity = if sc.additivity {
                FAULT_ADDITIVITY
            } else {
                BASE_ADDITIVITY
            };
            let offset = if sc.offset {
                let v = rng.random_range(OFFSET_PM.0..=OFFSET_PM.1);
                if rng.random_bool(0.5) {
                    v
                } else {
                    -v
                }
            } else {
                0.0
            };
            let y: Vec<f64> = (0..m)
                .map(|i| {
                    if dead == Some(i) {
                        return RESOLUTION_PM * normal(rng);
                    }
                    let mut r: f64 = cols.iter().map(|(c, col)| col[(i, 0)] * x[*c]).sum();
                    if k >= 2 {
                        r *= 1.0 + additivity * rng.random_range(-1.0..=1.0);
                    }
                    r + offset + RESOLUTION_PM * normal(rng)
                })
                .collect();
            s.truth_g.push(x);
            s.shifts_pm.push(y);
        }
    }
    s
}

/// Per entry, over the streams: SNR per frame, flagged per frame, frames flagged
/// (inconsistent, below_range, ambiguous), streams whose dead grating was named,
/// gratings named that were not dead, the method's name.
type Tally = (Vec<f64>, Vec<bool>, [usize; 3], usize, usize, String);

/// What is run on every stream.
#[derive(Debug, Clone, Copy)]
enum Entry {
    Default,
    Named(Method, bool),
}

impl Entry {
    fn all() -> Vec<Entry> {
        let mut v = vec![Entry::Default];
        for m in Method::ALL {
            if m != Method::De {
                v.push(Entry::Named(m, false));
            }
        }
        v.push(Entry::Named(Method::BranchAndBound, true));
        v
    }
}

fn pct(num: usize, den: usize) -> Option<f64> {
    (den > 0).then(|| 100.0 * num as f64 / den as f64)
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{v:.0}"))
}

/// Run the fault study: tables to `report`, CSV/JSON/SVG to `out`.
pub fn run(
    out: &Path,
    quick: bool,
    seed: u64,
    streams: u64,
    report: &mut String,
) -> Result<Vec<FaultRow>> {
    let per_load = if quick { 6 } else { 50 };
    let streams = if quick { 1 } else { streams.max(1) };
    let entries = Entry::all();
    let arrays = arrays();
    let bar = crate::progress::Bar::with(
        "faults",
        (arrays.len() * SCENARIOS.len() * streams as usize) as u64,
    );
    let mut rows = Vec::new();
    for arr in &arrays {
        for (si, sc) in SCENARIOS.iter().enumerate() {
            let mut acc: Vec<Tally> = entries
                .iter()
                .map(|_| (Vec::new(), Vec::new(), [0; 3], 0, 0, String::new()))
                .collect();
            for r in 0..streams {
                let s_seed = SEED_OFFSET + seed + 97 * r + 1_000_003 * si as u64;
                let mut rng = ChaCha8Rng::seed_from_u64(s_seed);
                let st = stream(arr, sc, per_load, &mut rng);
                for (e, a) in entries.iter().zip(acc.iter_mut()) {
                    tally_stream(*e, sc, &st, a)?;
                }
                bar.advance(1);
            }
            rows.extend(acc.into_iter().map(|t| fault_row(arr, sc, t, streams)));
        }
    }
    bar.end();
    write_fault_files(out, &rows, &arrays)?;
    fault_table(report, &rows, streams, per_load, seed)?;
    Ok(rows)
}

/// Reconstruct one stream with one entry and add what it got to its tally.
fn tally_stream(e: Entry, sc: &Scenario, st: &Stream, a: &mut Tally) -> Result<()> {
    let (m, n) = st.matrix.shape();
    let mut unc = Uncertainty::paper(m, n, RESOLUTION_PM);
    if sc.calibration {
        unc.matrix_sd_pm_per_g = st.matrix.map(|v| v.abs() * CALIBRATION_SD);
    }
    let names: Vec<String> = (1..=m).map(|i| format!("fbg{i}")).collect();
    let mut problem = SensingProblem::new(st.matrix.clone(), ULIMIT_G, true)?
        .with_min_load_g(PAPER_MIN_LOAD_G)?
        .with_uncertainty(unc.clone())?;
    let request = match e {
        Entry::Default => MethodRequest::Default {
            budget_us: DEFAULT_BUDGET_US,
        },
        Entry::Named(method, common_mode) => {
            if common_mode {
                problem = problem.with_common_mode(&vec![1.0; m])?;
            }
            MethodRequest::named(method)
        }
    };
    let prior = ReadingSettings {
        max_loads: DEFAULT_MAX_LOADS,
        resolution_pm: RESOLUTION_PM,
    };
    let frames = Frames {
        gratings: &names,
        shifts_pm: &st.shifts_pm,
    };
    let done = reconstruct(&problem, frames, &prior, &request, &Quiet)?;
    // The default may pick differently per stream: every pick, in order.
    a.5 = match e {
        Entry::Default if a.5.is_empty() => {
            format!("default → {}", done.setup.method.name())
        }
        Entry::Default => {
            let name = done.setup.method.name();
            let picks = a.5.trim_start_matches("default → ");
            if picks.split('/').any(|p| p == name) {
                a.5.clone()
            } else {
                format!("{}/{name}", a.5)
            }
        }
        Entry::Named(method, true) => format!("{} +cm", method.name()),
        Entry::Named(method, false) => method.name().to_string(),
    };
    for (x0, rec) in st.truth_g.iter().zip(&done.frames) {
        a.0.push(snr_db(x0, &rec.loads_g));
        a.1.push(!rec.flags.trusted());
        a.2[0] += usize::from(rec.flags.inconsistent);
        a.2[1] += usize::from(rec.flags.below_range);
        a.2[2] += usize::from(rec.flags.ambiguous);
    }
    let named: Vec<usize> = done.suspect_gratings.iter().map(|g| g.index).collect();
    a.3 += usize::from(st.dead.is_some_and(|d| named.contains(&d)));
    a.4 += named.iter().filter(|&&i| Some(i) != st.dead).count();
    Ok(())
}

/// One entry's row over a scenario's streams: RR, mean SNR, flag recall, false flags,
/// the flags by kind and the dead gratings named.
fn fault_row(arr: &Array, sc: &Scenario, t: Tally, streams: u64) -> FaultRow {
    let (snrs, flagged, kinds, dead_named, false_suspects, method) = t;
    let frames = snrs.len();
    let ok: Vec<bool> = snrs.iter().map(|&s| s >= RECOVERY_THRESHOLD_DB).collect();
    let missed = ok.iter().filter(|o| !**o).count();
    let missed_flagged = ok.iter().zip(&flagged).filter(|(o, f)| !**o && **f).count();
    let ok_flagged = ok.iter().zip(&flagged).filter(|(o, f)| **o && **f).count();
    FaultRow {
        array: arr.name.clone(),
        scenario: sc.name,
        method,
        frames,
        rr_pct: pct(frames - missed, frames).unwrap_or(0.0),
        mean_snr_db: snrs.iter().sum::<f64>() / frames.max(1) as f64,
        missed,
        flag_recall_pct: pct(missed_flagged, missed),
        false_flag_pct: pct(ok_flagged, frames - missed),
        inconsistent_pct: pct(kinds[0], frames).unwrap_or(0.0),
        below_range_pct: pct(kinds[1], frames).unwrap_or(0.0),
        ambiguous_pct: pct(kinds[2], frames).unwrap_or(0.0),
        dead_named,
        false_suspects,
        streams: streams as usize,
    }
}

/// `faults.csv`, `faults.json` and one chart per array (RR and flag recall per
/// scenario and method).
fn write_fault_files(out: &Path, rows: &[FaultRow], arrays: &[Array]) -> Result<()> {
    let header = [
        "array",
        "scenario",
        "method",
        "frames",
        "rr_pct",
        "mean_snr_db",
        "missed",
        "flag_recall_pct",
        "false_flag_pct",
        "inconsistent_pct",
        "below_range_pct",
        "ambiguous_pct",
        "dead_named",
        "false_suspects",
        "streams",
    ];
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.2}"));
    let csv_rows: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.array.clone(),
                r.scenario.to_string(),
                r.method.clone(),
                r.frames.to_string(),
                format!("{:.2}", r.rr_pct),
                format!("{:.2}", r.mean_snr_db),
                r.missed.to_string(),
                opt(r.flag_recall_pct),
                opt(r.false_flag_pct),
                format!("{:.2}", r.inconsistent_pct),
                format!("{:.2}", r.below_range_pct),
                format!("{:.2}", r.ambiguous_pct),
                r.dead_named.to_string(),
                r.false_suspects.to_string(),
                r.streams.to_string(),
            ]
        })
        .collect();
    write_csv(&out.join("faults.csv"), &header, &csv_rows)?;
    write_json(&out.join("faults.json"), &rows)?;
    for arr in arrays {
        let mut chart = Chart::new(
            format!("RR and flag recall under faults, {}", arr.name),
            "scenario (0 clean, 1 calibration, 2 additivity, 3 offset, 4 dead, 5 all)",
            "%",
        );
        let mut methods: Vec<String> = Vec::new();
        for r in rows.iter().filter(|r| r.array == arr.name) {
            if !methods.contains(&r.method) {
                methods.push(r.method.clone());
            }
        }
        for name in &methods {
            let pts = |f: &dyn Fn(&FaultRow) -> Option<f64>| -> Vec<(f64, f64)> {
                SCENARIOS
                    .iter()
                    .enumerate()
                    .filter_map(|(i, sc)| {
                        rows.iter()
                            .find(|r| {
                                r.array == arr.name && &r.method == name && r.scenario == sc.name
                            })
                            .and_then(f)
                            .map(|v| (i as f64, v))
                    })
                    .collect()
            };
            chart = chart.with(Series::new(
                format!("{name} RR"),
                pts(&|r| Some(r.rr_pct)),
                Mark::LinePoints,
            ));
            chart = chart.with(Series::new(
                format!("{name} recall"),
                pts(&|r| r.flag_recall_pct),
                Mark::Points,
            ));
        }
        let file = format!(
            "faults-{}.svg",
            arr.name.split(' ').next().unwrap_or("array")
        );
        chart.write_svg(&out.join(file))?;
    }
    Ok(())
}

/// The fault table of the report.
fn fault_table(
    report: &mut String,
    rows: &[FaultRow],
    streams: u64,
    per_load: usize,
    seed: u64,
) -> Result<()> {
    writeln!(
        report,
        "## Faults: RR, flag recall and false-flag rate ({} stream(s) × {} frames per scenario, seeds from {})\n",
        streams,
        4 * per_load,
        SEED_OFFSET + seed
    )?;
    writeln!(
        report,
        "Recall: flagged among frames below 12 dB; false flags: flagged among frames at or above it. `+cm`: with `--common-mode`. Dead: streams whose dead grating was named, of {streams}.\n"
    )?;
    writeln!(
        report,
        "| array | scenario | method | RR % | mean SNR dB | missed | flag recall % | false flags % | inconsistent % | below_range % | ambiguous % | dead named | false suspects |"
    )?;
    writeln!(
        report,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    )?;
    for r in rows {
        writeln!(
            report,
            "| {} | {} | {} | {:.1} | {:.1} | {} | {} | {} | {:.0} | {:.0} | {:.0} | {} | {} |",
            r.array,
            r.scenario,
            r.method,
            r.rr_pct,
            r.mean_snr_db,
            r.missed,
            fmt_opt(r.flag_recall_pct),
            fmt_opt(r.false_flag_pct),
            r.inconsistent_pct,
            r.below_range_pct,
            r.ambiguous_pct,
            if r.scenario == "dead" || r.scenario == "all" {
                format!("{}/{}", r.dead_named, r.streams)
            } else {
                "–".into()
            },
            r.false_suspects
        )?;
    }
    writeln!(report)?;
    Ok(())
}
