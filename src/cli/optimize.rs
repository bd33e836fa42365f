//! `fbgforge optimize` and `fbgforge place`: design optimisation from the command
//! line (the work is in `fbgforge::optimize::run`).

use super::progress::Bar;
use anyhow::Result;
use clap::Args;
use fbgforge::optimize::module::{
    parse_bounds, ModuleSettings, Objective, PaperStatementsPolicy, Preference, Variable,
};
use fbgforge::optimize::place::{PlaceObjective, PlaceSettings};
use fbgforge::optimize::run::{
    run_module, run_placement, ModuleRequest, ModuleSink, PlaceRequest, PlaceSink,
};
use fbgforge::prediction::Robustness;
use fbgforge::report::optimize::{ModuleJson, ModuleReportFolder, ModuleTable};
use fbgforge::report::place::{PlaceJson, PlaceReportFolder, PlaceTable};
use fbgforge::report::terminal::Fit;
use fbgforge::solvers::SolverKind;
use std::path::PathBuf;

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[
    ("ModuleSettings.vary", "--vary"),
    ("ModuleSettings.prefer", "--prefer"),
    ("ModuleSettings.paper_statements", "--paper-statements"),
    (
        "ModuleSettings.strain_margin_fraction",
        "--strain-margin-percent",
    ),
    ("ModuleSettings.max_force_n", "--max-force-n"),
    ("ModuleSettings.rate_hz", "--rate-hz"),
    ("ModuleSettings.min_fit_clearance_mm", "--min-clearance-mm"),
    ("ModuleRequest.landscape", "--landscape"),
    ("RunSettings.max_iters", "--max-iters"),
    ("RunSettings.swarm_iters", "--swarm-iters"),
    // The model's warning on the shipped default contact names verify's option.
    ("VerifyRequest.calibrate_into", "--calibrate-into"),
];

/// A library text in this file's flags ([`FLAGS`]): what the sinks print and write.
fn in_flag_words(text: &str) -> String {
    fbgforge::fields::in_words(text, FLAGS)
}

