//! `fbgforge verify`, `synth-log` and `calibrate-array`: logs to verdicts; and
//! `fbgforge bench verify`.

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use fbgforge::logs::{self, num::DateOrder, ForceColumns, LogFormat, ReadOptions};
use fbgforge::model::LoadCase;
use fbgforge::verify::analysis::{analyse, AnalysisOptions};
use fbgforge::verify::report::{self, VerifyReport};
use fbgforge::verify::verdict::{self, Status};
use fbgforge::verify::{calibrate, synth};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Load case on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CaseArg {
    /// Case I: core with a solid insert.
    #[value(name = "I", alias = "i", alias = "1")]
    I,
    /// Case II: hollow core.
    #[value(name = "II", alias = "ii", alias = "2")]
    II,
}

/// Day/month order on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DateOrderArg {
    /// 17/04/2025.
    Dmy,
    /// 04/17/2025.
    Mdy,
}

/// Arguments of `fbgforge verify`.
#[derive(Debug, Args)]
pub struct VerifyArgs {
    /// Design spec (TOML).
    pub design: PathBuf,
    /// Wavelength log (ENLIGHT Peaks or Sensors export, I-MON log, or CSV).
    #[arg(long)]
    pub log: PathBuf,
    /// Force-stand CSV.
    #[arg(long)]
    pub force: PathBuf,
    /// Format of the wavelength log (detected if omitted).
    #[arg(long, value_enum)]
    pub format: Option<LogFormat>,
    /// Order of day and month in slash dates (detected from the file if omitted).
    #[arg(long, value_enum)]
    pub date_order: Option<DateOrderArg>,
    /// Load case (default: I with --insert, II without).
    #[arg(long, value_enum)]
    pub case: Option<CaseArg>,
    /// Insert used in Case I.
    #[arg(long)]
    pub insert: Option<String>,
    /// Analyse only this core's gratings.
    #[arg(long)]
    pub core: Option<String>,
    /// Tolerance on the relative error of K (0.08 = 8 %).
    #[arg(long, default_value_t = verdict::DEFAULT_TOLERANCE)]
    pub tolerance: f64,
    /// Half-width of the wavelength windows, nm (default: half the smallest spacing, at most 2.5 nm).
    #[arg(long)]
    pub window_nm: Option<f64>,
    /// Known clock offset, force clock − wavelength clock, s (estimated if omitted).
    #[arg(long, allow_hyphen_values = true)]
    pub clock_offset_s: Option<f64>,
    /// Search range of the estimated clock offset around the prior, s.
    #[arg(long, default_value_t = 60.0)]
    pub max_offset_s: f64,
    /// Interrogator resolution, pm (default: 1 pm, 0.5 pm for I-MON logs).
    #[arg(long)]
    pub resolution_pm: Option<f64>,
    /// Name of the force log's time column.
    #[arg(long)]
    pub force_time_column: Option<String>,
    /// Name of the force log's force column.
    #[arg(long)]
    pub force_force_column: Option<String>,
    /// Factor from the force column's unit to N (default: from the column name, else 1).
    #[arg(long)]
    pub force_scale_to_n: Option<f64>,
    /// Print the report as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write report.md, report.json, SVG plots and CSVs into this folder.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

fn read_options(format: Option<LogFormat>, date_order: Option<DateOrderArg>) -> ReadOptions {
    ReadOptions {
        format,
        date_order: date_order.map(|d| match d {
            DateOrderArg::Dmy => DateOrder::DayMonthYear,
            DateOrderArg::Mdy => DateOrder::MonthDayYear,
        }),
    }
}

/// Run `fbgforge verify`. Returns status 2 after writing everything when the
/// verdict is FAIL, so scripts can tell a failed part from an error (status 1).
pub fn run_verify(a: VerifyArgs) -> Result<std::process::ExitCode> {
    let (report, series) = verify_files(&a)?;
    if let Some(dir) = &a.report {
        report::write_report(dir, &report, &series)?;
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report::summary(&report));
        if let Some(dir) = &a.report {
            println!("report: {}", dir.join("report.md").display());
        }
    }
    if report.verdict.overall == Status::Fail {
        return Ok(std::process::ExitCode::from(2));
    }
    Ok(std::process::ExitCode::SUCCESS)
}

