//! Study `reconstruct` (`cargo run --release -p fbgforge-studies -- reconstruct`): the additivity errors of the noise models, the
//! paper's protocol for every method, speed against accuracy, stream throughput, and
//! the failure studies (noise level, noise model — the default against the pessimistic
//! full-span hysteresis —, number of loads, ill-conditioned layouts, column
//! normalisation). Prints tables; writes CSV, JSON, SVG and a Markdown report of the
//! same numbers.

use anyhow::Result;
use fbgforge::array::kernel::{
    fit_paper, fit_power_law, matrix_from_positions, matrix_quality, paper_layout, DistanceKernel,
    TABLE1,
};
use fbgforge::array::methods::{reconstruct_stream, Method, MethodSettings, DEFAULT_METHOD};
use fbgforge::array::problem::SensingProblem;
use fbgforge::array::protocol::{
    run_protocol, summarise, test_cases, CaseResult, NoiseModel, ProtocolConfig, Summary,
    PAPER_TABLE3,
};
use fbgforge::output::{write_atomic, write_csv, write_json};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::progress::Progress;
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of the `reconstruct` study.
#[derive(Debug, Clone, clap::Args)]
pub struct BenchOptions {
    /// Output folder for the tables and charts.
    #[arg(long, default_value = "out/bench-reconstruct")]
    pub out: PathBuf,
    /// Array design whose model matrix plays the true array (default: the paper layout).
    #[arg(long)]
    pub design: Option<PathBuf>,
    /// First seed; the protocol is repeated for `repeats` consecutive seeds.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Independent repetitions of the 84-test protocol (pooled in the tables; the
    /// failure studies use the first five). `--quick` runs one.
    #[arg(long, default_value_t = 20)]
    pub repeats: u64,
    /// Quick run: one repetition, DE limited to 300 generations, coarser sweeps, two
    /// frames per load count in the scaling part.
    #[arg(long)]
    pub quick: bool,
    /// Which part to run: the paper's protocol and failure studies, the scaling
    /// study (6 × 8 to 32 × 256 cells), both, or the fault study alone.
    #[arg(long, value_enum, default_value_t = Part::All)]
    pub part: Part,
    /// Per-frame budget of the default method choice in the scaling part, µs
    /// (default 100).
    #[arg(long)]
    pub budget_us: Option<f64>,
}

/// Parts of the `reconstruct` study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Part {
    /// Protocol, speed, throughput, failure studies, then scaling.
    All,
    /// The paper's protocol, speed against accuracy, throughput, failure studies.
    Protocol,
    /// Time per frame and RR per method against the array's size.
    Scaling,
    /// RR, flag recall and false-flag rate per method under the paper's faults
    /// (calibration noise and placement, additivity, temperature offset, a dead
    /// grating).
    Faults,
    /// Issue 35's flag study: RR, recall and false flags per method under fourteen
    /// scenarios on three arrays, the stream diagnosis judged, and the ROC of the
    /// frame test's significance.
    Flags,
    /// Issue 35's budget comparison: at 16 × 64, the default within its budget
    /// against `bnb` run to its certified optimum, per load count.
    Budget,
}

/// Streams per array and scenario of the flag part (at most; `--repeats` lowers it).
pub const FLAG_STREAMS: u64 = 4;

/// Streams per scenario of the fault part (at most; `--repeats` lowers it).
pub const FAULT_STREAMS: u64 = 3;

/// RR below which a method counts as broken down, %.
pub const BREAKDOWN_RR_PCT: f64 = 50.0;

/// Pooled protocol result of one method.
#[derive(Debug, Clone, Serialize)]
pub struct PooledRun {
    /// Method name (with a note when the penalty was not tuned).
    pub method: String,
    /// Penalty per repetition.
    pub penalties: Vec<f64>,
    /// Per load count.
    pub by_load_count: Vec<Summary>,
    /// Over all tests.
    pub overall: Summary,
}

fn base_config(opts: &BenchOptions, seed: u64) -> ProtocolConfig {
    let mut cfg = ProtocolConfig::paper(seed);
    if opts.quick {
        cfg.de_generations = 300;
    }
    cfg
}

/// Run the protocol for `repeats` seeds and pool the tests.
pub fn pooled(true_a: &DMatrix<f64>, method: Method, cfgs: &[ProtocolConfig]) -> Result<PooledRun> {
    let mut cases: Vec<CaseResult> = Vec::new();
    let mut penalties = Vec::new();
    for cfg in cfgs {
        let r = run_protocol(true_a, method, cfg)?;
        penalties.push(r.penalty);
        cases.extend(r.cases);
    }
    let mut ks: Vec<usize> = cases.iter().map(|c| c.n_loads).collect();
    ks.sort_unstable();
    ks.dedup();
    Ok(PooledRun {
        method: method.name().to_string(),
        penalties,
        by_load_count: ks.iter().map(|&k| summarise(&cases, k)).collect(),
        overall: summarise(&cases, 0),
    })
}

fn f(v: f64, d: usize) -> String {
    format!("{v:.d$}")
}

