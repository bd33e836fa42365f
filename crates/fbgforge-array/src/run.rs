//! The reconstruction use case: a sensing matrix (measured CSV or a design's model)
//! and a file of grating shifts in, the loads CSV and a summary out. `fbgforge
//! reconstruct` calls [`reconstruct_file`]; the method is picked and the frames
//! reconstructed by [`super::reconstruct()`].

use super::faults::StreamSample;
use super::faults::{temperature_weights, SuspectGrating};
use super::io::{read_matrix_file, LoadsWriter, ShiftReader};
use super::kernel::matrix_from_design;
use super::methods::{Method, NoisePrior, ReadingSettings, DEFAULT_MAX_LOADS};
use super::problem::{default_min_load_g, SensingProblem, Uncertainty, UncertaintySummary};
use super::reconstruct::{MethodRequest, StreamEnd, StreamRun, CHUNK_FRAMES, DEFAULT_BUDGET_US};
use super::trust::FlagCounts;
use super::SensingMatrix;
use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};

pub use super::reconstruct::ChoiceSummary;

/// The paper's ulimit, used when neither the request nor a design gives one, g.
pub(crate) const PAPER_ULIMIT_G: f64 = 250.0;

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
    /// [`crate::choice`]).
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
    /// penalty of `support` and `bnb` ([`crate::methods::l0_penalty_for_resolution`];
    /// default: the paper's 0.5 pm, λ = 4).
    pub resolution_pm: Option<f64>,
    /// Column-normalise the matrix (the paper does).
    pub normalise: bool,
    /// Fit a per-frame common offset (a temperature change since the tare),
    /// weighted by each grating's temperature sensitivity where the design gives the
    /// gratings' wavelengths, equally otherwise (off by default: docs/array.md §11).
    pub common_mode: bool,
    /// Per-entry standard deviation of the matrix, pm/g, as a CSV shaped like the
    /// matrix (e.g. the scatter of repeated calibrations; `calibrate-array` does not
    /// write one yet).
    pub matrix_sd: Option<PathBuf>,
    /// Per-entry standard deviation of the matrix as a percentage of each entry
    /// (instead of `matrix_sd`).
    pub matrix_sd_pct: Option<f64>,
    /// Diagnose the stream (dead, stuck, drifting, swapped, saturated, noisy
    /// gratings named and left out or corrected; a common offset fitted when the
    /// frames call for it; on by default).
    pub dead_grating_check: bool,
    /// Significance of the per-frame test behind the flags, in (0, 0.5] (default
    /// 0.05: at most ~5 % of clean frames flagged; docs/array.md §11).
    pub significance: Option<f64>,
    /// The interrogator's window, pm: a shift beyond ± this is not a reading and
    /// its frame is `unusable` (default 2500 pm).
    pub window_pm: Option<f64>,
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
            common_mode: false,
            matrix_sd: None,
            matrix_sd_pct: None,
            dead_grating_check: true,
            significance: None,
            window_pm: None,
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
    /// Frames whose answer is the proven optimum of the method's objective.
    pub certified: usize,
    /// How many frames carry each flag (`trusted`: none).
    pub flags: FlagCounts,
    /// Gratings found faulty across the frames (dead or stuck, drifting, swapped,
    /// saturated, noisy), each with its reason, evidence and remedy.
    pub suspect_gratings: Vec<SuspectGrating>,
    /// Whether a per-frame common offset was fitted, and its mean over the frames,
    /// pm per unit mean temperature weight.
    pub common_mode: bool,
    /// Mean fitted common offset, pm (with `common_mode`).
    pub mean_common_mode_pm: Option<f64>,
    /// Who decided the common offset (asked, off, or the stream diagnosis) and why.
    pub common_mode_note: crate::faults::CommonModeNote,
    /// The default choice's budget kept on the mean over the frames (None for a
    /// named method).
    pub budget: Option<crate::reconstruct::BudgetNote>,
    /// The uncertainty the flags were judged against.
    pub uncertainty: UncertaintySummary,
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
    /// The most frames held in memory at once: one chunk of the file
    /// ([`CHUNK_FRAMES`]) and the diagnosis sample's frames (bounded), whatever the
    /// file's length.
    pub most_frames_held: usize,
    /// Output file.
    pub out: PathBuf,
}

