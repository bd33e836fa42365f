//! Study `fem` (`cargo run --release -p fbgforge-studies -- fem [--quick]`): mesh convergence of K, time per prediction against error for
//! the closed form and each finite-element mesh level, and the closed-form-vs-FE
//! comparison over the design space.
//!
//! Outputs (in `out_dir`): `fem_convergence.csv`, `fem_speed_accuracy.csv` and
//! `.svg`, and the comparison files written by [`super::fem_compare::run_comparison`].
//! A table of the same numbers is printed. The design is the paper's module
//! (`designs/clip-on-34mm.toml`, compiled in so the bench runs from any folder).

use super::fem_compare::paper_design;
use anyhow::{Context, Result};
use fbgforge::fem::{
    solve_configuration, Configuration, DomeContact, FemOptions, GeometryCache, SolverKind,
};
use fbgforge::model::LoadCase;
use fbgforge::output::write_csv;
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::progress::Progress;
use fbgforge::spec::Design;
use std::path::Path;
use std::time::Instant;

/// One mesh level of the convergence study.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LevelResult {
    /// Configuration label, e.g. `psc1 Case I blue`.
    pub configuration: String,
    /// Refinement level (cylinder element size 4 / 2^level mm).
    pub level: u32,
    /// Meridian element size, mm.
    pub element_size_mm: f64,
    /// Unknowns.
    pub unknowns: usize,
    /// Sensitivity of the configuration's first grating, pm/N.
    pub sensitivity_pm_per_n: f64,
    /// Best wall-clock time of one solve (mesh, assembly, factorisation, read-out), s.
    pub time_s: f64,
}

/// Solve `config` at levels 0..=max_level; each level timed as the best of `repeats`.
pub fn convergence(
    design: &Design,
    config: &Configuration,
    levels: std::ops::RangeInclusive<u32>,
    repeats: usize,
    solver: SolverKind,
    dome_contact: DomeContact,
    cache: &GeometryCache,
) -> Result<Vec<LevelResult>> {
    let mut out = Vec::new();
    for level in levels {
        let mut opt = FemOptions::level(level);
        opt.solver = solver;
        opt.dome_contact = dome_contact;
        let mut best = f64::INFINITY;
        let mut last = None;
        for _ in 0..repeats.max(1) {
            let t = Instant::now();
            let r = solve_configuration(design, config, &opt, cache)?;
            best = best.min(t.elapsed().as_secs_f64());
            last = Some(r);
        }
        let r = last.expect("at least one repeat");
        let (_, lambda, e) = r
            .strain_per_n
            .first()
            .cloned()
            .context("the configuration's core has no strain grating")?;
        out.push(LevelResult {
            configuration: match dome_contact {
                DomeContact::Gap => format!("{} (dome gap)", config.label()),
                _ => config.label(),
            },
            level,
            element_size_mm: opt.element_size_mm,
            unknowns: r.unknowns,
            sensitivity_pm_per_n: design.fiber.shift_pm(lambda, e, 0.0),
            time_s: best,
        });
    }
    Ok(out)
}

/// Observed order of convergence from the last three levels (element size halving),
/// and the Richardson-extrapolated K. None when the differences do not shrink.
pub fn observed_order(k: &[f64]) -> Option<(f64, f64)> {
    if k.len() < 3 {
        return None;
    }
    let n = k.len();
    let (d1, d2) = (k[n - 2] - k[n - 3], k[n - 1] - k[n - 2]);
    if d2 == 0.0 {
        return Some((f64::INFINITY, k[n - 1]));
    }
    let ratio = d1 / d2;
    if ratio <= 1.0 {
        return None;
    }
    let p = ratio.log2();
    Some((p, k[n - 1] + d2 / (ratio - 1.0)))
}

/// Arguments of the `fem` study.
#[derive(Debug, Clone, clap::Args)]
pub struct FemStudyArgs {
    /// Output folder for the CSV, Markdown and SVG files.
    #[arg(long, default_value = "out/fem")]
    pub out: std::path::PathBuf,
    /// Smoke run: one refinement level fewer and a 3 × 3 comparison grid (about 30 s
    /// instead of 2 min in a release build; quote the full run).
    #[arg(long)]
    pub quick: bool,
}

