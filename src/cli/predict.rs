//! `fbgforge predict` and `fbgforge sweep`: the opto-mechanical model from the command
//! line. `predict` on an array design prints its predicted sensing matrix (or the
//! response to one load) and maps each grating's sensitivity over the sheet.

use super::progress::Bar;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use fbgforge::array::kernel::ArrayModelKind;
use fbgforge::array::predict::{ArrayPredictor, SensitivityMap};
use fbgforge::fem::FemOptions;
use fbgforge::model::sweep::{self, SweepResult, PAPER_FIGURES};
use fbgforge::model::LoadCase;
use fbgforge::output::{ensure_dir, write_csv};
use fbgforge::plot::{Chart, HeatMaps, HeatPanel, Mark, Series, Stroke};
use fbgforge::prediction::{Fidelity, FidelityChoice, ModelledPrediction};
use std::path::{Path, PathBuf};

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[];

/// Arguments of `fbgforge predict`.
#[derive(Debug, Args)]
pub struct PredictArgs {
    /// Design spec (TOML) with a [module] or an [array] section.
    pub design: PathBuf,
    /// Arrays: which model predicts the sensing matrix: `sheet` (the physical model of
    /// the sheet, its fibers and its table) or `kernel` (the empirical distance kernel
    /// fitted to the paper). Default: the design's `array.model`, else `sheet`.
    #[arg(long, value_enum)]
    pub model: Option<ArrayModelArg>,
    /// Arrays: instead of the matrix, the response of each grating to 1 g on the
    /// indenter centred at X,Y (mm from the sheet's centre), e.g. `--load-at-mm 0,0`.
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    pub load_at_mm: Option<String>,
    /// Arrays: folder for the sensitivity map (SVG and CSV of each grating's
    /// sensitivity over the sheet; default out/predict).
    #[arg(long)]
    pub map_dir: Option<PathBuf>,
    /// Arrays: grid step of the sensitivity map, mm.
    #[arg(long, default_value_t = 2.0)]
    pub map_step_mm: f64,
    /// Apex force at which shifts and strains are reported, N.
    #[arg(long, default_value_t = 10.0)]
    pub force_n: f64,
    /// Temperature change from the reference temperature, K: adds the thermal shift
    /// and shows the shift after compensation with the reference grating.
    #[arg(long, default_value_t = 0.0)]
    pub delta_t_k: f64,
    /// Keep only one loading case (Case I needs an insert in the design).
    #[arg(long, value_enum)]
    pub case: Option<CaseArg>,
    /// Which model answers: `auto` uses the closed form inside its measured validity
    /// region (docs/model.md, "Where the closed form holds") and the finite-element
    /// model outside it, per loading case; `closed-form` and `fem` force one model.
    /// `closed-form` runs no finite-element solve at all, so it has no band (the band's
    /// readings are FE solves).
    #[arg(long, value_enum, default_value_t = FidelityArg::Auto)]
    pub fidelity: FidelityArg,
    /// Skip the prediction band (two more finite-element solves per configuration;
    /// implied by `--fidelity closed-form`).
    #[arg(long)]
    pub no_band: bool,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// `--model` values (arrays).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ArrayModelArg {
    /// The physical model of the sheet (docs/array.md §12).
    Sheet,
    /// The empirical kernel fitted to the paper's Tables 1–2 (docs/array.md §1).
    Kernel,
}

impl From<ArrayModelArg> for ArrayModelKind {
    fn from(m: ArrayModelArg) -> Self {
        match m {
            ArrayModelArg::Sheet => ArrayModelKind::Sheet,
            ArrayModelArg::Kernel => ArrayModelKind::Kernel,
        }
    }
}

/// `--fidelity` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FidelityArg {
    /// Closed form inside its measured validity region, finite elements outside.
    Auto,
    /// The closed form for every row, no finite-element solve (microseconds; no band).
    ClosedForm,
    /// The finite-element model for every row (a fraction of a second per configuration).
    Fem,
}

