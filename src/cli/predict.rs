//! `fbgforge predict` and `fbgforge sweep`: the opto-mechanical model from the command
//! line. `predict` on an array design prints its predicted sensing matrix (or the
//! response to one load) and maps each grating's sensitivity over the sheet. The flags
//! become the library's requests; the tables, JSON, charts and CSVs are the printers of
//! `fbgforge::report::predict`.

use super::progress::Bar;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use fbgforge::array::kernel::ArrayModelKind;
use fbgforge::array::predict::ArrayPredictor;
use fbgforge::fem::{FemOptions, GeometryCache};
use fbgforge::model::sweep;
use fbgforge::model::LoadCase;
use fbgforge::prediction::{
    FidelityChoice, PaperFiguresRequest, PredictSink, PredictionRequest, RunError, Spacing,
    SweepRequest,
};
use fbgforge::report::predict::{array, PaperFigureFiles, PredictJson, PredictTable, SweepFiles};
use fbgforge::report::terminal::Fit;
use std::path::{Path, PathBuf};

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[
    ("PredictionRequest.force_n", "--force-n"),
    ("PredictionRequest.delta_t_k", "--delta-t-k"),
    ("PredictionRequest.fidelity", "--fidelity"),
    ("PredictionRequest.fem_options", "--mesh-level"),
    ("PredictionRequest.refine_to_level", "--mesh-level"),
    ("PredictionRequest.spectrum", "--no-spectrum"),
    ("SweepRequest.force_n", "--force-n"),
    ("SweepRequest.start", "--from"),
    ("SweepRequest.stop", "--to"),
    ("SweepRequest.steps", "--steps"),
    // The model's warning on the shipped default contact names verify's option.
    ("VerifyRequest.calibrate_into", "--calibrate-into"),
];

/// A library text in this file's flags ([`FLAGS`]): what the sinks print and write.
fn in_flag_words(text: &str) -> String {
    fbgforge::fields::in_words(text, FLAGS)
}

/// Arguments of `fbgforge predict`.
#[derive(Debug, Args)]
pub struct PredictArgs {
    /// Design spec (TOML) with a [module] or an [array] section, or a shipped
    /// design's name (`clip-on-34mm`).
    #[arg(value_parser = super::designs::design_arg)]
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
    /// Skip the prediction band and the design interval (the bounding readings, the
    /// contact window's ends and Case II's stated-cylinders reading: more
    /// finite-element solves per configuration; implied by `--fidelity closed-form`).
    #[arg(long)]
    pub no_band: bool,
    /// Finite-element mesh level, 1 to 4 (fine). Element sizes are stated for the 34 mm
    /// module and scaled with the module's diameter; each level halves every size of
    /// the level below. Every FE reading is solved on level K and on level K − 1 and
    /// extrapolated from the two (Richardson); the step it takes is the row's stated
    /// discretisation error. So level 1 is extrapolated from level 0, a mesh with one
    /// element through each wall that never answers alone (its own step understates
    /// its error). Without this flag the policy picks, per configuration, the cheapest
    /// level from 1 up to 3 whose rows state a model error of at most 15 %; with it,
    /// level K for every row (docs/fem.md §5.3).
    #[arg(long, value_name = "K",
          value_parser = clap::value_parser!(u32).range(i64::from(fbgforge::fem::FemOptions::MIN_MESH_LEVEL)..=i64::from(fbgforge::fem::FemOptions::MAX_MESH_LEVEL)))]
    pub mesh_level: Option<u32>,
    /// Skip each grating's reflection spectrum over the design's force range (the
    /// transfer-matrix model on the FE strain profile along the grating, read from the
    /// same solve: milliseconds per grating, no extra finite-element solve; for an
    /// array, on the sheet model's profile under the indenter on each cell).
    #[arg(long)]
    pub no_spectrum: bool,
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