/// Run the whole benchmark: the fault or scaling part alone, or the protocol part
/// (kernel fit, additivity, protocol, speed against accuracy, throughput, failure
/// studies) followed, for `--part all`, by the scaling part.
pub fn run(opts: &BenchOptions) -> Result<()> {
    let opts = &BenchOptions {
        repeats: if opts.quick { 1 } else { opts.repeats.max(1) },
        ..opts.clone()
    };
    fbgforge::output::ensure_dir(&opts.out)?;
    let mut report = match opts.part {
        Part::Faults => {
            let mut report = String::from("# fbgforge-studies reconstruct --part faults\n\n");
            crate::reconstruct_faults::run(
                &opts.out,
                opts.quick,
                opts.seed,
                opts.repeats.min(FAULT_STREAMS),
                &mut report,
            )?;
            report
        }
        Part::Flags => {
            let mut report = String::from("# fbgforge-studies reconstruct --part flags\n\n");
            crate::reconstruct_flags::run(
                &opts.out,
                opts.quick,
                opts.seed,
                opts.repeats.min(FLAG_STREAMS),
                &mut report,
            )?;
            report
        }
        Part::Budget => {
            let mut report = String::from("# fbgforge-studies reconstruct --part budget\n\n");
            crate::reconstruct_budget::run(&opts.out, opts.quick, opts.seed, &mut report)?;
            report
        }
        Part::Scaling => {
            let mut report = String::from("# fbgforge-studies reconstruct --part scaling\n");
            crate::reconstruct_scaling::run(
                &opts.out,
                opts.quick,
                opts.seed,
                opts.budget_us,
                &mut report,
            )?;
            report
        }
        Part::All | Part::Protocol => protocol_part(opts)?,
    };
    if opts.part == Part::All {
        crate::reconstruct_scaling::run(
            &opts.out,
            opts.quick,
            opts.seed,
            opts.budget_us,
            &mut report,
        )?;
    }
    write_atomic(&opts.out.join("report.md"), report.as_bytes())?;
    println!("{report}");
    println!("written to {}", opts.out.display());
    Ok(())
}

/// The true array: a design's model matrix, or the paper layout's; and its name.
fn true_matrix(opts: &BenchOptions) -> Result<(DMatrix<f64>, String)> {
    Ok(match &opts.design {
        Some(p) => {
            let d = fbgforge::design::load(p)?;
            (
                fbgforge::array::kernel::matrix_from_design(&d)?
                    .0
                    .sensitivity_pm_per_g,
                d.name.clone(),
            )
        }
        None => {
            let (c, g) = paper_layout();
            (
                matrix_from_positions(&c, &g, &DistanceKernel::paper()),
                "paper layout".to_string(),
            )
        }
    })
}

/// The protocol part: kernel fit, additivity, the protocol per method, speed against
/// accuracy, stream throughput and the failure studies; the report so far.
fn protocol_part(opts: &BenchOptions) -> Result<String> {
    let (true_a, layout_name) = true_matrix(opts)?;
    let mut report = String::new();
    writeln!(report, "# fbgforge-studies reconstruct\n")?;
    writeln!(
        report,
        "True array: model matrix of the {layout_name}; seeds {}..{} ({} repetition(s) of the 84-test protocol, pooled){}.\n",
        opts.seed,
        opts.seed + opts.repeats - 1,
        opts.repeats,
        if opts.quick { "; QUICK run (DE ≤ 300 generations)" } else { "" }
    )?;
    kernel_fit_section(opts, &mut report)?;
    additivity_section(opts, &true_a, &mut report)?;
    let (cfgs, runs) = protocol_runs(opts, &true_a)?;
    protocol_section(opts, &runs, &mut report)?;
    speed_accuracy_section(opts, &runs)?;
    throughput_section(opts, &true_a, &cfgs, &mut report)?;
    // The failure studies rerun every method many times: five seeds are enough there.
    let studies = failure_studies(&true_a, opts, &cfgs[..cfgs.len().min(5)], &mut report)?;
    write_json(&opts.out.join("failure.json"), &studies)?;
    writeln!(
        report,
        "\nMost accurate method (protocol default): `{}`.",
        DEFAULT_METHOD.name()
    )?;
    Ok(report)
}