impl From<FidelityArg> for FidelityChoice {
    fn from(f: FidelityArg) -> Self {
        match f {
            FidelityArg::Auto => FidelityChoice::Auto,
            FidelityArg::ClosedForm => FidelityChoice::ClosedForm,
            FidelityArg::Fem => FidelityChoice::Fem,
        }
    }
}

fn model_name(f: Fidelity) -> &'static str {
    f.name()
}

/// Check the numbers of the request.
fn check_predict_args(a: &PredictArgs) -> Result<()> {
    if !a.force_n.is_finite() {
        bail!(
            "--force-n must be a finite number of newtons, got {}",
            a.force_n
        );
    }
    if !a.delta_t_k.is_finite() {
        bail!(
            "--delta-t-k must be a finite number of kelvin, got {}",
            a.delta_t_k
        );
    }
    Ok(())
}

/// Numbered footnotes: each distinct text once, in order of first use.
#[derive(Default)]
struct Footnotes(Vec<String>);

impl Footnotes {
    /// The index of `text`, added if new.
    fn index(&mut self, text: &str) -> usize {
        self.0.iter().position(|n| n == text).unwrap_or_else(|| {
            self.0.push(text.to_string());
            self.0.len() - 1
        })
    }
}

/// The table's header line.
fn print_predict_header(band: bool, temp: bool) {
    print!(
        "{:<12} {:<6} {:<4} {:<12} {:<14} {:>8} {:>10} {:>11} {:>10} {:>8}",
        "grating",
        "core",
        "case",
        "insert",
        "model",
        "E1 MPa",
        "K pm/N",
        "shift pm",
        "strain µε",
        "share"
    );
    if band {
        print!(" {:>21}", "band pm/N");
    }
    if temp {
        print!(" {:>11} {:>12}", "raw pm", "compens. pm");
    }
    println!("  warnings");
}

/// One row of the table; its warnings and model become numbered notes.
fn print_predict_row(
    row: &ModelledPrediction,
    (band, temp): (bool, bool),
    notes: &mut Footnotes,
    models: &mut Footnotes,
) {
    let d = &row.detail;
    let p = &d.prediction;
    let refs: Vec<String> = p
        .warnings
        .iter()
        .map(|w| format!("[{}]", notes.index(w) + 1))
        .collect();
    let share = if d.core_load_share.is_finite() {
        format!("{:.4}", d.core_load_share)
    } else {
        "-".to_string()
    };
    let m = models.index(&row.model_description);
    print!(
        "{:<12} {:<6} {:<4} {:<12} {:<14} {:>8.3} {:>+10.3} {:>+11.2} {:>+10.1} {:>8}",
        p.grating,
        p.core,
        p.case.to_string(),
        p.insert.as_deref().unwrap_or("-"),
        format!("{} (m{})", model_name(row.model), m + 1),
        d.core_modulus_mpa,
        p.sensitivity_pm_per_n,
        p.shift_pm,
        p.strain * 1e6,
        share
    );
    if band {
        let b = row
            .band_pm_per_n
            .map_or("-".to_string(), |[lo, hi]| format!("{lo:+.1} … {hi:+.1}"));
        print!(" {b:>21}");
    }
    if temp {
        let comp = d
            .compensated_shift_pm
            .map_or("-".to_string(), |c| format!("{c:+.2}"));
        print!(" {:>+11.2} {:>12}", d.raw_shift_pm, comp);
    }
    println!("  {}", refs.join(""));
}