impl ReconstructRequest {
    /// Check what can be checked before anything is read: a penalty needs a named
    /// method, and the matrix's uncertainty is given at most one way, as a percentage
    /// ≥ 0.
    pub fn validate(&self) -> Result<()> {
        if self.penalty.is_some() && self.method.is_none() {
            bail!("ReconstructRequest.penalty is a weight of one method: name the method with ReconstructRequest.method");
        }
        match (&self.matrix_sd, self.matrix_sd_pct) {
            (Some(_), Some(_)) => bail!(
                "give ReconstructRequest.matrix_sd FILE or ReconstructRequest.matrix_sd_pct P, not both"
            ),
            (None, Some(pct)) if !(pct.is_finite() && pct >= 0.0) => {
                bail!("ReconstructRequest.matrix_sd_pct must be a percentage ≥ 0, got {pct}")
            }
            _ => Ok(()),
        }
    }
}

/// A sensing matrix as read (or derived from a design), with what the design adds.
struct LoadedMatrix {
    matrix: SensingMatrix,
    /// The names were made up (a matrix of numbers only).
    generated_names: bool,
    /// The design's ulimit, g.
    ulimit_g: Option<f64>,
    /// The design's most simultaneous loads.
    max_loads: Option<usize>,
    /// The gratings' Bragg wavelengths (from a design), nm.
    wavelengths_nm: Option<Vec<f64>>,
}

/// Read the matrix CSV, or derive the model matrix of a design.
fn load_matrix(source: &MatrixSource) -> Result<LoadedMatrix> {
    Ok(match source {
        MatrixSource::Csv(p) => {
            let f = read_matrix_file(p)?;
            LoadedMatrix {
                matrix: f.matrix,
                generated_names: f.generated_names,
                ulimit_g: None,
                max_loads: None,
                wavelengths_nm: None,
            }
        }
        MatrixSource::Design(d) => {
            let design = crate::design::load(d)?;
            let (m, u) =
                matrix_from_design(&design).with_context(|| format!("design {}", d.display()))?;
            let arr = design.array.as_ref();
            LoadedMatrix {
                matrix: m,
                generated_names: false,
                ulimit_g: Some(u),
                max_loads: arr.and_then(|a| a.max_loads).map(|k| k as usize),
                wavelengths_nm: arr
                    .map(|a| a.gratings.iter().map(|g| g.bragg_wavelength_nm).collect()),
            }
        }
    })
}

/// The matrix's per-entry uncertainty: the paper's, a CSV shaped like the matrix, or
/// a percentage of each entry.
fn matrix_uncertainty(
    a: &ReconstructRequest,
    loaded: &LoadedMatrix,
    resolution_pm: f64,
) -> Result<Uncertainty> {
    let matrix = &loaded.matrix;
    let (m, n) = (matrix.n_gratings(), matrix.n_cells());
    let mut uncertainty = Uncertainty::paper(m, n, resolution_pm);
    if let Some(path) = &a.matrix_sd {
        let sd = read_matrix_file(path)
            .with_context(|| format!("ReconstructRequest.matrix_sd {}", path.display()))?
            .matrix;
        if sd.gratings != matrix.gratings || sd.cells != matrix.cells {
            if sd.sensitivity_pm_per_g.shape() != (m, n) {
                bail!(
                    "ReconstructRequest.matrix_sd {}: {} × {} entries, but the sensing matrix is {m} × {n}",
                    path.display(),
                    sd.n_gratings(),
                    sd.n_cells()
                );
            }
            if !loaded.generated_names {
                bail!(
                    "ReconstructRequest.matrix_sd {}: its gratings and cells must be the matrix's, in the same order ({} and {})",
                    path.display(),
                    matrix.gratings.join(", "),
                    matrix.cells.join(", ")
                );
            }
        }
        uncertainty.matrix_sd_pm_per_g = sd.sensitivity_pm_per_g;
    } else if let Some(pct) = a.matrix_sd_pct {
        uncertainty.matrix_sd_pm_per_g = matrix.sensitivity_pm_per_g.map(|v| v.abs() * pct / 100.0);
    }
    Ok(uncertainty)
}