/// Run the study with its arguments.
pub fn run(a: &FemStudyArgs) -> Result<()> {
    run_bench_with(&a.out, a.quick)
}

/// The paper module's configurations the bench converges, each with its finest level
/// and dome contact (`quick`: at most level 2; three levels are the fewest that give an
/// observed order).
fn bench_configurations(quick: bool) -> [(Configuration, u32, DomeContact); 3] {
    let config = |core: &str, case, insert: Option<&str>| Configuration {
        core: core.into(),
        case,
        insert: insert.map(String::from),
    };
    let configs = [
        (
            config("psc2", LoadCase::II, None),
            3u32,
            DomeContact::ApexPatch,
        ),
        (
            config("psc1", LoadCase::I, Some("blue")),
            2u32,
            DomeContact::ApexPatch,
        ),
        (
            config("psc1", LoadCase::I, Some("blue")),
            2u32,
            DomeContact::Gap,
        ),
    ];
    configs.map(|(c, max_level, dome)| {
        let max_level = if quick { max_level.min(2) } else { max_level };
        (c, max_level, dome)
    })
}

/// What the bench gathers: the convergence rows, the speed rows and the chart.
struct Bench<'a> {
    design: &'a Design,
    cache: &'a GeometryCache,
    rows: Vec<Vec<String>>,
    speed_rows: Vec<Vec<String>>,
    chart: Chart,
}

