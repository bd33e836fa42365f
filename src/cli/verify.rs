//! `fbgforge verify`, `synth-log` and `calibrate-array`: logs to verdicts.

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use fbgforge::logs::{num::DateOrder, ForceColumns, LogFormat, ReadOptions};
use fbgforge::model::LoadCase;
use fbgforge::verify::analysis::AnalysisOptions;
use fbgforge::verify::report;
use fbgforge::verify::verdict::{self, Status};
use fbgforge::array::calibrate;
use fbgforge::synth::{files, module_log as synth};
use fbgforge::verify::{VerifyOutcome, VerifyRequest};
use std::path::{Path, PathBuf};

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[];

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

/// What `fbgforge verify`'s exit status says, for `--help`.
pub const VERIFY_EXIT_STATUS_HELP: &str = "\
Exit status (after every output is written):
  0  PASS               every grating the model says responds was judged and passes
  1  error              nothing judged (bad input, unreadable log, ...)
  2  FAIL               a grating is off the model beyond the tolerance and the band,
                        or a grating the model says responds shows no response (dead)
  3  NOT JUDGED or      no prediction, a force that cannot be trusted (saturated
     NO RESPONSE        channel or gaps in too many presses), a missing channel;
                        or no grating responded to the force at all
  4  IN BAND            off the nominal prediction but inside the band between the
                        bounding contact readings: calibrate the contact
  5  CALIBRATE CONTACT  the bounding contact readings span more than a factor 3:
                        this configuration cannot be judged without calibrating the
                        contact (--calibrate-into on a part known to be good)";

/// Arguments of `fbgforge verify`.
#[derive(Debug, Args)]
#[command(after_help = VERIFY_EXIT_STATUS_HELP)]
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
    /// Largest accepted relative error of K against the model, as a fraction in
    /// (0, 0.5] (0.08 = 8 %). (`build --tolerance` is a meshing tolerance in mm; this
    /// is not.)
    #[arg(long, default_value_t = verdict::DEFAULT_TOLERANCE)]
    pub k_tolerance: f64,
    /// Half-width of the wavelength windows, nm, in (0, 10] (default: half the smallest
    /// spacing, at most 2.5 nm).
    #[arg(long)]
    pub window_nm: Option<f64>,
    /// Known clock offset, force clock − wavelength clock, s (estimated if omitted).
    #[arg(long, allow_hyphen_values = true)]
    pub clock_offset_s: Option<f64>,
    /// When the force recording started, read off the wavelength log's clock (for a
    /// force log with relative times), e.g. "2025-04-17 15:44:54.3": makes the lags
    /// absolute. An alternative to --clock-offset-s.
    #[arg(long)]
    pub force_start: Option<String>,
    /// Search range of the estimated clock offset around the prior, s, in [0, 86400].
    #[arg(long, default_value_t = 60.0)]
    pub max_offset_s: f64,
    /// Interrogator resolution, pm, in (0, 100] (default: 1 pm, 0.5 pm for I-MON logs).
    #[arg(long)]
    pub resolution_pm: Option<f64>,
    /// Name of the force log's time column.
    #[arg(long)]
    pub force_time_column: Option<String>,
    /// Order of day and month in the force log's slash dates (detected when the file
    /// tells, else day first).
    #[arg(long, value_enum)]
    pub force_date_order: Option<DateOrderArg>,
    /// Name of the force log's force column.
    #[arg(long)]
    pub force_force_column: Option<String>,
    /// Factor from the force column's unit to N, > 0 (default: from the column name,
    /// else 1).
    #[arg(long)]
    pub force_scale_to_n: Option<f64>,
    /// Print the report as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write report.html (self-contained), report.md, report.json, SVG plots and CSVs
    /// into this folder, whole or not at all (it is replaced; a failed run removes a
    /// previous report there).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Fit the design's contact reading ([module.contact] dome_contact_radius_mm) to the
    /// measured Case I K and write the calibrated design to this TOML (atomically);
    /// `predict` and `optimize` of that design then use the measurement.
    #[arg(long, value_name = "DESIGN.toml")]
    pub calibrate_into: Option<PathBuf>,
}