/// The problem: the matrix with its bounds, the load range's lower end, the matrix's
/// uncertainty, the dead-grating check and, when asked, the common-mode term.
fn sensing_problem(
    a: &ReconstructRequest,
    loaded: &LoadedMatrix,
    ulimit_g: f64,
    min_load_g: f64,
    uncertainty: Uncertainty,
) -> Result<SensingProblem> {
    let matrix = &loaded.matrix;
    let mut problem =
        SensingProblem::new(matrix.sensitivity_pm_per_g.clone(), ulimit_g, a.normalise)?
            .with_min_load_g(min_load_g)
            .map_err(|e| anyhow::anyhow!("ReconstructRequest.min_load_g: {e}"))?
            .with_uncertainty(uncertainty)
            .map_err(|e| anyhow::anyhow!("ReconstructRequest.matrix_sd: {e}"))?
            .with_dead_grating_check(a.dead_grating_check);
    if let Some(alpha) = a.significance {
        problem = problem
            .with_significance(alpha)
            .map_err(|e| anyhow::anyhow!("ReconstructRequest.significance: {e}"))?;
    }
    if let Some(w) = a.window_pm {
        problem = problem
            .with_window_pm(w)
            .map_err(|e| anyhow::anyhow!("ReconstructRequest.window_pm: {e}"))?;
    }
    if a.common_mode {
        let w = match &loaded.wavelengths_nm {
            Some(wl) => temperature_weights(wl),
            None => vec![1.0; matrix.n_gratings()],
        };
        problem = problem
            .with_common_mode(&w)
            .map_err(|e| anyhow::anyhow!("ReconstructRequest.common_mode: {e}"))?;
    }
    Ok(problem)
}

