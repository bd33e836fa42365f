//! Study `verify` (`cargo run --release -p fbgforge-studies -- verify [--quick]`): log
//! parsing throughput and the end-to-end verification time of a long synthetic
//! 8-grating log, stage by stage, through the library's verify use case; then the
//! accuracy of K, the segment lags, Δt_max and Q on the force-stand protocols labs
//! use (impulse, press-hold-release, staircase, sine), each with a pure transport
//! delay and with a standard-linear-solid lag (`protocols.csv`, `protocols.svg`).

use anyhow::{Context, Result};
use clap::Args;
use fbgforge::logs::{self, LogFormat, ReadOptions};
use fbgforge::progress::Progress;
use fbgforge::report::verify as report;
use fbgforge::synth::module_log::{self as synth, LogStyle};
use fbgforge::verify::{run as verify_run, VerifyRequest};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of the `verify` study.
#[derive(Debug, Clone, Args)]
pub struct BenchVerifyArgs {
    /// Output folder for the generated logs and the results.
    #[arg(long, default_value = "out/bench-verify")]
    pub out: PathBuf,
    /// Length of the end-to-end log, minutes.
    #[arg(long, default_value_t = 60.0)]
    pub minutes: f64,
    /// Sample rate of the wavelength and force logs, Hz.
    #[arg(long, default_value_t = 1000.0)]
    pub rate_hz: f64,
    /// Keep the generated logs (they are large) and the design (bench-design.toml)
    /// instead of deleting them.
    #[arg(long)]
    pub keep: bool,
    /// Smoke run: a 2-minute log at 100 Hz.
    #[arg(long)]
    pub quick: bool,
}

/// A design with eight gratings (seven strain gratings on one core and the reference),
/// for the benchmark.
pub fn bench_design() -> Result<fbgforge::spec::Design> {
    let text = include_str!("../../designs/clip-on-34mm.toml");
    let mut d = fbgforge::design::parse(text)?;
    let m = d
        .module
        .as_mut()
        .context("the shipped design has a module")?;
    let template = m
        .gratings
        .iter()
        .find(|g| g.role == fbgforge::spec::GratingRole::Strain)
        .cloned()
        .context("a strain grating")?;
    let reference = m
        .gratings
        .iter()
        .find(|g| g.role == fbgforge::spec::GratingRole::TemperatureReference)
        .cloned()
        .context("a reference grating")?;
    m.gratings = (0..7)
        .map(|k| {
            let mut g = template.clone();
            g.name = format!("fbg{}", k + 1);
            g.core = Some("psc1".into());
            g.pillar = Some((k % 4) as u32);
            g.center_height_mm = Some(if k < 4 { 20.0 } else { 35.0 });
            g.bragg_wavelength_nm = 1520.0 + 5.0 * k as f64;
            g
        })
        .collect();
    m.gratings.push(reference);
    d.validate()?;
    Ok(d)
}

/// CPU time used by this process so far (user + system), s, from /proc (Linux);
/// None elsewhere. On a shared machine it shows the work apart from waiting.
fn cpu_time_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// A stage's wall-clock and CPU time, s.
type Took = (f64, f64);

/// One row of the stage table: the stage, its wall-clock and CPU time (s), a note.
type StageRow = (String, f64, f64, String);

/// The files of the benchmark's run.
struct BenchFiles {
    design: PathBuf,
    log: PathBuf,
    force: PathBuf,
}

/// Run the study.
pub fn run(a: &BenchVerifyArgs) -> Result<()> {
    let a = &BenchVerifyArgs {
        minutes: if a.quick { 2.0 } else { a.minutes },
        rate_hz: if a.quick { 100.0 } else { a.rate_hz },
        ..a.clone()
    };
    let design = bench_design()?;
    fbgforge::output::ensure_dir(&a.out)?;
    eprintln!(
        "generating a {} min, {} Hz, 8-grating log ...",
        a.minutes, a.rate_hz
    );
    // Stages: generate, write, parse ×3, end to end.
    let pb = crate::progress::Bar::with("bench verify", 6);
    let files = BenchFiles {
        design: a.out.join("bench-design.toml"),
        log: a.out.join("bench-peaks.txt"),
        force: a.out.join("bench-force.csv"),
    };
    let truth = write_bench_logs(a, &design, &files, &pb)?;
    let mb = std::fs::metadata(&files.log)?.len() as f64 / 1e6;
    // Stage 1: parse from memory (throughput), best of three.
    let parse = parse_best_of_three(&files.log, &pb)?;
    // Stage 2: end to end from the files.
    pb.advance(1);
    let rows = end_to_end(a, &design, &files, &truth, (parse, mb))?;
    pb.end();
    write_stage_table(a, &rows, mb)?;
    if !a.keep {
        let _ = std::fs::remove_file(&files.design);
        let _ = std::fs::remove_file(&files.log);
        let _ = std::fs::remove_file(&files.force);
    }
    println!(
        "wrote {} and {}",
        a.out.join("bench_verify.csv").display(),
        a.out.join("bench_verify.svg").display()
    );
    protocol_accuracy(&a.out)
}

