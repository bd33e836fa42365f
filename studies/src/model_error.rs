//! Study `model-error` (`cargo run --release -p fbgforge-studies -- model-error`):
//! does the model's stated error hold, and do written designs keep their margins
//! under it? (issue 38)
//!
//! 1. **Containment.** Random valid designs, wider than the shipped family: diameter
//!    8–40 mm, cap and core walls from the printer's minimum to a quarter of the
//!    radius, dome 0.4–1 × the radius, cap modulus 20–200 MPa, core moduli 0.8–8 MPa,
//!    inserts 20–3000 MPa, a PolyJet or an FDM-like printer. Each is predicted by the
//!    policy with its band and design interval; counted: rows whose nominal lies
//!    outside its bounding readings widened by its model error (and of those, rows
//!    that do not say so, and rows whose readings do not fix K's sign), rows whose stated
//!    error exceeds 0.15 (the policy refines a configuration's mesh from level 1
//!    until it states at most that, up to level 3; and of those, rows that do not say
//!    so), rows whose nominal lies outside
//!    its design interval, and rows per mesh level. Each drawn design is written
//!    beside the rows (`designs/design-K.toml`) to re-run it with `fbgforge predict`.
//! 2. **Written designs.** `optimize` from some of those designs (a small budget),
//!    and each written design predicted again: counted, gratings of the written
//!    configuration at or over the strain limit at the far end of their design
//!    interval, and under the required 5 % margin; written designs with no room left
//!    in a wavelength window, or whose snap strains the cap beyond its permissible
//!    strain.
//!
//! Writes `model_error.csv` (one row per design and row) and `model_error.json` (the
//! counts) into `--out`. `--quick`: 3 designs, 1 optimisation.

use anyhow::Result;
use clap::Args;
use fbgforge::output::{ensure_dir, write_csv, write_json};
use fbgforge::prediction::{predict, PredictionRequest, MAX_MODEL_ERROR};
use fbgforge::spec::{Design, PrintProcess};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};

/// Arguments of the `model-error` study.
#[derive(Debug, Args)]
pub struct ModelErrorArgs {
    /// Random designs predicted.
    #[arg(long, default_value_t = 40)]
    pub designs: usize,
    /// Of those, designs optimised (a small budget each).
    #[arg(long, default_value_t = 4)]
    pub optimise: usize,
    /// Seed of the draws.
    #[arg(long, default_value_t = 38)]
    pub seed: u64,
    /// Output folder.
    #[arg(long, default_value = "out/model-error")]
    pub out: PathBuf,
    /// Smoke run: 3 designs, 1 optimisation.
    #[arg(long)]
    pub quick: bool,
}

