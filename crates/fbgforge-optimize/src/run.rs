//! The optimisation use cases: [`run_module`] (module design for Q or sensitivity)
//! and [`run_placement`] (grating placement in a flat array). Each loads the design,
//! runs the search, writes the optimised design as TOML (it loads, builds, predicts
//! and verifies) and hands what it found to a sink ([`ModuleSink`], [`PlaceSink`],
//! ripgrep's `Sink`): the report folder (summary JSON, SVG charts with their CSVs and
//! `report.html`), the terminal table and the JSON on stdout are implementations in
//! `fbgforge-report`; a caller that wants only the returned value passes `&mut ()`.

use super::materials::MaterialLibrary;
use super::module::{
    landscape, model_predictor, optimise_module, LandscapePoint, ModuleOutcome, ModuleProblem,
    ModuleSettings, Variable,
};
use super::place::{place, PlaceOutcome, PlaceSettings};
use super::quality::MeasuredPrototype;
use crate::fields::InWords;
use crate::output::write_atomic;
use crate::progress::Progress;
use crate::spec::Design;
use anyhow::Result;
use std::path::{Path, PathBuf};

/// What `run_module` optimises and where it writes.
#[derive(Debug, Clone)]
pub struct ModuleRequest {
    /// The start design (TOML).
    pub design: PathBuf,
    /// Material library (TOML); the shipped one when `None`.
    pub materials: Option<PathBuf>,
    /// Objective, variables, bounds, constraints and solvers.
    pub settings: ModuleSettings,
    /// The JSON of a verification of a printed prototype, to calibrate lag and R².
    pub measured: Option<PathBuf>,
    /// The two variables of the landscape chart (the first two varied when `None`).
    pub landscape: Option<Vec<Variable>>,
    /// Where the optimised design goes (default: `out/optimize/<name>.toml`).
    pub out: Option<PathBuf>,
    /// Report folder (default: `<out stem>-report` beside the design).
    pub report_dir: Option<PathBuf>,
    /// The caller's words for the library's option names, in which the written
    /// design's description states why it was chosen (`fbgforge_core::fields`).
    pub words: InWords,
}

/// The objective over two variables around the winner's optimum (the others held
/// there), for the landscape chart.
#[derive(Debug, Clone)]
pub struct Landscape {
    /// The two variables: along the grid's rows, and across them.
    pub variables: (Variable, Variable),
    /// Values of each variable.
    pub steps: usize,
    /// The grid, first variable outer.
    pub points: Vec<LandscapePoint>,
}

/// Values of each landscape variable.
const LANDSCAPE_STEPS: usize = 15;

/// What `run_module` did.
#[derive(Debug, Clone)]
pub struct ModuleRun {
    /// The search's outcome (best design, every run).
    pub outcome: ModuleOutcome,
    /// Where the optimised design was written.
    pub design_path: PathBuf,
    /// Where the report goes (the report sink writes it).
    pub report_dir: PathBuf,
    /// The landscape around the winner (`None` when fewer than two variables vary).
    pub landscape: Option<Landscape>,
}

/// Where a module optimisation's results go; every method has a no-op default.
pub trait ModuleSink {
    /// The search is done and the optimised design written.
    fn optimised(&mut self, _run: &ModuleRun) -> Result<()> {
        Ok(())
    }
}

impl ModuleSink for () {}

impl<A: ModuleSink, B: ModuleSink> ModuleSink for (A, B) {
    fn optimised(&mut self, run: &ModuleRun) -> Result<()> {
        self.0.optimised(run)?;
        self.1.optimised(run)
    }
}

impl<S: ModuleSink + ?Sized> ModuleSink for &mut S {
    fn optimised(&mut self, run: &ModuleRun) -> Result<()> {
        (**self).optimised(run)
    }
}