/// What the columns and the model choice mean.
fn print_predict_legend(band: bool, choice: FidelityChoice) {
    println!("K > 0: red shift (core cylinder in tension); K < 0: blue shift.");
    if band {
        println!(
            "band: K between the bounding contact readings (FE): pillars bonded to the cap (most coupled) and cylinders sliding with the domes touching over the apex patch only (least coupled); docs/model.md §5.6."
        );
    }
    println!(
        "share: Case I, share of F through the cap→core loop; Case II, share carried by the core (closed form only)."
    );
    match choice {
        FidelityChoice::Auto => {
            let v = fbgforge::prediction::validity();
            println!(
                "model (--fidelity auto): closed form where measured within {:.0} % of the FE model (D {}–{} mm; Case II core t/R ≤ {}; Case I {}), FE with the design's [module.contact] elsewhere.",
                v.tolerance * 100.0,
                v.diameter_range_mm.0,
                v.diameter_range_mm.1,
                v.max_wall_to_radius_case_ii,
                if v.max_wall_to_radius_case_i > 0.0 {
                    format!("core t/R ≤ {}", v.max_wall_to_radius_case_i)
                } else {
                    "never".to_string()
                }
            );
        }
        FidelityChoice::ClosedForm => {
            println!("model: closed form forced (--fidelity closed-form): no finite-element solve, so no band (--fidelity auto gives it).")
        }
        FidelityChoice::Fem => println!("model: finite elements forced (--fidelity fem)."),
    }
}

/// Parse `--load-at-mm X,Y`.
fn parse_load_at(s: &str) -> Result<(f64, f64)> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let num = |t: &str| t.parse::<f64>().ok().filter(|v| v.is_finite());
    match parts.as_slice() {
        [x, y] => match (num(x), num(y)) {
            (Some(x), Some(y)) => Ok((x, y)),
            _ => bail!(
                "--load-at-mm expects two numbers X,Y in mm, e.g. `0,0` or `-10,5`; got `{s}`"
            ),
        },
        _ => bail!("--load-at-mm expects two numbers X,Y in mm, e.g. `0,0` or `-10,5`; got `{s}`"),
    }
}

/// The sensitivity map as heat maps, one panel per grating, with the fibers, the
/// cells' borders and each grating marked.
fn map_chart(
    design: &fbgforge::spec::Design,
    p: &ArrayPredictor,
    map: &SensitivityMap,
) -> HeatMaps {
    let a = design.array.as_ref().expect("an array design");
    let (sx, sy) = p.sheet_mm();
    let mut lines: Vec<Vec<(f64, f64)>> = a
        .fiber_x_mm
        .iter()
        .map(|&x| vec![(x, -sy / 2.0), (x, sy / 2.0)])
        .collect();
    for i in 1..a.cells_x {
        let x = -sx / 2.0 + sx * i as f64 / a.cells_x as f64;
        lines.push(vec![(x, -sy / 2.0), (x, sy / 2.0)]);
    }
    for j in 1..a.cells_y {
        let y = -sy / 2.0 + sy * j as f64 / a.cells_y as f64;
        lines.push(vec![(-sx / 2.0, y), (sx / 2.0, y)]);
    }
    let panels = map
        .gratings
        .iter()
        .enumerate()
        .map(|(g, name)| {
            let v = &map.values_pm_per_g[g];
            let (lo, hi) = v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                    (l.min(x), h.max(x))
                });
            HeatPanel {
                title: format!("{name}: {lo:.3} … {hi:.3} pm/g"),
                x: map.x_mm.clone(),
                y: map.y_mm.clone(),
                values: (0..v.nrows())
                    .map(|j| v.row(j).iter().copied().collect())
                    .collect(),
                points: vec![map.grating_xy_mm[g]],
                lines: lines.clone(),
            }
        })
        .collect();
    HeatMaps {
        title: format!(
            "{}: sensitivity to 1 g on the indenter centred at (x, y), {} model (red: red shift, blue: blue shift)",
            design.name,
            p.kind().name()
        ),
        x_label: "x (mm)".into(),
        y_label: "y (mm)".into(),
        panels,
    }
}