/// The study's counts.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct ModelErrorReport {
    /// Valid designs drawn and predicted.
    pub designs: usize,
    /// Draws the spec refused (redrawn).
    pub invalid_draws: usize,
    /// Prediction rows checked.
    pub rows: usize,
    /// Rows whose nominal lies outside its bounding readings widened by its error.
    pub rows_outside_widened_band: usize,
    /// Of those, rows that do not say so ("the model is wrong here"): confidently
    /// wrong answers.
    pub rows_outside_unflagged: usize,
    /// Of those, rows whose bounding readings do not fix K's sign.
    pub rows_outside_sign_not_fixed: usize,
    /// Rows whose nominal lies outside its design interval.
    pub rows_outside_design_interval: usize,
    /// Rows whose stated model error exceeds 0.15.
    pub rows_over_max_error: usize,
    /// Of those, rows that do not say so ("stated model error"): confidently wrong
    /// answers.
    pub rows_over_max_error_unflagged: usize,
    /// Largest stated model error, fraction.
    pub max_model_error: f64,
    /// Rows by the policy mesh level they were answered at (index = level; the
    /// policy refines a configuration from level 1 until it states ≤ 15 %, up to 3).
    pub rows_by_mesh_level: [usize; 5],
    /// Designs optimised.
    pub optimised: usize,
    /// Optimisations that found no feasible design.
    pub optimise_failed: usize,
    /// Gratings of the written configurations checked.
    pub written_gratings: usize,
    /// Of those, at or over the strain limit at the far end of their design interval.
    pub written_at_or_over_limit: usize,
    /// Of those, with less than the required 5 % margin.
    pub written_under_margin: usize,
    /// The smallest strain margin of a written grating, percent of the limit.
    pub smallest_written_margin_percent: f64,
    /// Written designs whose wavelength window has no room left at the far end of the
    /// design interval (range and thermal span at or over a window's edge).
    pub written_wavelength_window_over: usize,
    /// Written designs whose snap strains the cap beyond its permissible strain.
    pub written_snap_over: usize,
    /// The smallest wavelength-window room of a written design, nm.
    pub smallest_written_window_room_nm: f64,
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// One random design around the family rule: see the module doc for the ranges.
pub fn random_design(base: &Design, rng: &mut impl Rng) -> Option<Design> {
    let diameter = lerp(8.0, 40.0, rng.random::<f64>());
    let mut d = fbgforge::family::scaled_design(base, diameter, 1.0).ok()?;
    if rng.random::<f64>() < 0.3 {
        d.printer.process = PrintProcess::Fdm;
        d.printer.resolution_mm = 0.1;
        d.printer.min_wall_mm = 0.4;
    }
    let w = d.printer.min_wall_mm;
    let m = d.module.as_mut()?;
    let r = diameter / 2.0;
    m.cap_wall_mm = lerp(w, (0.25 * r).min(3.0), rng.random::<f64>());
    m.core_wall_mm = lerp(w, (0.25 * r).min(3.0), rng.random::<f64>());
    m.dome_height_mm = lerp(0.4 * r, r, rng.random::<f64>());
    let cap = m.cap_material.clone();
    let cores: Vec<String> = m.cores.iter().map(|c| c.material.clone()).collect();
    let inserts: Vec<String> = m.inserts.iter().map(|i| i.material.clone()).collect();
    let mut set = |key: &str, lo: f64, hi: f64, rng: &mut dyn rand::RngCore| {
        if let Some(mat) = d.materials.get_mut(key) {
            // Log-uniform: moduli span orders of magnitude.
            let t: f64 = rng.random();
            mat.youngs_modulus_mpa = (lo.ln() + (hi.ln() - lo.ln()) * t).exp();
        }
    };
    set(&cap, 20.0, 200.0, rng);
    for c in &cores {
        set(c, 0.8, 8.0, rng);
    }
    for i in &inserts {
        set(i, 20.0, 3000.0, rng);
    }
    d.validate().ok()?;
    Some(d)
}

/// Predict `d` with its band and design interval; the CSV rows and the counts.
fn check_design(
    k: usize,
    d: &Design,
    report: &mut ModelErrorReport,
    csv: &mut Vec<Vec<String>>,
) -> Result<()> {
    let rows = predict(
        d,
        &PredictionRequest {
            band: true,
            design_interval: true,
            ..PredictionRequest::default()
        },
    )?;
    let m = d.module.as_ref().expect("a module design");
    for r in &rows {
        let p = &r.detail.prediction;
        report.rows += 1;
        let contained = r.nominal_contained().unwrap_or(true);
        let k_nom = p.sensitivity_pm_per_n;
        let in_interval = r
            .design_interval_pm_per_n
            .is_none_or(|[lo, hi]| k_nom >= lo && k_nom <= hi);
        let f = r.model_error_fraction.unwrap_or(0.0);
        report.rows_outside_widened_band += usize::from(!contained);
        let said = |text: &str| p.warnings.iter().any(|w| w.contains(text));
        if !contained {
            report.rows_outside_unflagged += usize::from(!said("the model is wrong here"));
            report.rows_outside_sign_not_fixed += usize::from(said("sign of K is not fixed"));
        }
        report.rows_outside_design_interval += usize::from(!in_interval);
        report.rows_over_max_error += usize::from(f > MAX_MODEL_ERROR);
        report.rows_over_max_error_unflagged +=
            usize::from(f > MAX_MODEL_ERROR && !said("stated model error"));
        report.max_model_error = report.max_model_error.max(f);
        if let Some(level) = r.mesh_level {
            report.rows_by_mesh_level[level as usize] += 1;
        }
        let b = r.band_readings;
        csv.push(vec![
            k.to_string(),
            format!("{:.3}", m.outer_diameter_mm),
            format!("{:.3}", m.cap_wall_mm),
            format!("{:.3}", m.core_wall_mm),
            format!("{:?}", d.printer.process),
            p.grating.clone(),
            p.case.to_string(),
            p.insert.clone().unwrap_or_else(|| "-".into()),
            r.model.name().to_string(),
            format!("{k_nom:.4}"),
            format!("{f:.4}"),
            r.mesh_level.map_or(String::new(), |k| k.to_string()),
            b.map_or(String::new(), |b| {
                format!("{:.4}", b.bonded_pillars_pm_per_n)
            }),
            b.map_or(String::new(), |b| {
                format!("{:.4}", b.sliding_apex_patch_pm_per_n)
            }),
            contained.to_string(),
            in_interval.to_string(),
        ]);
    }
    Ok(())
}