/// Everything `verify` does short of printing: read, analyse, judge.
pub fn verify_files(a: &VerifyArgs) -> Result<(VerifyReport, fbgforge::verify::analysis::Series)> {
    if a.tolerance.is_nan() || a.tolerance <= 0.0 {
        bail!("--tolerance must be positive, got {}", a.tolerance);
    }
    let design = fbgforge::spec::load(&a.design)?;
    let case = match a.case {
        Some(CaseArg::I) => LoadCase::I,
        Some(CaseArg::II) => LoadCase::II,
        None if a.insert.is_some() => LoadCase::I,
        None => LoadCase::II,
    };
    if let (Some(ins), Some(m)) = (&a.insert, &design.module) {
        if !m.inserts.iter().any(|i| &i.name == ins) {
            let names: Vec<&str> = m.inserts.iter().map(|i| i.name.as_str()).collect();
            bail!(
                "design `{}` has no insert named `{ins}`; its inserts are: {}",
                design.name,
                names.join(", ")
            );
        }
    }
    if case == LoadCase::II && a.insert.is_some() {
        bail!("--insert names the insert of Case I; Case II has none");
    }
    let log = logs::read_peak_log(&a.log, &read_options(a.format, a.date_order))?;
    let cols = ForceColumns {
        time: a.force_time_column.clone(),
        force: a.force_force_column.clone(),
        scale_to_n: a.force_scale_to_n,
    };
    let force = logs::read_force_log(&a.force, &cols)?;
    let opts = AnalysisOptions {
        core: a.core.clone(),
        window_half_width_nm: a.window_nm,
        clock_offset_s: a.clock_offset_s,
        max_clock_offset_s: a.max_offset_s,
        resolution_pm: a.resolution_pm,
    };
    let (m, series) = analyse(&design, &log, &force, &opts)?;
    // K is linear in force: any force gives the same sensitivity.
    let preds = fbgforge::model::predict(&design, 10.0).map_err(|e| format!("{e:#}"));
    let v = verdict::verdicts(
        &m,
        preds.as_deref().map_err(Clone::clone),
        case,
        a.insert.as_deref(),
        a.tolerance,
    );
    Ok((
        VerifyReport {
            design: design.name.clone(),
            measurement: m,
            verdict: v,
        },
        series,
    ))
}