/// Generate the run (pulses of 10–50 N every 10 s, a slow temperature ramp) and write
/// its wavelength and force logs; the truth.
fn write_bench_logs(
    a: &BenchVerifyArgs,
    design: &fbgforge::spec::Design,
    files: &BenchFiles,
    pb: &crate::progress::Bar,
) -> Result<synth::SynthTruth> {
    let amps = [10.0, 20.0, 30.0, 40.0, 50.0];
    let duration = a.minutes * 60.0;
    let n_pulses = ((duration - 10.0) / 10.0).floor().max(1.0) as usize;
    let peaks: Vec<f64> = (0..n_pulses).map(|i| amps[i % amps.len()]).collect();
    let cfg = synth::SynthConfig {
        sample_rate_hz: a.rate_hz,
        force_rate_hz: a.rate_hz,
        pulses: synth::pulse_train(&peaks, 4.0, 6.0, 5.0),
        duration_s: duration,
        temperature_ramp_k_per_s: 0.002,
        ..Default::default()
    };
    let (log, force, truth) = synth::generate(design, &cfg)?;
    pb.advance(1);
    synth::write_log(
        &files.log,
        LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &LogStyle::default(),
    )?;
    synth::write_force_csv(&files.force, &force)?;
    pb.advance(1);
    Ok(truth)
}

/// Parse the wavelength log from memory three times: the best wall-clock time and its
/// CPU time.
fn parse_best_of_three(log_path: &std::path::Path, pb: &crate::progress::Bar) -> Result<Took> {
    let bytes = std::fs::read(log_path)?;
    let mut parse_s = f64::MAX;
    let mut parse_cpu = f64::NAN;
    for _ in 0..3 {
        let c = cpu_time_s();
        let t = Instant::now();
        let pl = logs::parse_wavelength_bytes(&bytes, log_path, &ReadOptions::default())?;
        let el = t.elapsed().as_secs_f64();
        if el < parse_s {
            parse_s = el;
            parse_cpu = cpu_time_s().zip(c).map_or(f64::NAN, |(b, a)| b - a);
        }
        drop(pl);
        pb.advance(1);
    }
    Ok((parse_s, parse_cpu))
}