/// `fbgforge predict` on an array design.
fn run_predict_array(a: &PredictArgs, design: &fbgforge::spec::Design) -> Result<()> {
    let load = a.load_at_mm.as_deref().map(parse_load_at).transpose()?;
    if !(a.map_step_mm.is_finite() && a.map_step_mm > 0.0) {
        bail!(
            "--map-step-mm must be a positive number of mm, got {}",
            a.map_step_mm
        );
    }
    let p = ArrayPredictor::new(design, a.model.map(ArrayModelKind::from))
        .with_context(|| format!("{}: cannot predict the array", a.design.display()))?;
    let map = p.map(a.map_step_mm)?;
    let dir = a
        .map_dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/predict"));
    let stem = format!("{}-{}-sensitivity-map", design.name, p.kind().name());
    let svg = dir.join(format!("{stem}.svg"));
    let csv = dir.join(format!("{stem}.csv"));
    map_chart(design, &p, &map).write_svg(&svg)?;
    let (header, rows) = map.csv_rows();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    write_csv(&csv, &header, &rows)?;
    if let Some((x, y)) = load {
        let r = p
            .load_at(x, y)
            .with_context(|| format!("{}: --load-at-mm", a.design.display()))?;
        if a.json {
            let doc = serde_json::json!({
                "design": design.name,
                "model": p.kind().name(),
                "model_description": p.description(),
                "load_at_mm": r.load_at_mm,
                "gratings": r.gratings,
                "sensitivity_pm_per_g": r.sensitivity_pm_per_g,
                "map": {"svg": svg, "csv": csv},
            });
            println!("{}", serde_json::to_string_pretty(&doc)?);
            return Ok(());
        }
        println!(
            "{}: response to 1 g on the {} mm indenter centred at ({x}, {y}) mm",
            design.name,
            design
                .array
                .as_ref()
                .map_or(20.0, |arr| arr.indenter_diameter())
        );
        println!("model: {}", p.description());
        println!("{:<10} {:>12}", "grating", "pm/g");
        for (g, v) in r.gratings.iter().zip(&r.sensitivity_pm_per_g) {
            println!("{g:<10} {v:>12.5}");
        }
    } else {
        let m = p.matrix();
        if a.json {
            let rows: Vec<Vec<f64>> = (0..m.n_gratings())
                .map(|i| m.sensitivity_pm_per_g.row(i).iter().copied().collect())
                .collect();
            let doc = serde_json::json!({
                "design": design.name,
                "model": p.kind().name(),
                "model_description": p.description(),
                "gratings": m.gratings,
                "cells": m.cells,
                "sensitivity_pm_per_g": rows,
                "map": {"svg": svg, "csv": csv},
            });
            println!("{}", serde_json::to_string_pretty(&doc)?);
            return Ok(());
        }
        println!(
            "{}: predicted sensing matrix, pm/g (gratings × cells, 1 g on the indenter centred on each cell)",
            design.name
        );
        println!("model: {}", p.description());
        print!("{:<10}", "grating");
        for c in &m.cells {
            print!("{c:>10}");
        }
        println!();
        for (g, row) in m.gratings.iter().zip(m.sensitivity_pm_per_g.row_iter()) {
            print!("{g:<10}");
            for v in row.iter() {
                print!("{v:>10.5}");
            }
            println!();
        }
    }
    println!("sensitivity map: {} and {}", svg.display(), csv.display());
    Ok(())
}