/// Arguments of `fbgforge synth-log`.
#[derive(Debug, Args)]
pub struct SynthLogArgs {
    /// Design spec (TOML).
    pub design: PathBuf,
    /// Log format to write.
    #[arg(long, value_enum, default_value = "enlight-peaks")]
    pub format: LogFormat,
    /// Output folder (log.txt or log.csv, force.csv, truth.json).
    #[arg(long, default_value = "out/synth-log")]
    pub out: PathBuf,
    /// Core whose gratings respond (default: the first).
    #[arg(long)]
    pub core: Option<String>,
    /// Static K of the core's first grating, pm/N (the k-th gets K·(1 − 0.15 k)).
    #[arg(long, default_value_t = 12.0, allow_hyphen_values = true)]
    pub k_pm_per_n: f64,
    /// Wavelength sample rate, Hz.
    #[arg(long, default_value_t = 20.0)]
    pub rate_hz: f64,
    /// Force sample rate, Hz.
    #[arg(long, default_value_t = 100.0)]
    pub force_rate_hz: f64,
    /// Peak force of each pulse, N, comma-separated.
    #[arg(long, default_value = "10,20,30,40,50,25", value_delimiter = ',')]
    pub pulses_n: Vec<f64>,
    /// Duration of each haversine pulse, s.
    #[arg(long, default_value_t = 4.0)]
    pub pulse_s: f64,
    /// Rest between pulses, s.
    #[arg(long, default_value_t = 6.0)]
    pub rest_s: f64,
    /// SLS time constant τ, s.
    #[arg(long, default_value_t = 0.4)]
    pub tau_s: f64,
    /// Fraction of the response without lag.
    #[arg(long, default_value_t = 0.3)]
    pub instant_fraction: f64,
    /// Wavelength-log time at which the force recording starts, s.
    #[arg(long, default_value_t = -1.7, allow_hyphen_values = true)]
    pub force_start_s: f64,
    /// Noise on every peak, pm.
    #[arg(long, default_value_t = 0.3)]
    pub noise_pm: f64,
    /// Noise on the force, N.
    #[arg(long, default_value_t = 0.01)]
    pub force_noise_n: f64,
    /// Drift of the strain gratings, pm/s.
    #[arg(long, default_value_t = 0.05, allow_hyphen_values = true)]
    pub drift_pm_per_s: f64,
    /// Temperature ramp, K/s (up for half the run, then down).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub temperature_ramp_k_per_s: f64,
    /// Probability that a peak drops out of a row.
    #[arg(long, default_value_t = 0.0)]
    pub dropout: f64,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Decimal commas (ENLIGHT) or `;`-separated CSV with decimal commas.
    #[arg(long)]
    pub decimal_comma: bool,
    /// Lead the file with a UTF-8 BOM.
    #[arg(long)]
    pub bom: bool,
    /// ENLIGHT metadata lines before the header.
    #[arg(long, default_value_t = 45)]
    pub metadata_lines: usize,
    /// ENLIGHT timestamps on a 12-hour clock.
    #[arg(long)]
    pub twelve_hour: bool,
    /// Array calibration instead: a schedule CSV (start_s,end_s,cell,load_g); the log
    /// follows the power-law kernel of reference §2 and `matrix_truth.csv` is written.
    #[arg(long)]
    pub schedule: Option<PathBuf>,
}

/// Run `fbgforge synth-log`.
pub fn run_synth_log(a: SynthLogArgs) -> Result<()> {
    let design = fbgforge::spec::load(&a.design)?;
    let style = LogStyle {
        decimal_comma: a.decimal_comma,
        bom: a.bom,
        metadata_lines: a.metadata_lines,
        twelve_hour: a.twelve_hour,
    };
    let log_path = a.out.join(format!("log.{}", synth::extension(a.format)));
    if let Some(schedule) = &a.schedule {
        let n_cells = design
            .array
            .as_ref()
            .map_or(0, |x| (x.cells_x * x.cells_y) as usize);
        let sched = calibrate::read_schedule(schedule, n_cells)?;
        let matrix = calibrate::power_law_matrix(&design)?;
        let log = calibrate::synth_calibration_log(
            &design,
            &matrix,
            &sched,
            a.rate_hz,
            a.noise_pm,
            a.drift_pm_per_s,
            a.seed,
        )?;
        let cfg = synth::SynthConfig {
            sample_rate_hz: a.rate_hz,
            ..Default::default()
        };
        synth::write_log(&log_path, a.format, &log, &cfg, &style)?;
        let truth = a.out.join("matrix_truth.csv");
        calibrate::write_matrix_csv(
            &truth,
            &matrix,
            &["synthetic truth: power-law kernel 44.7 pm·mm²/g · d^-2.05 (reference §2)".into()],
        )?;
        println!("wrote {} and {}", log_path.display(), truth.display());
        return Ok(());
    }
    let pulses = synth::pulse_train(&a.pulses_n, a.pulse_s, a.rest_s, 5.0);
    let duration = pulses
        .last()
        .map_or(30.0, |p| p.start_s + p.duration_s + a.rest_s);
    let cfg = synth::SynthConfig {
        core: a.core.clone(),
        sensitivity_pm_per_n: a.k_pm_per_n,
        sample_rate_hz: a.rate_hz,
        force_rate_hz: a.force_rate_hz,
        pulses,
        duration_s: duration,
        tau_s: a.tau_s,
        instant_fraction: a.instant_fraction,
        force_start_s: a.force_start_s,
        noise_pm: a.noise_pm,
        force_noise_n: a.force_noise_n,
        drift_pm_per_s: a.drift_pm_per_s,
        temperature_ramp_k_per_s: a.temperature_ramp_k_per_s,
        dropout_fraction: a.dropout,
        seed: a.seed,
        ..Default::default()
    };
    let (log, force, mut truth) = synth::generate(&design, &cfg)?;
    truth.clock_offset_s = synth::reported_offset_s(&cfg, a.format);
    synth::write_log(&log_path, a.format, &log, &cfg, &style)?;
    let force_path = a.out.join("force.csv");
    synth::write_force_csv(&force_path, &force)?;
    fbgforge::output::write_json(&a.out.join("truth.json"), &truth)?;
    println!(
        "wrote {}, {} and {}",
        log_path.display(),
        force_path.display(),
        a.out.join("truth.json").display()
    );
    Ok(())
}