/// The library's verify use case stage by stage from the files (read the logs, judge,
/// write the report), timed; the stage table with `parse` (and the log's size, MB).
fn end_to_end(
    a: &BenchVerifyArgs,
    design: &fbgforge::spec::Design,
    files: &BenchFiles,
    truth: &synth::SynthTruth,
    (parse, mb): (Took, f64),
) -> Result<Vec<StageRow>> {
    let (parse_s, parse_cpu) = parse;
    let (log_path, force_path, design_path) = (&files.log, &files.force, &files.design);
    let cpu = || cpu_time_s().unwrap_or(f64::NAN);
    let (t_all, c_all) = (Instant::now(), cpu());
    fbgforge::output::write_atomic(design_path, design.to_toml().as_bytes())?;
    let req = VerifyRequest::new(design_path.clone(), log_path.clone(), force_path.clone());
    let (t, c) = (Instant::now(), cpu());
    let pl = logs::read_peak_log(log_path, &ReadOptions::default())?;
    let read_log = (t.elapsed().as_secs_f64(), cpu() - c);
    drop(pl);
    let (t, c) = (Instant::now(), cpu());
    let inputs = verify_run::read_inputs(&req)?;
    let read_force = (
        t.elapsed().as_secs_f64() - read_log.0,
        cpu() - c - read_log.1,
    );
    let fl = &inputs.force;
    let (t, c) = (Instant::now(), cpu());
    let outcome = verify_run::judge(&req, &inputs)?;
    let analysed = (t.elapsed().as_secs_f64(), cpu() - c);
    let (t, c) = (Instant::now(), cpu());
    let (rep, series) = (&outcome.report, &outcome.series);
    report::write_report(&a.out.join("report"), rep, series)?;
    let reported = (t.elapsed().as_secs_f64(), cpu() - c);
    let total = (t_all.elapsed().as_secs_f64(), cpu() - c_all);
    let worst_k = rep
        .measurement
        .gratings
        .iter()
        .zip(truth.gratings.iter().filter(|g| !g.reference))
        .map(|(g, t)| {
            (g.sensitivity_pm_per_n - t.sensitivity_pm_per_n).abs() / t.sensitivity_pm_per_n.abs()
        })
        .fold(0.0, f64::max);
    let rows: Vec<(String, f64, f64, String)> = vec![
        (
            "parse ENLIGHT peaks (memory)".into(),
            parse_s,
            parse_cpu,
            format!("{:.0} MB/s ({mb:.0} MB, target >= 100 MB/s)", mb / parse_s),
        ),
        (
            "read wavelength log (file)".into(),
            read_log.0,
            read_log.1,
            format!("{:.0} MB/s", mb / read_log.0),
        ),
        (
            "read force log".into(),
            read_force.0,
            read_force.1,
            format!("{} samples", fl.force_n.len()),
        ),
        (
            "align, fit, pulses".into(),
            analysed.0,
            analysed.1,
            format!(
                "{} gratings, {} pulses",
                rep.measurement.gratings.len(),
                rep.measurement.pulse_count
            ),
        ),
        (
            "verdict + report".into(),
            reported.0,
            reported.1,
            String::new(),
        ),
        (
            "end to end".into(),
            total.0,
            total.1,
            format!("target < 10 s; worst K error {:.3} %", 100.0 * worst_k),
        ),
    ];
    Ok(rows)
}

/// The stage table: printed, `bench_verify.csv` and `bench_verify.svg`.
fn write_stage_table(a: &BenchVerifyArgs, rows: &[StageRow], mb: f64) -> Result<()> {
    println!("{:<32} {:>10} {:>10}  note", "stage", "wall s", "cpu s");
    for (s, t, c, n) in rows {
        println!("{s:<32} {t:>10.3} {c:>10.3}  {n}");
    }
    let csv_rows: Vec<Vec<String>> = rows
        .iter()
        .map(|(s, t, c, n)| vec![s.clone(), format!("{t:.4}"), format!("{c:.4}"), n.clone()])
        .collect();
    fbgforge::output::write_csv(
        &a.out.join("bench_verify.csv"),
        &["stage", "wall_s", "cpu_s", "note"],
        &csv_rows,
    )?;
    let chart = fbgforge::plot::Chart::new(
        format!(
            "bench verify: {} min at {} Hz, 8 gratings ({mb:.0} MB)",
            a.minutes, a.rate_hz
        ),
        "stage (1 parse, 2 read log, 3 read force, 4 analyse, 5 report, 6 total)",
        "time (s)",
    )
    .with(fbgforge::plot::Series::new(
        "wall clock",
        rows.iter()
            .enumerate()
            .map(|(i, r)| ((i + 1) as f64, r.1))
            .collect(),
        fbgforge::plot::Mark::Points,
    ))
    .with(fbgforge::plot::Series::new(
        "CPU (both cores)",
        rows.iter()
            .enumerate()
            .map(|(i, r)| ((i + 1) as f64, r.2))
            .collect(),
        fbgforge::plot::Mark::Points,
    ));
    chart.write_svg(&a.out.join("bench_verify.svg"))?;
    Ok(())
}

/// One protocol run for the accuracy table.
struct ProtocolCase {
    protocol: &'static str,
    cfg: synth::SynthConfig,
}