fn date_order(d: DateOrderArg) -> DateOrder {
    match d {
        DateOrderArg::Dmy => DateOrder::DayMonthYear,
        DateOrderArg::Mdy => DateOrder::MonthDayYear,
    }
}

fn read_options(format: Option<LogFormat>, d: Option<DateOrderArg>) -> ReadOptions {
    ReadOptions {
        format,
        date_order: d.map(date_order),
    }
}

/// Run `fbgforge verify`. After writing everything it returns status 0 for PASS, 2 for
/// FAIL, 3 when nothing could be judged (NO RESPONSE or NOT JUDGED), 4 for IN BAND
/// (off the nominal prediction, inside the contact band) and 5 for CALIBRATE CONTACT
/// (a configuration whose contact band is too wide to judge without calibrating it), so
/// scripts can tell a failed part, an undecided one, a contact reading to calibrate and
/// an error (status 1) apart ([`VERIFY_EXIT_STATUS_HELP`]).
pub fn run_verify(a: VerifyArgs) -> Result<std::process::ExitCode> {
    if let Some(dir) = &a.report {
        report::check_report_dir(dir)?;
    }
    // A failed run leaves no report behind: a previous one would pass for this run's.
    let stale = |e: anyhow::Error| {
        if let Some(dir) = &a.report {
            if dir.exists() && report::remove_stale_report(dir).is_ok() {
                eprintln!(
                    "note: removed the previous report in {} (this run wrote none)",
                    dir.display()
                );
            }
        }
        e
    };
    let VerifyOutcome {
        report,
        series,
        calibration,
    } = fbgforge::verify::run(&verify_request(&a)).map_err(stale)?;
    if let Some(dir) = &a.report {
        report::write_report(dir, &report, &series).map_err(stale)?;
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report::summary(&report));
        if let Some(dir) = &a.report {
            println!("report: {}", dir.join("report.html").display());
        }
    }
    if let (Some(c), Some(path)) = (&calibration, &a.calibrate_into) {
        // On stderr with --json, so the JSON stays one document.
        let text = format!(
            "calibrated {}: dome_contact_radius_mm {:.4} → {:.4} mm ({} FE solves); {}; written to {}",
            c.configuration.label(),
            c.previous_radius_mm,
            c.radius_mm,
            c.evaluations,
            c.gratings
                .iter()
                .map(|g| format!(
                    "{} measured {:+.3}, model {:+.3} → {:+.3} pm/N",
                    g.grating, g.measured_pm_per_n, g.before_pm_per_n, g.after_pm_per_n
                ))
                .collect::<Vec<_>>()
                .join("; "),
            path.display()
        );
        if a.json {
            eprintln!("{text}");
        } else {
            println!("{text}");
        }
    }
    Ok(match report.verdict.overall {
        Status::Pass => std::process::ExitCode::SUCCESS,
        Status::Fail => std::process::ExitCode::from(2),
        Status::InBand => std::process::ExitCode::from(4),
        Status::CalibrateContact => std::process::ExitCode::from(5),
        Status::NotJudged | Status::NoResponse => std::process::ExitCode::from(3),
    })
}

