//! Study `verdicts` (`cargo run --release -p fbgforge-studies -- verdicts [--quick]`):
//! are the verifier's verdicts tested against their alternatives? Scenarios are drawn
//! at random from a space wider than any one issue's list ([`space`]), simulated by the
//! study's own forward model ([`forward`]) and written as labs' files ([`files`]);
//! each is verified twice through the library's use case (`fbgforge::verify::run`),
//! with the clock offset given and estimated, and the verdict compared with what the
//! truth calls for ([`truth`]). Written: `verdicts.csv` (one row per run),
//! `verdict_confusion.md` (expected × given, and per class) and `verdicts.json` (the
//! counts the test reads).

pub mod files;
pub mod forward;
pub mod space;
pub mod truth;

use anyhow::{Context, Result};
use clap::Args;
use fbgforge::model::LoadCase;
use fbgforge::verify::{run as verify_run, VerifyRequest};
use rayon::prelude::*;
use serde::Serialize;
use space::{Class, Scenario};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use truth::{Expectation, Fault, Given, ModelK};

/// Arguments of the `verdicts` study.
#[derive(Debug, Clone, Args)]
pub struct VerdictStudyArgs {
    /// Output folder.
    #[arg(long, default_value = "out/verdicts")]
    pub out: PathBuf,
    /// Scenarios to draw.
    #[arg(long, default_value_t = 400)]
    pub scenarios: usize,
    /// Seed of the first scenario (the others follow).
    #[arg(long, default_value_t = 1)]
    pub first_seed: u64,
    /// Draw only scenarios of this class (its name in the table, e.g. `loose-bond`).
    #[arg(long)]
    pub only: Option<String>,
    /// Keep every scenario's files (else only those of confidently wrong verdicts).
    #[arg(long)]
    pub keep: bool,
    /// Smoke run: the fixed seeds the test suite runs.
    #[arg(long)]
    pub quick: bool,
}

/// Scenarios of the quick form (the test's fixed seeds).
pub const QUICK_SCENARIOS: usize = 60;

/// How a verdict compares with the truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Hash, PartialOrd, Ord)]
#[serde(rename_all = "kebab-case")]
pub enum Outcome {
    /// A definite verdict the truth calls for.
    Right,
    /// A refusal: naming an uncertainty, or a fault that is there.
    Refused,
    /// A definite verdict against the truth, or a refusal naming a fault that is not
    /// there.
    ConfidentlyWrong,
}

/// One verification of one scenario.
#[derive(Debug, Clone, Serialize)]
pub struct RunRow {
    /// Scenario number.
    pub id: usize,
    /// Its seed.
    pub seed: u64,
    /// Its class.
    pub class: Class,
    /// A second class.
    pub second: Option<Class>,
    /// Protocol.
    pub protocol: space::Protocol,
    /// Wavelength rate, Hz.
    pub rate_hz: f64,
    /// `given` or `estimated`.
    pub clock: &'static str,
    /// What the truth calls for.
    pub expected: String,
    /// The data decide it.
    pub definite: bool,
    /// The verdict.
    pub given: Given,
    /// Its reason code (the verifier's `reason_code`), or the error.
    pub code: String,
    /// Right, refused or confidently wrong.
    pub outcome: Outcome,
    /// K measured of each strain grating / model K.
    pub k_ratio_measured: [f64; 2],
    /// True K / model K.
    pub k_ratio_true: [f64; 2],
    /// The verifier's reason, in short.
    pub reason: String,
}

/// The counts the test reads.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Runs (two per scenario).
    pub runs: usize,
    /// Confidently wrong verdicts.
    pub confidently_wrong: usize,
    /// Runs whose truth the data decide.
    pub definite_truth: usize,
    /// Of those, the ones given a right definite verdict.
    pub definite_right: usize,
    /// Share of the definite-truth runs given a right definite verdict.
    pub definite_rate: f64,
    /// Errors (nothing judged).
    pub errors: usize,
}

/// The study's designs: the shipped clip-on module with and without its reference
/// grating, written once into `out`.
fn write_designs(out: &Path) -> Result<(PathBuf, PathBuf, ModelK)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let with = root.join("designs/clip-on-34mm.toml");
    let design = fbgforge::design::load(&with)?;
    let mut without = design.clone();
    if let Some(m) = without.module.as_mut() {
        m.gratings
            .retain(|g| g.role != fbgforge::spec::GratingRole::TemperatureReference);
    }
    let without_path = out.join("design-without-reference.toml");
    fbgforge::output::write_atomic(&without_path, without.to_toml().as_bytes())?;
    let preds =
        fbgforge::verify::run::model_predictions(&design, LoadCase::II, None, Some("psc2"))?;
    let find = |name: &str| {
        preds
            .iter()
            .find(|p| p.detail.prediction.grating == name)
            .with_context(|| format!("the model predicts {name}"))
    };
    let (a, b) = (find("lambda_21")?, find("lambda_22")?);
    let model = ModelK {
        k: [
            a.detail.prediction.sensitivity_pm_per_n,
            b.detail.prediction.sensitivity_pm_per_n,
        ],
        band: [
            a.band_pm_per_n.context("a band")?,
            b.band_pm_per_n.context("a band")?,
        ],
        tolerance: fbgforge::verify::verdict::DEFAULT_TOLERANCE,
        hysteresis_limit_percent: hysteresis_limit_percent(&design),
    };
    Ok((with, without_path, model))
}