/// What `run_placement` optimises and where it writes.
#[derive(Debug, Clone)]
pub struct PlaceRequest {
    /// The array design (TOML).
    pub design: PathBuf,
    /// Objective, method, solvers.
    pub settings: PlaceSettings,
    /// Where the optimised design goes (default: `out/place/<name>.toml`).
    pub out: Option<PathBuf>,
    /// Report folder (default: `<out stem>-report` beside the design).
    pub report_dir: Option<PathBuf>,
}

/// What `run_placement` did.
#[derive(Debug, Clone)]
pub struct PlaceRun {
    /// The search's outcome.
    pub outcome: PlaceOutcome,
    /// Where the optimised design was written.
    pub design_path: PathBuf,
    /// Where the report goes (the report sink writes it).
    pub report_dir: PathBuf,
    /// The start design, as loaded.
    pub start: Design,
    /// Seeds the layouts were scored on after the search (held out from it).
    pub held_out_seeds: usize,
}

/// Where a placement's results go; every method has a no-op default.
pub trait PlaceSink {
    /// The search is done and the placed design written.
    fn placed(&mut self, _run: &PlaceRun) -> Result<()> {
        Ok(())
    }
}

impl PlaceSink for () {}

impl<A: PlaceSink, B: PlaceSink> PlaceSink for (A, B) {
    fn placed(&mut self, run: &PlaceRun) -> Result<()> {
        self.0.placed(run)?;
        self.1.placed(run)
    }
}

impl<S: PlaceSink + ?Sized> PlaceSink for &mut S {
    fn placed(&mut self, run: &PlaceRun) -> Result<()> {
        (**self).placed(run)
    }
}

/// The landscape's two variables and their places among the varied ones: the request's
/// (checked before the work, so a typo costs nothing) or the first two varied.
fn landscape_variables(req: &ModuleRequest) -> Result<Vec<(Variable, usize)>> {
    let vary = &req.settings.vary;
    let chosen: Vec<Variable> = match &req.landscape {
        Some(v) => {
            anyhow::ensure!(
                v.len() == 2,
                "ModuleRequest.landscape needs exactly two variables, got {}",
                v.len()
            );
            v.clone()
        }
        None => vary.iter().take(2).copied().collect(),
    };
    chosen
        .into_iter()
        .map(|x| match vary.iter().position(|v| *v == x) {
            Some(i) => Ok((x, i)),
            None => anyhow::bail!(
                "ModuleRequest.landscape variable `{}` is not in ModuleSettings.vary",
                x.name()
            ),
        })
        .collect()
}

