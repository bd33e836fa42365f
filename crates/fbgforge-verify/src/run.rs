//! The verify use case: a design and two log files in, a judged report out.
//! `fbgforge verify`, the verify study and the Python bindings all call [`run`] or
//! [`run_with`] (or its two stages, [`read_inputs`] and [`judge`]), so the pipeline is
//! written once; the results go to a [`VerifySink`].

use super::analysis::{analyse, analyse_assigned, analyse_owned, AnalysisOptions, Series};
use super::report::VerifyReport;
use super::sink::VerifySink;
use super::verdict;
use crate::logs::{self, ForceLog, ForceReadOptions, PeakLog, ReadOptions};
use crate::model::LoadCase;
use crate::prediction::ContactCalibration;
use crate::spec::Design;
use anyhow::{bail, Result};
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// What to verify and how.
#[derive(Debug, Clone)]
pub struct VerifyRequest {
    /// Design spec (TOML).
    pub design: PathBuf,
    /// Wavelength log (ENLIGHT Peaks or Sensors export, I-MON log, or CSV).
    pub log: PathBuf,
    /// Force-stand CSV.
    pub force: PathBuf,
    /// How to read the wavelength log (format and date order detected when `None`).
    pub read: ReadOptions,
    /// How to read the force log: which columns hold time and force, their unit.
    pub force_read: ForceReadOptions,
    /// Load case (default: I with an insert, II without).
    pub case: Option<LoadCase>,
    /// Insert used in Case I.
    pub insert: Option<String>,
    /// Analysis options (core, windows, clock offset, resolution).
    pub analysis: AnalysisOptions,
    /// Largest accepted relative error of K against the model (0.08 = 8 %).
    pub k_tolerance: f64,
    /// When the force recording started, on the wavelength log's wall clock, as the
    /// user read it (`2025-04-17 15:44:54.3`; ISO, or slash dates in the wavelength
    /// log's date order): gives the clock offset of a relative force log, so lags are
    /// absolute. An alternative to `analysis.clock_offset_s`.
    pub force_start: Option<String>,
    /// Fit the design's contact reading (`[module.contact].dome_contact_radius_mm`) to
    /// the measured Case I K and write the calibrated design here (atomically).
    pub calibrate_into: Option<PathBuf>,
}

impl VerifyRequest {
    /// A request with every option at its default.
    pub fn new(design: PathBuf, log: PathBuf, force: PathBuf) -> Self {
        VerifyRequest {
            design,
            log,
            force,
            read: ReadOptions::default(),
            force_read: ForceReadOptions::default(),
            case: None,
            insert: None,
            analysis: AnalysisOptions::default(),
            k_tolerance: verdict::DEFAULT_TOLERANCE,
            force_start: None,
            calibrate_into: None,
        }
    }

    /// The load case the request names or implies.
    pub(crate) fn load_case(&self) -> LoadCase {
        self.case.unwrap_or(if self.insert.is_some() {
            LoadCase::I
        } else {
            LoadCase::II
        })
    }

    /// Check the request's numbers (each finite and in its range, the error naming the
    /// field and the range) and that the clock offset is given at most one way.
    pub fn validate(&self) -> Result<()> {
        let tol = self.k_tolerance;
        if !(tol > 0.0 && tol <= verdict::MAX_TOLERANCE) {
            bail!(
                "the K tolerance (VerifyRequest.k_tolerance) must be a fraction in (0, {}] (0.08 = 8 %), got {tol}",
                verdict::MAX_TOLERANCE
            );
        }
        self.analysis.validate()?;
        if let Some(f) = self.force_read.scale_to_n {
            if !(f > 0.0 && f.is_finite()) {
                bail!("the force column's factor to N (ForceReadOptions.scale_to_n) must be a finite number > 0, got {f}");
            }
        }
        if self.force_start.is_some() && self.analysis.clock_offset_s.is_some() {
            bail!(
                "give either VerifyRequest.force_start or AnalysisOptions.clock_offset_s, not both"
            );
        }
        Ok(())
    }
}

/// A judged report and the aligned series behind it (for plots).
#[derive(Debug, Clone)]
pub struct VerifyOutcome {
    /// The report: measurement and verdict.
    pub report: VerifyReport,
    /// Aligned force and wavelength series.
    pub series: Series,
    /// The contact calibration, when one was asked for (`calibrate_into`).
    pub calibration: Option<ContactCalibration>,
}

/// The inputs of a verification, read and checked.
#[derive(Debug, Clone)]
pub struct VerifyInputs {
    /// The design.
    pub design: Design,
    /// The wavelength log.
    pub log: PeakLog,
    /// The force log.
    pub force: ForceLog,
}