/// Read a sensing matrix (or derive it from a design) and a shifts file, reconstruct
/// every frame, write the loads CSV and return the summary; `progress` hears the frames.
///
/// The file is streamed (docs/array.md §11.10): a first pass reads and checks every
/// row and keeps the stream diagnosis's bounded sample ([`StreamSample`]); the
/// second reads it again [`CHUNK_FRAMES`] rows at a time, reconstructs each chunk
/// (in parallel within it) and appends its rows to a temporary file renamed into
/// place at the end, so memory stays flat in the number of frames
/// ([`ReconstructSummary::most_frames_held`]) and a failure leaves no output.
///
/// ```
/// use fbgforge_array::run::{reconstruct_file, MatrixSource, ReconstructRequest};
///
/// // The paper's 6 × 8 matrix (two gratings, two cells shown) and two frames: cell A
/// // loaded with 100 g, then nothing.
/// let dir = tempfile::tempdir()?;
/// let (matrix, shifts) = (dir.path().join("A.csv"), dir.path().join("shifts.csv"));
/// std::fs::write(&matrix, "grating,A,B\nfbg1,0.10,0.02\nfbg2,0.03,0.09\n")?;
/// std::fs::write(&shifts, "time_s,fbg1,fbg2\n0.0,10.0,3.0\n0.1,0.0,0.0\n")?;
/// let mut req = ReconstructRequest::new(MatrixSource::Csv(matrix), shifts);
/// req.method = Some("nnls".into());
/// req.out = Some(dir.path().join("loads.csv"));
/// let summary = reconstruct_file(&req, &fbgforge_core::progress::Quiet)?;
/// assert_eq!((summary.frames, summary.method), (2, "nnls"));
/// // The mean load over the two frames: 50 g on A, none on B.
/// assert!((summary.mean_load_g[0] - 50.0).abs() < 1e-6 && summary.mean_load_g[1].abs() < 1e-6);
/// assert!(std::fs::read_to_string(dir.path().join("loads.csv"))?.starts_with("time_s,A,B"));
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn reconstruct_file(
    a: &ReconstructRequest,
    progress: &dyn crate::progress::Progress,
) -> Result<ReconstructSummary> {
    a.validate()?;
    let named = a.method.as_deref().map(Method::from_name).transpose()?;
    let loaded = load_matrix(&a.matrix)?;
    let ulimit_g = a.ulimit_g.or(loaded.ulimit_g).unwrap_or(PAPER_ULIMIT_G);
    if !(ulimit_g.is_finite() && ulimit_g > 0.0) {
        bail!("ReconstructRequest.ulimit_g must be a positive load in g, got {ulimit_g}");
    }
    let prior = ReadingSettings {
        max_loads: a
            .max_loads
            .or(loaded.max_loads)
            .unwrap_or(DEFAULT_MAX_LOADS),
        resolution_pm: a.resolution_pm.unwrap_or(NoisePrior::paper().resolution_pm),
    };
    prior.check()?;
    let request = match named {
        Some(method) => MethodRequest::Named {
            method,
            penalty: a.penalty,
        },
        None => MethodRequest::Default {
            budget_us: a.budget_us.unwrap_or(DEFAULT_BUDGET_US),
        },
    };
    request.check()?;
    let matrix = &loaded.matrix;
    let min_load_g = a.min_load_g.unwrap_or(default_min_load_g(ulimit_g));
    let uncertainty = matrix_uncertainty(a, &loaded, prior.resolution_pm)?;
    let problem = sensing_problem(a, &loaded, ulimit_g, min_load_g, uncertainty)?;
    let (sample, frames) = sample_file(a, &loaded, &problem)?;
    let run = StreamRun::start(&problem, &prior, &request, &sample, &matrix.gratings)?;
    let held_by_sample = sample.most_frames_held();
    drop(sample);
    let out = a.out.clone().unwrap_or_else(|| default_out(&a.shifts));
    progress.begin("reconstruct", frames as u64);
    let (end, totals) = reconstruct_chunks(a, &loaded, run, frames, &out, progress);
    progress.end();
    let (end, mut totals) = (end, totals?);
    totals.most_frames_held += held_by_sample;
    Ok(summarise(
        a,
        matrix,
        &problem,
        &prior,
        (end, totals),
        (ulimit_g, min_load_g),
        out,
    ))
}

/// The first pass over the shifts file: every row read and checked, the diagnosis
/// sample kept (bounded: [`StreamSample`]); the number of frames.
fn sample_file(
    a: &ReconstructRequest,
    loaded: &LoadedMatrix,
    problem: &SensingProblem,
) -> Result<(StreamSample, usize)> {
    let gratings = &loaded.matrix.gratings;
    let mut reader = ShiftReader::open(&a.shifts, gratings, loaded.generated_names)?;
    let mut sample = StreamSample::new(problem);
    while let Some(chunk) = reader.next_chunk(CHUNK_FRAMES)? {
        for y in &chunk.frames_pm {
            sample.push(y);
        }
    }
    if reader.frames() == 0 {
        bail!("{}: no frames after the header", a.shifts.display());
    }
    Ok((sample, reader.frames()))
}