/// The hysteresis limit the design states for the core under test, % of span (its
/// material's, else the printer's default): the truth's threshold is the design's, not
/// one of the study's own.
fn hysteresis_limit_percent(design: &fbgforge::spec::Design) -> f64 {
    fbgforge::verify::analysis::hysteresis_limit_percent_span(design, Some("psc2"))
}

/// The nominal wavelengths and model K of the study's gratings.
fn gratings(model: &ModelK) -> forward::Gratings {
    forward::Gratings {
        nominal_nm: [1540.060, 1530.701, 1560.146],
        model_k: model.k,
    }
}

/// Run the study.
pub fn run(a: &VerdictStudyArgs) -> Result<()> {
    let n = if a.quick {
        QUICK_SCENARIOS
    } else {
        a.scenarios
    };
    fbgforge::output::ensure_dir(&a.out)?;
    let (with, without, model) = write_designs(&a.out)?;
    let only = match a.only.as_deref() {
        Some(name) => Some(Class::named(name).with_context(|| {
            format!(
                "--only {name}: no such class (one of {})",
                Class::ALL.map(Class::name).join(", ")
            )
        })?),
        None => None,
    };
    let scenarios: Vec<Scenario> = (0..n)
        .map(|i| space::draw_of(i, a.first_seed + i as u64, only))
        .collect();
    eprintln!(
        "verdict study: {} scenarios, two clocks each ...",
        scenarios.len()
    );
    let pb = crate::progress::Bar::with("verdicts", scenarios.len() as u64);
    let rows: Vec<RunRow> = scenarios
        .par_iter()
        .map(|s| {
            let r = run_scenario(s, &model, (&with, &without), &a.out, a.keep);
            fbgforge::progress::Progress::advance(&pb, 1);
            r
        })
        .collect::<Result<Vec<Vec<RunRow>>>>()?
        .into_iter()
        .flatten()
        .collect();
    fbgforge::progress::Progress::end(&pb);
    let summary = summarise(&rows);
    write_outputs(&a.out, &rows, &summary)?;
    println!(
        "{} runs: {} confidently wrong, {} of {} definite-truth runs given the right definite verdict ({:.1} %), {} errors; wrote {}",
        summary.runs,
        summary.confidently_wrong,
        summary.definite_right,
        summary.definite_truth,
        100.0 * summary.definite_rate,
        summary.errors,
        a.out.join("verdict_confusion.md").display()
    );
    for r in rows
        .iter()
        .filter(|r| r.outcome == Outcome::ConfidentlyWrong)
    {
        println!(
            "  wrong: #{} seed {} {}{} ({:?}, {} Hz, {}): expected {}, given {} [{}] K/model {:.3},{:.3} (truth {:.3},{:.3}): {}",
            r.id,
            r.seed,
            r.class.name(),
            r.second.map(|c| format!("+{}", c.name())).unwrap_or_default(),
            r.protocol,
            r.rate_hz,
            r.clock,
            r.expected,
            r.given.word(),
            r.code,
            r.k_ratio_measured[0],
            r.k_ratio_measured[1],
            r.k_ratio_true[0],
            r.k_ratio_true[1],
            r.reason
        );
    }
    Ok(())
}

/// One scenario (`seed`, of class `only`) simulated and written into `out` with the
/// study's designs, for a test to verify on its own: the scenario and its files (with
/// the true clock offset).
pub fn write_one(
    out: &Path,
    seed: u64,
    only: Option<Class>,
) -> Result<(Scenario, files::RunFiles)> {
    fbgforge::output::ensure_dir(out)?;
    let (with, without, model) = write_designs(out)?;
    let s = space::draw_of(0, seed, only);
    let ph = forward::simulate(&s);
    let wl = forward::interrogate(&s, &ph, &gratings(&model));
    let force = forward::stand(&s);
    let files = files::write_run(&out.join("scenario"), &s, &wl, &force, (&with, &without))?;
    Ok((s, files))
}