/// The library request that `fbgforge verify`'s flags describe.
fn verify_request(a: &VerifyArgs) -> VerifyRequest {
    let mut req = VerifyRequest::new(a.design.clone(), a.log.clone(), a.force.clone());
    req.read = read_options(a.format, a.date_order);
    req.force_columns = ForceColumns {
        time: a.force_time_column.clone(),
        force: a.force_force_column.clone(),
        scale_to_n: a.force_scale_to_n,
        date_order: a.force_date_order.map(date_order),
    };
    req.case = a.case.map(|c| match c {
        CaseArg::I => LoadCase::I,
        CaseArg::II => LoadCase::II,
    });
    req.insert = a.insert.clone();
    req.analysis = AnalysisOptions {
        core: a.core.clone(),
        window_half_width_nm: a.window_nm,
        clock_offset_s: a.clock_offset_s,
        max_clock_offset_s: a.max_offset_s,
        resolution_pm: a.resolution_pm,
    };
    req.k_tolerance = a.k_tolerance;
    req.force_start = a.force_start.clone();
    req.calibrate_into = a.calibrate_into.clone();
    req
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
    /// Duration of each pulse, s.
    #[arg(long, default_value_t = 4.0)]
    pub pulse_s: f64,
    /// Shape of each pulse: the force-stand protocol.
    #[arg(long, value_enum, default_value = "haversine")]
    pub shape: ShapeArg,
    /// Ramp duration of a trapezoid or of each staircase step, s.
    #[arg(long, default_value_t = 1.0)]
    pub ramp_s: f64,
    /// Steps up (and as many down) of a staircase.
    #[arg(long, default_value_t = 10)]
    pub steps: u32,
    /// Cycles of a sine filling each pulse.
    #[arg(long, default_value_t = 8)]
    pub cycles: u32,
    /// Pure transport delay of the response behind the force, s (on top of the
    /// SLS lag).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub delay_s: f64,
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
    /// The interrogator's wavelength step, pm: peaks are rounded to it (an SM125
    /// reports 1 pm steps); 0 leaves them unrounded.
    #[arg(long, default_value_t = 0.0)]
    pub step_pm: f64,
    /// The force channel saturates at this force, N (a clipped load cell).
    #[arg(long)]
    pub force_saturation_n: Option<f64>,
    /// The force stand's clock runs this many ppm fast against the interrogator's.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub force_skew_ppm: f64,
    /// Set one grating's K, pm/N, as NAME=K (repeatable; 0 makes a dead grating).
    #[arg(long, value_name = "NAME=K", allow_hyphen_values = true)]
    pub grating_k: Vec<String>,
}

/// Pulse shape on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ShapeArg {
    /// Impulse-like haversine presses.
    Haversine,
    /// Press-hold-release (trapezoid, ramps of --ramp-s).
    Trapezoid,
    /// Staircase of --steps steps up and down (ramps of --ramp-s).
    Staircase,
    /// Sine from rest, --cycles per pulse.
    Sine,
}

