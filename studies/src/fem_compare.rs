//! The closed-form model against the finite-element reference over the design space:
//! the measurement behind the validity region of the model policy
//! ([`fbgforge::prediction::validity`]).
//!
//! The grid: outer diameters 10 to 40 mm and walls (cap = core) 0.8 to 3 mm, each a
//! member of the clip-on family scaled from the paper's module ([`scaled_design`]),
//! with the paper's moduli: Case I with core psc1 (E1 = 3.2 MPa) and each insert, and
//! Case II with core psc2 (E1 = 1.4 MPa), E2 = 44 MPa. Grid points the spec
//! validation rejects (walls too thick for the diameter) are listed as skipped.

use anyhow::{anyhow, Result};
use fbgforge::family::scaled_design;
use fbgforge::fem::{
    configurations, solve_configuration, Configuration, FemOptions, GeometryCache,
};
use fbgforge::model::{GratingPrediction, LoadCase};
use fbgforge::output::{write_atomic, write_csv};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::profile::ModuleProfile;
use fbgforge::progress::Progress;
use fbgforge::spec::Design;
use serde::Serialize;
use std::path::Path;

/// The paper's module, compiled in.
pub const PAPER_DESIGN_TOML: &str = include_str!("../../designs/clip-on-34mm.toml");

/// The paper's module as a design.
pub fn paper_design() -> Result<Design> {
    fbgforge::design::parse(PAPER_DESIGN_TOML).map_err(|e| anyhow::anyhow!("built-in design: {e}"))
}

/// Outer diameters of the comparison grid, mm.
pub const GRID_DIAMETERS_MM: [f64; 7] = [10.0, 13.0, 16.0, 22.0, 28.0, 34.0, 40.0];
/// Wall thicknesses of the comparison grid (cap and core alike), mm.
pub const GRID_WALLS_MM: [f64; 6] = [0.8, 1.2, 1.5, 2.0, 2.5, 3.0];
/// The closed form's error bound claimed by the paper.
pub use fbgforge::prediction::TOLERANCE;

/// K of the first grating of `config` among closed-form predictions.
pub fn closed_form_k(preds: &[GratingPrediction], config: &Configuration) -> Result<f64> {
    preds
        .iter()
        .find(|p| p.core == config.core && p.case == config.case && p.insert == config.insert)
        .map(|p| p.sensitivity_pm_per_n)
        .ok_or_else(|| anyhow!("the closed form gave no prediction for {}", config.label()))
}

/// One row of the comparison.
#[derive(Debug, Clone, Serialize)]
pub struct ComparisonRow {
    /// Outer diameter, mm.
    pub diameter_mm: f64,
    /// Cap and core wall, mm.
    pub wall_mm: f64,
    /// Core wall over core mid-surface radius (the thin-shell ratio).
    pub wall_to_radius: f64,
    /// Configuration label.
    pub configuration: String,
    /// Loading case.
    pub case: LoadCase,
    /// Insert (Case I).
    pub insert: Option<String>,
    /// Closed-form K, pm/N (None when the closed form failed).
    pub closed_form_pm_per_n: Option<f64>,
    /// Finite-element K with the default contacts (pillars bonded along their length,
    /// domes tied at the apex patch), pm/N: the reference.
    pub fem_pm_per_n: f64,
    /// Finite-element K with the closed form's series load path (cap bonded to the
    /// pillars only in the base clip band, [`fbgforge::fem::PillarCoupling::BaseClip`]), pm/N.
    pub fem_base_clip_pm_per_n: f64,
    /// (K_closed − K_FE) / |K_FE| against the reference.
    pub relative_error: Option<f64>,
    /// (K_closed − K_FE,clip) / |K_FE,clip|: the error of the closed form's mechanics
    /// alone, with the load path it assumes.
    pub relative_error_base_clip: Option<f64>,
}