/// Read, analyse and judge (and calibrate, when asked): the outcome, returned.
///
/// ```
/// use fbgforge_verify::{run, verdict::Status, VerifyRequest};
/// use std::fmt::Write as _;
///
/// // A run of six 30 N presses: the force stand's log, and the wavelength log of a part
/// // whose grating λ_11 (1546.295 nm) shifts by K = 12 pm/N with a lag of τ = 0.3 s,
/// // beside an unloaded λ_12 and the temperature reference λ_temp.
/// let force_at = |t: f64| {
///     let x = (t - 5.0) % 10.0;
///     if t > 5.0 && t < 65.0 && x < 4.0 { 15.0 * (1.0 - (std::f64::consts::TAU * x / 4.0).cos()) } else { 0.0 }
/// };
/// let (mut force, mut peaks) = (String::from("time_s,force_N\n"), String::from("time_s,a,b,c\n"));
/// let mut shift = 0.0;
/// for i in 0..7000 {
///     let t = i as f64 / 100.0;
///     writeln!(force, "{t:.2},{:.4}", force_at(t))?;
///     shift += (12.0 * force_at(t) - shift) * 0.01 / 0.3;
///     let noise = 0.2 * ((i as f64 * 0.7).sin());
///     if i % 5 == 0 {
///         writeln!(peaks, "{t:.2},{:.5},{:.5},{:.5}", 1546.295 + (shift + noise) / 1e3, 1524.570 + noise / 1e3, 1560.146)?;
///     }
/// }
/// let dir = tempfile::tempdir()?;
/// let (log, stand) = (dir.path().join("peaks.csv"), dir.path().join("stand.csv"));
/// std::fs::write(&log, peaks)?;
/// std::fs::write(&stand, force)?;
///
/// let design = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../designs/clip-on-34mm.toml");
/// let mut req = VerifyRequest::new(design, log, stand);
/// req.analysis.core = Some("psc1".into());
/// let outcome = run(&req)?;
/// let g = &outcome.report.measurement.gratings[0];
/// assert_eq!(g.grating, "lambda_11");
/// assert!((g.sensitivity_pm_per_n - 12.0).abs() < 0.2, "{}", g.sensitivity_pm_per_n);
/// // The model's K of this core is far from 12 pm/N: the part fails.
/// assert_eq!(outcome.report.verdict.overall, Status::Fail);
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn run(req: &VerifyRequest) -> Result<VerifyOutcome> {
    run_with(req, &mut ())
}

/// [`run`], handing the results to `sink` (the judged report and the series, then the
/// contact calibration) once everything has been computed: a failed calibration
/// leaves the sink untold.
pub fn run_with(req: &VerifyRequest, sink: &mut dyn VerifySink) -> Result<VerifyOutcome> {
    let (inputs, tracks) = read_inputs_assigned(req)?;
    let given;
    let req_used = match &req.force_start {
        None => req,
        Some(text) => {
            let mut r = req.clone();
            r.analysis.clock_offset_s = Some(offset_from_force_start(text, &inputs, &r.read)?);
            given = r;
            &given
        }
    };
    // The inputs handed over: the log's peaks are freed once assigned to gratings, the
    // two logs' times become the analysis's own.
    let VerifyInputs { design, log, force } = inputs;
    let logs = (Cow::Owned(log), tracks, Cow::Owned(force));
    let mut outcome = judge_log(req_used, &design, logs)?;
    if let Some(path) = &req.calibrate_into {
        outcome.calibration = Some(calibrate_into(req, &design, &outcome.report, path, &*sink)?);
    }
    sink.judged(&outcome.report, &outcome.series)?;
    if let (Some(c), Some(path)) = (&outcome.calibration, &req.calibrate_into) {
        sink.calibrated(c, path)?;
    }
    Ok(outcome)
}

