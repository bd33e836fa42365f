//! `fbgforge verify`, `synth-log` and `calibrate-array`: logs to verdicts.

use super::log_args::{date_order, read_options, DateOrderArg, LogFormatArg, SpectrumArgs};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use fbgforge::array::calibrate::{self, CalibrateRequest};
use fbgforge::logs::ForceReadOptions;
use fbgforge::model::LoadCase;
use fbgforge::report::calibrate::{Charts, Table};
use fbgforge::report::synth::written;
use fbgforge::report::verify::{Printer, ReportFolder};
use fbgforge::synth::{files, module_log as synth};
use fbgforge::verify::analysis::AnalysisOptions;
use fbgforge::verify::verdict::{self, Status};
use fbgforge::verify::VerifyRequest;
use std::path::{Path, PathBuf};

/// These subcommands' request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[
    // verify
    ("VerifyRequest.case", "--case"),
    ("VerifyRequest.insert", "--insert"),
    ("VerifyRequest.k_tolerance", "--k-tolerance"),
    ("VerifyRequest.force_start", "--force-start"),
    ("VerifyRequest.calibrate_into", "--calibrate-into"),
    ("AnalysisOptions.core", "--core"),
    ("AnalysisOptions.window_half_width_nm", "--window-nm"),
    ("AnalysisOptions.clock_offset_s", "--clock-offset-s"),
    ("AnalysisOptions.max_clock_offset_s", "--max-offset-s"),
    ("AnalysisOptions.resolution_pm", "--resolution-pm"),
    ("ReadOptions.format", "--format"),
    ("ReadOptions.date_order", "--date-order"),
    ("ForceReadOptions.time", "--force-time-column"),
    ("ForceReadOptions.force", "--force-force-column"),
    ("ForceReadOptions.scale_to_n", "--force-scale-to-n"),
    ("ForceReadOptions.date_order", "--force-date-order"),
    // synth-log
    ("SynthLogRequest.schedule", "--schedule"),
    ("ModelSource.insert", "--insert"),
    ("ModelSource.core", "--core"),
    ("TrainSettings.peaks_n", "--pulses-n"),
    ("TrainSettings.pulse_s", "--pulse-s"),
    ("TrainSettings.rest_s", "--rest-s"),
    ("SynthConfig.sample_rate_hz", "--rate-hz"),
    ("SynthConfig.force_rate_hz", "--force-rate-hz"),
    ("SynthConfig.tau_s", "--tau-s"),
    ("SynthConfig.sensitivity_pm_per_n", "--k-pm-per-n"),
    ("SynthConfig.force_start_s", "--force-start-s"),
    ("SynthConfig.drift_pm_per_s", "--drift-pm-per-s"),
    (
        "SynthConfig.temperature_ramp_k_per_s",
        "--temperature-ramp-k-per-s",
    ),
    ("SynthConfig.noise_pm", "--noise-pm"),
    ("SynthConfig.quantization_pm", "--step-pm"),
    ("LogStyle.metadata_lines", "--metadata-lines"),
    ("SynthConfig.force_noise_n", "--force-noise-n"),
    // calibrate-array
    ("CalibrateRequest.log", "--log"),
    ("CalibrateRequest.schedule", "--schedule"),
    ("CalibrateRequest.window_half_width_nm", "--window-nm"),
    ("CalibrateRequest.out", "--out"),
    ("CalibrateRequest.fit_sheet", "--fit-sheet"),
    ("CalibrateRequest.resolution_pm", "--resolution-pm"),
    ("CalibrateRequest.model_tolerance", "--model-tolerance"),
];

/// A library text in this file's flags ([`FLAGS`]): what the sinks write.
fn in_flag_words(text: &str) -> String {
    fbgforge::fields::in_words(text, FLAGS)
}

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
    /// Design spec (TOML), or a shipped design's name.
    #[arg(value_parser = super::designs::design_arg)]
    pub design: PathBuf,
    /// Wavelength log (ENLIGHT Peaks or Sensors export, I-MON log, or CSV), or a
    /// spectrum log (an I-MON log read by its pixels with --imon-calibration).
    #[arg(long)]
    pub log: PathBuf,
    /// Force-stand CSV.
    #[arg(long)]
    pub force: PathBuf,
    /// Format of the wavelength log (detected if omitted).
    #[arg(long, value_enum)]
    pub format: Option<LogFormatArg>,
    /// Order of day and month in slash dates (detected from the file if omitted).
    #[arg(long, value_enum)]
    pub date_order: Option<DateOrderArg>,
    #[command(flatten)]
    pub spectrum: SpectrumArgs,
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