/// The paper's pairings: Case I with psc1 and each insert, Case II with psc2.
fn paper_configurations(design: &Design) -> Result<Vec<Configuration>> {
    Ok(configurations(design)?
        .into_iter()
        .filter(|c| {
            matches!(
                (c.case, c.core.as_str()),
                (LoadCase::I, "psc1") | (LoadCase::II, "psc2")
            )
        })
        .collect())
}

/// Mesh options scaled with the module so every grid point has the same mesh count
/// as the paper's module at `level`.
pub fn scaled_options(design: &Design, level: u32) -> FemOptions {
    let mut opt = FemOptions::level(level);
    if let Some(m) = &design.module {
        opt.element_size_mm *= m.outer_diameter_mm / 34.0;
        opt.dome_element_size_mm *= m.outer_diameter_mm / 34.0;
    }
    opt
}

/// Compare the closed form and the FE model on every paper configuration of `design`
/// (the FE structures from and to `cache`).
pub fn compare_design(
    design: &Design,
    level: u32,
    cache: &GeometryCache,
) -> Result<Vec<ComparisonRow>> {
    let m = design
        .module
        .as_ref()
        .ok_or_else(|| anyhow!("the design has no module"))?;
    let p = ModuleProfile::from_module(m);
    let opt = scaled_options(design, level);
    let closed = fbgforge::model::predict(design, 1.0);
    let mut rows = Vec::new();
    for c in paper_configurations(design)? {
        let k_of = |opt: &FemOptions| -> Result<f64> {
            let fe = solve_configuration(design, &c, opt, cache)?;
            let (_, lambda, e) = fe
                .strain_per_n
                .first()
                .cloned()
                .ok_or_else(|| anyhow!("no strain grating on {}", c.core))?;
            Ok(design.fiber.shift_pm(lambda, e, 0.0))
        };
        let k_fe = k_of(&opt)?;
        let mut clip = opt;
        clip.pillar_coupling = fbgforge::fem::PillarCoupling::BaseClip;
        let k_clip = k_of(&clip)?;
        let k_cf = closed
            .as_ref()
            .ok()
            .and_then(|preds| closed_form_k(preds, &c).ok());
        rows.push(ComparisonRow {
            diameter_mm: m.outer_diameter_mm,
            wall_mm: m.core_wall_mm,
            wall_to_radius: m.core_wall_mm
                / (0.5 * (p.core_outer_radius_mm + p.core_inner_radius_mm)),
            configuration: c.label(),
            case: c.case,
            insert: c.insert.clone(),
            closed_form_pm_per_n: k_cf,
            fem_pm_per_n: k_fe,
            fem_base_clip_pm_per_n: k_clip,
            relative_error: k_cf.map(|k| (k - k_fe) / k_fe.abs()),
            relative_error_base_clip: k_cf.map(|k| (k - k_clip) / k_clip.abs()),
        });
    }
    Ok(rows)
}

/// Run the grid, write `fem_comparison.csv`, `.md` and `.svg` into `out_dir`, print
/// the table, and return the rows.
pub fn run_comparison(out_dir: &Path) -> Result<Vec<ComparisonRow>> {
    run_comparison_on(out_dir, &GRID_DIAMETERS_MM, &GRID_WALLS_MM)
}