use synth::LogStyle;

/// Arguments of `fbgforge calibrate-array`.
#[derive(Debug, Args)]
pub struct CalibrateArrayArgs {
    /// Design spec with an [array] (TOML).
    pub design: PathBuf,
    /// Wavelength log of the calibration run.
    #[arg(long)]
    pub log: PathBuf,
    /// Schedule CSV: `start_s,end_s,cell,load_g`, times in s from the log's first row.
    #[arg(long)]
    pub schedule: PathBuf,
    /// Format of the wavelength log (detected if omitted).
    #[arg(long, value_enum)]
    pub format: Option<LogFormat>,
    /// Order of day and month in slash dates.
    #[arg(long, value_enum)]
    pub date_order: Option<DateOrderArg>,
    /// Half-width of the wavelength windows, nm.
    #[arg(long)]
    pub window_nm: Option<f64>,
    /// Output CSV (default: out/<design>/sensing_matrix.csv).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Run `fbgforge calibrate-array`.
pub fn run_calibrate_array(a: CalibrateArrayArgs) -> Result<()> {
    let design = fbgforge::spec::load(&a.design)?;
    let n_cells = design
        .array
        .as_ref()
        .map(|x| (x.cells_x * x.cells_y) as usize)
        .with_context(|| format!("design `{}` has no [array] to calibrate", design.name))?;
    let sched = calibrate::read_schedule(&a.schedule, n_cells)?;
    let log = logs::read_peak_log(&a.log, &read_options(a.format, a.date_order))?;
    let m = calibrate::calibrate(&design, &log, &sched, a.window_nm)?;
    let out = a.out.clone().unwrap_or_else(|| {
        Path::new("out")
            .join(&design.name)
            .join("sensing_matrix.csv")
    });
    calibrate::write_matrix_csv(
        &out,
        &m,
        &[format!(
            "measured sensing matrix, pm/g, from {} and {}",
            a.log.display(),
            a.schedule.display()
        )],
    )?;
    print!("{:<8}", "grating");
    for c in &m.cells {
        print!("{c:>10}");
    }
    println!();
    for (g, row) in m.gratings.iter().zip(&m.pm_per_g) {
        print!("{g:<8}");
        for v in row {
            print!("{v:>10.5}");
        }
        println!();
    }
    for (k, w) in &log.warnings.counts {
        println!("warning {k} ×{}: {}", w.count, w.first);
    }
    println!("wrote {}", out.display());
    Ok(())
}

/// Arguments of `fbgforge bench verify`.
#[derive(Debug, Args)]
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
}