/// Run `fbgforge synth-log`.
pub fn run_synth_log(a: SynthLogArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    let style = LogStyle {
        decimal_comma: a.decimal_comma,
        bom: a.bom,
        metadata_lines: a.metadata_lines,
        twelve_hour: a.twelve_hour,
    };
    if let Some(schedule) = &a.schedule {
        let files = files::write_synth_log(
            &design,
            &files::SynthLogRequest {
                format: a.format,
                out_dir: a.out.clone(),
                style,
                run: files::SynthRun::ArrayCalibration {
                    schedule: schedule.clone(),
                    sample_rate_hz: a.rate_hz,
                    noise_pm: a.noise_pm,
                    drift_pm_per_s: a.drift_pm_per_s,
                    seed: a.seed,
                },
            },
        )?;
        let truth = files.matrix_truth.unwrap_or_default();
        println!("wrote {} and {}", files.log.display(), truth.display());
        return Ok(());
    }
    let shape = match a.shape {
        ShapeArg::Haversine => synth::PulseShape::Haversine,
        ShapeArg::Trapezoid => synth::PulseShape::Trapezoid { ramp_s: a.ramp_s },
        ShapeArg::Staircase => synth::PulseShape::Staircase {
            steps: a.steps,
            ramp_s: a.ramp_s,
        },
        ShapeArg::Sine => synth::PulseShape::Sine { cycles: a.cycles },
    };
    let (pulses, duration) = synth::train(&a.pulses_n, a.pulse_s, a.rest_s, 5.0, shape)?;
    let grating_k = a
        .grating_k
        .iter()
        .map(|g| {
            let (name, k) = g
                .split_once('=')
                .with_context(|| format!("--grating-k `{g}`: expected NAME=K, e.g. lambda_21=0"))?;
            let k: f64 = k
                .trim()
                .parse()
                .with_context(|| format!("--grating-k `{g}`: `{k}` is not a number (pm/N)"))?;
            Ok((name.trim().to_string(), k))
        })
        .collect::<Result<Vec<_>>>()?;
    let cfg = synth::SynthConfig {
        core: a.core.clone(),
        sensitivity_pm_per_n: a.k_pm_per_n,
        sample_rate_hz: a.rate_hz,
        force_rate_hz: a.force_rate_hz,
        pulses,
        duration_s: duration,
        tau_s: a.tau_s,
        instant_fraction: a.instant_fraction,
        transport_delay_s: a.delay_s,
        force_start_s: a.force_start_s,
        noise_pm: a.noise_pm,
        force_noise_n: a.force_noise_n,
        drift_pm_per_s: a.drift_pm_per_s,
        temperature_ramp_k_per_s: a.temperature_ramp_k_per_s,
        dropout_fraction: a.dropout,
        seed: a.seed,
        quantization_pm: a.step_pm,
        force_saturation_n: a.force_saturation_n,
        force_clock_skew_ppm: a.force_skew_ppm,
        grating_sensitivity_pm_per_n: grating_k,
        ..Default::default()
    };
    let files = files::write_synth_log(
        &design,
        &files::SynthLogRequest {
            format: a.format,
            out_dir: a.out.clone(),
            style,
            run: files::SynthRun::Module(cfg),
        },
    )?;
    println!(
        "wrote {}, {} and {}",
        files.log.display(),
        files.force.unwrap_or_default().display(),
        files.truth.unwrap_or_default().display()
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
    /// Also fit the silicone's modulus of the sheet model to the measured matrix and
    /// report the misfit of every entry (JSON beside the matrix: `<out>.modulus-fit.json`).
    #[arg(long)]
    pub fit_modulus: bool,
}

/// Run `fbgforge calibrate-array`.
pub fn run_calibrate_array(a: CalibrateArrayArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    let cal = calibrate::calibrate_array(
        &design,
        &a.log,
        &a.schedule,
        &read_options(a.format, a.date_order),
        a.window_nm,
    )?;
    let (m, warnings) = (cal.matrix, cal.warnings);
    let out = a.out.clone().unwrap_or_else(|| {
        Path::new("out")
            .join(&design.name)
            .join("sensing_matrix.csv")
    });
    fbgforge::array::io::write_matrix_with_comments(
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
    for (g, row) in m.gratings.iter().zip(m.sensitivity_pm_per_g.row_iter()) {
        print!("{g:<8}");
        for v in row.iter() {
            print!("{v:>10.5}");
        }
        println!();
    }
    for (k, w) in &warnings.counts {
        println!("warning {k} ×{}: {}", w.count, w.first);
    }
    println!("wrote {}", out.display());
    if a.fit_modulus {
        let f = fbgforge::array::sheet::fit::fit_modulus(&design, &m).with_context(|| {
            format!("{}: fitting the sheet model's modulus", a.design.display())
        })?;
        let path = out.with_extension("modulus-fit.json");
        fbgforge::output::write_json(&path, &f)?;
        println!(
            "sheet model's modulus: design {} MPa (misfit {:.1} %), fitted {:.4} MPa (misfit {:.1} %; {:.1} % at half, {:.1} % at twice){}",
            f.design_modulus_mpa,
            100.0 * f.design_rel_rms,
            f.fitted_modulus_mpa,
            100.0 * f.fitted_rel_rms,
            100.0 * f.rel_rms_at_half_and_double.0,
            100.0 * f.rel_rms_at_half_and_double.1,
            if f.at_search_limit {
                " — at the end of the search range (0.05–50 MPa): the modulus alone cannot reach this matrix's level"
            } else {
                ""
            }
        );
        let worst = f
            .entries
            .iter()
            .filter_map(|e| e.misfit_pct.map(|p| (p, e)))
            .max_by(|x, y| x.0.abs().total_cmp(&y.0.abs()));
        if let Some((p, e)) = worst {
            println!(
                "largest misfit: {} × cell {}: measured {:.5}, model {:.5} pm/g ({p:+.1} %); every entry in {}",
                e.grating,
                e.cell,
                e.measured_pm_per_g,
                e.model_pm_per_g,
                path.display()
            );
        }
    }
    Ok(())
}