/// Simulate, write and verify one scenario with both clocks.
fn run_scenario(
    s: &Scenario,
    model: &ModelK,
    designs: (&Path, &Path),
    out: &Path,
    keep: bool,
) -> Result<Vec<RunRow>> {
    let ph = forward::simulate(s);
    let wl = forward::interrogate(s, &ph, &gratings(model));
    let force = forward::stand(s);
    let dir = out.join(format!("scenario-{:04}", s.id));
    let files = files::write_run(&dir, s, &wl, &force, designs)?;
    let mut rows = Vec::new();
    for given in [true, false] {
        let e = truth::expect(s, model, given);
        rows.push(verify_once(s, &files, &e, model, given));
    }
    if !keep && rows.iter().all(|r| r.outcome != Outcome::ConfidentlyWrong) {
        let _ = std::fs::remove_dir_all(&dir);
    }
    Ok(rows)
}

/// Verify one scenario's files with the offset given or estimated, and judge the
/// verdict against the truth.
fn verify_once(
    s: &Scenario,
    files: &files::RunFiles,
    e: &Expectation,
    model: &ModelK,
    given: bool,
) -> RunRow {
    let mut req = VerifyRequest::new(files.design.clone(), files.log.clone(), files.force.clone());
    req.case = Some(LoadCase::II);
    req.analysis.core = Some("psc2".into());
    if given {
        req.analysis.clock_offset_s = Some(files.offset_s);
    }
    let (verdict, code, reason, measured) = match verify_run(&req) {
        Ok(o) => read_outcome(&o.report, model),
        Err(err) => (
            Given::Error,
            "error".to_string(),
            format!("{err:#}"),
            [f64::NAN; 2],
        ),
    };
    let outcome = judge(verdict, &code, &reason, e);
    RunRow {
        id: s.id,
        seed: s.seed,
        class: s.class,
        second: s.second,
        protocol: s.protocol,
        rate_hz: s.wl_rate_hz,
        clock: if given { "given" } else { "estimated" },
        expected: e.label.clone(),
        definite: e.definite && !e.right.is_empty(),
        given: verdict,
        code,
        outcome,
        k_ratio_measured: measured,
        k_ratio_true: s.k_ratio,
        reason: reason.chars().take(400).collect(),
    }
}

/// The verdict, its reason code and reason, and the measured K over the model's.
fn read_outcome(
    report: &fbgforge::verify::VerifyReport,
    model: &ModelK,
) -> (Given, String, String, [f64; 2]) {
    let v = serde_json::to_value(report).unwrap_or_default();
    let verdict = &v["verdict"];
    let given = match verdict["overall"].as_str().unwrap_or("") {
        "pass" => Given::Pass,
        "fail" => Given::Fail,
        "in_band" => Given::InBand,
        "calibrate_contact" => Given::CalibrateContact,
        "no_response" => Given::NoResponse,
        _ => Given::NotJudged,
    };
    let gratings = verdict["gratings"].as_array().cloned().unwrap_or_default();
    // The module's reason, else the first grating's that explains the verdict.
    let explaining = gratings
        .iter()
        .find(|g| g["status"].as_str() == verdict["overall"].as_str());
    let code = verdict["reason_code"]
        .as_str()
        .or_else(|| explaining.and_then(|g| g["reason_code"].as_str()))
        .unwrap_or("")
        .to_string();
    let reason = verdict["reason"]
        .as_str()
        .or_else(|| explaining.and_then(|g| g["reason"].as_str()))
        .unwrap_or("")
        .to_string();
    let mut measured = [f64::NAN; 2];
    for (k, name) in ["lambda_21", "lambda_22"].iter().enumerate() {
        if let Some(g) = report
            .measurement
            .gratings
            .iter()
            .find(|g| g.grating == *name)
        {
            measured[k] = g.sensitivity_pm_per_n / model.k[k];
        }
    }
    (given, code, reason, measured)
}

/// The fault a refusal states as a fact, from its reason code (or, for a verifier
/// without codes, its words).
fn stated_fault(given: Given, code: &str, reason: &str) -> Option<Fault> {
    match (given, code) {
        (Given::NoResponse, _) | (_, "no_response") => Some(Fault::NoResponse),
        (_, "instrument") => Some(Fault::Instrument),
        (_, "clock") => Some(Fault::Clock),
        (_, "force_untrusted") => Some(Fault::Force),
        (_, "") if reason.contains("force cannot be trusted") => Some(Fault::Force),
        _ => None,
    }
}

/// Right, refused or confidently wrong.
fn judge(given: Given, code: &str, reason: &str, e: &Expectation) -> Outcome {
    if given.definite() {
        return if e.right.contains(&given) {
            Outcome::Right
        } else {
            Outcome::ConfidentlyWrong
        };
    }
    match stated_fault(given, code, reason) {
        Some(f) if !e.faults.contains(&f) => Outcome::ConfidentlyWrong,
        _ => Outcome::Refused,
    }
}