/// A design with eight gratings (seven strain gratings on one core and the reference),
/// for the benchmark.
pub fn bench_design() -> Result<fbgforge::spec::Design> {
    let text = include_str!("../../designs/clip-on-34mm.toml");
    let mut d = fbgforge::spec::parse(text)?;
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

/// Run `fbgforge bench verify`.
pub fn bench(a: BenchVerifyArgs) -> Result<()> {
    let design = bench_design()?;
    fbgforge::output::ensure_dir(&a.out)?;
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
    eprintln!(
        "generating a {} min, {} Hz, 8-grating log ...",
        a.minutes, a.rate_hz
    );
    // Stages: generate, write, parse ×3, end to end.
    let pb = fbgforge::progress::bar(6, "bench verify");
    let (log, force, truth) = synth::generate(&design, &cfg)?;
    pb.inc(1);
    let log_path = a.out.join("bench-peaks.txt");
    let force_path = a.out.join("bench-force.csv");
    synth::write_log(
        &log_path,
        LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &LogStyle::default(),
    )?;
    synth::write_force_csv(&force_path, &force)?;
    pb.inc(1);
    drop(log);
    let mb = std::fs::metadata(&log_path)?.len() as f64 / 1e6;
    let bytes = std::fs::read(&log_path)?;

    // Stage 1: parse from memory (throughput), best of three.
    let mut parse_s = f64::MAX;
    let mut parse_cpu = f64::NAN;
    for _ in 0..3 {
        let c = cpu_time_s();
        let t = Instant::now();
        let pl = logs::parse_wavelength_bytes(&bytes, &log_path, &ReadOptions::default())?;
        let el = t.elapsed().as_secs_f64();
        if el < parse_s {
            parse_s = el;
            parse_cpu = cpu_time_s().zip(c).map_or(f64::NAN, |(b, a)| b - a);
        }
        drop(pl);
        pb.inc(1);
    }
    drop(bytes);

    // Stage 2: end to end from the files.
    pb.inc(1);
    let cpu = || cpu_time_s().unwrap_or(f64::NAN);
    let (t_all, c_all) = (Instant::now(), cpu());
    let (t, c) = (Instant::now(), cpu());
    let pl = logs::read_peak_log(&log_path, &ReadOptions::default())?;
    let read_log = (t.elapsed().as_secs_f64(), cpu() - c);
    let (t, c) = (Instant::now(), cpu());
    let fl = logs::read_force_log(&force_path, &ForceColumns::default())?;
    let read_force = (t.elapsed().as_secs_f64(), cpu() - c);
    let (t, c) = (Instant::now(), cpu());
    let (m, series) = analyse(&design, &pl, &fl, &AnalysisOptions::default())?;
    let analysed = (t.elapsed().as_secs_f64(), cpu() - c);
    let (t, c) = (Instant::now(), cpu());
    let preds = fbgforge::model::predict(&design, 10.0).map_err(|e| format!("{e:#}"));
    let v = verdict::verdicts(
        &m,
        preds.as_deref().map_err(Clone::clone),
        LoadCase::II,
        None,
        verdict::DEFAULT_TOLERANCE,
    );
    let rep = VerifyReport {
        design: design.name.clone(),
        measurement: m,
        verdict: v,
    };
    report::write_report(&a.out.join("report"), &rep, &series)?;
    let reported = (t.elapsed().as_secs_f64(), cpu() - c);
    let total = (t_all.elapsed().as_secs_f64(), cpu() - c_all);
    pb.finish_and_clear();

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
    println!("{:<32} {:>10} {:>10}  note", "stage", "wall s", "cpu s");
    for (s, t, c, n) in &rows {
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
    if a.keep {
        // So that `fbgforge verify` can be run on the kept logs.
        fbgforge::output::write_atomic(
            &a.out.join("bench-design.toml"),
            design.to_toml().as_bytes(),
        )?;
    } else {
        let _ = std::fs::remove_file(&log_path);
        let _ = std::fs::remove_file(&force_path);
    }
    println!(
        "wrote {} and {}",
        a.out.join("bench_verify.csv").display(),
        a.out.join("bench_verify.svg").display()
    );
    Ok(())
}