/// The protocols of `tests/verify_protocols.rs`: 1 s presses at 2 Hz, press-hold-release
/// with 10 s plateaus at 10 Hz, a 0–250 g staircase in 25 g steps at 10 Hz, sines of
/// 0.1, 0.25 (at 2 Hz) and 0.5 Hz.
fn protocol_cases() -> Vec<ProtocolCase> {
    use synth::{shaped_train, PulseShape, SynthConfig};
    let base = SynthConfig::default();
    vec![
        ProtocolCase {
            protocol: "impulse",
            cfg: SynthConfig {
                sample_rate_hz: 2.0,
                pulses: synth::pulse_train(&[10.0, 20.0, 30.0, 40.0, 50.0, 25.0], 1.0, 9.0, 5.0),
                duration_s: 65.0,
                ..base.clone()
            },
        },
        ProtocolCase {
            protocol: "press-hold-release",
            cfg: SynthConfig {
                sample_rate_hz: 10.0,
                pulses: shaped_train(
                    &[20.0, 40.0, 30.0],
                    12.0,
                    10.0,
                    5.0,
                    PulseShape::Trapezoid { ramp_s: 1.0 },
                ),
                duration_s: 75.0,
                ..base.clone()
            },
        },
        ProtocolCase {
            protocol: "staircase",
            cfg: SynthConfig {
                sample_rate_hz: 10.0,
                sensitivity_pm_per_n: 38.0,
                pulses: shaped_train(
                    &[0.250 * 9.80665],
                    20.0 * 0.3 + 19.0 * 5.0,
                    0.0,
                    8.0,
                    PulseShape::Staircase {
                        steps: 10,
                        ramp_s: 0.3,
                    },
                ),
                duration_s: 120.0,
                ..base.clone()
            },
        },
        ProtocolCase {
            protocol: "sine 0.1 Hz",
            cfg: SynthConfig {
                sample_rate_hz: 10.0,
                pulses: shaped_train(&[40.0], 40.0, 0.0, 6.0, PulseShape::Sine { cycles: 4 }),
                duration_s: 56.0,
                ..base.clone()
            },
        },
        ProtocolCase {
            protocol: "sine 0.25 Hz",
            cfg: SynthConfig {
                sample_rate_hz: 2.0,
                pulses: shaped_train(&[40.0], 32.0, 0.0, 6.0, PulseShape::Sine { cycles: 8 }),
                duration_s: 48.0,
                ..base.clone()
            },
        },
        ProtocolCase {
            protocol: "sine 0.5 Hz",
            cfg: SynthConfig {
                sample_rate_hz: 10.0,
                pulses: shaped_train(&[40.0], 20.0, 0.0, 6.0, PulseShape::Sine { cycles: 10 }),
                duration_s: 36.0,
                ..base
            },
        },
    ]
}

/// The worst errors of one protocol run against its truth, offset given.
struct ProtocolErrors {
    /// The protocol the analysis detected.
    detected: &'static str,
    /// Worst relative error of K.
    k: f64,
    /// Worst error of a segment's lag, s (NaN when the segments differ in number).
    lag_s: f64,
    /// Worst error of Δt_max, s.
    max_lag_s: f64,
    /// The true Δt_max of the first strain grating, s.
    true_max_lag_s: f64,
    /// Q's ratio between the first two gratings over their K's ratio.
    q_ratio: f64,
}

/// Generate `cfg`'s run, write it as CSV into `out`, analyse it with the true offset
/// and compare with the truth.
fn protocol_errors(
    design: &fbgforge::spec::Design,
    out: &std::path::Path,
    cfg: &synth::SynthConfig,
) -> Result<ProtocolErrors> {
    use fbgforge::verify::analysis::{analyse, AnalysisOptions};
    let (log, force, truth) = synth::generate(design, cfg)?;
    let (lp, fp) = (out.join("protocol-log.csv"), out.join("protocol-force.csv"));
    synth::write_log(&lp, LogFormat::Csv, &log, cfg, &LogStyle::default())?;
    synth::write_force_csv(&fp, &force)?;
    let pl = logs::read_peak_log(&lp, &ReadOptions::default())?;
    let fl = logs::read_force_log(&fp, &logs::ForceReadOptions::default())?;
    let opts = AnalysisOptions {
        clock_offset_s: Some(synth::reported_offset_s(cfg, LogFormat::Csv)),
        ..Default::default()
    };
    let (m, _) = analyse(design, &pl, &fl, &opts)?;
    let strain: Vec<_> = truth.gratings.iter().filter(|g| !g.reference).collect();
    let (mut k_err, mut lag_err, mut dt_err) = (0.0f64, 0.0f64, 0.0f64);
    for (g, t) in m.gratings.iter().zip(&strain) {
        k_err = k_err.max((g.sensitivity_pm_per_n / t.sensitivity_pm_per_n - 1.0).abs());
        for (p, l) in g.pulses.iter().zip(&t.lags_s) {
            lag_err = lag_err.max((p.lag_s - l).abs());
        }
        if g.pulses.len() != t.lags_s.len() {
            lag_err = f64::NAN;
        }
        dt_err = dt_err.max((g.max_lag_s - t.max_lag_s).abs());
    }
    let q = |i: usize| m.gratings.get(i).and_then(|g| g.quality_q_pm_per_n_s);
    let q_ratio = match (q(0), q(1)) {
        (Some(a), Some(b)) => {
            a / b / (strain[0].sensitivity_pm_per_n / strain[1].sensitivity_pm_per_n)
        }
        _ => f64::NAN,
    };
    Ok(ProtocolErrors {
        detected: m.protocol.name(),
        k: k_err,
        lag_s: lag_err,
        max_lag_s: dt_err,
        true_max_lag_s: strain[0].max_lag_s,
        q_ratio,
    })
}