impl Bench<'_> {
    /// Converge one configuration level by level (envelope solver): its rows, its
    /// observed order and K_ref printed, its series on the chart; returns K_ref.
    fn converge(
        &mut self,
        (config, max_level, dome): &(Configuration, u32, DomeContact),
        name: &str,
        pb: &crate::progress::Bar,
    ) -> Result<f64> {
        let mut levels = Vec::new();
        for level in 0..=*max_level {
            let repeats = if level <= 1 { 3 } else { 1 };
            let mut r = convergence(
                self.design,
                config,
                level..=level,
                repeats,
                SolverKind::Envelope,
                *dome,
                self.cache,
            )?;
            levels.push(r.pop().expect("one level"));
            pb.advance(1);
        }
        let ks: Vec<f64> = levels.iter().map(|l| l.sensitivity_pm_per_n).collect();
        let (order, k_ref) = match observed_order(&ks) {
            Some((p, k)) => (Some(p), k),
            None => (None, *ks.last().expect("levels")),
        };
        let mut pts = Vec::new();
        for l in &levels {
            let err = report_level(l, k_ref, "", &mut self.speed_rows, &mut pts);
            self.rows.push(vec![
                l.configuration.clone(),
                l.level.to_string(),
                format!("{}", l.element_size_mm),
                l.unknowns.to_string(),
                format!("{:.6}", l.sensitivity_pm_per_n),
                format!("{:.6}", k_ref),
                format!("{:.6}", err),
                order
                    .map(|p| format!("{p:.3}"))
                    .unwrap_or_else(|| "n/a".into()),
                format!("{:.6}", l.time_s),
            ]);
        }
        match order {
            Some(p) => {
                println!("{name}: observed order of convergence {p:.2}, K_ref = {k_ref:.4} pm/N")
            }
            None => {
                println!("{name}: differences do not shrink monotonically; K_ref = finest level")
            }
        }
        self.add_series(Series::new(format!("FE, {name}"), pts, Mark::LinePoints));
        Ok(k_ref)
    }

    fn add_series(&mut self, s: Series) {
        self.chart.series.push(s);
    }

    /// The default options: level 1 extrapolated with level 0 (Richardson, p = 1).
    fn default_options(
        &mut self,
        (config, dome): (&Configuration, DomeContact),
        name: &str,
        k_ref: f64,
    ) -> Result<()> {
        let opt = FemOptions {
            dome_contact: dome,
            ..FemOptions::default()
        };
        let mut best = f64::INFINITY;
        let mut k = f64::NAN;
        for _ in 0..3 {
            let t = Instant::now();
            let r = solve_configuration(self.design, config, &opt, self.cache)?;
            best = best.min(t.elapsed().as_secs_f64());
            let (_, lambda, e) = r.strain_per_n[0].clone();
            k = self.design.fiber.shift_pm(lambda, e, 0.0);
        }
        let err = ((k - k_ref) / k_ref).abs() * 100.0;
        println!(
            "{:<22} default (level 1 + Richardson p = 1 from level 0): K = {k:.4} pm/N, error {err:.4} %, {best:.4} s",
            name
        );
        self.speed_rows.push(vec![
            "FE default (levels 0+1, Richardson p = 1)".into(),
            name.to_string(),
            format!("{best:.6e}"),
            format!("{err:.6}"),
        ]);
        if err > 0.0 {
            self.add_series(Series::new(
                format!("FE default (Richardson), {name}"),
                vec![(best, err)],
                Mark::Points,
            ));
        }
        Ok(())
    }

    /// The same levels with faer's Cholesky (the default solver): same K, other time.
    fn faer(
        &mut self,
        (config, max_level, dome): &(Configuration, u32, DomeContact),
        name: &str,
        k_ref: f64,
    ) -> Result<()> {
        let faer_levels = (*max_level).min(2);
        let faer = convergence(
            self.design,
            config,
            0..=faer_levels,
            1,
            SolverKind::Faer,
            *dome,
            self.cache,
        )?;
        let mut fpts = Vec::new();
        for l in &faer {
            report_level(l, k_ref, "faer", &mut self.speed_rows, &mut fpts);
        }
        self.add_series(Series::new(
            format!("FE faer, {name}"),
            fpts,
            Mark::LinePoints,
        ));
        Ok(())
    }

    /// The closed form on the same configuration, if the model is available.
    fn closed_form(&mut self, config: &Configuration, name: &str, k_ref: f64) {
        match closed_form_time_and_k(self.design, config) {
            Ok((t, k)) => {
                let err = ((k - k_ref) / k_ref).abs() * 100.0;
                println!("{:<22} closed form: K = {k:.4} pm/N, error {err:.2} %, {t:.3e} s per prediction", config.label());
                self.speed_rows.push(vec![
                    "closed form".into(),
                    config.label(),
                    format!("{t:.6e}"),
                    format!("{err:.6}"),
                ]);
                self.add_series(Series::new(
                    format!("closed form, {name}"),
                    vec![(t, err.max(1e-6))],
                    Mark::Points,
                ));
            }
            Err(e) => println!("{:<22} closed form: not available ({e})", config.label()),
        }
    }

    /// The convergence and speed tables as CSV and the chart as SVG.
    fn write(&self, out_dir: &Path) -> Result<()> {
        write_csv(
            &out_dir.join("fem_convergence.csv"),
            &[
                "configuration",
                "level",
                "element_size_mm",
                "unknowns",
                "sensitivity_pm_per_n",
                "converged_sensitivity_pm_per_n",
                "relative_error_percent",
                "observed_order",
                "time_s",
            ],
            &self.rows,
        )?;
        write_csv(
            &out_dir.join("fem_speed_accuracy.csv"),
            &[
                "method",
                "configuration",
                "time_per_prediction_s",
                "relative_error_percent",
            ],
            &self.speed_rows,
        )?;
        self.chart
            .write_svg(&out_dir.join("fem_speed_accuracy.svg"))?;
        println!(
            "wrote {}, {}, {}",
            out_dir.join("fem_convergence.csv").display(),
            out_dir.join("fem_speed_accuracy.csv").display(),
            out_dir.join("fem_speed_accuracy.svg").display()
        );
        Ok(())
    }
}