/// Run `fbgforge verify`. After writing everything it returns status 0 for PASS, 2 for
/// FAIL, 3 when nothing could be judged (NO RESPONSE or NOT JUDGED), 4 for IN BAND
/// (off the nominal prediction, inside the contact band) and 5 for CALIBRATE CONTACT
/// (a configuration whose contact band is too wide to judge without calibrating it), so
/// scripts can tell a failed part, an undecided one, a contact reading to calibrate and
/// an error (status 1) apart ([`VERIFY_EXIT_STATUS_HELP`]).
pub fn run_verify(a: VerifyArgs) -> Result<std::process::ExitCode> {
    // The report folder is checked before the run; the summary or the JSON follows it.
    let folder = a
        .report
        .as_deref()
        .map(|dir| ReportFolder::new(dir, in_flag_words))
        .transpose()?;
    let printer = Printer::new(a.json, a.report.as_deref(), in_flag_words);
    let mut sinks = (folder, printer);
    let outcome =
        fbgforge::verify::run_with(&verify_request(&a), &mut sinks).inspect_err(|_| {
            // A failed run leaves no report behind: a previous one would pass for this run's.
            if let Some(folder) = &sinks.0 {
                if folder.failed() {
                    eprintln!(
                        "note: removed the previous report in {} (this run wrote none)",
                        folder.dir().display()
                    );
                }
            }
        })?;
    Ok(match outcome.report.verdict.overall {
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
    req.read = read_options(a.format, a.date_order, &a.spectrum);
    req.force_read = ForceReadOptions {
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
    /// Design spec (TOML), or a shipped design's name.
    #[arg(value_parser = super::designs::design_arg)]
    pub design: PathBuf,
    /// Log format to write.
    #[arg(long, value_enum, default_value = "enlight-peaks")]
    pub format: LogFormatArg,
    /// Output folder (log.txt or log.csv, force.csv, truth.json).
    #[arg(long, default_value = "out/synth-log")]
    pub out: PathBuf,
    /// Core whose gratings respond (default: the first).
    #[arg(long)]
    pub core: Option<String>,
    /// Static K of the core's first grating, pm/N (the k-th gets K·(1 − 0.15 k)).
    #[arg(
        long,
        default_value_t = 12.0,
        allow_hyphen_values = true,
        conflicts_with = "from_model"
    )]
    pub k_pm_per_n: f64,
    /// Every grating of the core gets the K the design's model predicts (for --case and
    /// --insert; Case II by default, as `verify` judges): a log on which `verify` PASSes.
    /// The default pulses are scaled so that every shift stays within half its window.
    #[arg(long, conflicts_with = "schedule")]
    pub from_model: bool,
    /// With --from-model: the load case whose prediction the log follows (default II,
    /// or I when --insert is given).
    #[arg(long, value_enum, requires = "from_model")]
    pub case: Option<CaseArg>,
    /// With --from-model: the insert of Case I.
    #[arg(long, requires = "from_model")]
    pub insert: Option<String>,
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
    /// imon-pixels: the pixel calibration a0,a1,… written with the log (default: 512
    /// pixels from 1595 down to 1510 nm, 166 pm per pixel, as an I-MON 512); read the
    /// log back with the same --imon-calibration.
    #[arg(
        long,
        value_name = "A0,A1,…",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub imon_calibration: Vec<f64>,
    /// imon-pixels: each grating's reflection line shape: the transfer-matrix model of the
    /// design's grating (its length, `[fiber]` index_modulation and apodisation) or a
    /// Gaussian of --fwhm-nm.
    #[arg(long, value_enum, default_value = "grating")]
    pub line_shape: LineShapeArg,
    /// imon-pixels: FWHM of the Gaussian line shape, nm.
    #[arg(long, default_value_t = 0.33)]
    pub fwhm_nm: f64,
    /// imon-pixels: white noise on every pixel, counts (peaks are 30,000 counts high on a
    /// floor of 1,000).
    #[arg(long, default_value_t = 10.0)]
    pub pixel_noise_counts: f64,
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

/// The reflection line shape of a synthetic spectrum on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LineShapeArg {
    /// The design's grating by the transfer-matrix model.
    Grating,
    /// A Gaussian of --fwhm-nm.
    Gaussian,
}

/// How `synth-log` makes the spectra of an `imon-pixels` log.
fn spectrum_style(a: &SynthLogArgs) -> fbgforge::logs::SpectrumStyle {
    let default = fbgforge::logs::SpectrumStyle::default();
    fbgforge::logs::SpectrumStyle {
        imon_calibration: if a.imon_calibration.is_empty() {
            default.imon_calibration.clone()
        } else {
            a.imon_calibration.clone()
        },
        line_shape: match a.line_shape {
            LineShapeArg::Grating => fbgforge::logs::LineShape::Design,
            LineShapeArg::Gaussian => fbgforge::logs::LineShape::Gaussian { fwhm_nm: a.fwhm_nm },
        },
        noise_counts: a.pixel_noise_counts,
        seed: a.seed,
        ..default
    }
}

/// Run `fbgforge synth-log`.
pub fn run_synth_log(a: SynthLogArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    let run = match &a.schedule {
        Some(schedule) => files::SynthRun::ArrayCalibration {
            schedule: schedule.clone(),
            sample_rate_hz: a.rate_hz,
            noise_pm: a.noise_pm,
            drift_pm_per_s: a.drift_pm_per_s,
            seed: a.seed,
        },
        None => files::SynthRun::Module(synth_config(&a, &design)?),
    };
    let req = files::SynthLogRequest {
        format: a.format.into(),
        out_dir: a.out.clone(),
        style: LogStyle {
            decimal_comma: a.decimal_comma,
            bom: a.bom,
            metadata_lines: a.metadata_lines,
            twelve_hour: a.twelve_hour,
            spectrum: spectrum_style(&a),
        },
        run,
    };
    println!("{}", written(&files::write_synth_log(&design, &req)?));
    Ok(())
}

/// The module run that `fbgforge synth-log`'s flags describe.
fn synth_config(a: &SynthLogArgs, design: &fbgforge::spec::Design) -> Result<synth::SynthConfig> {
    let shape = match a.shape {
        ShapeArg::Haversine => synth::PulseShape::Haversine,
        ShapeArg::Trapezoid => synth::PulseShape::Trapezoid { ramp_s: a.ramp_s },
        ShapeArg::Staircase => synth::PulseShape::Staircase {
            steps: a.steps,
            ramp_s: a.ramp_s,
        },
        ShapeArg::Sine => synth::PulseShape::Sine { cycles: a.cycles },
    };
    let grating_k = synth_grating_k(a, design)?;
    let peaks_n = if a.from_model && a.pulses_n == DEFAULT_PULSES_N {
        // The default protocol scaled so that the model's shifts stay in their windows.
        let top = fbgforge::synth::from_model::largest_force_n(design, &grating_k);
        let peaks: Vec<f64> = a.pulses_n.iter().map(|p| p / 50.0 * top).collect();
        // Printed to its two significant figures (7.8, not 7.800000000000001).
        let decimals = (1.0 - top.log10().floor()).max(0.0) as usize;
        println!("pulses scaled to the model: {top:.decimals$} N at most (--pulses-n sets them)");
        peaks
    } else {
        a.pulses_n.clone()
    };
    let (pulses, duration) = synth::train(&synth::TrainSettings {
        peaks_n,
        pulse_s: a.pulse_s,
        rest_s: a.rest_s,
        lead_s: 5.0,
        shape,
    })?;
    Ok(synth::SynthConfig {
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
    })
}

/// `synth-log`'s default pulses, N (`--pulses-n`).
const DEFAULT_PULSES_N: [f64; 6] = [10.0, 20.0, 30.0, 40.0, 50.0, 25.0];

/// The K's set by name: `--grating-k`, and with `--from-model` the model's under them.
fn synth_grating_k(
    a: &SynthLogArgs,
    design: &fbgforge::spec::Design,
) -> Result<Vec<(String, f64)>> {
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
    if a.from_model {
        from_model_k(a, design, grating_k)
    } else {
        Ok(grating_k)
    }
}

use synth::LogStyle;

/// `--from-model`: the model's K for every grating of the core, the `--grating-k`
/// settings on top; the K's are printed, as the log's truth.
fn from_model_k(
    a: &SynthLogArgs,
    design: &fbgforge::spec::Design,
    explicit: Vec<(String, f64)>,
) -> Result<Vec<(String, f64)>> {
    use fbgforge::synth::from_model::{model_sensitivities, ModelSource};
    let source = ModelSource {
        core: a.core.clone(),
        case: a.case.map(|c| match c {
            CaseArg::I => LoadCase::I,
            CaseArg::II => LoadCase::II,
        }),
        insert: a.insert.clone(),
    };
    let mut k = model_sensitivities(design, &source)
        .map_err(|e| anyhow::anyhow!(in_flag_words(&format!("{e:#}"))))?;
    for (name, v) in explicit {
        match k.iter_mut().find(|(n, _)| *n == name) {
            Some(slot) => slot.1 = v,
            None => k.push((name, v)),
        }
    }
    println!(
        "{}",
        fbgforge::report::synth::model_k_line(source.load_case(), source.insert.as_deref(), &k)
    );
    Ok(k)
}

/// Arguments of `fbgforge calibrate-array`.
#[derive(Debug, Args)]
pub struct CalibrateArrayArgs {
    /// Design spec with an [array] (TOML), or a shipped design's name.
    #[arg(value_parser = super::designs::design_arg)]
    pub design: PathBuf,
    /// Wavelength log of the calibration run.
    #[arg(long)]
    pub log: PathBuf,
    /// Schedule CSV: `start_s,end_s,cell,load_g`, one line per load resting on a cell
    /// (a staircase: one line per step with the total mass; simultaneous loads:
    /// overlapping lines on different cells); times in s from the log's first row, a
    /// hint: the load changes are found in the data.
    #[arg(long)]
    pub schedule: PathBuf,
    /// Format of the wavelength log (detected if omitted).
    #[arg(long, value_enum)]
    pub format: Option<LogFormatArg>,
    /// Order of day and month in slash dates.
    #[arg(long, value_enum)]
    pub date_order: Option<DateOrderArg>,
    #[command(flatten)]
    pub spectrum: SpectrumArgs,
    /// Half-width of the wavelength windows, nm.
    #[arg(long)]
    pub window_nm: Option<f64>,
    /// The interrogator's resolution, pm (default 0.5, the paper's I-MON): Table 2's
    /// resolution in g, and the smallest baseline change that counts as drift.
    #[arg(long)]
    pub resolution_pm: Option<f64>,
    /// The model's relative band for the comparison with the prediction (default 0.4
    /// = ±40 %, the models' largest error against the paper's Table 1).
    #[arg(long)]
    pub model_tolerance: Option<f64>,
    /// Output CSV of the matrix (default: out/<design>/sensing_matrix.csv), written
    /// only when no fault makes it unusable and every cell was loaded; beside it
    /// `<out>.sd.csv` (per-entry scatter, for `reconstruct --matrix-sd`),
    /// `<out>.calibration.json`, the charts and their CSVs; with a fault the matrix
    /// goes to `<out>.faulty.csv` and nothing is written at `<out>`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also fit the sheet's unknowns (modulus, thickness, table interface) to the
    /// measured matrix and say which the data pin down (`<out>.sheet-fit.json`).
    #[arg(long, alias = "fit-modulus")]
    pub fit_sheet: bool,
    /// Print the whole calibration as one JSON object on stdout instead of the text.
    #[arg(long)]
    pub json: bool,
}

/// Exit code of a calibration whose faults make the matrix unusable.
pub const EXIT_UNUSABLE: u8 = 3;

/// Run `fbgforge calibrate-array`: exit 0 when the matrix is usable, 3
/// ([`EXIT_UNUSABLE`]) when a fault makes it unusable, 1 on an error.
pub fn run_calibrate_array(a: CalibrateArrayArgs) -> Result<std::process::ExitCode> {
    let design = fbgforge::design::load(&a.design)?;
    let out = a.out.clone().unwrap_or_else(|| {
        Path::new("out")
            .join(&design.name)
            .join("sensing_matrix.csv")
    });
    let req = CalibrateRequest {
        design_file: Some(a.design.clone()),
        log: a.log.clone(),
        schedule: a.schedule.clone(),
        read: read_options(a.format, a.date_order, &a.spectrum),
        window_half_width_nm: a.window_nm,
        resolution_pm: a.resolution_pm,
        model_tolerance: a.model_tolerance,
        out: Some(out.clone()),
        fit_sheet: a.fit_sheet,
    };
    let mut charts = Charts::beside(&out);
    let outcome = if a.json {
        calibrate::run(&design, &req, &mut charts)?
    } else {
        charts.announce = true;
        calibrate::run(&design, &req, &mut (Table, charts))?
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&outcome)?);
    }
    Ok(if outcome.calibration.usable {
        std::process::ExitCode::SUCCESS
    } else {
        std::process::ExitCode::from(EXIT_UNUSABLE)
    })
}
