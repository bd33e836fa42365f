//! Study `build`: meshing tolerance against triangles, time and volume error, and the
//! build timings of the 34 mm module, its mold and the 10–22 mm family (the README's
//! geometry tables). `--quick` runs one repeat on two tolerances.

use anyhow::Result;
use clap::Args;
use fbgforge::geometry::{self, mesh};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::progress::Progress;
use fbgforge::spec::Design;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of the `build` study.
#[derive(Debug, Args)]
pub struct BuildStudyArgs {
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
    /// Smoke run: one repeat, two tolerances (what the test suite runs).
    #[arg(long)]
    pub quick: bool,
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

/// The tolerance sweep (the study's first part): each distinct solid (one per kind: the
/// inserts are alike) meshed at every tolerance, `repeats` times (the median timed).
fn tolerance_sweep(
    distinct: &[&geometry::PartSolid],
    tolerances: &[f64],
    repeats: usize,
) -> Result<Vec<SweepRow>> {
    let pb = crate::progress::Bar::with("sweep", (distinct.len() * tolerances.len()) as u64);
    let mut rows = Vec::new();
    for s in distinct {
        for &tol in tolerances {
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
            pb.advance(1);
        }
    }
    pb.end();
    Ok(rows)
}

/// The build timings (the study's second and third parts): every part of the module
/// plus the mold at the default tolerance (B-rep, meshes, checks: what `fbgforge
/// build` does before writing), together and one by one; then the 13 diameters 10..22
/// mm, interpolated in the shipped family, in parallel.
fn build_timings(design: &Design, array: &Design, repeats: usize) -> Result<Timings> {
    let mut totals = Vec::new();
    let mut per_part: Vec<(String, f64)> = Vec::new();
    for _ in 0..repeats {
        let t = Instant::now();
        geometry::build_parts(design, None, None)?;
        geometry::build_parts(array, None, None)?;
        totals.push(t.elapsed().as_secs_f64());
    }
    for name in geometry::part_names(design)
        .into_iter()
        .chain(geometry::part_names(array))
    {
        let d = if name.starts_with("mold") {
            array
        } else {
            design
        };
        let sel = [name.clone()];
        let mut times = Vec::new();
        for _ in 0..repeats {
            let t = Instant::now();
            geometry::build_parts(d, None, Some(&sel))?;
            times.push(t.elapsed().as_secs_f64());
        }
        per_part.push((name, median_s(times) * 1e3));
    }
    let knots: Vec<Design> = fbgforge::design::load_designs(&fbgforge::design::designs_dir())?
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
        .map(|&dm| fbgforge::family::interpolate(&knots, dm))
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
    Ok(Timings {
        module_and_mold_ms: median_s(totals) * 1e3,
        module_and_mold_target_ms: 300.0,
        per_part_ms: per_part,
        family_diameters_mm: diameters,
        family_parallel_s: median_s(fam_times),
        family_target_s: 2.0,
        rayon_threads: rayon::current_num_threads(),
    })
}

/// The study's tables on stdout.
fn print_tables(design: &Design, repeats: usize, rows: &[SweepRow], timings: &Timings) {
    println!(
        "meshing tolerance sweep ({}; median of {repeats})",
        design.name
    );
    println!(
        "  {:<8} {:>8} {:>10} {:>10} {:>10}",
        "part", "tol mm", "triangles", "time ms", "vol err %"
    );
    for r in rows {
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
}

/// The sweep's three charts: |volume error|, triangles and time against tolerance, one
/// series per part.
fn write_charts(
    a: &BuildStudyArgs,
    design: &Design,
    parts: &[&str],
    rows: &[SweepRow],
) -> Result<()> {
    let series = |f: &dyn Fn(&SweepRow) -> f64| -> Vec<Series> {
        parts
            .iter()
            .map(|name| {
                let pts = rows
                    .iter()
                    .filter(|r| r.part == *name)
                    .map(|r| (r.tolerance_mm, f(r)))
                    .collect();
                Series::new(name.to_string(), pts, Mark::LinePoints)
            })
            .collect()
    };
    let log_chart = |title: String, y_label: &str, f: &dyn Fn(&SweepRow) -> f64| {
        let mut c = Chart::new(title, "tolerance (mm)", y_label);
        c.x_log = true;
        c.y_log = true;
        c.series = series(f);
        c
    };
    log_chart(
        format!("{}: |volume error| against meshing tolerance", design.name),
        "|mesh − exact| / exact (%)",
        &|r| r.volume_error_percent.abs().max(1e-6),
    )
    .write_svg(&a.out.join("volume-error.svg"))?;
    log_chart(
        format!(
            "{}: triangles and time against meshing tolerance",
            design.name
        ),
        "triangles",
        &|r| r.triangles as f64,
    )
    .write_svg(&a.out.join("triangles.svg"))?;
    log_chart(
        format!("{}: meshing time against tolerance", design.name),
        "time (ms)",
        &|r| r.time_ms.max(1e-3),
    )
    .write_svg(&a.out.join("time.svg"))?;
    Ok(())
}

/// Run the study, print its tables and write its CSV, JSON and charts into `a.out`.
pub fn run(a: &BuildStudyArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    let array = fbgforge::design::load(&a.array)?;
    let repeats = if a.quick { 1 } else { a.repeats.max(1) };
    let solids = geometry::build_solids(&design, None)?;
    let tolerances: &[f64] = if a.quick {
        &[0.1, 0.025]
    } else {
        &[0.1, 0.05, 0.025, 0.01, 0.005]
    };
    let mut kinds_seen = Vec::new();
    let distinct: Vec<_> = solids
        .iter()
        .filter(|s| {
            let new = !kinds_seen.contains(&s.kind);
            kinds_seen.push(s.kind);
            new
        })
        .collect();
    let rows = tolerance_sweep(&distinct, tolerances, repeats)?;
    let timings = build_timings(&design, &array, repeats)?;
    print_tables(&design, repeats, &rows, &timings);
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
    fbgforge::output::write_csv(
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
    fbgforge::output::write_json(&a.out.join("timings.json"), &timings)?;
    let parts: Vec<&str> = distinct.iter().map(|s| s.name.as_str()).collect();
    write_charts(a, &design, &parts, &rows)?;
    println!(
        "wrote {}/{{tolerance-sweep.csv, timings.json, volume-error.svg, triangles.svg, time.svg}}",
        a.out.display()
    );
    Ok(())
}
