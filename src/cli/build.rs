//! `fbgforge build`: design spec to STL, STEP and manifest; `fbgforge` with no
//! arguments builds every shipped design; `fbgforge bench build` measures meshing
//! tolerance against triangles, time and volume error, and the build timings.

use crate::geometry::{self, mesh, BuiltPart};
use crate::plot::{Chart, Mark, Series};
use crate::spec::{self, Design};
use anyhow::{bail, Context, Result};
use clap::Args;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `fbgforge build`.
#[derive(Debug, Args)]
pub struct BuildArgs {
    /// The design spec (TOML).
    pub design: PathBuf,
    /// Output folder [default: out/<design name>/].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Meshing chord tolerance, mm [default: half the printer's resolution].
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// Comma-separated parts to build (cap, core, insert-<name>, mold) [default: all].
    #[arg(long, value_delimiter = ',')]
    pub parts: Option<Vec<String>>,
}

/// What one design build wrote.
#[derive(Debug, Clone)]
pub struct BuildReport {
    /// Output folder.
    pub dir: PathBuf,
    /// Parts built.
    pub parts: Vec<BuiltPart>,
    /// Every file written, manifest last.
    pub files: Vec<PathBuf>,
}

/// Build a loaded design into `dir`: every part is built, meshed and checked and every
/// file rendered in memory before the first file is written.
pub fn build_design(
    design: &Design,
    dir: &Path,
    tolerance_mm: Option<f64>,
    parts: Option<&[String]>,
) -> Result<BuildReport> {
    let built = geometry::build_parts(design, tolerance_mm, parts)
        .with_context(|| format!("design `{}`: nothing was written", design.name))?;
    let tol = tolerance_mm.unwrap_or(design.printer.default_tolerance_mm());
    let rendered = geometry::export::render(design, &built, tol)?;
    let files = geometry::export::write_all(dir, &rendered)?;
    Ok(BuildReport {
        dir: dir.to_path_buf(),
        parts: built,
        files,
    })
}

fn default_out(design: &Design) -> PathBuf {
    Path::new("out").join(&design.name)
}

fn print_table(design: &str, r: &BuildReport) {
    println!("{design} -> {}", r.dir.display());
    println!(
        "  {:<20} {:>9} {:>14} {:>14} {:>9} {:>9}",
        "part", "triangles", "mesh mm³", "exact mm³", "error %", "tol mm"
    );
    for p in &r.parts {
        println!(
            "  {:<20} {:>9} {:>14.3} {:>14.3} {:>9.4} {:>9.4}",
            p.name,
            p.mesh.triangles.len(),
            p.mesh_volume_mm3,
            p.exact_volume_mm3,
            p.volume_error() * 100.0,
            p.mesh_tolerance_mm
        );
    }
}

/// `fbgforge build`.
pub fn run(a: BuildArgs) -> Result<()> {
    let design = spec::load(&a.design)?;
    let dir = a.out.clone().unwrap_or_else(|| default_out(&design));
    let r = build_design(&design, &dir, a.tolerance, a.parts.as_deref())?;
    print_table(&design.name, &r);
    println!("  wrote {} files (STL, STEP, manifest.json)", r.files.len());
    Ok(())
}

/// The folder of shipped designs: `designs/` under the working directory, else the
/// crate's own.
pub fn designs_dir() -> PathBuf {
    let local = PathBuf::from("designs");
    if local.is_dir() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("designs")
    }
}

/// Every `*.toml` in `dir`, loaded and validated, sorted by file name.
pub fn load_designs(dir: &Path) -> Result<Vec<(PathBuf, Design)>> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read the designs folder {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let d = spec::load(&p)?;
            Ok((p, d))
        })
        .collect()
}

