//! `fbgforge verify`, `synth-log` and `calibrate-array`: logs to verdicts.

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use fbgforge::logs::{self, num::DateOrder, ForceColumns, LogFormat, ReadOptions};
use fbgforge::model::LoadCase;
use fbgforge::verify::analysis::AnalysisOptions;
use fbgforge::verify::report;
use fbgforge::verify::verdict::{self, Status};
use fbgforge::verify::{calibrate, synth};
use fbgforge::verify::{VerifyOutcome, VerifyRequest};
use std::path::{Path, PathBuf};

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
    /// Largest accepted relative error of K against the model, as a fraction
    /// (0.08 = 8 %). (`build --tolerance` is a meshing tolerance in mm; this is not.)
    #[arg(long, default_value_t = verdict::DEFAULT_TOLERANCE)]
    pub k_tolerance: f64,
    /// Half-width of the wavelength windows, nm (default: half the smallest spacing, at most 2.5 nm).
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
    /// Search range of the estimated clock offset around the prior, s.
    #[arg(long, default_value_t = 60.0)]
    pub max_offset_s: f64,
    /// Interrogator resolution, pm (default: 1 pm, 0.5 pm for I-MON logs).
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
    /// Factor from the force column's unit to N (default: from the column name, else 1).
    #[arg(long)]
    pub force_scale_to_n: Option<f64>,
    /// Print the report as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Write report.md, report.json, SVG plots and CSVs into this folder.
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
/// FAIL, 3 when nothing could be judged (NO RESPONSE or NOT JUDGED) and 4 for IN BAND
/// (off the nominal prediction, inside the contact band), so scripts can tell a failed
/// part, an undecided one, a contact reading to calibrate and an error (status 1) apart.
pub fn run_verify(a: VerifyArgs) -> Result<std::process::ExitCode> {
    let VerifyOutcome {
        report,
        series,
        calibration,
    } = fbgforge::verify::run(&verify_request(&a))?;
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
        fbgforge::array::io::write_matrix_with_comments(
            &truth,
            &matrix,
            &["synthetic truth: power-law kernel fitted to Table 1, about 44.7 pm·mm²/g · d^-2.05 (reference §2)".into()],
        )?;
        println!("wrote {} and {}", log_path.display(), truth.display());
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
    let pulses = synth::shaped_train(&a.pulses_n, a.pulse_s, a.rest_s, 5.0, shape);
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
        transport_delay_s: a.delay_s,
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
    /// Also fit the silicone's modulus of the sheet model to the measured matrix and
    /// report the misfit of every entry (JSON beside the matrix: `<out>.modulus-fit.json`).
    #[arg(long)]
    pub fit_modulus: bool,
}

/// Run `fbgforge calibrate-array`.
pub fn run_calibrate_array(a: CalibrateArrayArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
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
    for (k, w) in &log.warnings.counts {
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