/// The kernel fitted to Table 1 (bare power law and regularised), with its residuals.
fn kernel_fit_section(opts: &BenchOptions, report: &mut String) -> Result<()> {
    let bare = fit_power_law(&TABLE1)?;
    let reg = fit_paper();
    let mut rows = Vec::new();
    writeln!(report, "## Kernel fit (Table 1, Table 2)\n")?;
    writeln!(
        report,
        "Bare power law: c = {:.2} pm·mm^n/g, n = {:.3}, rms log residual {:.3}. Regularised (with Table 2 at d = 0): c = {:.1}, n = {:.3}, d0 = {:.2} mm, rms log residual {:.3}.\n",
        bare.kernel.scale_pm_mm_n_per_g, bare.kernel.exponent, bare.rms_log_residual,
        reg.kernel.scale_pm_mm_n_per_g, reg.kernel.exponent, reg.kernel.core_radius_mm, reg.rms_log_residual
    )?;
    writeln!(report, "| d mm | measured pm/g | power law pm/g | error % | regularised pm/g | error % |\n|---|---|---|---|---|---|")?;
    for (k, r) in reg.residuals.iter().enumerate() {
        let b = bare.residuals.get(k);
        writeln!(
            report,
            "| {:.2} | {:.4} | {} | {} | {:.4} | {:+.1} |",
            r.distance_mm,
            r.measured_pm_per_g,
            b.map_or("–".into(), |b| f(b.fitted_pm_per_g, 4)),
            b.map_or("–".into(), |b| format!("{:+.1}", b.relative_error_pct)),
            r.fitted_pm_per_g,
            r.relative_error_pct
        )?;
        rows.push(vec![
            f(r.distance_mm, 2),
            f(r.measured_pm_per_g, 4),
            b.map_or(String::new(), |b| f(b.fitted_pm_per_g, 5)),
            f(r.fitted_pm_per_g, 5),
        ]);
    }
    write_csv(
        &opts.out.join("kernel_fit.csv"),
        &[
            "distance_mm",
            "measured_pm_per_g",
            "power_law_pm_per_g",
            "regularised_pm_per_g",
        ],
        &rows,
    )?;
    write_json(&opts.out.join("kernel_fit.json"), &(&bare, &reg))?;
    Ok(())
}

/// The additivity errors of the noise models against the paper's.
fn additivity_section(
    opts: &BenchOptions,
    true_a: &DMatrix<f64>,
    report: &mut String,
) -> Result<()> {
    let default_noise = base_config(opts, opts.seed).noise;
    let models = [
        ("proportional (default)", default_noise),
        (
            "proportional, no additivity term",
            NoiseModel {
                additivity_frac: 0.0,
                ..default_noise
            },
        ),
        ("full span (previous, pessimistic)", NoiseModel::full_span()),
    ];
    writeln!(
        report,
        "\n## Additivity errors of the noise models\n\nPaper's tests (cells B+G, E+F, A+D+H, 100 g each), single readings summed against the simultaneous reading, 300 simulated repetitions. Largest relative error per test near gratings (≥ 50 % of the largest reading) and far: median and 95th percentile over tests; worst = median over repetitions of the largest error over all three tests, the statistic comparable to the paper's \"up to 31.5 % near, 92 % far\".\n\n| noise model | near median % | near p95 % | near worst % | far median % | far p95 % | far worst % |\n|---|---|---|---|---|---|---|"
    )?;
    let mut add = Vec::new();
    for (name, noise) in models {
        let a = additivity_check(true_a, &noise, opts.seed);
        writeln!(
            report,
            "| {name} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            a.near_median_pct,
            a.near_p95_pct,
            a.near_worst_median_pct,
            a.far_median_pct,
            a.far_p95_pct,
            a.far_worst_median_pct
        )?;
        add.push((name, a));
    }
    writeln!(report, "| paper | | | 31.5 | | | 92 |")?;
    write_json(&opts.out.join("additivity.json"), &add)?;
    Ok(())
}

/// The 84-test protocol for every method, pooled over the seeds, and the default
/// method with its fixed penalty; the configurations used.
fn protocol_runs(
    opts: &BenchOptions,
    true_a: &DMatrix<f64>,
) -> Result<(Vec<ProtocolConfig>, Vec<PooledRun>)> {
    let cfgs: Vec<ProtocolConfig> = (0..opts.repeats)
        .map(|r| base_config(opts, opts.seed + r))
        .collect();
    let bar = crate::progress::Bar::with("protocol", Method::ALL.len() as u64);
    let mut runs = Vec::new();
    for m in Method::ALL {
        runs.push(pooled(true_a, m, &cfgs)?);
        bar.advance(1);
    }
    // What `fbgforge reconstruct` delivers: the default method with its fixed default
    // penalty, no per-run tuning on the 22 validation cases.
    let fixed: Vec<ProtocolConfig> = cfgs
        .iter()
        .map(|c| ProtocolConfig {
            tune_penalty: false,
            ..c.clone()
        })
        .collect();
    let mut default_run = pooled(true_a, DEFAULT_METHOD, &fixed)?;
    default_run.method = format!("{} (fixed default penalty)", DEFAULT_METHOD.name());
    runs.push(default_run);
    bar.end();
    Ok((cfgs, runs))
}

