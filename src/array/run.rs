//! The reconstruction use case: a sensing matrix (measured CSV or a design's model)
//! and a file of grating shifts in, the loads CSV and a summary out. `fbgforge
//! reconstruct` calls [`reconstruct_file`]; the method is picked and the frames
//! reconstructed by [`super::reconstruct()`].

use super::io::{read_matrix_file, read_shifts_for, write_loads};
use super::kernel::matrix_from_design;
use super::methods::{check_resolution, Method, NoisePrior, ReadingPrior, DEFAULT_MAX_LOADS};
use super::problem::{default_min_load_g, SensingProblem};
use super::reconstruct::{reconstruct, Frames, MethodRequest, DEFAULT_BUDGET_US};
use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};

pub use super::reconstruct::ChoiceSummary;

/// The paper's ulimit, used when neither the request nor a design gives one, g.
pub const PAPER_ULIMIT_G: f64 = 250.0;

/// Where the sensing matrix comes from.
#[derive(Debug, Clone)]
pub enum MatrixSource {
    /// A measured matrix CSV: header `grating,<cells…>`, one row per grating, pm/g;
    /// or numbers only (no header, no names), as numpy.savetxt or MATLAB writematrix
    /// write it.
    Csv(PathBuf),
    /// The model sensing matrix of an array design.
    Design(PathBuf),
}

/// What to reconstruct and how; `None` fields take the method's or design's default.
#[derive(Debug, Clone)]
pub struct ReconstructRequest {
    /// The sensing matrix.
    pub matrix: MatrixSource,
    /// Shifts CSV: header `[time_s,]<grating names…>`, one row per frame, pm.
    pub shifts: PathBuf,
    /// Method name (default: the most accurate method within `budget_us`, see
    /// [`crate::array::choice`]).
    pub method: Option<String>,
    /// Per-frame time budget of the automatic method choice, µs (default
    /// [`DEFAULT_BUDGET_US`]); ignored when a method is named.
    pub budget_us: Option<f64>,
    /// Most simultaneous loads (default: the design's `max_loads`, else
    /// [`DEFAULT_MAX_LOADS`]).
    pub max_loads: Option<usize>,
    /// Largest load per cell, g (default: the design's ulimit, else 250 g).
    pub ulimit_g: Option<f64>,
    /// Smallest load a loaded cell carries, g (default: the paper's 25 g, or 0 when
    /// ulimit is not above 25 g).
    pub min_load_g: Option<f64>,
    /// Penalty weight (default: the method's tuned default, or for `support` and
    /// `bnb` the one that follows `resolution_pm`).
    pub penalty: Option<f64>,
    /// The interrogator's resolution (noise standard deviation), pm; sets the ℓ0
    /// penalty of `support` and `bnb` ([`crate::array::methods::l0_penalty_for_resolution`];
    /// default: the paper's 0.5 pm, λ = 4).
    pub resolution_pm: Option<f64>,
    /// Column-normalise the matrix (the paper does).
    pub normalise: bool,
    /// Output CSV of loads (default: `out/reconstruct/<shifts name>-loads.csv`).
    pub out: Option<PathBuf>,
}

impl ReconstructRequest {
    /// A request with every default.
    pub fn new(matrix: MatrixSource, shifts: PathBuf) -> Self {
        ReconstructRequest {
            matrix,
            shifts,
            method: None,
            budget_us: None,
            max_loads: None,
            ulimit_g: None,
            min_load_g: None,
            penalty: None,
            resolution_pm: None,
            normalise: true,
            out: None,
        }
    }
}

/// JSON summary of a reconstruction run.
#[derive(Debug, Serialize)]
pub struct ReconstructSummary {
    /// Method used.
    pub method: &'static str,
    /// How it was chosen, when no method was named.
    pub choice: Option<ChoiceSummary>,
    /// Penalty used.
    pub penalty: f64,
    /// Most simultaneous loads considered (support methods).
    pub max_loads: usize,
    /// Whether columns were normalised.
    pub normalised: bool,
    /// Upper bound per cell, g.
    pub ulimit_g: f64,
    /// Smallest load of a loaded cell (prior of `wsupport`), g.
    pub min_load_g: f64,
    /// Gratings (rows of the matrix).
    pub gratings: usize,
    /// Number of frames.
    pub frames: usize,
    /// Frames where the method did not converge (for `bnb`: stopped at its node
    /// budget, best support found but not certified).
    pub not_converged: usize,
    /// Cell labels.
    pub cells: Vec<String>,
    /// Mean load per cell over all frames, g.
    pub mean_load_g: Vec<f64>,
    /// Largest residual ‖Ax − y‖ over the frames, pm.
    pub max_residual_pm: f64,
    /// One-off set-up: building the method for the matrix (and, for the automatic
    /// choice, timing the candidates), ms. Not part of the per-frame time.
    pub setup_ms: f64,
    /// Wall time of reconstructing the frames alone, per frame, µs (all threads).
    pub time_per_frame_us: f64,
    /// Threads used for the frames (in parallel from 512 frames on).
    pub threads: usize,
    /// Output file.
    pub out: PathBuf,
}