/// The counts over every run.
fn summarise(rows: &[RunRow]) -> Summary {
    let definite: Vec<&RunRow> = rows.iter().filter(|r| r.definite).collect();
    let right = definite
        .iter()
        .filter(|r| r.outcome == Outcome::Right)
        .count();
    Summary {
        runs: rows.len(),
        confidently_wrong: rows
            .iter()
            .filter(|r| r.outcome == Outcome::ConfidentlyWrong)
            .count(),
        definite_truth: definite.len(),
        definite_right: right,
        definite_rate: if definite.is_empty() {
            1.0
        } else {
            right as f64 / definite.len() as f64
        },
        errors: rows.iter().filter(|r| r.given == Given::Error).count(),
    }
}

/// `verdicts.csv`, `verdict_confusion.md`, `verdicts.json`.
fn write_outputs(out: &Path, rows: &[RunRow], summary: &Summary) -> Result<()> {
    let header = [
        "id",
        "seed",
        "class",
        "second",
        "protocol",
        "rate_hz",
        "clock",
        "expected",
        "definite",
        "given",
        "code",
        "outcome",
        "k21_measured",
        "k22_measured",
        "k21_true",
        "k22_true",
        "reason",
    ];
    let csv_rows: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.id.to_string(),
                r.seed.to_string(),
                r.class.name(),
                r.second.map(Class::name).unwrap_or_default(),
                format!("{:?}", r.protocol),
                r.rate_hz.to_string(),
                r.clock.into(),
                r.expected.clone(),
                r.definite.to_string(),
                r.given.word().into(),
                r.code.clone(),
                format!("{:?}", r.outcome),
                format!("{:.4}", r.k_ratio_measured[0]),
                format!("{:.4}", r.k_ratio_measured[1]),
                format!("{:.4}", r.k_ratio_true[0]),
                format!("{:.4}", r.k_ratio_true[1]),
                r.reason.replace(['\n', ','], " "),
            ]
        })
        .collect();
    fbgforge::output::write_csv(&out.join("verdicts.csv"), &header, &csv_rows)?;
    fbgforge::output::write_atomic(
        &out.join("verdict_confusion.md"),
        confusion_markdown(rows, summary).as_bytes(),
    )?;
    fbgforge::output::write_json(&out.join("verdicts.json"), summary)
}

/// The confusion table (expected × given) and the per-class table, in Markdown.
pub fn confusion_markdown(rows: &[RunRow], summary: &Summary) -> String {
    let columns = [
        Given::Pass,
        Given::Fail,
        Given::InBand,
        Given::CalibrateContact,
        Given::NotJudged,
        Given::NoResponse,
        Given::Error,
    ];
    let mut by_expected: BTreeMap<String, BTreeMap<Given, usize>> = BTreeMap::new();
    for r in rows {
        *by_expected
            .entry(r.expected.clone())
            .or_default()
            .entry(r.given)
            .or_default() += 1;
    }
    let mut md = String::from("| expected \\ given |");
    for c in columns {
        md.push_str(&format!(" {} |", c.word()));
    }
    md.push_str("\n|---|");
    md.push_str(&"---|".repeat(columns.len()));
    md.push('\n');
    for (exp, counts) in &by_expected {
        md.push_str(&format!("| {exp} |"));
        for c in columns {
            md.push_str(&format!(" {} |", counts.get(&c).copied().unwrap_or(0)));
        }
        md.push('\n');
    }
    md.push_str("\n| class | runs | right | refused | confidently wrong | definite-truth runs right |\n|---|---|---|---|---|---|\n");
    for class in Class::ALL {
        let of: Vec<&RunRow> = rows.iter().filter(|r| r.class == class).collect();
        if of.is_empty() {
            continue;
        }
        let count = |o: Outcome| of.iter().filter(|r| r.outcome == o).count();
        let def: Vec<&&RunRow> = of.iter().filter(|r| r.definite).collect();
        let def_right = def.iter().filter(|r| r.outcome == Outcome::Right).count();
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} of {} |\n",
            class.name(),
            of.len(),
            count(Outcome::Right),
            count(Outcome::Refused),
            count(Outcome::ConfidentlyWrong),
            def_right,
            def.len()
        ));
    }
    md.push_str(&format!(
        "\n{} runs, {} confidently wrong; {} of {} definite-truth runs given the right definite verdict ({:.1} %); {} errors.\n",
        summary.runs,
        summary.confidently_wrong,
        summary.definite_right,
        summary.definite_truth,
        100.0 * summary.definite_rate,
        summary.errors
    ));
    md
}