/// A use case's error in the command line's words: `design` (the spec's path) before
/// what does not fit the design, and `failed` (e.g. "cannot predict") before what the
/// model could not do.
fn in_context(e: RunError, design: &Path, failed: &str) -> anyhow::Error {
    match e {
        RunError::Request(e) | RunError::Output(e) => e,
        RunError::Design(e) => e.context(design.display().to_string()),
        RunError::Model(e) => e.context(format!("{}: {failed}", design.display())),
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
    array::write_map(design, &p, &map, (&svg, &csv))?;
    let response = match load {
        Some((x, y)) => Some((
            (x, y),
            p.load_at(x, y)
                .with_context(|| format!("{}: --load-at-mm", a.design.display()))?,
        )),
        None => None,
    };
    let spectra = if a.no_spectrum {
        None
    } else {
        p.spectra(design).with_context(|| {
            format!("{}: cannot predict the array's spectra", a.design.display())
        })?
    };
    let shown = array::ArrayPrediction {
        design,
        predictor: &p,
        load: response.as_ref().map(|(at, r)| (*at, r)),
        map_files: (&svg, &csv),
        spectra: spectra.as_ref(),
    };
    let mut out = std::io::stdout();
    if a.json {
        array::write_json(&mut out, &shown)
    } else {
        array::write_table(&mut Fit::new(out), &shown)
    }
}

/// Run `fbgforge predict`.
pub fn run_predict(a: PredictArgs) -> Result<()> {
    let choice = FidelityChoice::from(a.fidelity);
    let request = PredictionRequest {
        force_n: a.force_n,
        delta_t_k: a.delta_t_k,
        case: a.case.map(LoadCase::from),
        fidelity: choice,
        band: !a.no_band,
        design_interval: !a.no_band,
        fem_options: FemOptions::mesh_level(a.mesh_level.unwrap_or(FemOptions::DEFAULT_MESH_LEVEL)),
        // A level asked for is kept; without one the policy refines where it must.
        refine_to_level: match a.mesh_level {
            Some(_) => None,
            None => Some(FemOptions::AUTO_FINEST_MESH_LEVEL),
        },
        spectrum: !a.no_spectrum,
        ..Default::default()
    };
    request.check()?;
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
    let out = std::io::stdout();
    let mut sink: Box<dyn PredictSink> = if a.json {
        Box::new(PredictJson::new(out, in_flag_words))
    } else {
        Box::new(PredictTable::new(Fit::new(out), in_flag_words))
    };
    fbgforge::prediction::predict_into(&design, &request, &mut *sink)
        .map_err(|e| in_context(e, &a.design, "cannot predict"))?;
    Ok(())
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
    /// Design spec (TOML) with a [module] section, or a shipped design's name.
    #[arg(value_parser = super::designs::design_arg)]
    pub design: PathBuf,
    /// Parameter to sweep, e.g. e1_mpa, e2_mpa, es_mpa, outer_diameter_mm, core_wall_mm,
    /// cap_wall_mm (an unknown name lists them all).
    #[arg(long)]
    pub param: Option<String>,
    /// First value of the range. For a modulus (e1_mpa, e2_mpa, es_mpa) without
    /// --from/--to, the range is the material library's: the smallest to the largest
    /// modulus of the cores, caps or inserts the design's printer makes
    /// (designs/library/materials.toml), in --steps values (41 by default).
    #[arg(long)]
    pub from: Option<f64>,
    /// Last value of the range (must be larger than --from); see --from for a
    /// modulus's default.
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

/// The range of a sweep: --from/--to, else for a modulus the library's range of the
/// materials the design's printer makes for that part.
fn sweep_range(
    design: &fbgforge::spec::Design,
    param: &sweep::SweepParam,
    from: Option<f64>,
    to: Option<f64>,
) -> Result<(f64, f64)> {
    use fbgforge::optimize::materials::{MaterialLibrary, MaterialRole};
    if let (Some(start), Some(stop)) = (from, to) {
        return Ok((start, stop));
    }
    let role = match param.name {
        "e1_mpa" => MaterialRole::Core,
        "e2_mpa" => MaterialRole::Cap,
        "es_mpa" => MaterialRole::Insert,
        _ => bail!("--from and --to are required for a sweep of {}", param.name),
    };
    let process = design.printer.process;
    let (role_name, process_name) = (
        format!("{role:?}").to_lowercase(),
        format!("{process:?}").to_lowercase(),
    );
    let Some((lo, hi)) = MaterialLibrary::shipped().modulus_range(role, process) else {
        bail!(
            "the material library offers no {role_name} material for this printer ({process_name}); \
             give --from and --to for a sweep of {}",
            param.name
        );
    };
    let (start, stop) = (from.unwrap_or(lo), to.unwrap_or(hi));
    if from.is_none() || to.is_none() {
        print!(
            "{}",
            fbgforge::report::terminal::fit(&format!(
                "range from the material library ({process_name} {role_name}s): \
                 {start}..{stop} MPa\n"
            ))
        );
    }
    Ok((start, stop))
}

/// Run `fbgforge sweep`: one parameter over a range, or the paper's figures.
pub fn run_sweep(a: SweepArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    if let Some(dir) = &a.paper_figures {
        let request = PaperFiguresRequest {
            steps: a.steps,
            fidelity: a.fidelity.into(),
            band: !a.no_band,
            fem_options: FemOptions::default(),
            cache: GeometryCache::default(),
        };
        let mut sink =
            PaperFigureFiles::new(dir.clone(), Fit::new(std::io::stdout()), in_flag_words);
        return fbgforge::prediction::paper_figures(&design, &request, &Bar::new(), &mut sink)
            .map_err(RunError::into_inner);
    }
    let Some(name) = a.param.as_deref() else {
        bail!(
            "--param is required (or use --paper-figures DIR); known parameters: {}",
            sweep::param_names().join(", ")
        );
    };
    let param = sweep::find_param(name)?;
    let (start, stop) = sweep_range(&design, param, a.from, a.to)?;
    let request = SweepRequest {
        param,
        start,
        stop,
        steps: a.steps,
        spacing: if a.log {
            Spacing::Log
        } else if a.linear {
            Spacing::Linear
        } else {
            Spacing::Auto
        },
        values: None,
        force_n: a.force_n,
        case: a.case.map(LoadCase::from),
        fidelity: a.fidelity.into(),
        band: !a.no_band,
        fem_options: FemOptions::default(),
        cache: GeometryCache::default(),
    };
    let stem = format!("{}-{}", design.name, param.name);
    let svg = a
        .plot
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/sweep").join(format!("{stem}.svg")));
    let csv = a
        .csv
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/sweep").join(format!("{stem}.csv")));
    let mut sink = SweepFiles::new(svg, csv, Fit::new(std::io::stdout()), in_flag_words);
    fbgforge::prediction::sweep(&design, &request, &Bar::new(), &mut sink)
        .map_err(|e| in_context(e, &a.design, "sweep failed"))?;
    Ok(())
}