/// K, lag, Δt_max and Q accuracy per protocol and dynamics, offset given: printed as a
/// table, written to `protocols.csv` and `protocols.svg`.
fn protocol_accuracy(out: &std::path::Path) -> Result<()> {
    let design = fbgforge::design::parse(include_str!("../../designs/clip-on-34mm.toml"))?;
    let mut rows: Vec<Vec<String>> = Vec::new();
    let mut points = (Vec::new(), Vec::new());
    println!(
        "\n{:<20} {:>5} {:<10} {:<19} {:>9} {:>10} {:>10} {:>10} {:>9}",
        "protocol",
        "Hz",
        "dynamics",
        "detected",
        "K err %",
        "lag err s",
        "Δt err s",
        "Δt_max s",
        "Q/K ratio"
    );
    for case in protocol_cases() {
        for (dynamics, delay, r) in [("delay 0.3 s", 0.3, 1.0), ("SLS τ 0.4 s", 0.0, 0.3)] {
            let cfg = synth::SynthConfig {
                transport_delay_s: delay,
                instant_fraction: r,
                tau_s: 0.4,
                ..case.cfg.clone()
            };
            let e = protocol_errors(&design, out, &cfg)?;
            let (k_err, lag_err, dt_err, q_ratio) = (e.k, e.lag_s, e.max_lag_s, e.q_ratio);
            println!(
                "{:<20} {:>5} {:<10} {:<19} {:>9.3} {:>10.4} {:>10.4} {:>10.4} {:>9.4}",
                case.protocol,
                cfg.sample_rate_hz,
                dynamics,
                e.detected,
                100.0 * k_err,
                lag_err,
                dt_err,
                e.true_max_lag_s,
                q_ratio
            );
            let i = rows.len() as f64 + 1.0;
            points.0.push((i, 100.0 * k_err));
            points.1.push((i, dt_err));
            rows.push(vec![
                case.protocol.into(),
                format!("{}", cfg.sample_rate_hz),
                dynamics.into(),
                e.detected.into(),
                format!("{:.4}", 100.0 * k_err),
                format!("{lag_err:.5}"),
                format!("{dt_err:.5}"),
                format!("{:.5}", e.true_max_lag_s),
                format!("{q_ratio:.5}"),
            ]);
        }
    }
    let _ = std::fs::remove_file(out.join("protocol-log.csv"));
    let _ = std::fs::remove_file(out.join("protocol-force.csv"));
    fbgforge::output::write_csv(
        &out.join("protocols.csv"),
        &[
            "protocol",
            "rate_hz",
            "dynamics",
            "detected",
            "worst_k_error_percent",
            "worst_segment_lag_error_s",
            "worst_max_lag_error_s",
            "true_max_lag_s",
            "q_ratio_over_k_ratio",
        ],
        &rows,
    )?;
    fbgforge::plot::Chart::new(
        "verify: accuracy per protocol (offset given; case number as in protocols.csv)",
        "case",
        "K error (%) and Δt_max error (s)",
    )
    .with(fbgforge::plot::Series::new(
        "worst K error, %",
        points.0,
        fbgforge::plot::Mark::Points,
    ))
    .with(fbgforge::plot::Series::new(
        "worst Δt_max error, s",
        points.1,
        fbgforge::plot::Mark::Points,
    ))
    .write_svg(&out.join("protocols.svg"))?;
    println!(
        "wrote {} and {}",
        out.join("protocols.csv").display(),
        out.join("protocols.svg").display()
    );
    Ok(())
}
