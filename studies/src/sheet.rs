//! Study `sheet` (`cargo run --release -p fbgforge-studies -- sheet`): the physical
//! model of the array's sheet (docs/array.md §12) measured.
//!
//! Parts (`--part`, default all):
//! * `paper`: the shipped design against Tables 1 and 2 (raw gratings, mirror-averaged
//!   shape after one common scale, the direct load), with the empirical kernel beside;
//! * `fit`: the two fitted constants (the composite's modulus, the table interface)
//!   fitted again to Table 1;
//! * `speed`: time of the 60 × 80 sheet's matrix against the discretisation (the
//!   speed goal: ≤ 2 s), and each resolution's error against the finest and against
//!   Table 1 — the speed–accuracy chart;
//! * `trends`: sensitivity and its fall-off with distance as thickness, fiber depth,
//!   modulus and table interface change.
//!
//! Writes CSV, JSON and SVG into `--out` (default out/study-sheet).

use anyhow::{bail, Context, Result};
use clap::Args;
use fbgforge::array::kernel::{describe_kernel, DistanceKernel, TABLE1};
use fbgforge::array::sheet::fit::{compare_with_paper, fit_table1, modulus_profile, table1_model};
use fbgforge::array::sheet::{design_matrix, Resolution, SheetModel};
use fbgforge::output::{write_csv, write_json};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::spec::{BaseCondition, Design};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of the `sheet` study.
#[derive(Debug, Args)]
pub struct SheetStudyArgs {
    /// The paper's array design.
    #[arg(long, default_value = "designs/tactile-array-60x80.toml")]
    pub design: PathBuf,
    /// One part only: paper, fit, speed or trends.
    #[arg(long)]
    pub part: Option<String>,
    /// Timed repeats per resolution (the minimum and median are reported).
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
    /// Output folder.
    #[arg(long, default_value = "out/study-sheet")]
    pub out: PathBuf,
    /// Smoke run: one repeat, three resolutions, no fit.
    #[arg(long)]
    pub quick: bool,
}

/// Run the study.
pub fn run(a: &SheetStudyArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    let parts: Vec<&str> = match a.part.as_deref() {
        None => vec!["paper", "fit", "speed", "trends"],
        Some(p @ ("paper" | "fit" | "speed" | "trends")) => vec![p],
        Some(p) => bail!("unknown part `{p}`; expected paper, fit, speed or trends"),
    };
    for p in parts {
        match p {
            "paper" => paper(&design, a)?,
            "fit" if !a.quick => fit(&design, a)?,
            "fit" => {}
            "speed" => speed(&design, a)?,
            _ => trends(&design, a)?,
        }
    }
    Ok(())
}