/// The protocol's table beside the paper's Table 3, its CSV and JSON, the penalties.
fn protocol_section(opts: &BenchOptions, runs: &[PooledRun], report: &mut String) -> Result<()> {
    writeln!(report, "\n## Protocol (Table 3 side by side)\n")?;
    writeln!(report, "| method | loads | SNR dB | SEM dB | error % | RR % | µs/frame mean | µs/frame median | not converged |\n|---|---|---|---|---|---|---|---|---|")?;
    let mut rows = Vec::new();
    for p in PAPER_TABLE3 {
        writeln!(
            report,
            "| paper (DE) | {} | {:.2} | {:.2} | {:.2} | {:.0} | < 1 s | | – |",
            p.n_loads, p.snr_db, p.sem_db, p.error_pct, p.rr_pct
        )?;
    }
    for r in runs {
        for s in r.by_load_count.iter().chain(std::iter::once(&r.overall)) {
            let k = if s.n_loads == 0 {
                "all".to_string()
            } else {
                s.n_loads.to_string()
            };
            writeln!(
                report,
                "| {} | {} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} | {:.1} | {} |",
                r.method,
                k,
                s.mean_snr_db,
                s.sem_snr_db,
                s.rel_error_pct,
                s.rr_pct,
                s.time_per_frame_us,
                s.median_time_per_frame_us,
                s.not_converged
            )?;
            rows.push(vec![
                r.method.to_string(),
                k,
                f(s.mean_snr_db, 3),
                f(s.sem_snr_db, 3),
                f(s.rel_error_pct, 3),
                f(s.rr_pct, 1),
                f(s.time_per_frame_us, 2),
                f(s.median_time_per_frame_us, 2),
                s.not_converged.to_string(),
                s.tests.to_string(),
            ]);
        }
    }
    for p in PAPER_TABLE3 {
        rows.push(vec![
            "paper".into(),
            p.n_loads.to_string(),
            f(p.snr_db, 3),
            f(p.sem_db, 3),
            f(p.error_pct, 3),
            f(p.rr_pct, 1),
            String::new(),
            String::new(),
            String::new(),
            if p.n_loads == 1 {
                "24".into()
            } else {
                "20".into()
            },
        ]);
    }
    write_csv(
        &opts.out.join("protocol.csv"),
        &[
            "method",
            "loads",
            "snr_db",
            "sem_db",
            "rel_error_pct",
            "rr_pct",
            "time_per_frame_us",
            "median_time_per_frame_us",
            "not_converged",
            "tests",
        ],
        &rows,
    )?;
    write_json(&opts.out.join("protocol.json"), &runs)?;
    let penalties: Vec<String> = runs
        .iter()
        .map(|r| format!("{} {:?}", r.method, r.penalties))
        .collect();
    writeln!(
        report,
        "\nTuned penalties per repetition: {}.\n",
        penalties.join("; ")
    )?;
    Ok(())
}

/// Time per frame against accuracy: the chart and its CSV.
fn speed_accuracy_section(opts: &BenchOptions, runs: &[PooledRun]) -> Result<()> {
    let paper_mean = (24.0 * PAPER_TABLE3[0].snr_db
        + 20.0 * (PAPER_TABLE3[1].snr_db + PAPER_TABLE3[2].snr_db + PAPER_TABLE3[3].snr_db))
        / 84.0;
    let mut chart = Chart::new(
        "Reconstruction: time per frame against accuracy (paper protocol)",
        "median time per frame, µs (one thread)",
        "mean SNR over 84 tests, dB",
    );
    chart.x_log = true;
    let mut rows = Vec::new();
    for r in runs {
        chart = chart.with(Series::new(
            r.method.clone(),
            vec![(
                r.overall.median_time_per_frame_us.max(1e-3),
                r.overall.mean_snr_db,
            )],
            Mark::Points,
        ));
        rows.push(vec![
            r.method.to_string(),
            f(r.overall.median_time_per_frame_us, 3),
            f(r.overall.mean_snr_db, 3),
            f(r.overall.rr_pct, 1),
        ]);
    }
    chart = chart.with(Series::new(
        "paper DE (< 1 s)",
        vec![(1e6, paper_mean)],
        Mark::Points,
    ));
    rows.push(vec![
        "paper".into(),
        "1000000".into(),
        f(paper_mean, 3),
        f(100.0 * 82.0 / 84.0, 1),
    ]);
    chart.write_svg(&opts.out.join("speed_accuracy.svg"))?;
    write_csv(
        &opts.out.join("speed_accuracy.csv"),
        &[
            "method",
            "median_time_per_frame_us",
            "mean_snr_db",
            "rr_pct",
        ],
        &rows,
    )?;
    Ok(())
}

/// Frames per second of every method (DE left out) on a stream of the protocol's
/// frames.
fn throughput_section(
    opts: &BenchOptions,
    true_a: &DMatrix<f64>,
    cfgs: &[ProtocolConfig],
    report: &mut String,
) -> Result<()> {
    let frames_n = if opts.quick { 20_000 } else { 200_000 };
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let cases = test_cases(true_a, &cfgs[0], &mut rng);
    let frames: Vec<Vec<f64>> = (0..frames_n)
        .map(|k| cases[k % cases.len()].shifts_pm.clone())
        .collect();
    let measured = cfgs[0].noise.calibrate(true_a, &mut rng);
    let problem = SensingProblem::new(measured, cfgs[0].ulimit_g, true)?
        .with_min_load_g(cfgs[0].min_load_g)?;
    let mut tp_rows = Vec::new();
    writeln!(
        report,
        "## Stream throughput ({frames_n} frames, `reconstruct_stream`, {} rayon threads)\n",
        rayon::current_num_threads()
    )?;
    writeln!(report, "| method | frames/s | µs/frame |\n|---|---|---|")?;
    for m in Method::ALL {
        if m == Method::De {
            continue; // milliseconds per frame: a stream benchmark would take minutes
        }
        let t0 = Instant::now();
        let res = reconstruct_stream(&problem, &MethodSettings::for_method(m), &frames)?;
        let dt = t0.elapsed().as_secs_f64();
        let fps = res.len() as f64 / dt;
        writeln!(report, "| {} | {:.0} | {:.2} |", m.name(), fps, 1e6 / fps)?;
        tp_rows.push(vec![m.name().to_string(), f(fps, 0), f(1e6 / fps, 3)]);
    }
    write_csv(
        &opts.out.join("throughput.csv"),
        &["method", "frames_per_s", "us_per_frame"],
        &tp_rows,
    )?;
    Ok(())
}