/// Run `fbgforge predict`.
pub fn run_predict(a: PredictArgs) -> Result<()> {
    check_predict_args(&a)?;
    let design = fbgforge::design::load(&a.design)?;
    if design.module.is_none() && design.array.is_some() {
        return run_predict_array(&a, &design);
    }
    if a.model.is_some() || a.load_at_mm.is_some() {
        bail!(
            "{}: --model and --load-at-mm are for array designs; this design has no [array] section",
            a.design.display()
        );
    }
    let case = a.case.map(LoadCase::from);
    if case == Some(LoadCase::I) && design.module.as_ref().is_some_and(|m| m.inserts.is_empty()) {
        bail!(
            "{}: Case I needs a solid insert, but the design lists none under [[module.inserts]]",
            a.design.display()
        );
    }
    let choice = FidelityChoice::from(a.fidelity);
    // The band's readings are FE solves: the closed form alone runs none (the library
    // skips them too; this also sets the table's columns).
    let band = !a.no_band && choice != FidelityChoice::ClosedForm;
    let rows = fbgforge::prediction::predict(
        &design,
        &fbgforge::prediction::PredictionRequest {
            force_n: a.force_n,
            delta_t_k: a.delta_t_k,
            case,
            fidelity: choice,
            band,
            ..Default::default()
        },
    )
    .with_context(|| format!("{}: cannot predict", a.design.display()))?;
    let statements = fbgforge::prediction::check_paper_statements(&design, &rows);
    if a.json {
        let doc = serde_json::json!({
            "design": design.name,
            "force_n": a.force_n,
            "delta_t_k": a.delta_t_k,
            "fidelity": choice,
            "predictions": rows,
            "paper_statements": statements,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    println!(
        "{}: predicted sensitivity at F = {} N",
        design.name, a.force_n
    );
    let temp = a.delta_t_k != 0.0;
    let mut notes = Footnotes::default();
    let mut models = Footnotes::default();
    print_predict_header(band, temp);
    for row in &rows {
        print_predict_row(row, (band, temp), &mut notes, &mut models);
    }
    for (i, m) in models.0.iter().enumerate() {
        println!("m{}: {m}", i + 1);
    }
    print_predict_legend(band, choice);
    for (i, n) in notes.0.iter().enumerate() {
        println!("[{}] {n}", i + 1);
    }
    if let Some(s) = statements {
        print_statements(&s);
    }
    Ok(())
}

/// The paper's Case I statements on this design, each with its verdict.
fn print_statements(s: &fbgforge::prediction::PaperStatements) {
    let failed = s.failures();
    println!(
        "paper's Case I statements (docs/model.md §7.2) on {}: {}",
        s.design,
        if failed.is_empty() {
            "every one checked holds".to_string()
        } else {
            format!(
                "{} FAIL{}",
                failed
                    .iter()
                    .map(|c| c.statement)
                    .collect::<Vec<_>>()
                    .join(", "),
                if failed.len() == 1 { "S" } else { "" }
            )
        }
    );
    for c in &s.checks {
        let v = match c.holds {
            Some(true) => "holds",
            Some(false) => "FAILS",
            None => "not checked",
        };
        println!("  {:<34} {v:<12} {}", c.statement, c.detail);
    }
}

/// Loading case filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CaseArg {
    /// Case I (core on a solid insert).
    #[value(name = "I", alias = "i", alias = "1")]
    I,
    /// Case II (hollow core).
    #[value(name = "II", alias = "ii", alias = "2")]
    II,
}

impl From<CaseArg> for LoadCase {
    fn from(c: CaseArg) -> Self {
        match c {
            CaseArg::I => LoadCase::I,
            CaseArg::II => LoadCase::II,
        }
    }
}

/// Arguments of `fbgforge sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// Design spec (TOML) with a [module] section.
    pub design: PathBuf,
    /// Parameter to sweep, e.g. e1_mpa, e2_mpa, es_mpa, outer_diameter_mm, core_wall_mm,
    /// cap_wall_mm (an unknown name lists them all).
    #[arg(long)]
    pub param: Option<String>,
    /// First value of the range.
    #[arg(long)]
    pub from: Option<f64>,
    /// Last value of the range (must be larger than --from).
    #[arg(long)]
    pub to: Option<f64>,
    /// Number of values, including both ends.
    #[arg(long, default_value_t = 41)]
    pub steps: usize,
    /// Space the values evenly in log (a log x axis); the default when --to is more
    /// than 20 × --from.
    #[arg(long, conflicts_with = "linear")]
    pub log: bool,
    /// Space the values evenly (a linear x axis), even over a range wider than 20 ×.
    #[arg(long)]
    pub linear: bool,
    /// Apex force, N.
    #[arg(long, default_value_t = 50.0)]
    pub force_n: f64,
    /// Keep only one loading case.
    #[arg(long, value_enum)]
    pub case: Option<CaseArg>,
    /// SVG chart to write (default out/sweep/<design>-<param>.svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// CSV of the same numbers (default out/sweep/<design>-<param>.csv).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Instead of one sweep, write the paper's parametric figures (Figs. 9a–c, 11a–b:
    /// F = 50 N with the paper's fixed moduli) as SVG + CSV into this folder.
    #[arg(long)]
    pub paper_figures: Option<PathBuf>,
    /// Which model answers at each step: `auto`, the model policy of `predict` (the
    /// default: Case I by the FE model, a fraction of a second per configuration and
    /// step), the closed form (microseconds a step) or the FE model throughout.
    #[arg(long, value_enum, default_value_t = FidelityArg::Auto)]
    pub fidelity: FidelityArg,
    /// Skip the shaded prediction band (two more FE solves per configuration and step).
    #[arg(long)]
    pub no_band: bool,
}

/// How a sweep's output names its model.
fn fidelity_label(f: FidelityArg) -> &'static str {
    match f {
        FidelityArg::ClosedForm => "closed form",
        FidelityArg::Fem => "finite elements",
        FidelityArg::Auto => "model policy",
    }
}