/// Run the FE benchmark; `quick` stops every convergence study one level earlier
/// and compares on a 3 × 3 corner-and-centre subset of the grid (a smoke run of a
/// few seconds; its K_ref is less accurate, so the full run is the one to quote).
pub fn run_bench_with(out_dir: &Path, quick: bool) -> Result<()> {
    fbgforge::output::ensure_dir(out_dir)?;
    let design = paper_design()?;
    // The study's own FE cache: repeats after the first time warm solves, as a
    // sweep's later steps are.
    let cache = GeometryCache::default();
    let configs = bench_configurations(quick);
    let pb = crate::progress::Bar::with("fem levels", configs.iter().map(|c| c.1 as u64 + 1).sum());
    let mut chart = Chart::new(
        "Clip-on module (34 mm): time per prediction against error of K",
        "time per prediction, s",
        "|K − K_converged| / |K_converged|, %",
    );
    chart.x_log = true;
    chart.y_log = true;
    let mut bench = Bench {
        design: &design,
        cache: &cache,
        rows: Vec::new(),
        speed_rows: Vec::new(),
        chart,
    };
    println!("Finite-element convergence of K (paper module; K_ref = Richardson extrapolation)");
    println!(
        "{:<22} {:>5} {:>8} {:>9} {:>14} {:>10} {:>10}",
        "configuration", "level", "h, mm", "unknowns", "K, pm/N", "error, %", "time, s"
    );
    for c in &configs {
        let (config, _, dome) = c;
        let name = match dome {
            DomeContact::Gap => format!("{} (dome gap)", config.label()),
            _ => config.label(),
        };
        let k_ref = bench.converge(c, &name, &pb)?;
        bench.default_options((config, *dome), &name, k_ref)?;
        bench.faer(c, &name, k_ref)?;
        if *dome != DomeContact::Gap {
            bench.closed_form(config, &name, k_ref);
        }
    }
    pb.end();
    bench.write(out_dir)?;
    if quick {
        super::fem_compare::run_comparison_on(out_dir, &[10.0, 22.0, 40.0], &[0.8, 1.5, 3.0])?;
    } else {
        super::fem_compare::run_comparison(out_dir)?;
    }
    Ok(())
}

/// Time per closed-form prediction (one configuration) and its K for `config`.
/// Print one mesh level's row, add it to the speed/accuracy table and chart, and
/// return its error against `k_ref`, %. `solver` names a non-default solver.
fn report_level(
    l: &LevelResult,
    k_ref: f64,
    solver: &str,
    speed_rows: &mut Vec<Vec<String>>,
    points: &mut Vec<(f64, f64)>,
) -> f64 {
    let err = ((l.sensitivity_pm_per_n - k_ref) / k_ref).abs() * 100.0;
    let (note, label) = if solver.is_empty() {
        (String::new(), format!("FE level {}", l.level))
    } else {
        (
            format!("  ({solver} Cholesky)"),
            format!("FE level {} ({solver})", l.level),
        )
    };
    println!(
        "{:<22} {:>5} {:>8.3} {:>9} {:>14.4} {:>10.4} {:>10.4}{note}",
        l.configuration,
        l.level,
        l.element_size_mm,
        l.unknowns,
        l.sensitivity_pm_per_n,
        err,
        l.time_s
    );
    speed_rows.push(vec![
        label,
        l.configuration.clone(),
        format!("{:.6e}", l.time_s),
        format!("{:.6}", err),
    ]);
    // The reference level itself (error 0) cannot sit on a log axis.
    if err > 0.0 {
        points.push((l.time_s, err));
    }
    err
}

fn closed_form_time_and_k(design: &Design, config: &Configuration) -> Result<(f64, f64)> {
    let first = fbgforge::model::predict(design, 1.0)?;
    let k = super::fem_compare::closed_form_k(&first, config)?;
    let n = 2000;
    let t = Instant::now();
    for _ in 0..n {
        std::hint::black_box(fbgforge::model::predict(std::hint::black_box(design), 1.0)?);
    }
    let per_call = t.elapsed().as_secs_f64() / n as f64;
    Ok((
        per_call / first.len().max(1) as f64 * config_grating_count(&first, config) as f64,
        k,
    ))
}

fn config_grating_count(
    preds: &[fbgforge::model::GratingPrediction],
    config: &Configuration,
) -> usize {
    preds
        .iter()
        .filter(|p| p.core == config.core && p.case == config.case && p.insert == config.insert)
        .count()
        .max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn observed_order_of_a_known_sequence() {
        // K_h = 10 + 3 h^2 at h = 1, 1/2, 1/4.
        let k = [13.0, 10.75, 10.1875];
        let (p, k_ref) = observed_order(&k).unwrap();
        assert!((p - 2.0).abs() < 1e-12 && (k_ref - 10.0).abs() < 1e-12);
        assert!(observed_order(&[1.0, 2.0, 4.0]).is_none());
    }
}