/// One point of a sweep.
#[derive(Debug, Clone, Serialize)]
pub struct SweepPoint {
    /// Method name.
    pub method: &'static str,
    /// Study name.
    pub study: String,
    /// Swept value (noise factor, number of loads, layout index, normalised 0/1).
    pub value: f64,
    /// Label of the swept value.
    pub label: String,
    /// Mean SNR, dB.
    pub mean_snr_db: f64,
    /// RR, %.
    pub rr_pct: f64,
    /// Tests without convergence.
    pub not_converged: usize,
}

/// Where each method breaks down.
#[derive(Debug, Clone, Serialize)]
pub struct Breakdown {
    /// Method name.
    pub method: &'static str,
    /// Smallest noise factor with RR < 50 % (None: never in the sweep).
    pub noise_factor: Option<f64>,
    /// Smallest number of loads with RR < 50 %.
    pub loads: Option<usize>,
    /// Layouts with RR < 50 %.
    pub layouts: Vec<String>,
}

/// All failure studies.
#[derive(Debug, Clone, Serialize)]
pub struct FailureStudies {
    /// Every sweep point.
    pub points: Vec<SweepPoint>,
    /// Breakdown per method.
    pub breakdown: Vec<Breakdown>,
    /// Quality proxies per layout: (name, coherence, condition, column norm ratio).
    pub layouts: Vec<(String, f64, f64, f64)>,
}