/// A range wider than this factor is swept in log steps unless `--linear` is given.
const AUTO_LOG_RATIO: f64 = 20.0;

/// Whether a sweep over `from..to` uses log spacing: asked for, refused, or by default
/// over a range of more than [`AUTO_LOG_RATIO`] ×.
fn log_spacing(from: f64, to: f64, log: bool, linear: bool) -> bool {
    log || (!linear && from > 0.0 && to / from > AUTO_LOG_RATIO)
}

/// `steps` values from `from` to `to` with equal ratios between neighbours.
fn log_values(from: f64, to: f64, steps: usize) -> Vec<f64> {
    let r = (to / from).ln();
    (0..steps)
        .map(|i| {
            if i + 1 == steps {
                to
            } else {
                from * (r * i as f64 / (steps - 1) as f64).exp()
            }
        })
        .collect()
}

/// The sweep's chart: one colour per configuration (case and insert), one dash per
/// grating within it, and one band per configuration (the envelope of its gratings'
/// bands, outlined), with the legend beside the plot: twelve series stay readable.
fn sweep_chart(r: &SweepResult, title: &str, log_x: bool) -> Chart {
    let mut c = Chart::new(
        title,
        r.label.clone(),
        format!("Δλ at {} N (pm)", r.force_n),
    );
    c.x_log = log_x;
    let mut groups: Vec<(LoadCase, Option<String>)> = Vec::new();
    for s in &r.series {
        let key = (s.case, s.insert.clone());
        if !groups.contains(&key) {
            groups.push(key);
        }
    }
    let f = r.force_n;
    for (gi, key) in groups.iter().enumerate() {
        let members: Vec<_> = r
            .series
            .iter()
            .filter(|s| (s.case, s.insert.clone()) == *key)
            .collect();
        for (k, s) in members.iter().enumerate() {
            c = c.with(
                Series::new(
                    s.label(),
                    s.x.iter()
                        .copied()
                        .zip(s.shift_pm.iter().copied())
                        .collect(),
                    Mark::Line,
                )
                .with_color(gi)
                .with_stroke(Stroke::ALL[k % Stroke::ALL.len()])
                .with_role("shift"),
            );
        }
        // The band of K as a band of the shift at the sweep's force, the envelope
        // over the configuration's gratings.
        let first = members[0];
        let banded = members
            .iter()
            .all(|s| s.band_pm_per_n.len() == s.x.len() && s.x.len() == first.x.len());
        if banded && !first.x.is_empty() {
            let band: Vec<(f64, f64, f64)> = (0..first.x.len())
                .map(|i| {
                    let (lo, hi) = members.iter().fold((f64::MAX, f64::MIN), |(a, b), s| {
                        let [p, q] = s.band_pm_per_n[i];
                        (a.min(p * f).min(q * f), b.max(p * f).max(q * f))
                    });
                    (first.x[i], lo, hi)
                })
                .collect();
            let what = match &key.1 {
                Some(i) => format!("Case {} · {i}", key.0),
                None => format!("Case {}", key.0),
            };
            c = c.with(
                Series::new(
                    format!("band, {what} (contact readings)"),
                    Vec::new(),
                    Mark::Line,
                )
                .with_band(band)
                .with_color(gi)
                .with_stroke(Stroke::Dotted)
                .with_role("band"),
            );
        }
    }
    c
}