/// Arguments of `fbgforge optimize`.
#[derive(Debug, Args)]
pub struct OptimizeArgs {
    /// Start design (TOML with a [module] section, or a shipped design's name).
    #[arg(value_parser = super::designs::design_arg)]
    pub design: PathBuf,
    /// What the table ranks by: q (|K|·R²/Δt_max), sensitivity (|K|) or force-range
    /// (the largest force before the strain or wavelength limit).
    #[arg(long, default_value = "q")]
    pub objective: String,
    /// Variables to search, comma-separated (outer_diameter_mm, cap_wall_mm,
    /// core_wall_mm, dome_height_ratio, overall_height_mm).
    #[arg(
        long,
        default_value = "outer_diameter_mm,cap_wall_mm,core_wall_mm,dome_height_ratio"
    )]
    pub vary: String,
    /// Search bounds replacing the defaults, e.g. `outer_diameter_mm=10:22,cap_wall_mm=0.5:2`.
    #[arg(long)]
    pub bounds: Option<String>,
    /// Largest force the module must take, N (strain and window constraints).
    #[arg(long, default_value_t = 20.0)]
    pub max_force_n: f64,
    /// Largest allowed grating strain at that force, microstrain.
    #[arg(long, default_value_t = 3000.0)]
    pub max_strain_microstrain: f64,
    /// Smallest printable fit clearance, mm (default: the printer's resolution).
    #[arg(long)]
    pub min_clearance_mm: Option<f64>,
    /// Core materials to try, comma-separated (default: the design's and the library's
    /// for this printer).
    #[arg(long)]
    pub cores: Option<String>,
    /// Inserts to try, comma-separated; `none` is a hollow core (default: the design's,
    /// the library's for this printer, and none).
    #[arg(long)]
    pub inserts: Option<String>,
    /// Material library TOML replacing the shipped `designs/library/materials.toml`.
    #[arg(long)]
    pub materials: Option<PathBuf>,
    /// JSON of `fbgforge verify --json` for a print of this design: calibrates the Q model.
    #[arg(long)]
    pub measured: Option<PathBuf>,
    /// Solver: nelder-mead, particle-swarm or both.
    #[arg(long, default_value = "both")]
    pub solver: String,
    /// Random starts per solver besides the design's own point.
    #[arg(long, default_value_t = 2)]
    pub starts: usize,
    /// Iteration limit per Nelder–Mead run.
    #[arg(long, default_value_t = 200)]
    pub max_iters: u64,
    /// Iteration limit of the particle swarm.
    #[arg(long, default_value_t = 80)]
    pub swarm_iters: u64,
    /// Seed of starts and swarms.
    #[arg(long, default_value_t = 2024)]
    pub seed: u64,
    /// How K is scored over the model's own uncertainty, the design interval (Case I:
    /// the domes' contact radius 1.30–1.48 × the apex patch; Case II: the closed form
    /// and the stated cylinders' FE reading; each widened by its model error): `worst`
    /// (smallest |K| scored), `quantile:P` (e.g. quantile:0.1) or `nominal`. The limits
    /// always hold at the interval's far end.
    #[arg(long, default_value = "worst")]
    pub robust: String,
    /// Share of the strain limit every grating keeps free at the far end of its design
    /// interval, percent.
    #[arg(long, default_value_t = 5.0)]
    pub strain_margin_percent: f64,
    /// What to do with a front design that fails one of the paper's statements (the
    /// check `predict` prints): `exclude` (never write it while another design of the
    /// front meets them all) or `report` (write the preferred design and name what it
    /// fails in the JSON, the table and the design's description).
    #[arg(long, default_value = "exclude")]
    pub paper_statements: String,
    /// Interrogator sample rate, Hz: Δt_max is never below one sample period (default:
    /// the design's interrogator_rate_hz, 2 Hz when absent, or the --measured log's).
    #[arg(long)]
    pub rate_hz: Option<f64>,
    /// Which design of the Pareto front to write: knee, objective (the table's best by
    /// --objective), sensitivity, force-range, lag or r-squared.
    #[arg(long, default_value = "knee")]
    pub prefer: String,
    /// The two variables of the Q landscape plot (default: the first two varied).
    #[arg(long)]
    pub landscape: Option<String>,
    /// Where to write the optimised design (default `out/optimize/<name>-optimised.toml`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Folder for the JSON summary, CSVs and SVG plots (default: beside --out).
    #[arg(long)]
    pub report_dir: Option<PathBuf>,
    /// Print the JSON summary on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

fn split_list(s: &str) -> Vec<String> {
    s.split(',')
        .map(|x| x.trim().to_string())
        .filter(|x| !x.is_empty())
        .collect()
}

/// Build module settings from the arguments (checked by the library).
pub fn module_settings(a: &OptimizeArgs) -> Result<ModuleSettings> {
    let vary = Variable::parse_list(&a.vary)?;
    let mut s = ModuleSettings {
        objective: Objective::parse(&a.objective)?,
        max_force_n: a.max_force_n,
        max_grating_strain: a.max_strain_microstrain * 1e-6,
        min_fit_clearance_mm: a.min_clearance_mm,
        vary,
        bounds: a
            .bounds
            .as_deref()
            .map(parse_bounds)
            .transpose()?
            .unwrap_or_default(),
        cores: a.cores.as_deref().map(split_list),
        inserts: a.inserts.as_deref().map(split_list),
        solvers: SolverKind::parse(&a.solver)?,
        extra_starts: a.starts,
        seed: a.seed,
        robustness: Robustness::parse(&a.robust)?,
        strain_margin_fraction: a.strain_margin_percent / 100.0,
        rate_hz: a.rate_hz,
        prefer: Preference::parse(&a.prefer)?,
        paper_statements: PaperStatementsPolicy::parse(&a.paper_statements)?,
        ..ModuleSettings::default()
    };
    s.run.max_iters = a.max_iters;
    s.run.swarm_iters = a.swarm_iters;
    s.check()?;
    Ok(s)
}