/// Optimise a module design: load it, search every material choice, write the
/// optimised design, hand the outcome and the landscape around the winner to `sink`,
/// and return them; `progress` hears one step per material choice.
///
/// ```
/// use fbgforge_optimize::module::{ModuleSettings, Objective, Variable};
/// use fbgforge_optimize::run::{run_module, ModuleRequest};
/// use fbgforge_core::progress::Quiet;
///
/// let dir = tempfile::tempdir()?;
/// let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
/// let mut settings = ModuleSettings {
///     objective: Objective::Sensitivity,
///     vary: vec![Variable::CapWallMm],
///     inserts: Some(vec!["none".into()]),
///     extra_starts: 0,
///     solvers: vec![fbgforge_model::solvers::SolverKind::NelderMead],
///     ..ModuleSettings::default()
/// };
/// settings.run.max_iters = 4;
/// let request = ModuleRequest {
///     design: root.join("designs/clip-on-34mm.toml"),
///     materials: None,
///     settings,
///     measured: None,
///     landscape: None,
///     out: Some(dir.path().join("optimised.toml")),
///     report_dir: None,
///     words: fbgforge_core::fields::own_words,
/// };
/// let run = run_module(&request, &Quiet, &mut ())?;
/// // Never worse than the start, and the written design loads back.
/// let best = &run.outcome.choices[run.outcome.best_choice];
/// assert!(best.best.as_ref().unwrap().objective >= run.outcome.start.objective * (1.0 - 1e-9));
/// assert_eq!(fbgforge_core::design::load(&run.design_path)?.name, run.outcome.design.name);
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn run_module(
    req: &ModuleRequest,
    progress: &dyn Progress,
    sink: &mut dyn ModuleSink,
) -> Result<ModuleRun> {
    req.settings.check()?;
    let design = crate::design::load(&req.design)?;
    let lib = match &req.materials {
        Some(p) => MaterialLibrary::load(p)?,
        None => MaterialLibrary::shipped(),
    };
    let settings = &req.settings;
    let landscape_vars = landscape_variables(req)?;
    let measured = req
        .measured
        .as_deref()
        .map(MeasuredPrototype::load)
        .transpose()?;
    let predictor = model_predictor();
    let outcome = optimise_module(
        &design,
        &lib,
        settings,
        measured.as_ref(),
        predictor.clone(),
        progress,
    )?;
    let mut outcome = outcome;
    outcome.design.description = outcome.design.description.as_deref().map(req.words);
    let out = req.out.clone().unwrap_or_else(|| {
        PathBuf::from("out/optimize").join(format!("{}.toml", outcome.design.name))
    });
    let report_dir = req
        .report_dir
        .clone()
        .unwrap_or_else(|| report_beside(&out));
    write_design(&out, &outcome.design)?;
    let landscape = match landscape_vars.as_slice() {
        [(va, a), (vb, b)] => {
            // Over two variables at the optimum of the winning choice.
            let win = &outcome.choices[outcome.best_choice];
            let p = ModuleProblem::new(
                &design,
                win.choice.clone(),
                &lib,
                settings,
                outcome.calibration,
                predictor,
            )?;
            let at = win
                .best
                .as_ref()
                .map(|e| e.x.clone())
                .unwrap_or_else(|| p.start_point());
            Some(Landscape {
                variables: (*va, *vb),
                steps: LANDSCAPE_STEPS,
                points: landscape(&p, &at, *a, *b, LANDSCAPE_STEPS),
            })
        }
        _ => None,
    };
    let run = ModuleRun {
        outcome,
        design_path: out,
        report_dir,
        landscape,
    };
    sink.optimised(&run)?;
    Ok(run)
}

/// Optimise grating placement: load the array design, search, write the design and
/// hand the outcome to `sink`; `progress` hears the search's three stages.
pub fn run_placement(
    req: &PlaceRequest,
    progress: &dyn Progress,
    sink: &mut dyn PlaceSink,
) -> Result<PlaceRun> {
    req.settings.check()?;
    let design = crate::design::load(&req.design)?;
    let outcome = place(&design, &req.settings, progress)?;
    let out = req.out.clone().unwrap_or_else(|| {
        PathBuf::from("out/place").join(format!("{}.toml", outcome.design.name))
    });
    let report_dir = req
        .report_dir
        .clone()
        .unwrap_or_else(|| report_beside(&out));
    write_design(&out, &outcome.design)?;
    let run = PlaceRun {
        outcome,
        design_path: out,
        report_dir,
        start: design,
        held_out_seeds: req.settings.test_seeds.len(),
    };
    sink.placed(&run)?;
    Ok(run)
}

/// Default report folder: `<out stem>-report` beside the written design.
fn report_beside(out: &Path) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "design".into());
    out.parent()
        .unwrap_or(Path::new("."))
        .join(format!("{stem}-report"))
}

/// Write a design as TOML, atomically, after checking that it loads back.
pub(crate) fn write_design(path: &Path, d: &Design) -> Result<()> {
    let text = format!(
        "# Written by fbgforge; loads with `fbgforge build/predict/verify`.\n{}",
        d.to_toml()
    );
    crate::design::parse(&text)
        .map_err(|e| anyhow::anyhow!("internal: the written design does not load back: {e}"))?;
    write_atomic(path, text.as_bytes())
}