/// `fbgforge` with no arguments: build the shipped default designs into `out/`.
pub fn run_default() -> Result<()> {
    let designs = load_designs(&designs_dir())?;
    if designs.is_empty() {
        bail!("no designs found in {}", designs_dir().display());
    }
    let t = Instant::now();
    let pb = crate::progress::bar(designs.len() as u64, "build");
    let mut reports = Vec::new();
    for (_, d) in &designs {
        reports.push((
            d.name.clone(),
            build_design(d, &default_out(d), None, None)?,
        ));
        pb.inc(1);
    }
    pb.finish_and_clear();
    for (name, r) in &reports {
        print_table(name, r);
    }
    let files: usize = reports.iter().map(|(_, r)| r.files.len()).sum();
    println!(
        "built {} designs, {} files in {:.2} s; open the STL files in your slicer (see README)",
        reports.len(),
        files,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Arguments of `fbgforge bench build`.
#[derive(Debug, Args)]
pub struct BenchBuildArgs {
    /// Module design for the tolerance sweep and the build timing.
    #[arg(long, default_value = "designs/clip-on-34mm.toml")]
    pub design: PathBuf,
    /// Array design whose mold is timed with the module.
    #[arg(long, default_value = "designs/tactile-array-60x80.toml")]
    pub array: PathBuf,
    /// Output folder for the CSV, JSON and SVG files.
    #[arg(long, default_value = "out/bench-build")]
    pub out: PathBuf,
    /// Repetitions of each timing (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
}

fn median_s(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// One row of the tolerance sweep.
#[derive(Debug, Clone, serde::Serialize)]
struct SweepRow {
    part: String,
    tolerance_mm: f64,
    triangles: usize,
    time_ms: f64,
    volume_error_percent: f64,
}

/// Timings of the two targets.
#[derive(Debug, Clone, serde::Serialize)]
struct Timings {
    module_and_mold_ms: f64,
    module_and_mold_target_ms: f64,
    per_part_ms: Vec<(String, f64)>,
    family_diameters_mm: Vec<f64>,
    family_parallel_s: f64,
    family_target_s: f64,
    rayon_threads: usize,
}

/// `fbgforge bench build`.
pub fn bench(a: BenchBuildArgs) -> Result<()> {
    let design = spec::load(&a.design)?;
    let array = spec::load(&a.array)?;
    let repeats = a.repeats.max(1);
    let solids = geometry::build_solids(&design, None)?;
    let tolerances = [0.1, 0.05, 0.025, 0.01, 0.005];

    // 1. Tolerance sweep: one distinct solid per kind (the inserts are alike).
    let mut kinds_seen = Vec::new();
    let distinct: Vec<_> = solids
        .iter()
        .filter(|s| {
            let new = !kinds_seen.contains(&s.kind);
            kinds_seen.push(s.kind);
            new
        })
        .collect();
    let pb = crate::progress::bar((distinct.len() * tolerances.len()) as u64, "sweep");
    let mut rows = Vec::new();
    for s in &distinct {
        for &tol in &tolerances {
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..repeats {
                let t = Instant::now();
                let m = mesh::mesh_solid(&s.name, &s.solid, tol)?;
                times.push(t.elapsed().as_secs_f64());
                last = Some(m);
            }
            let m = last.expect("at least one repeat");
            rows.push(SweepRow {
                part: s.name.clone(),
                tolerance_mm: tol,
                triangles: m.triangles.len(),
                time_ms: median_s(times) * 1e3,
                volume_error_percent: (m.volume_mm3() - s.exact_volume_mm3) / s.exact_volume_mm3
                    * 100.0,
            });
            pb.inc(1);
        }
    }
    pb.finish_and_clear();

    // 2. Every part of the module plus the mold at the default tolerance: B-rep,
    // meshes, checks (what `fbgforge build` does before writing).
    let mut totals = Vec::new();
    let mut per_part: Vec<(String, f64)> = Vec::new();
    for _ in 0..repeats {
        let t = Instant::now();
        geometry::build_parts(&design, None, None)?;
        geometry::build_parts(&array, None, None)?;
        totals.push(t.elapsed().as_secs_f64());
    }
    for name in geometry::part_names(&design)
        .into_iter()
        .chain(geometry::part_names(&array))
    {
        let d = if name == "mold" { &array } else { &design };
        let sel = [name.clone()];
        let mut times = Vec::new();
        for _ in 0..repeats {
            let t = Instant::now();
            geometry::build_parts(d, None, Some(&sel))?;
            times.push(t.elapsed().as_secs_f64());
        }
        per_part.push((name, median_s(times) * 1e3));
    }

    // 3. The 13 diameters 10..22 mm, interpolated in the shipped family, in parallel.
    let knots: Vec<Design> = load_designs(&designs_dir())?
        .into_iter()
        .map(|(_, d)| d)
        .filter(|d| {
            d.module
                .as_ref()
                .is_some_and(|m| m.outer_diameter_mm <= 22.0)
        })
        .collect();
    let diameters: Vec<f64> = (10..=22).map(f64::from).collect();
    let family: Vec<Design> = diameters
        .iter()
        .map(|&dm| geometry::family::interpolate(&knots, dm))
        .collect::<Result<_, _>>()?;
    let mut fam_times = Vec::new();
    for _ in 0..repeats {
        let t = Instant::now();
        family
            .par_iter()
            .map(|d| geometry::build_parts(d, None, None).map(|_| ()))
            .collect::<Result<Vec<()>, _>>()?;
        fam_times.push(t.elapsed().as_secs_f64());
    }
    let timings = Timings {
        module_and_mold_ms: median_s(totals) * 1e3,
        module_and_mold_target_ms: 300.0,
        per_part_ms: per_part,
        family_diameters_mm: diameters,
        family_parallel_s: median_s(fam_times),
        family_target_s: 2.0,
        rayon_threads: rayon::current_num_threads(),
    };

    // Report.
    println!(
        "meshing tolerance sweep ({}; median of {repeats})",
        design.name
    );
    println!(
        "  {:<8} {:>8} {:>10} {:>10} {:>10}",
        "part", "tol mm", "triangles", "time ms", "vol err %"
    );
    for r in &rows {
        println!(
            "  {:<8} {:>8.3} {:>10} {:>10.2} {:>10.4}",
            r.part, r.tolerance_mm, r.triangles, r.time_ms, r.volume_error_percent
        );
    }
    println!("build at the default tolerance (B-rep + mesh + checks):");
    for (n, ms) in &timings.per_part_ms {
        println!("  {n:<20} {ms:>8.1} ms");
    }
    println!(
        "  all parts of {} + mold: {:.1} ms (target < {} ms)",
        design.name, timings.module_and_mold_ms, timings.module_and_mold_target_ms
    );
    println!(
        "13 diameters 10..22 mm in parallel ({} threads): {:.3} s (target < {} s)",
        timings.rayon_threads, timings.family_parallel_s, timings.family_target_s
    );

    let csv_rows: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.part.clone(),
                r.tolerance_mm.to_string(),
                r.triangles.to_string(),
                format!("{:.3}", r.time_ms),
                format!("{:.5}", r.volume_error_percent),
            ]
        })
        .collect();
    crate::output::write_csv(
        &a.out.join("tolerance-sweep.csv"),
        &[
            "part",
            "tolerance_mm",
            "triangles",
            "time_ms",
            "volume_error_percent",
        ],
        &csv_rows,
    )?;
    crate::output::write_json(&a.out.join("timings.json"), &timings)?;
    let series = |f: &dyn Fn(&SweepRow) -> f64| -> Vec<Series> {
        distinct
            .iter()
            .map(|s| {
                let pts = rows
                    .iter()
                    .filter(|r| r.part == s.name)
                    .map(|r| (r.tolerance_mm, f(r)))
                    .collect();
                Series::new(s.name.clone(), pts, Mark::LinePoints)
            })
            .collect()
    };
    let mut err_chart = Chart::new(
        format!("{}: |volume error| against meshing tolerance", design.name),
        "tolerance (mm)",
        "|mesh − exact| / exact (%)",
    );
    err_chart.x_log = true;
    err_chart.y_log = true;
    err_chart.series = series(&|r| r.volume_error_percent.abs().max(1e-6));
    err_chart.write_svg(&a.out.join("volume-error.svg"))?;
    let mut tri_chart = Chart::new(
        format!(
            "{}: triangles and time against meshing tolerance",
            design.name
        ),
        "tolerance (mm)",
        "triangles",
    );
    tri_chart.x_log = true;
    tri_chart.y_log = true;
    tri_chart.series = series(&|r| r.triangles as f64);
    tri_chart.write_svg(&a.out.join("triangles.svg"))?;
    let mut time_chart = Chart::new(
        format!("{}: meshing time against tolerance", design.name),
        "tolerance (mm)",
        "time (ms)",
    );
    time_chart.x_log = true;
    time_chart.y_log = true;
    time_chart.series = series(&|r| r.time_ms.max(1e-3));
    time_chart.write_svg(&a.out.join("time.svg"))?;
    println!(
        "wrote {}/{{tolerance-sweep.csv, timings.json, volume-error.svg, triangles.svg, time.svg}}",
        a.out.display()
    );
    Ok(())
}
