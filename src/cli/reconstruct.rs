//! `fbgforge reconstruct` (cell loads of a flat array from grating shifts) and
//! `fbgforge bench reconstruct` (the paper's protocol, speed against accuracy, and
//! where each method fails).

use anyhow::{bail, Context, Result};
use clap::Args;
use fbgforge::array::io::{read_matrix, read_shifts, write_loads};
use fbgforge::array::kernel::matrix_from_design;
use fbgforge::array::methods::{reconstruct_stream, Method, MethodSettings, DEFAULT_METHOD};
use fbgforge::array::problem::{SensingProblem, PAPER_MIN_LOAD_G};
use fbgforge::array::SensingMatrix;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The paper's ulimit, used when neither `--ulimit-g` nor a design gives one, g.
pub const PAPER_ULIMIT_G: f64 = 250.0;

/// Arguments of `fbgforge reconstruct`.
#[derive(Debug, Args)]
pub struct ReconstructArgs {
    /// Sensing matrix CSV: header `grating,<cells…>`, one row per grating, pm/g.
    #[arg(long, conflicts_with = "design", required_unless_present = "design")]
    pub matrix: Option<PathBuf>,
    /// Use the model sensing matrix of this array design instead of a measured one.
    #[arg(long)]
    pub design: Option<PathBuf>,
    /// Shifts CSV: header `[time_s,]<grating names…>`, one row per frame, pm.
    #[arg(long)]
    pub shifts: PathBuf,
    /// Method: wsupport, support, nnls, lasso, omp or de (default: wsupport).
    #[arg(long)]
    pub method: Option<String>,
    /// Largest load per cell, g (default: the design's ulimit, else 250 g).
    #[arg(long, allow_negative_numbers = true)]
    pub ulimit_g: Option<f64>,
    /// Smallest load a loaded cell carries, g: the lower end of the array's rated
    /// range, a prior of the default `wsupport` method (default: the paper's 25 g, or
    /// 0 when ulimit is not above 25 g; 0 disables it; must be below ulimit).
    #[arg(long, allow_negative_numbers = true)]
    pub min_load_g: Option<f64>,
    /// Penalty weight of the method (default: the method's tuned default).
    #[arg(long, allow_negative_numbers = true)]
    pub penalty: Option<f64>,
    /// Do not column-normalise the matrix (the paper normalises).
    #[arg(long)]
    pub no_normalise: bool,
    /// Output CSV of loads in g, `time_s,<cells…>`; when the shifts have no `time_s`
    /// column the first column is `frame`, the 0-based row index
    /// (default: out/reconstruct/<shifts name>-loads.csv).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout instead of the text summary.
    #[arg(long)]
    pub json: bool,
}

/// JSON summary of a reconstruction run.
#[derive(Debug, Serialize)]
pub struct ReconstructSummary {
    /// Method used.
    pub method: &'static str,
    /// Penalty used.
    pub penalty: f64,
    /// Whether columns were normalised.
    pub normalised: bool,
    /// Upper bound per cell, g.
    pub ulimit_g: f64,
    /// Smallest load of a loaded cell (prior of `wsupport`), g.
    pub min_load_g: f64,
    /// Number of frames.
    pub frames: usize,
    /// Frames where the method did not converge.
    pub not_converged: usize,
    /// Cell labels.
    pub cells: Vec<String>,
    /// Mean load per cell over all frames, g.
    pub mean_load_g: Vec<f64>,
    /// Largest residual ‖Ax − y‖ over the frames, pm.
    pub max_residual_pm: f64,
    /// Wall time per frame, µs (all threads).
    pub time_per_frame_us: f64,
    /// Output file.
    pub out: PathBuf,
}

/// Run `fbgforge reconstruct`.
pub fn run(a: ReconstructArgs) -> Result<()> {
    let method = match &a.method {
        Some(name) => Method::from_name(name)?,
        None => DEFAULT_METHOD,
    };
    let (matrix, design_ulimit): (SensingMatrix, Option<f64>) = match (&a.matrix, &a.design) {
        (Some(p), _) => (read_matrix(p)?, None),
        (None, Some(d)) => {
            let design = fbgforge::spec::load(d)?;
            let (m, u) =
                matrix_from_design(&design).with_context(|| format!("design {}", d.display()))?;
            (m, Some(u))
        }
        (None, None) => bail!("give --matrix A.csv or --design array.toml"),
    };
    let ulimit_g = a.ulimit_g.or(design_ulimit).unwrap_or(PAPER_ULIMIT_G);
    if !(ulimit_g.is_finite() && ulimit_g > 0.0) {
        bail!("--ulimit-g must be a positive load in g, got {ulimit_g}");
    }
    let stream = read_shifts(&a.shifts, &matrix.gratings)?;
    // The paper's 25 g unless told otherwise; an array rated for less than that in
    // total (ulimit ≤ 25 g) gets no lower end rather than an error about a value the
    // user never gave.
    let min_load_g = a.min_load_g.unwrap_or(if PAPER_MIN_LOAD_G < ulimit_g {
        PAPER_MIN_LOAD_G
    } else {
        0.0
    });
    let problem = SensingProblem::new(
        matrix.sensitivity_pm_per_g.clone(),
        ulimit_g,
        !a.no_normalise,
    )?
    .with_min_load_g(min_load_g)
    .map_err(|e| anyhow::anyhow!("--min-load-g: {e}"))?;
    let mut settings = MethodSettings::for_method(method);
    if let Some(p) = a.penalty {
        settings.penalty = p;
    }
    let t0 = Instant::now();
    let results = reconstruct_stream(&problem, method, settings, &stream.frames_pm)?;
    let elapsed = t0.elapsed().as_secs_f64();
    let out = a.out.clone().unwrap_or_else(|| default_out(&a.shifts));
    let loads: Vec<Vec<f64>> = results.iter().map(|r| r.loads_g.clone()).collect();
    write_loads(&out, &matrix.cells, stream.time_s.as_deref(), &loads)?;
    let n = results.len().max(1) as f64;
    let summary = ReconstructSummary {
        method: method.name(),
        penalty: settings.penalty,
        normalised: !a.no_normalise,
        ulimit_g,
        min_load_g,
        frames: results.len(),
        not_converged: results.iter().filter(|r| !r.converged).count(),
        mean_load_g: (0..matrix.n_cells())
            .map(|j| results.iter().map(|r| r.loads_g[j]).sum::<f64>() / n)
            .collect(),
        cells: matrix.cells.clone(),
        max_residual_pm: results.iter().map(|r| r.residual_pm).fold(0.0, f64::max),
        time_per_frame_us: 1e6 * elapsed / n,
        out: out.clone(),
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "{} frames, method {} (penalty {}), {:.1} µs/frame, {} not converged → {}",
            summary.frames,
            summary.method,
            summary.penalty,
            summary.time_per_frame_us,
            summary.not_converged,
            out.display()
        );
    }
    Ok(())
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