/// What the failure studies sweep: noise factors, layouts (collinear, shifted) and
/// noise models.
struct FailureSweeps {
    noise_factors: Vec<f64>,
    cells: Vec<(f64, f64)>,
    layouts: Vec<(String, Vec<(f64, f64)>)>,
    kernel: DistanceKernel,
    noise_models: [(&'static str, NoiseModel); 4],
}

/// The sweeps of the failure studies (coarser with `--quick`).
fn failure_sweeps(opts: &BenchOptions, cfgs: &[ProtocolConfig]) -> FailureSweeps {
    let noise_factors: Vec<f64> = if opts.quick {
        vec![0.0, 1.0, 2.0, 4.0]
    } else {
        vec![0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0]
    };
    let (cells, gratings) = paper_layout();
    let mut layouts: Vec<(String, Vec<(f64, f64)>)> = vec![("paper".into(), gratings.clone())];
    for eps in [6.0, 3.0, 1.0, 0.0] {
        layouts.push((
            format!("collinear ±{eps} mm"),
            gratings
                .iter()
                .map(|&(x, y)| (x, y.signum() * eps))
                .collect(),
        ));
    }
    for dx in [10.0, 20.0, 30.0] {
        layouts.push((
            format!("shifted +{dx} mm"),
            gratings.iter().map(|&(x, y)| (x + dx, y)).collect(),
        ));
    }
    let kernel = DistanceKernel::paper();
    let noise_models = [
        ("proportional (default)", cfgs[0].noise),
        (
            "proportional, no additivity term",
            NoiseModel {
                additivity_frac: 0.0,
                ..cfgs[0].noise
            },
        ),
        (
            "proportional, no linearity, no additivity",
            NoiseModel {
                additivity_frac: 0.0,
                linearity_frac: 0.0,
                ..cfgs[0].noise
            },
        ),
        ("full span (previous)", NoiseModel::full_span()),
    ];
    FailureSweeps {
        noise_factors,
        cells,
        layouts,
        kernel,
        noise_models,
    }
}

fn failure_studies(
    true_a: &DMatrix<f64>,
    opts: &BenchOptions,
    cfgs: &[ProtocolConfig],
    report: &mut String,
) -> Result<FailureStudies> {
    let sw = failure_sweeps(opts, cfgs);
    let total = Method::ALL.len()
        * (sw.noise_factors.len() + 1 + sw.layouts.len() + 2 + sw.noise_models.len());
    let bar = crate::progress::Bar::with("failure", total as u64);
    let mut points = Vec::new();
    let mut breakdown = Vec::new();
    for m in Method::ALL {
        let mut bd = Breakdown {
            method: m.name(),
            noise_factor: None,
            loads: None,
            layouts: Vec::new(),
        };
        let mut at = SweepAt {
            true_a,
            m,
            cfgs,
            bar: &bar,
            points: &mut points,
        };
        sweep_noise(&mut at, &sw, &mut bd)?;
        sweep_noise_models(&mut at, &sw)?;
        sweep_loads(&mut at, &mut bd)?;
        sweep_layouts(&mut at, &sw, &mut bd)?;
        sweep_normalisation(&mut at)?;
        breakdown.push(bd);
    }
    bar.end();
    let (cells, kernel) = (&sw.cells, &sw.kernel);
    let layout_quality: Vec<(String, f64, f64, f64)> = sw
        .layouts
        .iter()
        .map(|(name, g)| {
            let q = matrix_quality(&matrix_from_positions(cells, g, kernel));
            (
                name.clone(),
                q.mutual_coherence,
                q.condition_number,
                q.column_norm_ratio,
            )
        })
        .collect();
    failure_charts(opts, &points)?;
    failure_tables(report, &points, &sw, &layout_quality, &breakdown)?;
    Ok(FailureStudies {
        points,
        breakdown,
        layouts: layout_quality,
    })
}

/// One method's sweeps: the true matrix, the method, the base configurations, the
/// progress bar and where the points go.
struct SweepAt<'a> {
    true_a: &'a DMatrix<f64>,
    m: Method,
    cfgs: &'a [ProtocolConfig],
    bar: &'a crate::progress::Bar,
    points: &'a mut Vec<SweepPoint>,
}

/// Noise × the paper's model: the first factor with RR below the breakdown.
fn sweep_noise(at: &mut SweepAt, sw: &FailureSweeps, bd: &mut Breakdown) -> Result<()> {
    let (true_a, m, cfgs, bar) = (at.true_a, at.m, at.cfgs, at.bar);
    let points = &mut *at.points;
    let noise_factors = &sw.noise_factors;
    for &nf in noise_factors {
        let c: Vec<ProtocolConfig> = cfgs
            .iter()
            .map(|c| ProtocolConfig {
                noise: c.noise.scaled(nf),
                ..c.clone()
            })
            .collect();
        let r = pooled(true_a, m, &c)?;
        if r.overall.rr_pct < BREAKDOWN_RR_PCT && bd.noise_factor.is_none() {
            bd.noise_factor = Some(nf);
        }
        points.push(SweepPoint {
            method: m.name(),
            study: "noise".into(),
            value: nf,
            label: format!("×{nf}"),
            mean_snr_db: r.overall.mean_snr_db,
            rr_pct: r.overall.rr_pct,
            not_converged: r.overall.not_converged,
        });
        bar.advance(1);
    }
    Ok(())
}

/// The noise models (the default against the pessimistic full-span hysteresis), per
/// load count.
fn sweep_noise_models(at: &mut SweepAt, sw: &FailureSweeps) -> Result<()> {
    let (true_a, m, cfgs, bar) = (at.true_a, at.m, at.cfgs, at.bar);
    let points = &mut *at.points;
    let noise_models = &sw.noise_models;
    for (k, (name, model)) in noise_models.iter().enumerate() {
        let c: Vec<ProtocolConfig> = cfgs
            .iter()
            .map(|c| ProtocolConfig {
                noise: *model,
                ..c.clone()
            })
            .collect();
        let r = pooled(true_a, m, &c)?;
        for s in r.by_load_count.iter().chain(std::iter::once(&r.overall)) {
            let loads = if s.n_loads == 0 {
                "all".to_string()
            } else {
                s.n_loads.to_string()
            };
            points.push(SweepPoint {
                method: m.name(),
                study: "noise model".into(),
                value: k as f64,
                label: format!("{name}, {loads} loads"),
                mean_snr_db: s.mean_snr_db,
                rr_pct: s.rr_pct,
                not_converged: s.not_converged,
            });
        }
        bar.advance(1);
    }
    Ok(())
}

/// Number of loads 1..8: the first count with RR below the breakdown.
fn sweep_loads(at: &mut SweepAt, bd: &mut Breakdown) -> Result<()> {
    let (true_a, m, cfgs, bar) = (at.true_a, at.m, at.cfgs, at.bar);
    let points = &mut *at.points;
    let c: Vec<ProtocolConfig> = cfgs
        .iter()
        .map(|c| ProtocolConfig {
            singles_per_mass: 0,
            multi_load_counts: (1..=8).collect(),
            max_loads: true_a.nrows(),
            ..c.clone()
        })
        .collect();
    let r = pooled(true_a, m, &c)?;
    for s in &r.by_load_count {
        if s.rr_pct < BREAKDOWN_RR_PCT && bd.loads.is_none() {
            bd.loads = Some(s.n_loads);
        }
        points.push(SweepPoint {
            method: m.name(),
            study: "loads".into(),
            value: s.n_loads as f64,
            label: s.n_loads.to_string(),
            mean_snr_db: s.mean_snr_db,
            rr_pct: s.rr_pct,
            not_converged: s.not_converged,
        });
    }
    bar.advance(1);
    Ok(())
}

/// The layouts: those with RR below the breakdown.
fn sweep_layouts(at: &mut SweepAt, sw: &FailureSweeps, bd: &mut Breakdown) -> Result<()> {
    let (m, cfgs, bar) = (at.m, at.cfgs, at.bar);
    let points = &mut *at.points;
    let (cells, kernel, layouts) = (&sw.cells, &sw.kernel, &sw.layouts);
    for (k, (name, g)) in layouts.iter().enumerate() {
        let a = matrix_from_positions(cells, g, kernel);
        let r = pooled(&a, m, cfgs)?;
        if r.overall.rr_pct < BREAKDOWN_RR_PCT {
            bd.layouts.push(name.clone());
        }
        points.push(SweepPoint {
            method: m.name(),
            study: "layout".into(),
            value: k as f64,
            label: name.clone(),
            mean_snr_db: r.overall.mean_snr_db,
            rr_pct: r.overall.rr_pct,
            not_converged: r.overall.not_converged,
        });
        bar.advance(1);
    }
    Ok(())
}

/// Column normalisation on and off.
fn sweep_normalisation(at: &mut SweepAt) -> Result<()> {
    let (true_a, m, cfgs, bar) = (at.true_a, at.m, at.cfgs, at.bar);
    let points = &mut *at.points;
    for norm in [true, false] {
        let c: Vec<ProtocolConfig> = cfgs
            .iter()
            .map(|c| ProtocolConfig {
                normalise: norm,
                ..c.clone()
            })
            .collect();
        let r = pooled(true_a, m, &c)?;
        points.push(SweepPoint {
            method: m.name(),
            study: "normalisation".into(),
            value: if norm { 1.0 } else { 0.0 },
            label: if norm {
                "normalised".into()
            } else {
                "raw".into()
            },
            mean_snr_db: r.overall.mean_snr_db,
            rr_pct: r.overall.rr_pct,
            not_converged: r.overall.not_converged,
        });
        bar.advance(1);
    }
    Ok(())
}

/// `failure.csv` and the SNR and RR charts of the noise and load sweeps.
fn failure_charts(opts: &BenchOptions, points: &[SweepPoint]) -> Result<()> {
    let rows: Vec<Vec<String>> = points
        .iter()
        .map(|p| {
            vec![
                p.study.clone(),
                p.method.to_string(),
                p.label.clone(),
                f(p.value, 3),
                f(p.mean_snr_db, 3),
                f(p.rr_pct, 1),
                p.not_converged.to_string(),
            ]
        })
        .collect();
    write_csv(
        &opts.out.join("failure.csv"),
        &[
            "study",
            "method",
            "label",
            "value",
            "mean_snr_db",
            "rr_pct",
            "not_converged",
        ],
        &rows,
    )?;
    for (study, title, xl) in [
        (
            "noise",
            "Mean SNR against noise (× the paper's noise model)",
            "noise factor",
        ),
        (
            "loads",
            "RR against the number of simultaneous loads",
            "number of loads",
        ),
    ] {
        let mut snr = Chart::new(title.replace("RR", "mean SNR"), xl, "mean SNR, dB");
        let mut rr = Chart::new(title.replace("Mean SNR", "RR"), xl, "RR (SNR ≥ 12 dB), %");
        for m in Method::ALL {
            let pts: Vec<&SweepPoint> = points
                .iter()
                .filter(|p| p.study == study && p.method == m.name())
                .collect();
            snr = snr.with(Series::new(
                m.name(),
                pts.iter()
                    .map(|p| (p.value, p.mean_snr_db.clamp(-20.0, 80.0)))
                    .collect(),
                Mark::LinePoints,
            ));
            rr = rr.with(Series::new(
                m.name(),
                pts.iter().map(|p| (p.value, p.rr_pct)).collect(),
                Mark::LinePoints,
            ));
        }
        snr.write_svg(&opts.out.join(format!("{study}_snr.svg")))?;
        rr.write_svg(&opts.out.join(format!("{study}_rr.svg")))?;
    }
    Ok(())
}

/// The failure tables (RR / SNR per sweep and method), the layout proxies and the
/// breakdown per method.
fn failure_tables(
    report: &mut String,
    points: &[SweepPoint],
    sw: &FailureSweeps,
    layout_quality: &[(String, f64, f64, f64)],
    breakdown: &[Breakdown],
) -> Result<()> {
    let (noise_factors, layouts, noise_models) = (&sw.noise_factors, &sw.layouts, &sw.noise_models);
    writeln!(
        report,
        "\n## Where methods fail (RR % / mean SNR dB, all 84 tests pooled)\n"
    )?;
    let table = |report: &mut String, study: &str, labels: Vec<String>| -> Result<()> {
        writeln!(
            report,
            "| {study} | {} |",
            Method::ALL.map(|m| m.name()).join(" | ")
        )?;
        writeln!(report, "|---|{}", "---|".repeat(Method::ALL.len()))?;
        for l in labels {
            let cells: Vec<String> = Method::ALL
                .iter()
                .map(|m| {
                    points
                        .iter()
                        .find(|p| p.study == study && p.method == m.name() && p.label == l)
                        .map_or("–".into(), |p| {
                            format!("{:.0} / {:.1}", p.rr_pct, p.mean_snr_db)
                        })
                })
                .collect();
            writeln!(report, "| {l} | {} |", cells.join(" | "))?;
        }
        writeln!(report)?;
        Ok(())
    };
    table(
        report,
        "noise",
        noise_factors.iter().map(|v| format!("×{v}")).collect(),
    )?;
    table(report, "loads", (1..=8).map(|k| k.to_string()).collect())?;
    table(
        report,
        "layout",
        layouts.iter().map(|(n, _)| n.clone()).collect(),
    )?;
    table(
        report,
        "noise model",
        noise_models
            .iter()
            .flat_map(|(n, _)| {
                ["1", "2", "3", "4", "all"]
                    .into_iter()
                    .map(move |k| format!("{n}, {k} loads"))
            })
            .collect(),
    )?;
    table(
        report,
        "normalisation",
        vec!["normalised".into(), "raw".into()],
    )?;
    writeln!(report, "Layout proxies:\n\n| layout | mutual coherence | condition number | min/max column norm |\n|---|---|---|---|")?;
    for (n, mu, kappa, ratio) in layout_quality {
        writeln!(report, "| {n} | {mu:.3} | {kappa:.1} | {ratio:.3} |")?;
    }
    writeln!(report, "\nBreakdown (first point with RR < {BREAKDOWN_RR_PCT:.0} %):\n\n| method | noise factor | loads | layouts |\n|---|---|---|---|")?;
    for b in breakdown {
        writeln!(
            report,
            "| {} | {} | {} | {} |",
            b.method,
            b.noise_factor
                .map_or("none in sweep".into(), |v| format!("×{v}")),
            b.loads.map_or("none ≤ 8".into(), |v| v.to_string()),
            if b.layouts.is_empty() {
                "none".into()
            } else {
                b.layouts.join(", ")
            }
        )?;
    }
    Ok(())
}

/// Simulated additivity errors (paper Figs. 6–8).
#[derive(Debug, Clone, Serialize)]
pub struct AdditivityCheck {
    /// Simulated repetitions of the three tests.
    pub trials: usize,
    /// Median over tests of the largest near-grating error, %.
    pub near_median_pct: f64,
    /// 95th percentile of the same, %.
    pub near_p95_pct: f64,
    /// Median over tests of the largest far-grating error, %.
    pub far_median_pct: f64,
    /// 95th percentile of the same, %.
    pub far_p95_pct: f64,
    /// Median over repetitions of the largest near-grating error over all three tests,
    /// % (the statistic comparable to the paper's "up to 31.5 %").
    pub near_worst_median_pct: f64,
    /// Median over repetitions of the largest far-grating error over all three tests,
    /// % (comparable to the paper's "up to 92 %").
    pub far_worst_median_pct: f64,
}

/// Compare the sum of single-load readings with the simultaneous reading, as the paper's
/// additivity tests do, under the noise model.
pub fn additivity_check(
    true_a: &DMatrix<f64>,
    noise: &fbgforge::array::protocol::NoiseModel,
    seed: u64,
) -> AdditivityCheck {
    let n = true_a.ncols();
    // Cells B+G, E+F, A+D+H of the 8-cell array (indices 1+6, 4+5, 0+3+7).
    let tests: Vec<Vec<usize>> = vec![vec![1, 6], vec![4, 5], vec![0, 3, 7]]
        .into_iter()
        .map(|t| t.into_iter().filter(|&c| c < n).collect())
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xADD);
    let (mut near, mut far) = (Vec::new(), Vec::new());
    let (mut near_worst, mut far_worst) = (Vec::new(), Vec::new());
    let trials = 300;
    for _ in 0..trials {
        let (mut worst_near, mut worst_far) = (0.0f64, 0.0f64);
        for t in &tests {
            let mut sum = vec![0.0; true_a.nrows()];
            let mut x_all = vec![0.0; n];
            for &c in t {
                let mut x = vec![0.0; n];
                x[c] = 100.0;
                x_all[c] = 100.0;
                for (s, v) in sum.iter_mut().zip(noise.measure(true_a, &x, &mut rng)) {
                    *s += v;
                }
            }
            let sim = noise.measure(true_a, &x_all, &mut rng);
            let clean: Vec<f64> = (0..true_a.nrows())
                .map(|i| (0..n).map(|j| true_a[(i, j)] * x_all[j]).sum())
                .collect();
            let top = clean.iter().copied().fold(0.0, f64::max);
            let (mut e_near, mut e_far) = (0.0f64, 0.0f64);
            for i in 0..sum.len() {
                let e = 100.0 * (sim[i] - sum[i]).abs() / sum[i].abs().max(1e-9);
                if clean[i] >= 0.5 * top {
                    e_near = e_near.max(e);
                } else {
                    e_far = e_far.max(e);
                }
            }
            near.push(e_near);
            far.push(e_far);
            worst_near = worst_near.max(e_near);
            worst_far = worst_far.max(e_far);
        }
        near_worst.push(worst_near);
        far_worst.push(worst_far);
    }
    let pct = |v: &mut Vec<f64>, q: f64| {
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * q).round() as usize]
    };
    AdditivityCheck {
        trials,
        near_median_pct: pct(&mut near, 0.5),
        near_p95_pct: pct(&mut near, 0.95),
        far_median_pct: pct(&mut far, 0.5),
        far_p95_pct: pct(&mut far, 0.95),
        near_worst_median_pct: pct(&mut near_worst, 0.5),
        far_worst_median_pct: pct(&mut far_worst, 0.5),
    }
}