/// Read a sensing matrix (or derive it from a design) and a shifts file, reconstruct
/// every frame, write the loads CSV and return the summary; `progress` hears the frames.
pub fn reconstruct_file(
    a: &ReconstructRequest,
    progress: &dyn crate::progress::Progress,
) -> Result<ReconstructSummary> {
    let named = a.method.as_deref().map(Method::from_name).transpose()?;
    if a.penalty.is_some() && named.is_none() {
        bail!("--penalty is a weight of one method: name the method with --method");
    }
    let (matrix, generated_names, design_ulimit, design_max_loads) = match &a.matrix {
        MatrixSource::Csv(p) => {
            let f = read_matrix_file(p)?;
            (f.matrix, f.generated_names, None, None)
        }
        MatrixSource::Design(d) => {
            let design = crate::design::load(d)?;
            let (m, u) =
                matrix_from_design(&design).with_context(|| format!("design {}", d.display()))?;
            let k = design.array.as_ref().and_then(|arr| arr.max_loads);
            (m, false, Some(u), k.map(|k| k as usize))
        }
    };
    let ulimit_g = a.ulimit_g.or(design_ulimit).unwrap_or(PAPER_ULIMIT_G);
    if !(ulimit_g.is_finite() && ulimit_g > 0.0) {
        bail!("--ulimit-g must be a positive load in g, got {ulimit_g}");
    }
    let max_loads = a
        .max_loads
        .or(design_max_loads)
        .unwrap_or(DEFAULT_MAX_LOADS);
    if max_loads == 0 {
        bail!("--max-loads must be at least 1");
    }
    let stream = read_shifts_for(&a.shifts, &matrix.gratings, generated_names)?;
    let min_load_g = a.min_load_g.unwrap_or(default_min_load_g(ulimit_g));
    let problem = SensingProblem::new(matrix.sensitivity_pm_per_g.clone(), ulimit_g, a.normalise)?
        .with_min_load_g(min_load_g)
        .map_err(|e| anyhow::anyhow!("--min-load-g: {e}"))?;
    let resolution_pm = a.resolution_pm.unwrap_or(NoisePrior::paper().resolution_pm);
    check_resolution(resolution_pm).map_err(|e| anyhow::anyhow!("--resolution-pm: {e}"))?;
    let prior = ReadingPrior {
        max_loads,
        resolution_pm,
    };
    let request = match named {
        Some(method) => MethodRequest::Named {
            method,
            penalty: a.penalty,
        },
        None => {
            let budget_us = a.budget_us.unwrap_or(DEFAULT_BUDGET_US);
            if !(budget_us.is_finite() && budget_us > 0.0) {
                bail!("--budget-us: the per-frame budget must be a positive time in µs, got {budget_us}");
            }
            MethodRequest::Default { budget_us }
        }
    };
    let frames = Frames {
        gratings: &matrix.gratings,
        shifts_pm: &stream.frames_pm,
    };
    let done = reconstruct(&problem, frames, &prior, &request, progress)?;
    let results = &done.frames;
    let out = a.out.clone().unwrap_or_else(|| default_out(&a.shifts));
    let loads: Vec<Vec<f64>> = results.iter().map(|r| r.loads_g.clone()).collect();
    write_loads(&out, &matrix.cells, stream.time_s.as_deref(), &loads)?;
    let n = results.len().max(1) as f64;
    let summary = ReconstructSummary {
        method: done.setup.method.name(),
        penalty: done.setup.penalty(),
        choice: done.setup.choice,
        max_loads: max_loads.min(matrix.n_gratings()).min(matrix.n_cells()),
        normalised: a.normalise,
        ulimit_g,
        min_load_g,
        gratings: matrix.n_gratings(),
        frames: results.len(),
        not_converged: results.iter().filter(|r| !r.converged).count(),
        mean_load_g: (0..matrix.n_cells())
            .map(|j| results.iter().map(|r| r.loads_g[j]).sum::<f64>() / n)
            .collect(),
        cells: matrix.cells.clone(),
        max_residual_pm: results.iter().map(|r| r.residual_pm).fold(0.0, f64::max),
        setup_ms: done.setup.setup_ms,
        time_per_frame_us: done.time_per_frame_us,
        threads: done.threads,
        out: out.clone(),
    };
    Ok(summary)
}

fn default_out(shifts: &Path) -> PathBuf {
    let stem = shifts
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("shifts");
    PathBuf::from("out")
        .join("reconstruct")
        .join(format!("{stem}-loads.csv"))
}