/// Fit the design's contact reading to the measured K of the gratings that responded,
/// and write the calibrated design to `path` (its header in the front end's words).
fn calibrate_into(
    req: &VerifyRequest,
    design: &Design,
    report: &VerifyReport,
    path: &Path,
    sink: &dyn VerifySink,
) -> Result<ContactCalibration> {
    use crate::prediction::{calibrate_contact, with_contact_radius};
    if req.load_case() != LoadCase::I {
        bail!("VerifyRequest.calibrate_into fits the Case I contact reading: give a Case I log (VerifyRequest.case I VerifyRequest.insert NAME)");
    }
    let Some(insert) = req.insert.clone() else {
        bail!("VerifyRequest.calibrate_into needs the insert used (VerifyRequest.insert NAME)");
    };
    if let Some(why) = &report.measurement.force_trust.not_judged {
        bail!("VerifyRequest.calibrate_into: the force cannot be trusted, so neither can K: {why}");
    }
    let responded: Vec<_> = report
        .measurement
        .gratings
        .iter()
        .zip(&report.verdict.gratings)
        .filter(|(_, v)| v.responded)
        .map(|(g, _)| g)
        .collect();
    let Some(core) = responded.first().and_then(|g| g.core.clone()) else {
        bail!(
            "VerifyRequest.calibrate_into: no grating responded to the force, so there is no K to calibrate on"
        );
    };
    let measured: Vec<(String, f64)> = responded
        .iter()
        .filter(|g| g.core.as_deref() == Some(core.as_str()))
        .map(|g| (g.grating.clone(), g.sensitivity_pm_per_n))
        .collect();
    let config = crate::model::Configuration {
        core,
        case: LoadCase::I,
        insert: Some(insert.clone()),
    };
    let cal = calibrate_contact(
        design,
        &config,
        &measured,
        &crate::fem::FemOptions::default(),
    )?;
    let mut out = with_contact_radius(design, cal.radius_mm);
    if let Some(m) = out.module.as_mut() {
        m.contact.note = Some(format!(
            "dome_contact_radius_mm calibrated by fbgforge verify on {} with {} (insert {insert}): was {:.4} mm",
            req.log.display(),
            req.force.display(),
            cal.previous_radius_mm
        ));
    }
    let header = sink.in_words(&format!(
        "# Written by fbgforge verify VerifyRequest.calibrate_into from {}: [module.contact] calibrated on a measured Case I log.",
        req.design.display()
    ));
    let text = format!("{header}\n{}", out.to_toml());
    crate::design::parse(&text)
        .map_err(|e| anyhow::anyhow!("internal: the calibrated design does not load back: {e}"))?;
    crate::output::write_atomic(path, text.as_bytes())?;
    Ok(cal)
}

/// Stage 1: check the request against the design and read both logs.
pub fn read_inputs(req: &VerifyRequest) -> Result<VerifyInputs> {
    req.validate()?;
    let design = crate::design::load(&req.design)?;
    check_insert(&design, req)?;
    let log = logs::read_peak_log(&req.log, &req.read)?;
    let force = logs::read_force_log(&req.force, &req.force_read)?;
    Ok(VerifyInputs { design, log, force })
}

/// [`read_inputs`], with a long log's peaks assigned to the design's gratings as it is
/// read ([`logs::read_peak_log_assigned`]: its peak table never held whole) and before
/// the force log is read: the log without its peaks and the tracks, or (a log read
/// whole, a design whose gratings the analysis will refuse) the log and no tracks.
fn read_inputs_assigned(
    req: &VerifyRequest,
) -> Result<(VerifyInputs, Option<Vec<logs::assign::GratingTrack>>)> {
    req.validate()?;
    let design = crate::design::load(&req.design)?;
    check_insert(&design, req)?;
    // Windows the analysis refuses: read as before, for the analysis to say why.
    let (log, tracks) = match crate::analysis::grating_windows(&design, &req.analysis) {
        Ok(w) => logs::read_peak_log_assigned(&req.log, &req.read, &w)?,
        Err(_) => (logs::read_peak_log(&req.log, &req.read)?, None),
    };
    let force = logs::read_force_log(&req.force, &req.force_read)?;
    Ok((VerifyInputs { design, log, force }, tracks))
}

/// The clock offset a `force_start` wall-clock time gives (force clock − wavelength
/// clock, s), checked against what the two logs carry.
pub(crate) fn offset_from_force_start(
    text: &str,
    inputs: &VerifyInputs,
    read: &ReadOptions,
) -> Result<f64> {
    use crate::logs::{num, Clock};
    if inputs.log.clock != Clock::Absolute {
        bail!("VerifyRequest.force_start needs a wavelength log with wall-clock times; {} has relative times: give AnalysisOptions.clock_offset_s instead", inputs.log.source.display());
    }
    if inputs.force.clock == Clock::Absolute {
        bail!("VerifyRequest.force_start is for a force log with relative times; {} carries wall-clock times already (drop VerifyRequest.force_start)", inputs.force.source.display());
    }
    let (date, secs) = num::parse_datetime(text.as_bytes()).ok_or_else(|| {
        anyhow::anyhow!(
            "VerifyRequest.force_start `{text}`: expected a date and time such as 2025-04-17 15:44:54.3"
        )
    })?;
    let order = read.date_order.unwrap_or(num::DateOrder::DayMonthYear);
    let days = num::date_to_days(&date, order)
        .map_err(|e| anyhow::anyhow!("VerifyRequest.force_start `{text}`: {e}"))?;
    let start = days as f64 * 86400.0 + secs;
    // The force log's first sample (its own time force.time_s[0]) was taken at `start`.
    Ok(inputs.force.time_s[0] - start)
}

