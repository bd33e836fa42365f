//! `fbgforge reconstruct`: cell loads of a flat array from grating shifts (the work is
//! `fbgforge::array::reconstruct_file`).

use anyhow::Result;
use clap::Args;
use fbgforge::array::run::{reconstruct_file, MatrixSource, ReconstructRequest};
use fbgforge::report::reconstruct::summary_text;
use std::path::PathBuf;

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[
    ("ReconstructRequest.method", "--method"),
    ("ReconstructRequest.penalty", "--penalty"),
    ("ReconstructRequest.ulimit_g", "--ulimit-g"),
    ("ReconstructRequest.min_load_g", "--min-load-g"),
    ("ReconstructRequest.matrix_sd", "--matrix-sd"),
    ("ReconstructRequest.matrix_sd_pct", "--matrix-sd-pct"),
    ("ReconstructRequest.common_mode", "--common-mode"),
    ("ReconstructRequest.budget_us", "--budget-us"),
    ("ReconstructRequest.significance", "--significance"),
    ("ReconstructRequest.window_pm", "--window-pm"),
    (
        "ReconstructRequest.dead_grating_check",
        "--keep-all-gratings",
    ),
    ("SensingProblem.significance", "--significance"),
    ("ReconstructRequest.max_loads", "--max-loads"),
    ("ReconstructRequest.resolution_pm", "--resolution-pm"),
    ("ReadingSettings.max_loads", "--max-loads"),
    ("ReadingSettings.resolution_pm", "--resolution-pm"),
    ("MethodRequest.budget_us", "--budget-us"),
];

/// Arguments of `fbgforge reconstruct`.
#[derive(Debug, Args)]
pub struct ReconstructArgs {
    /// Sensing matrix CSV: header `grating,<cells…>`, one row per grating, pm/g; or
    /// numbers only, without header (numpy.savetxt, MATLAB writematrix): gratings are
    /// then named fbg1…, cells A…, and the shifts may be numbers only too.
    #[arg(
        long,
        conflicts_with_all = ["design", "design_flag"],
        required_unless_present_any = ["design", "design_flag"]
    )]
    pub matrix: Option<PathBuf>,
    /// Array design (TOML, or a shipped design's name) whose model sensing matrix is
    /// used instead of a measured one (--matrix).
    #[arg(value_parser = super::designs::design_arg, value_name = "DESIGN")]
    pub design: Option<PathBuf>,
    /// The design as a flag (the form before the design became the first argument,
    /// as in every other subcommand).
    #[arg(
        long = "design",
        value_parser = super::designs::design_arg,
        value_name = "DESIGN",
        conflicts_with = "design",
        hide_short_help = true
    )]
    pub design_flag: Option<PathBuf>,
    /// Shifts CSV: header `[time_s,]<grating names…>`, one row per frame, pm.
    #[arg(long, required_unless_present = "log", conflicts_with = "log")]
    pub shifts: Option<PathBuf>,
    /// Instead of --shifts, an interrogator's wavelength log (any format `verify --log`
    /// reads) of the array DESIGN, read as `live` reads one: each grating found in its
    /// window, the tare taken on the first frames at rest (--tare-frames, spanning
    /// ≥ 1 s), the shifts of the later frames from it, written to <log name>-shifts.csv
    /// (beside --out, else in out/reconstruct) and reconstructed.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// With --log: frames the tare window holds at least (as `live`'s --tare-frames).
    #[arg(long, default_value_t = 50, requires = "log")]
    pub tare_frames: usize,
    /// Method: wsupport, support, bnb, nnls, lasso, omp or de (default: the most
    /// accurate method within --budget-us per frame for this array, chosen from its
    /// size and matrix alone: the work each candidate does on probe frames synthesised
    /// from the matrix, converted to time by per-operation costs measured once, so the
    /// same array and settings give the same method whatever the file holds; the
    /// choice and why is printed).
    #[arg(long)]
    pub method: Option<String>,
    /// Per-frame time budget of the automatic method choice, µs (default 100, i.e.
    /// 10 000 frames/s on one thread). Ignored with --method.
    #[arg(long, allow_negative_numbers = true)]
    pub budget_us: Option<f64>,
    /// Most cells loaded at once the support methods consider (default: the design's
    /// max_loads, else 4, the paper's largest test).
    #[arg(long)]
    pub max_loads: Option<usize>,
    /// Largest load per cell, g (default: the design's ulimit, else 250 g).
    #[arg(long, allow_negative_numbers = true)]
    pub ulimit_g: Option<f64>,
    /// Smallest load a loaded cell carries, g: the lower end of the array's rated
    /// range, a prior of the default `wsupport` method (default: the paper's 25 g, or
    /// 0 when ulimit is not above 25 g; 0 disables it; must be below ulimit).
    #[arg(long, allow_negative_numbers = true)]
    pub min_load_g: Option<f64>,
    /// Penalty weight of the method (default: the method's tuned default; for support
    /// and bnb, 16 × resolution²).
    #[arg(long, allow_negative_numbers = true)]
    pub penalty: Option<f64>,
    /// The interrogator's resolution, the noise standard deviation of a shift, pm
    /// (default 0.5, the paper's): sets the ℓ0 penalty of support and bnb to
    /// 16 × resolution² (λ = 4 at 0.5 pm, 1 at 0.25 pm).
    #[arg(long, allow_negative_numbers = true)]
    pub resolution_pm: Option<f64>,
    /// Do not column-normalise the matrix (the paper normalises).
    #[arg(long)]
    pub no_normalise: bool,
    /// Fit a per-frame common offset (a temperature change since the tare), weighted
    /// by each grating's temperature sensitivity when --design gives the gratings'
    /// wavelengths, equally with --matrix. Costs one grating's worth of information.
    #[arg(long)]
    pub common_mode: bool,
    /// Per-entry standard deviation of the sensing matrix, pm/g: a CSV shaped like
    /// the matrix (e.g. the scatter of repeated calibrations; calibrate-array does
    /// not write one yet). Used by the
    /// per-frame residual test (flag `inconsistent`) and the rival test (`ambiguous`).
    #[arg(long, conflicts_with = "matrix_sd_pct")]
    pub matrix_sd: Option<PathBuf>,
    /// Per-entry standard deviation of the sensing matrix, % of each entry (default:
    /// one calibration reading per column at 200 g, i.e. resolution / 200 g).
    #[arg(long, allow_negative_numbers = true)]
    pub matrix_sd_pct: Option<f64>,
    /// Keep every grating and the frames as read: no stream diagnosis (by default
    /// dead, stuck, drifting, swapped, saturated and noisy gratings are named with
    /// their reason and left out or corrected, and a common offset is fitted when
    /// the frames call for it; the summary says which and why).
    #[arg(long)]
    pub keep_all_gratings: bool,
    /// Significance of the per-frame test behind the flags, in (0, 0.5] (default
    /// 0.05: a right answer is flagged with at most this probability, on any array;
    /// smaller flags fewer right answers and finds fewer wrong ones; docs/array.md
    /// §11).
    #[arg(long)]
    pub significance: Option<f64>,
    /// The interrogator's window, pm: a shift beyond ± this is not a reading and its
    /// frame is flagged `unusable` with no loads (default 2500).
    #[arg(long)]
    pub window_pm: Option<f64>,
    /// Output CSV of loads in g, `time_s,<cells…>`; when the shifts have no `time_s`
    /// column the first column is `frame`, the 0-based row index
    /// (default: out/reconstruct/<shifts name>-loads.csv).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout instead of the text summary.
    #[arg(long)]
    pub json: bool,
}