/// Run `fbgforge optimize`: the report folder, then the table or the JSON on stdout.
pub fn run_optimize(a: OptimizeArgs) -> Result<()> {
    let req = ModuleRequest {
        design: a.design.clone(),
        materials: a.materials.clone(),
        settings: module_settings(&a)?,
        measured: a.measured.clone(),
        landscape: a
            .landscape
            .as_deref()
            .map(Variable::parse_list)
            .transpose()?,
        out: a.out.clone(),
        report_dir: a.report_dir.clone(),
        words: in_flag_words,
    };
    let folder = ModuleReportFolder::new(in_flag_words);
    let out = std::io::stdout();
    let mut sink: Box<dyn ModuleSink> = if a.json {
        Box::new((folder, ModuleJson::new(out, in_flag_words)))
    } else {
        Box::new((folder, ModuleTable::new(Fit::new(out), in_flag_words)))
    };
    run_module(&req, &Bar::new(), &mut *sink)?;
    Ok(())
}

/// Arguments of `fbgforge place`.
#[derive(Debug, Args)]
pub struct PlaceArgs {
    /// Start design (TOML with an [array] section, or a shipped design's name).
    #[arg(value_parser = super::designs::design_arg)]
    pub design: PathBuf,
    /// Objective: protocol (RR + mean SNR on the seeded protocol) or coherence (proxy).
    #[arg(long, default_value = "protocol")]
    pub objective: String,
    /// Reconstruction method the protocol uses.
    #[arg(long, default_value = "wsupport")]
    pub method: String,
    /// Also move the fibers along x (the mold's slits follow).
    #[arg(long)]
    pub vary_fibers: bool,
    /// Solver: nelder-mead, particle-swarm or both.
    #[arg(long, default_value = "both")]
    pub solver: String,
    /// Iteration limit per run (Nelder–Mead and swarm).
    #[arg(long, default_value_t = 90)]
    pub max_iters: u64,
    /// Random layouts for measuring the coherence proxy against the protocol (0: skip).
    #[arg(long, default_value_t = 40)]
    pub agreement_samples: usize,
    /// Where to write the placed design (default `out/place/<name>-placed.toml`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Folder for the JSON summary, CSV and SVG plots (default: beside --out).
    #[arg(long)]
    pub report_dir: Option<PathBuf>,
    /// Print the JSON summary on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Build placement settings from the arguments (checked by the library).
pub fn place_settings(a: &PlaceArgs) -> Result<PlaceSettings> {
    let mut s = PlaceSettings {
        objective: PlaceObjective::parse(&a.objective)?,
        method: fbgforge::array::methods::Method::from_name(&a.method)?,
        vary_fibers: a.vary_fibers,
        solvers: SolverKind::parse(&a.solver)?,
        agreement_samples: a.agreement_samples,
        ..PlaceSettings::default()
    };
    s.run.max_iters = a.max_iters;
    s.run.swarm_iters = a.max_iters;
    s.check()?;
    Ok(s)
}

/// Run `fbgforge place`: the report folder, then the table or the JSON on stdout.
pub fn run_place(a: PlaceArgs) -> Result<()> {
    let req = PlaceRequest {
        design: a.design.clone(),
        settings: place_settings(&a)?,
        out: a.out.clone(),
        report_dir: a.report_dir.clone(),
    };
    let folder = PlaceReportFolder::new(in_flag_words);
    let out = std::io::stdout();
    let mut sink: Box<dyn PlaceSink> = if a.json {
        Box::new((folder, PlaceJson::new(out, in_flag_words)))
    } else {
        Box::new((folder, PlaceTable::new(Fit::new(out))))
    };
    run_placement(&req, &Bar::new(), &mut *sink)?;
    Ok(())
}