fn sweep_csv(r: &SweepResult, path: &Path) -> Result<()> {
    let header = [
        "param",
        "value",
        "grating",
        "case",
        "insert",
        "force_n",
        "band_low_pm_per_n",
        "band_high_pm_per_n",
        "shift_pm",
        "sensitivity_pm_per_n",
    ];
    let mut rows = Vec::new();
    for s in &r.series {
        for i in 0..s.x.len() {
            let band = |k: usize| {
                s.band_pm_per_n
                    .get(i)
                    .filter(|_| s.band_pm_per_n.len() == s.x.len())
                    .map_or(String::new(), |b| format!("{:.6}", b[k]))
            };
            rows.push(vec![
                r.param.clone(),
                format!("{}", s.x[i]),
                s.grating.clone(),
                s.case.to_string(),
                s.insert.clone().unwrap_or_default(),
                format!("{}", r.force_n),
                band(0),
                band(1),
                format!("{:.6}", s.shift_pm[i]),
                format!("{:.6}", s.sensitivity_pm_per_n[i]),
            ]);
        }
    }
    write_csv(path, &header, &rows)
}

/// Run `fbgforge sweep`.
pub fn run_sweep(a: SweepArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    if let Some(dir) = &a.paper_figures {
        return write_paper_figures(&design, dir, a.steps, a.fidelity, !a.no_band);
    }
    let Some(name) = a.param.as_deref() else {
        bail!(
            "--param is required (or use --paper-figures DIR); known parameters: {}",
            sweep::param_names().join(", ")
        );
    };
    let param = sweep::find_param(name)?;
    let (Some(from), Some(to)) = (a.from, a.to) else {
        bail!("--from and --to are required for a sweep of {}", param.name);
    };
    if !a.force_n.is_finite() {
        bail!(
            "--force-n must be a finite number of newtons, got {}",
            a.force_n
        );
    }
    let mut values = sweep::sweep_values(param, from, to, a.steps)?;
    let log_x = log_spacing(from, to, a.log, a.linear);
    if log_x {
        values = log_values(from, to, a.steps);
    }
    let case = a.case.map(LoadCase::from);
    if case == Some(LoadCase::I) && design.module.as_ref().is_some_and(|m| m.inserts.is_empty()) {
        bail!(
            "{}: Case I needs a solid insert, but the design lists none",
            a.design.display()
        );
    }
    let predictor = fbgforge::prediction::sweep_predictor_with_band(
        a.fidelity.into(),
        case,
        FemOptions::default(),
        !a.no_band,
    );
    let r = sweep::run_with(
        &design,
        param,
        &values,
        a.force_n,
        case,
        predictor.as_deref(),
        &Bar::new(),
    )
    .with_context(|| format!("{}: sweep failed", a.design.display()))?;
    let stem = format!("{}-{}", design.name, param.name);
    let svg = a
        .plot
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/sweep").join(format!("{stem}.svg")));
    let csv = a
        .csv
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/sweep").join(format!("{stem}.csv")));
    sweep_chart(
        &r,
        &format!(
            "{}: Δλ at {} N vs {} ({})",
            design.name,
            a.force_n,
            param.name,
            fidelity_label(a.fidelity)
        ),
        log_x,
    )
    .write_svg(&svg)?;
    sweep_csv(&r, &csv)?;
    println!(
        "{}: {} over {from}..{to} ({} {} steps), F = {} N, model: {}",
        design.name,
        param.name,
        a.steps,
        if log_x { "log" } else { "linear" },
        a.force_n,
        fidelity_label(a.fidelity)
    );
    println!(
        "{:<36} {:>14} {:>14}",
        "series", "Δλ first pm", "Δλ last pm"
    );
    for s in &r.series {
        println!(
            "{:<36} {:>+14.3} {:>+14.3}",
            s.label(),
            s.shift_pm.first().copied().unwrap_or(f64::NAN),
            s.shift_pm.last().copied().unwrap_or(f64::NAN)
        );
    }
    default_contact_note(
        &design,
        a.fidelity,
        r.series.iter().any(|s| s.case == LoadCase::I),
    );
    println!("wrote {} and {}", svg.display(), csv.display());
    Ok(())
}