fn paper(design: &Design, a: &SheetStudyArgs) -> Result<()> {
    let model = SheetModel::from_design(design)?;
    let c = compare_with_paper(&model, design)?;
    let k = DistanceKernel::paper();
    println!(
        "Table 1 (load at the centre), pm/g; model: sheet, {}",
        model.base.describe()
    );
    println!(
        "{:<6} {:>8} {:>10} {:>10} {:>8} {:>10} {:>8}",
        "FBG", "d mm", "paper", "sheet", "err %", "kernel", "err %"
    );
    let mut rows = Vec::new();
    for r in &c.table1 {
        let kv = k.sensitivity_pm_per_g(r.distance_mm);
        let ke = 100.0 * (kv - r.measured_pm_per_g) / r.measured_pm_per_g;
        println!(
            "{:<6} {:>8.2} {:>10.4} {:>10.4} {:>+8.1} {:>10.4} {:>+8.1}",
            r.grating, r.distance_mm, r.measured_pm_per_g, r.model_pm_per_g, r.error_pct, kv, ke
        );
        rows.push(vec![
            r.grating.clone(),
            format!("{}", r.distance_mm),
            format!("{}", r.measured_pm_per_g),
            format!("{:.6}", r.model_pm_per_g),
            format!("{:.2}", r.error_pct),
            format!("{kv:.6}"),
            format!("{ke:.2}"),
        ]);
    }
    println!(
        "mirror pairs (geometric means), common scale {:.3}: {}",
        c.common_scale,
        c.pairs
            .iter()
            .map(|p| format!(
                "{:.2} mm: paper {:.4}, sheet×scale {:.4} ({:+.1} %)",
                p.distance_mm, p.measured_pm_per_g, p.scaled_model_pm_per_g, p.shape_error_pct
            ))
            .collect::<Vec<_>>()
            .join("; ")
    );
    println!(
        "Table 2 (load right above a grating): paper 0.371 pm/g, sheet {:.3} pm/g ({:+.1} %; per grating {}), fiber following the silicone {:.2} pm/g",
        c.table2_model_mean_pm_per_g,
        c.table2_error_pct,
        c.table2_model_pm_per_g
            .iter()
            .map(|v| format!("{v:.3}"))
            .collect::<Vec<_>>()
            .join(", "),
        c.table2_silicone_pm_per_g
    );
    write_csv(
        &a.out.join("paper-table1.csv"),
        &[
            "grating",
            "distance_mm",
            "paper_pm_per_g",
            "sheet_pm_per_g",
            "sheet_error_pct",
            "kernel_pm_per_g",
            "kernel_error_pct",
        ],
        &rows,
    )?;
    write_json(
        &a.out.join("paper.json"),
        &serde_json::json!({"sheet": c, "kernel": describe_kernel(&k)}),
    )?;
    let pts = |f: &dyn Fn(usize) -> f64| -> Vec<(f64, f64)> {
        (0..6).map(|i| (TABLE1[i].1, f(i))).collect()
    };
    Chart::new(
        "Table 1: sensitivity to a load at the array centre",
        "distance grating–load (mm)",
        "sensitivity (pm/g)",
    )
    .with(Series::new(
        "paper (Table 1)",
        pts(&|i| TABLE1[i].0),
        Mark::Points,
    ))
    .with(Series::new(
        "sheet model",
        pts(&|i| c.table1[i].model_pm_per_g),
        Mark::Points,
    ))
    .with(Series::new(
        "sheet model, mirror pairs × common scale",
        c.pairs
            .iter()
            .rev()
            .map(|p| (p.distance_mm, p.scaled_model_pm_per_g))
            .collect(),
        Mark::LinePoints,
    ))
    .with(Series::new(
        "empirical kernel",
        (0..=40)
            .map(|i| {
                let d = 10.0 + i as f64;
                (d, k.sensitivity_pm_per_g(d))
            })
            .collect(),
        Mark::Line,
    ))
    .write_svg(&a.out.join("paper-table1.svg"))?;
    Ok(())
}

fn fit(design: &Design, a: &SheetStudyArgs) -> Result<()> {
    let t0 = Instant::now();
    let f = fit_table1(design)?;
    let s = t0.elapsed().as_secs_f64();
    println!(
        "fit to Table 1: E = {:.3} MPa, k_t = {:.4} N/mm³, rms log misfit {:.4} ({} solves, {s:.1} s)",
        f.youngs_modulus_mpa, f.tangential_stiffness_n_per_mm3, f.table1_rms_log, f.evaluations
    );
    let moduli = [0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0];
    let profile = modulus_profile(design, &moduli)?;
    println!("profile: the best interface for each modulus");
    println!(
        "{:>10} {:>14} {:>12} {:>10} {:>12} {:>10}",
        "E MPa", "k_t N/mm³", "k_t/μ 1/mm", "rms log", "shape %", "direct"
    );
    let mut rows = Vec::new();
    for p in &profile {
        let mut m = SheetModel::from_design(design)?;
        m.youngs_modulus_mpa = p.youngs_modulus_mpa;
        m.base = BaseCondition::Gripping {
            tangential_stiffness_n_per_mm3: p.tangential_stiffness_n_per_mm3,
        };
        let c = compare_with_paper(&m, design)?;
        println!(
            "{:>10.3} {:>14.5} {:>12.4} {:>10.4} {:>12.1} {:>10.3}",
            p.youngs_modulus_mpa,
            p.tangential_stiffness_n_per_mm3,
            p.stiffness_over_shear_modulus_per_mm,
            p.table1_rms_log,
            c.worst_shape_error_pct,
            c.table2_model_mean_pm_per_g
        );
        rows.push(serde_json::json!({"profile": p, "worst_shape_error_pct": c.worst_shape_error_pct,
            "common_scale": c.common_scale, "table2_model_mean_pm_per_g": c.table2_model_mean_pm_per_g}));
    }
    write_json(
        &a.out.join("fit.json"),
        &serde_json::json!({"fit": f, "profile": rows}),
    )?;
    Ok(())
}