fn check_insert(design: &Design, req: &VerifyRequest) -> Result<()> {
    if let (Some(ins), Some(m)) = (&req.insert, &design.module) {
        if !m.inserts.iter().any(|i| &i.name == ins) {
            let names: Vec<&str> = m.inserts.iter().map(|i| i.name.as_str()).collect();
            bail!(
                "design `{}` has no insert named `{ins}`; its inserts are: {}",
                design.name,
                names.join(", ")
            );
        }
    }
    if req.load_case() == LoadCase::II && req.insert.is_some() {
        bail!("VerifyRequest.insert names the insert of Case I; Case II has none");
    }
    Ok(())
}

/// What the verdict compares with: the model policy's rows, with the band, for one
/// configuration (and one core, when given).
pub fn model_predictions(
    design: &Design,
    case: LoadCase,
    insert: Option<&str>,
    core: Option<&str>,
) -> Result<Vec<crate::prediction::ModelledPrediction>> {
    crate::prediction::predict(
        design,
        &crate::prediction::PredictionRequest {
            case: Some(case),
            insert: insert.map(String::from),
            core: core.map(String::from),
            band: true,
            ..Default::default()
        },
    )
}

/// Whether the design's contact reading was calibrated on a measured part: its
/// `[module.contact]` note says so (as `calibrate_into` writes it).
pub(crate) fn contact_is_calibrated(design: &Design) -> bool {
    design
        .module
        .as_ref()
        .and_then(|m| m.contact.note.as_deref())
        .is_some_and(|n| n.to_ascii_lowercase().contains("calibrated"))
}

/// What the verdict knows of the contact: calibrated or not, and in Case I (with the
/// insert and the core known) the K a calibration can reach (two FE solves; unknown
/// when they fail).
fn contact_knowledge(
    design: &Design,
    req: &VerifyRequest,
    core: Option<&str>,
) -> verdict::ContactKnowledge {
    let reach = match (req.load_case(), &req.insert, core) {
        (LoadCase::I, Some(insert), Some(core)) => crate::prediction::calibration_reach(
            design,
            &crate::model::Configuration {
                core: core.to_string(),
                case: LoadCase::I,
                insert: Some(insert.clone()),
            },
            &crate::fem::FemOptions::default(),
        )
        .ok(),
        _ => None,
    };
    verdict::ContactKnowledge {
        calibrated: contact_is_calibrated(design),
        reach,
    }
}

/// Stage 2: align, fit and judge read inputs against the model.
pub fn judge(req: &VerifyRequest, inputs: &VerifyInputs) -> Result<VerifyOutcome> {
    judge_log(
        req,
        &inputs.design,
        (
            Cow::Borrowed(&inputs.log),
            None,
            Cow::Borrowed(&inputs.force),
        ),
    )
}

/// [`judge`] of the parts of the inputs; a log handed over (`Cow::Owned`) has its
/// peaks freed once they are assigned to gratings (a force log handed over with it:
/// its times become the analysis's own).
fn judge_log(
    req: &VerifyRequest,
    design: &Design,
    (log, tracks, force): (
        Cow<'_, PeakLog>,
        Option<Vec<logs::assign::GratingTrack>>,
        Cow<'_, ForceLog>,
    ),
) -> Result<VerifyOutcome> {
    let analysis = &req.analysis;
    let (m, series) = match (log, tracks) {
        (Cow::Borrowed(l), _) => analyse(design, l, &force, analysis)?,
        (Cow::Owned(l), None) => analyse_owned(design, l, force.into_owned(), analysis)?,
        (Cow::Owned(l), Some(t)) => analyse_assigned(design, l, t, force.into_owned(), analysis)?,
    };
    // The one model policy, with the band, for the configuration under test only.
    let mut cores: Vec<&String> = m.gratings.iter().filter_map(|g| g.core.as_ref()).collect();
    cores.sort();
    cores.dedup();
    let core = (cores.len() == 1).then(|| cores[0].as_str());
    let preds = model_predictions(design, req.load_case(), req.insert.as_deref(), core)
        .map_err(|e| format!("{e:#}"));
    let opts = verdict::JudgeOptions {
        case: req.load_case(),
        insert: req.insert.as_deref(),
        tolerance: req.k_tolerance,
        gate: verdict::ResponseGate::default(),
        contact: contact_knowledge(design, req, core),
    };
    let v = verdict::verdicts_with_policy(&m, preds.as_deref().map_err(Clone::clone), &opts);
    Ok(VerifyOutcome {
        report: VerifyReport {
            design: design.name.clone(),
            measurement: m,
            verdict: v,
        },
        series,
        calibration: None,
    })
}