/// Say so when Case I curves by the FE rest on the shipped default contact radius.
fn default_contact_note(design: &fbgforge::spec::Design, f: FidelityArg, case_i: bool) {
    let default = design
        .module
        .as_ref()
        .is_some_and(|m| m.contact_radius_is_default());
    if case_i && default && f != FidelityArg::ClosedForm {
        println!(
            "note: Case I: {}",
            fbgforge::prediction::DEFAULT_CONTACT_WARNING
        );
    }
}

fn write_paper_figures(
    design: &fbgforge::spec::Design,
    dir: &Path,
    steps: usize,
    fidelity: FidelityArg,
    band: bool,
) -> Result<()> {
    ensure_dir(dir)?;
    let steps = steps.max(2);
    let pb = Bar::new();
    let mut trends: Vec<Vec<String>> = Vec::new();
    for fig in PAPER_FIGURES {
        let predictor = fbgforge::prediction::sweep_predictor_with_band(
            fidelity.into(),
            Some(fig.case),
            FemOptions::default(),
            band,
        );
        let r = sweep::run_paper_figure_with(design, fig, steps, predictor.as_deref(), &pb)
            .with_context(|| format!("paper figure {}", fig.id))?;
        let title = format!("{} ({})", fig.title, fidelity_label(fidelity));
        sweep_chart(&r, &title, false).write_svg(&dir.join(format!("{}.svg", fig.id)))?;
        sweep_csv(&r, &dir.join(format!("{}.csv", fig.id)))?;
        let first = &r.series[0];
        println!(
            "{:<18} {:<58} Δλ {:+9.2} → {:+9.2} pm ({})",
            fig.id,
            fig.title,
            first.shift_pm[0],
            first.shift_pm[first.shift_pm.len() - 1],
            first.label()
        );
        // Which of the paper's trends each model's curve reproduces: the nominal, and
        // the bounding readings when the band was computed.
        let mut curves: Vec<(String, Vec<f64>)> =
            vec![(nominal_label(fidelity, fig.case), first.shift_pm.clone())];
        if first.readings_pm_per_n.len() == first.x.len() {
            for (k, name) in [
                (0, "FE, pillars bonded (band's reading)"),
                (
                    1,
                    "FE, cylinders sliding, domes on the apex patch (band's reading)",
                ),
            ] {
                curves.push((
                    name.to_string(),
                    first
                        .readings_pm_per_n
                        .iter()
                        .map(|r| r[k] * sweep::PAPER_FORCE_N)
                        .collect(),
                ));
            }
        }
        for (name, y) in curves {
            let v = sweep::paper_trend(fig, &first.x, &y);
            println!(
                "    {:<62} {:<14} {}",
                name,
                if v.reproduced {
                    "reproduced"
                } else {
                    "NOT reproduced"
                },
                v.detail
            );
            trends.push(vec![
                fig.id.to_string(),
                name,
                v.reproduced.to_string(),
                v.detail,
            ]);
        }
    }
    default_contact_note(design, fidelity, true);
    write_csv(
        &dir.join("trends.csv"),
        &["figure", "model", "reproduced", "detail"],
        &trends,
    )?;
    println!(
        "wrote {} figures (SVG + CSV) and trends.csv to {}, model: {}",
        PAPER_FIGURES.len(),
        dir.display(),
        fidelity_label(fidelity)
    );
    Ok(())
}

/// The model of a figure's nominal curve, in words.
fn nominal_label(f: FidelityArg, case: LoadCase) -> String {
    match (f, case) {
        (FidelityArg::ClosedForm, _) => "closed form".into(),
        (FidelityArg::Fem, _) => "FE, design contact".into(),
        (FidelityArg::Auto, LoadCase::I) => "policy: FE, design contact (default)".into(),
        (FidelityArg::Auto, LoadCase::II) => "policy: closed form".into(),
    }
}