/// Time `f` `n` times: (min, median) seconds.
fn time_it(n: usize, mut f: impl FnMut() -> Result<()>) -> Result<(f64, f64)> {
    let mut t = Vec::with_capacity(n);
    for _ in 0..n.max(1) {
        let t0 = Instant::now();
        f()?;
        t.push(t0.elapsed().as_secs_f64());
    }
    t.sort_by(f64::total_cmp);
    Ok((t[0], t[t.len() / 2]))
}

fn speed(design: &Design, a: &SheetStudyArgs) -> Result<()> {
    let base = SheetModel::from_design(design)?;
    let reference = {
        let mut m = base.clone();
        m.resolution = Resolution::fine().refined(2.0);
        table1_model(&m, design)?
    };
    let factors: Vec<f64> = if a.quick {
        vec![0.5, 1.0, 2.0]
    } else {
        vec![0.25, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0, 2.8]
    };
    let repeats = if a.quick { 1 } else { a.repeats };
    let cells = fbgforge::profile::ArrayLayout::from_array(design.array.as_ref().context("array")?)
        .cell_centers_mm;
    let gratings = fbgforge::array::sheet::gratings_of(design)?;
    println!(
        "{:>7} {:>9} {:>9} {:>8} {:>11} {:>11} {:>14} {:>14}",
        "factor",
        "segment",
        "panel",
        "ρ step",
        "min ms",
        "median ms",
        "err vs fine %",
        "Table 1 shape %"
    );
    let mut rows = Vec::new();
    let mut json = Vec::new();
    for f in factors {
        let mut m = base.clone();
        m.resolution = Resolution::standard().refined(f);
        let (tmin, tmed) = time_it(repeats, || {
            let sol = m.solve()?;
            let _ = sol.strain_per_n(&gratings, &cells);
            Ok(())
        })?;
        let t1 = table1_model(&m, design)?;
        let err = t1
            .iter()
            .zip(&reference)
            .map(|(x, r)| ((x - r) / r).abs())
            .fold(0.0, f64::max)
            * 100.0;
        let shape = compare_with_paper(&m, design)?.worst_shape_error_pct;
        println!(
            "{f:>7.2} {:>9.3} {:>9.3} {:>8.3} {:>11.1} {:>11.1} {:>14.3} {:>14.1}",
            m.resolution.segment_mm,
            m.resolution.panel_fraction,
            m.resolution.rho_step_mm,
            tmin * 1e3,
            tmed * 1e3,
            err,
            shape
        );
        rows.push(vec![
            format!("{f}"),
            format!("{}", m.resolution.segment_mm),
            format!("{}", m.resolution.panel_fraction),
            format!("{}", m.resolution.rho_step_mm),
            format!("{:.2}", tmin * 1e3),
            format!("{:.2}", tmed * 1e3),
            format!("{err:.4}"),
            format!("{shape:.2}"),
        ]);
        json.push(serde_json::json!({
            "refinement": f, "resolution": m.resolution, "min_ms": tmin * 1e3,
            "median_ms": tmed * 1e3, "max_error_vs_finest_pct": err,
            "table1_worst_shape_error_pct": shape,
        }));
    }
    let (tmin, tmed) = time_it(repeats, || design_matrix(design).map(|_| ()))?;
    println!(
        "the 60 × 80 sheet's matrix at the standard resolution (design_matrix): min {:.0} ms, median {:.0} ms (goal ≤ 2000 ms)",
        tmin * 1e3,
        tmed * 1e3
    );
    write_csv(
        &a.out.join("speed.csv"),
        &[
            "refinement",
            "segment_mm",
            "panel_fraction",
            "rho_step_mm",
            "min_ms",
            "median_ms",
            "max_error_vs_finest_pct",
            "table1_worst_shape_error_pct",
        ],
        &rows,
    )?;
    write_json(
        &a.out.join("speed.json"),
        &serde_json::json!({"rows": json, "design_matrix_min_ms": tmin * 1e3,
            "design_matrix_median_ms": tmed * 1e3, "goal_ms": 2000.0, "repeats": repeats}),
    )?;
    let pts = |i: usize| -> Vec<(f64, f64)> {
        rows.iter()
            .map(|r| {
                (
                    r[4].parse().unwrap_or(f64::NAN),
                    r[i].parse().unwrap_or(f64::NAN),
                )
            })
            .collect()
    };
    let mut c = Chart::new(
        "Sheet model: time of the 60 × 80 matrix against error",
        "time per matrix, min (ms)",
        "error (%)",
    )
    .with(Series::new(
        "largest Table 1 error vs the finest resolution",
        pts(6),
        Mark::LinePoints,
    ))
    .with(Series::new(
        "worst mirror-pair shape error vs Table 1",
        pts(7),
        Mark::LinePoints,
    ));
    c.x_log = true;
    c.y_log = true;
    c.write_svg(&a.out.join("speed.svg"))?;
    Ok(())
}