/// The second pass: the file read again a chunk at a time, each chunk reconstructed
/// and its rows appended to a temporary file renamed to `out` at the end.
fn reconstruct_chunks(
    a: &ReconstructRequest,
    loaded: &LoadedMatrix,
    mut run: StreamRun,
    frames: usize,
    out: &Path,
    progress: &dyn crate::progress::Progress,
) -> (StreamEnd, Result<Totals>) {
    let matrix = &loaded.matrix;
    let mut totals = Totals::new(matrix.n_cells());
    let written = crate::output::write_atomic_with(out, |w| {
        let mut reader = ShiftReader::open(&a.shifts, &matrix.gratings, loaded.generated_names)?;
        let mut writer = LoadsWriter::start(w, &matrix.cells, reader.timed())?;
        while let Some(chunk) = reader.next_chunk(CHUNK_FRAMES)? {
            let done = run.reconstruct_chunk(&chunk.frames_pm, progress);
            totals.add(&done);
            writer.rows(chunk.time_s.as_deref(), &done)?;
        }
        if reader.frames() != frames {
            bail!(
                "{} changed while it was read: {frames} frames on the first pass, {} on the second",
                a.shifts.display(),
                reader.frames()
            );
        }
        totals.most_frames_held = reader.most_frames_held();
        writer.finish()
    });
    (run.finish(), written.map(|()| totals))
}

/// What the summary needs of the frames, accumulated chunk by chunk.
struct Totals {
    frames: usize,
    not_converged: usize,
    certified: usize,
    load_sum_g: Vec<f64>,
    max_residual_pm: f64,
    offsets: (f64, usize),
    most_frames_held: usize,
}

impl Totals {
    fn new(cells: usize) -> Self {
        Totals {
            frames: 0,
            not_converged: 0,
            certified: 0,
            load_sum_g: vec![0.0; cells],
            max_residual_pm: 0.0,
            offsets: (0.0, 0),
            most_frames_held: 0,
        }
    }

    fn add(&mut self, results: &[crate::methods::Reconstruction]) {
        for r in results {
            self.frames += 1;
            self.not_converged += usize::from(!r.converged);
            self.certified += usize::from(r.certified);
            for (s, v) in self.load_sum_g.iter_mut().zip(&r.loads_g) {
                *s += v;
            }
            self.max_residual_pm = self.max_residual_pm.max(r.residual_pm);
            if let Some(c) = r.common_mode_pm {
                self.offsets.0 += c;
                self.offsets.1 += 1;
            }
        }
    }
}

/// The run's summary: the method and why, the flags, the loads, the times.
fn summarise(
    a: &ReconstructRequest,
    matrix: &SensingMatrix,
    problem: &SensingProblem,
    prior: &ReadingSettings,
    (done, totals): (StreamEnd, Totals),
    (ulimit_g, min_load_g): (f64, f64),
    out: PathBuf,
) -> ReconstructSummary {
    let n = totals.frames.max(1) as f64;
    ReconstructSummary {
        method: done.setup.method.name(),
        penalty: done.setup.penalty(),
        choice: done.setup.choice.clone(),
        max_loads: prior
            .max_loads
            .min(matrix.n_gratings())
            .min(matrix.n_cells()),
        normalised: a.normalise,
        ulimit_g,
        min_load_g,
        gratings: matrix.n_gratings(),
        frames: totals.frames,
        not_converged: totals.not_converged,
        certified: totals.certified,
        flags: done.flag_counts,
        suspect_gratings: done.diagnosis.suspects.clone(),
        common_mode: done.diagnosis.common_mode.fitted,
        common_mode_note: done.diagnosis.common_mode.clone(),
        budget: done.budget.clone(),
        mean_common_mode_pm: (totals.offsets.1 > 0)
            .then(|| totals.offsets.0 / totals.offsets.1 as f64),
        uncertainty: problem.uncertainty_summary(),
        mean_load_g: totals.load_sum_g.iter().map(|s| s / n).collect(),
        cells: matrix.cells.clone(),
        max_residual_pm: totals.max_residual_pm,
        setup_ms: done.setup.setup_ms,
        time_per_frame_us: done.time_per_frame_us,
        threads: done.threads,
        most_frames_held: totals.most_frames_held,
        out,
    }
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