/// Optimise from `d` on a small budget and check the written configuration's
/// gratings at the far end of their design intervals.
fn check_written(d: &Design, dir: &Path, report: &mut ModelErrorReport) -> Result<()> {
    use fbgforge::optimize::module::ModuleSettings;
    use fbgforge::optimize::run::{run_module, ModuleRequest};
    let start = dir.join(format!("start-{}.toml", report.optimised));
    fbgforge::output::write_atomic(&start, d.to_toml().as_bytes())?;
    let mut settings = ModuleSettings {
        extra_starts: 0,
        front_levels: 1,
        inserts: Some(vec!["insert_blue".into(), "none".into()]),
        ..ModuleSettings::default()
    };
    settings.run.max_iters = 30;
    settings.run.swarm_iters = 10;
    let out = dir.join(format!("written-{}.toml", report.optimised));
    let req = ModuleRequest {
        design: start,
        materials: None,
        settings,
        measured: None,
        landscape: None,
        out: Some(out.clone()),
        report_dir: Some(dir.join(format!("written-{}-report", report.optimised))),
        words: str::to_string,
    };
    report.optimised += 1;
    let run = match run_module(&req, &fbgforge::progress::Quiet, &mut ()) {
        Ok(r) => r,
        Err(_) => {
            report.optimise_failed += 1;
            return Ok(());
        }
    };
    let written = fbgforge::design::load(&out)?;
    let choice = &run.outcome.written_choice;
    if let Some(m) = run.outcome.written.margins {
        report.written_wavelength_window_over += usize::from(m.wavelength_window_nm <= 0.0);
        report.written_snap_over += usize::from(m.snap_strain_percent.is_some_and(|s| s < 0.0));
        report.smallest_written_window_room_nm = report
            .smallest_written_window_room_nm
            .min(m.wavelength_window_nm);
    }
    let rows = predict(
        &written,
        &PredictionRequest {
            band: true,
            design_interval: true,
            ..PredictionRequest::default()
        },
    )?;
    for r in rows.iter().filter(|r| {
        let p = &r.detail.prediction;
        match &choice.insert_material {
            Some(_) => p.case == fbgforge::model::LoadCase::I,
            None => p.case == fbgforge::model::LoadCase::II,
        }
    }) {
        let Some(c) = r.limit_check else { continue };
        report.written_gratings += 1;
        report.written_at_or_over_limit += usize::from(c.strain_margin_microstrain <= 0.0);
        report.written_under_margin += usize::from(!c.meets_margin);
        report.smallest_written_margin_percent = report
            .smallest_written_margin_percent
            .min(c.strain_margin_percent);
    }
    Ok(())
}

/// Run the study.
pub fn run(a: &ModelErrorArgs) -> Result<ModelErrorReport> {
    ensure_dir(&a.out)?;
    let (n, n_opt) = if a.quick {
        (3, 1)
    } else {
        (a.designs, a.optimise)
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let base = fbgforge::design::load(&root.join("designs/clip-on-34mm.toml"))?;
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
    let mut report = ModelErrorReport {
        smallest_written_margin_percent: f64::INFINITY,
        smallest_written_window_room_nm: f64::INFINITY,
        ..ModelErrorReport::default()
    };
    let mut csv = Vec::new();
    let mut designs = Vec::new();
    while designs.len() < n && report.invalid_draws < 100 * n.max(1) {
        match random_design(&base, &mut rng) {
            Some(d) => designs.push(d),
            None => report.invalid_draws += 1,
        }
    }
    let drawn = a.out.join("designs");
    ensure_dir(&drawn)?;
    for (k, d) in designs.iter().enumerate() {
        // Each drawn design beside its rows, to re-run one with `fbgforge predict`.
        fbgforge::output::write_atomic(
            &drawn.join(format!("design-{k}.toml")),
            d.to_toml().as_bytes(),
        )?;
        check_design(k, d, &mut report, &mut csv)?;
        report.designs += 1;
    }
    for d in designs.iter().take(n_opt) {
        check_written(d, &a.out, &mut report)?;
    }
    write_csv(
        &a.out.join("model_error.csv"),
        &[
            "design",
            "d_mm",
            "cap_wall_mm",
            "core_wall_mm",
            "printer",
            "grating",
            "case",
            "insert",
            "model",
            "k_pm_per_n",
            "model_error_fraction",
            "mesh_level",
            "bonded_pm_per_n",
            "sliding_apex_patch_pm_per_n",
            "contained",
            "in_design_interval",
        ],
        &csv,
    )?;
    write_json(&a.out.join("model_error.json"), &report)?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(report)
}