fn trends(design: &Design, a: &SheetStudyArgs) -> Result<()> {
    let base = SheetModel::from_design(design)?;
    let mut variants: Vec<(String, String, SheetModel)> = Vec::new();
    for h in [3.0, 4.0, 5.0, 6.0, 8.0] {
        let mut m = base.clone();
        m.thickness_mm = h;
        m.fiber_depth_mm = h / 2.0;
        variants.push(("thickness_mm".into(), format!("{h}"), m));
    }
    for zf in [1.0, 1.75, 2.5, 3.25, 4.0] {
        let mut m = base.clone();
        m.fiber_depth_mm = zf;
        variants.push(("fiber_depth_mm".into(), format!("{zf}"), m));
    }
    for e in [0.25, 0.5, 1.0, 2.0, 4.0] {
        let mut m = base.clone();
        m.youngs_modulus_mpa = e;
        variants.push(("youngs_modulus_mpa".into(), format!("{e}"), m));
    }
    for (name, b) in [
        ("bonded", BaseCondition::Bonded),
        (
            "gripping 0.1",
            BaseCondition::Gripping {
                tangential_stiffness_n_per_mm3: 0.1,
            },
        ),
        (
            "gripping 0.02",
            BaseCondition::Gripping {
                tangential_stiffness_n_per_mm3: 0.02,
            },
        ),
        (
            "gripping 0.005",
            BaseCondition::Gripping {
                tangential_stiffness_n_per_mm3: 0.005,
            },
        ),
        ("frictionless", BaseCondition::Frictionless),
    ] {
        let mut m = base.clone();
        m.base = b;
        variants.push(("base".into(), name.into(), m));
    }
    if a.quick {
        variants.truncate(2);
    }
    println!(
        "{:<20} {:>16} {:>11} {:>11} {:>11} {:>11} {:>12}",
        "parameter", "value", "14.58 mm", "25.74 mm", "39.53 mm", "direct", "far/near"
    );
    let mut rows = Vec::new();
    for (p, v, m) in &variants {
        let c = compare_with_paper(m, design)?;
        let pair = |i: usize| c.pairs[i].model_pm_per_g;
        let ratio = pair(0) / pair(2);
        println!(
            "{p:<20} {v:>16} {:>11.4} {:>11.4} {:>11.4} {:>11.4} {:>12.4}",
            pair(2),
            pair(1),
            pair(0),
            c.table2_model_mean_pm_per_g,
            ratio
        );
        rows.push(vec![
            p.clone(),
            v.clone(),
            format!("{:.6}", pair(2)),
            format!("{:.6}", pair(1)),
            format!("{:.6}", pair(0)),
            format!("{:.6}", c.table2_model_mean_pm_per_g),
            format!("{ratio:.5}"),
        ]);
    }
    write_csv(
        &a.out.join("trends.csv"),
        &[
            "parameter",
            "value",
            "pair_14_58_mm_pm_per_g",
            "pair_25_74_mm_pm_per_g",
            "pair_39_53_mm_pm_per_g",
            "direct_pm_per_g",
            "far_over_near",
        ],
        &rows,
    )?;
    Ok(())
}
