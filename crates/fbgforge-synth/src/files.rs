//! The file-level helpers beside verification, as use cases the command line
//! (`synth-log`, `calibrate-array`) and the Python binding share: write a synthetic log
//! set whose answers are known ([`write_synth_log`]) and measure an array's sensing
//! matrix from a logged loading run ([`calibrate_array`]).

use crate::array::calibrate;
use crate::array::SensingMatrix;
use crate::logs::{self, LogFormat};
use crate::spec::Design;
use crate::{array_log, module_log as synth};
use anyhow::Result;
use serde::Serialize;
use std::path::PathBuf;

/// What a synthetic log set is made of.
#[derive(Debug, Clone)]
pub enum SynthRun {
    /// A module pressed by a pulse train: wavelength log, force log and the truth.
    Module(synth::SynthConfig),
    /// An array loaded cell by cell as a schedule says: the wavelength log and the
    /// true matrix (the power-law kernel of reference §2).
    ArrayCalibration {
        /// Schedule CSV: `start_s,end_s,cell,load_g`.
        schedule: PathBuf,
        /// Wavelength sample rate, Hz.
        sample_rate_hz: f64,
        /// Noise on every peak, pm.
        noise_pm: f64,
        /// Drift of every grating, pm/s.
        drift_pm_per_s: f64,
        /// Random seed.
        seed: u64,
    },
}

/// Where and how to write a synthetic log set.
#[derive(Debug, Clone)]
pub struct SynthLogRequest {
    /// Format of the wavelength log.
    pub format: LogFormat,
    /// Output folder: `log.<ext>`, and `force.csv` + `truth.json` or `matrix_truth.csv`.
    pub out_dir: PathBuf,
    /// How the log is written (decimal commas, BOM, metadata, 12-hour clock).
    pub style: logs::LogStyle,
    /// The run.
    pub run: SynthRun,
}

/// The files a synthetic log set was written to, and its known answers.
#[derive(Debug, Clone, Serialize)]
pub struct SynthLogFiles {
    /// The wavelength log.
    pub log: PathBuf,
    /// The force log (module runs).
    pub force: Option<PathBuf>,
    /// `truth.json` (module runs).
    pub truth: Option<PathBuf>,
    /// `matrix_truth.csv` (array calibration runs).
    pub matrix_truth: Option<PathBuf>,
    /// The known answers of a module run, as `truth.json` holds them.
    pub truth_values: Option<synth::SynthTruth>,
    /// The true sensing matrix of an array calibration run.
    pub matrix: Option<SensingMatrix>,
}

/// The style with an `imon-pixels` log's line shapes taken from `design`'s gratings of
/// those names when it asks for them ([`logs::LineShape::Design`]).
fn resolved_style(
    design: &Design,
    style: &logs::LogStyle,
    names: &[String],
) -> Result<logs::LogStyle> {
    let mut style = style.clone();
    if style.spectrum.line_shape == logs::LineShape::Design {
        let gratings = names
            .iter()
            .map(|n| {
                design
                    .bragg_grating(n)
                    .ok_or_else(|| anyhow::anyhow!("design `{}` has no grating `{n}`", design.name))
            })
            .collect::<Result<Vec<_>>>()?;
        style.spectrum.line_shape = logs::LineShape::Gratings(gratings);
    }
    Ok(style)
}

/// Generate a synthetic run for `design` and write it, each file atomically.
pub fn write_synth_log(design: &Design, req: &SynthLogRequest) -> Result<SynthLogFiles> {
    let log_path = req
        .out_dir
        .join(format!("log.{}", synth::extension(req.format)));
    match &req.run {
        SynthRun::ArrayCalibration {
            schedule,
            sample_rate_hz,
            noise_pm,
            drift_pm_per_s,
            seed,
        } => {
            let n_cells = design
                .array
                .as_ref()
                .map_or(0, |x| (x.cells_x * x.cells_y) as usize);
            let sched = calibrate::read_schedule(schedule, n_cells)?;
            let matrix = calibrate::power_law_matrix(design)?;
            let log = array_log::synth_calibration_log(
                design,
                &matrix,
                &sched,
                *sample_rate_hz,
                *noise_pm,
                *drift_pm_per_s,
                *seed,
            )?;
            let cfg = synth::SynthConfig {
                sample_rate_hz: *sample_rate_hz,
                ..Default::default()
            };
            let style = resolved_style(design, &req.style, &log.names)?;
            synth::write_log(&log_path, req.format, &log, &cfg, &style)?;
            let truth = req.out_dir.join("matrix_truth.csv");
            crate::array::io::write_matrix_with_comments(
                &truth,
                &matrix,
                &["synthetic truth: power-law kernel fitted to Table 1, about 44.7 pm·mm²/g · d^-2.05 (reference §2)".into()],
            )?;
            Ok(SynthLogFiles {
                log: log_path,
                force: None,
                truth: None,
                matrix_truth: Some(truth),
                truth_values: None,
                matrix: Some(matrix),
            })
        }
        SynthRun::Module(cfg) => {
            let (log, force, mut truth) = synth::generate(design, cfg)?;
            truth.clock_offset_s = synth::reported_offset_s(cfg, req.format);
            let style = resolved_style(design, &req.style, &log.names)?;
            synth::write_log(&log_path, req.format, &log, cfg, &style)?;
            let force_path = req.out_dir.join("force.csv");
            synth::write_force_csv(&force_path, &force)?;
            let truth_path = req.out_dir.join("truth.json");
            crate::output::write_json(&truth_path, &truth)?;
            Ok(SynthLogFiles {
                log: log_path,
                force: Some(force_path),
                truth: Some(truth_path),
                matrix_truth: None,
                truth_values: Some(truth),
                matrix: None,
            })
        }
    }
}