/// [`run_comparison`] on a chosen grid of outer diameters and walls, mm.
pub fn run_comparison_on(
    out_dir: &Path,
    diameters_mm: &[f64],
    walls_mm: &[f64],
) -> Result<Vec<ComparisonRow>> {
    let base = paper_design()?;
    let pb = crate::progress::Bar::with("comparison", (diameters_mm.len() * walls_mm.len()) as u64);
    let mut rows = Vec::new();
    let mut skipped = Vec::new();
    let cache = GeometryCache::default();
    for &d in diameters_mm {
        for &w in walls_mm {
            pb.advance(1);
            match scaled_design(&base, d, w) {
                Ok(design) => rows.extend(compare_design(&design, 1, &cache)?),
                Err(e) => skipped.push((d, w, e.to_string())),
            }
        }
    }
    pb.end();
    let fmt_opt = |v: Option<f64>, prec: usize| {
        v.map(|x| format!("{x:.prec$}"))
            .unwrap_or_else(|| "n/a".into())
    };
    let csv_rows: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                format!("{}", r.diameter_mm),
                format!("{}", r.wall_mm),
                format!("{:.4}", r.wall_to_radius),
                r.configuration.clone(),
                fmt_opt(r.closed_form_pm_per_n, 4),
                format!("{:.4}", r.fem_pm_per_n),
                fmt_opt(r.relative_error.map(|e| e * 100.0), 2),
                format!("{:.4}", r.fem_base_clip_pm_per_n),
                fmt_opt(r.relative_error_base_clip.map(|e| e * 100.0), 2),
            ]
        })
        .collect();
    write_csv(
        &out_dir.join("fem_comparison.csv"),
        &[
            "diameter_mm",
            "wall_mm",
            "wall_to_radius",
            "configuration",
            "closed_form_pm_per_n",
            "fem_pm_per_n",
            "relative_error_percent",
            "fem_base_clip_pm_per_n",
            "relative_error_base_clip_percent",
        ],
        &csv_rows,
    )?;
    let mut md = String::from(
        "| D, mm | wall, mm | t/R | configuration | K closed form, pm/N | K FE, pm/N | error, % | K FE base clip, pm/N | error vs base clip, % |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in &csv_rows {
        md.push_str(&format!("| {} |\n", r.join(" | ")));
    }
    for (d, w, e) in &skipped {
        md.push_str(&format!(
            "| {d} | {w} | – | skipped: {} | | | | | |\n",
            e.replace('|', "/")
        ));
    }
    write_atomic(&out_dir.join("fem_comparison.md"), md.as_bytes())?;
    println!("\nClosed form against FE (level 1 mesh scaled with D):");
    print!("{md}");

    let mut chart = Chart::new(
        "Closed form against FE: |relative error| of K (8 % line = the paper's bound)",
        "core wall / core radius t/R",
        "|K_closed − K_FE| / |K_FE|, %",
    );
    chart.y_log = true;
    let mut labels: Vec<String> = rows.iter().map(|r| r.configuration.clone()).collect();
    labels.dedup();
    labels.sort();
    labels.dedup();
    let mut any = false;
    for l in &labels {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| &r.configuration == l)
            .filter_map(|r| {
                r.relative_error
                    .map(|e| (r.wall_to_radius, (e * 100.0).abs()))
            })
            .collect();
        any |= !pts.is_empty();
        chart = chart.with(Series::new(format!("{l} vs FE"), pts, Mark::Points));
        let clip: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| &r.configuration == l)
            .filter_map(|r| {
                r.relative_error_base_clip
                    .map(|e| (r.wall_to_radius, (e * 100.0).abs()))
            })
            .collect();
        chart = chart.with(Series::new(
            format!("{l} vs FE base clip"),
            clip,
            Mark::Points,
        ));
    }
    if any {
        let (x0, x1) = rows.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
            (a.min(r.wall_to_radius), b.max(r.wall_to_radius))
        });
        chart = chart.with(Series::new("8 %", vec![(x0, 8.0), (x1, 8.0)], Mark::Line));
        chart.write_svg(&out_dir.join("fem_comparison.svg"))?;
    } else {
        println!("(no closed-form predictions: the comparison chart is not drawn)");
    }
    println!(
        "wrote {}, {}{}",
        out_dir.join("fem_comparison.csv").display(),
        out_dir.join("fem_comparison.md").display(),
        if any {
            format!(", {}", out_dir.join("fem_comparison.svg").display())
        } else {
            String::new()
        }
    );
    Ok(rows)
}