/// The shifts of a wavelength log from its tare, read as `live` reads a log
/// (`fbgforge::live::replay`), written to <log name>-shifts.csv beside `out` (the
/// loads), else in out/reconstruct: that file's path. Says what the tare took unless
/// `quiet` (JSON on stdout).
fn shifts_from_log(
    design: &std::path::Path,
    log: &std::path::Path,
    tare_frames: usize,
    resolution_pm: Option<f64>,
    (out, quiet): (Option<&std::path::Path>, bool),
) -> Result<PathBuf> {
    use fbgforge::live::interpret::InterpretOptions;
    let d = fbgforge::design::load(design)?;
    let defaults = InterpretOptions::default();
    let opts = InterpretOptions {
        tare_frames,
        resolution_pm: resolution_pm.unwrap_or(defaults.resolution_pm),
        ..defaults
    };
    let tared = fbgforge::live::replay::tare_log(&d, log, &Default::default(), &opts)?;
    let stem = log
        .file_stem()
        .map_or("log".into(), |s| s.to_string_lossy().into_owned());
    let dir = out
        .and_then(|o| o.parent())
        .filter(|p| !p.as_os_str().is_empty())
        .map_or(PathBuf::from("out/reconstruct"), |p| p.to_path_buf());
    let path = dir.join(format!("{stem}-shifts.csv"));
    tared.write_shifts_csv(&path)?;
    if !quiet {
        let first = tared.skipped.first();
        let text = format!(
            "{}: tare on the first {} frames at rest; {} frames read, {} skipped{}; \
             shifts in {}\n",
            log.display(),
            tared.tare_frames,
            tared.shifts_pm.len(),
            tared.skipped.len(),
            first.map(|s| format!(" (first: {s})")).unwrap_or_default(),
            path.display()
        );
        print!("{}", fbgforge::report::terminal::fit(&text));
    }
    Ok(path)
}

/// Run `fbgforge reconstruct`.
pub fn run(a: ReconstructArgs) -> Result<()> {
    let design = a.design.or(a.design_flag);
    let shifts = match (&a.shifts, &a.log, &design) {
        (Some(s), _, _) => s.clone(),
        (None, Some(log), Some(d)) => shifts_from_log(
            d,
            log,
            a.tare_frames,
            a.resolution_pm,
            (a.out.as_deref(), a.json),
        )?,
        (None, Some(_), None) => {
            anyhow::bail!("--log needs the array design: reconstruct DESIGN --log LOG")
        }
        (None, None, _) => anyhow::bail!("give --shifts SHIFTS.csv or --log WAVELENGTH_LOG"),
    };
    let matrix = match (a.matrix, design) {
        (Some(p), _) => MatrixSource::Csv(p),
        (None, Some(d)) => MatrixSource::Design(d),
        (None, None) => {
            anyhow::bail!("give an array design (reconstruct DESIGN) or --matrix A.csv")
        }
    };
    let req = ReconstructRequest {
        method: a.method,
        budget_us: a.budget_us,
        max_loads: a.max_loads,
        ulimit_g: a.ulimit_g,
        min_load_g: a.min_load_g,
        penalty: a.penalty,
        resolution_pm: a.resolution_pm,
        normalise: !a.no_normalise,
        common_mode: a.common_mode,
        matrix_sd: a.matrix_sd,
        matrix_sd_pct: a.matrix_sd_pct,
        dead_grating_check: !a.keep_all_gratings,
        significance: a.significance,
        window_pm: a.window_pm,
        out: a.out,
        ..ReconstructRequest::new(matrix, shifts)
    };
    let summary = reconstruct_file(&req, &super::progress::Bar::new())?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print!("{}", summary_text(&summary));
    }
    Ok(())
}
