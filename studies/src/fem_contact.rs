//! Study `contact` (`cargo run --release -p fbgforge-studies -- contact [--quick]`):
//! the contact readings of the clip-on module and the unilateral contact solver.
//!
//! 1. Hertz (rigid sphere on an elastic half-space): force and contact radius against
//!    the exact answer as the mesh is refined (`contact_hertz.csv`).
//! 2. The module with unilateral contact across the printed clearances (34 mm design,
//!    PSC 1, Case I): Δλ(F) and K(F) over a force range at each mesh level and with the
//!    default options, the knee where the dome clearance closes (`contact_curve.csv`,
//!    `contact_curve.svg`, `contact_knee.csv`).
//! 3. Timing of that non-linear solve with the default options (the benchmark: under
//!    2 s on 2 cores in a release build).
//! 4. Convergence of the nominal reading (domes in contact within the design's radius)
//!    and of the bounding readings (`contact_readings.csv`).
//! 5. The contact radii consistent with the paper's Case I statements: K_I of each
//!    insert against K_II, for radii around the default (`contact_window.csv`).

use super::fem_compare::paper_design;
use anyhow::{Context, Result};
use fbgforge::fem::contact::{self, ContactPair};
use fbgforge::fem::element::{ElasticConstants, Formulation};
use fbgforge::fem::mesh::Mesh;
use fbgforge::fem::solve::{EnvelopeCholesky, Problem, R, Z};
use fbgforge::fem::{
    solve_configuration, solve_response, Configuration, ContactReading, FemOptions, GeometryCache,
};
use fbgforge::model::LoadCase;
use fbgforge::output::{ensure_dir, write_csv};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::spec::Design;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of the `contact` study.
#[derive(Debug, clap::Args)]
pub struct ContactStudyArgs {
    /// Output folder.
    #[arg(long, default_value = "out/contact")]
    pub out: PathBuf,
    /// Smoke run: coarser meshes, fewer radii (seconds; quote the full run).
    #[arg(long)]
    pub quick: bool,
}

/// Run the study.
pub fn run(a: &ContactStudyArgs) -> Result<()> {
    ensure_dir(&a.out)?;
    let design = paper_design()?;
    // The study's own FE cache, for every solve below.
    let cache = GeometryCache::default();
    hertz(&a.out, a.quick)?;
    curves(&design, &a.out, a.quick, &cache)?;
    timing(&design, a.quick, &cache)?;
    readings(&design, &a.out, a.quick, &cache)?;
    window(&design, &a.out, a.quick, &cache)?;
    Ok(())
}

fn doubled(c: &[f64]) -> Vec<f64> {
    let mut out = Vec::new();
    for w in c.windows(2) {
        out.push(w[0]);
        out.push(0.5 * (w[0] + w[1]));
    }
    out.push(*c.last().expect("coordinates"));
    out
}

fn graded(h: f64, fine_to: f64, end: f64, growth: f64) -> Vec<f64> {
    let n = (fine_to / h).round().max(1.0) as usize;
    let mut c: Vec<f64> = (0..=n).map(|k| fine_to * k as f64 / n as f64).collect();
    let mut step = fine_to / n as f64;
    while *c.last().expect("coordinates") < end {
        step *= growth;
        let next = (c.last().expect("coordinates") + step).min(end);
        c.push(next);
    }
    c
}

/// One Hertz solve: (force N, outermost touching radius mm, unknowns, time s).
fn hertz_solve(e: f64, nu: f64, rs: f64, d: f64, h: f64) -> Result<(f64, f64, usize, f64)> {
    let t = Instant::now();
    let a = (rs * d).sqrt();
    let size = 200.0 * a;
    let mut mesh = Mesh::default();
    let r = doubled(&graded(h, 2.0 * a, size, 1.25));
    let z: Vec<f64> = doubled(&graded(h, 2.0 * a, size, 1.25))
        .iter()
        .rev()
        .map(|t| size - t)
        .collect();
    let ids: Vec<Vec<usize>> = r
        .iter()
        .map(|&x| z.iter().map(|&y| mesh.add_node(x, y)).collect())
        .collect();
    mesh.add_block(&ids, 0);
    let mut fixed: Vec<(usize, usize)> = ids.iter().map(|c| (c[0], Z)).collect();
    fixed.extend(ids[0].iter().map(|&n| (n, R)));
    let surface: Vec<usize> = ids.iter().map(|c| *c.last().expect("column")).collect();
    let problem = Problem {
        mesh,
        materials: vec![ElasticConstants {
            youngs_modulus_mpa: e,
            poisson_ratio: nu,
        }],
        formulation: Formulation::MixedQ9P1,
        fixed,
        ties: vec![],
        interpolations: vec![],
        loads: vec![],
    };
    let pairs: Vec<ContactPair> = surface
        .iter()
        .filter(|&&n| problem.mesh.nodes[n][0] <= 3.0 * a)
        .map(|&n| {
            let x = problem.mesh.nodes[n][0];
            ContactPair {
                a: n,
                b: None,
                normal: [0.0, 1.0],
                gap_mm: rs - (rs * rs - x * x).sqrt(),
            }
        })
        .collect();
    let factored = problem.factor_with(&EnvelopeCholesky)?;
    let reduced = contact::reduce(&factored, &[], &pairs, |_| Ok(vec![]))?;
    let s = reduced.solve(0.0, d)?;
    let force: f64 = s.normal_force_n.iter().sum();
    let edge = pairs
        .iter()
        .zip(&s.normal_force_n)
        .filter(|(_, l)| **l > 0.0)
        .map(|(p, _)| problem.mesh.nodes[p.a][0])
        .fold(0.0, f64::max);
    Ok((force, edge, factored.unknowns(), t.elapsed().as_secs_f64()))
}

fn hertz(out: &Path, quick: bool) -> Result<()> {
    let (e, nu, rs, d): (f64, f64, f64, f64) = (10.0, 0.3, 20.0, 0.01);
    let a = (rs * d).sqrt();
    let exact = 4.0 / 3.0 * e / (1.0 - nu * nu) * rs.sqrt() * f64::powf(d, 1.5);
    println!("Hertz, rigid sphere R = {rs} mm into E = {e} MPa, ν = {nu}, d = {d} mm: a = {a:.4} mm, F = {exact:.6} N");
    println!(
        "{:>8} {:>9} {:>12} {:>9} {:>12} {:>9}",
        "a/h", "unknowns", "F N", "error %", "edge/a", "time s"
    );
    let mut rows = Vec::new();
    let ratios: &[f64] = if quick {
        &[4.0, 8.0]
    } else {
        &[4.0, 8.0, 16.0, 32.0]
    };
    for &k in ratios {
        let (f, edge, n, t) = hertz_solve(e, nu, rs, d, a / k)?;
        let err = 100.0 * (f / exact - 1.0);
        println!(
            "{k:>8} {n:>9} {f:>12.6} {err:>+9.3} {:>12.4} {t:>9.3}",
            edge / a
        );
        rows.push(vec![
            k.to_string(),
            n.to_string(),
            f.to_string(),
            err.to_string(),
            (edge / a).to_string(),
            t.to_string(),
        ]);
    }
    write_csv(
        &out.join("contact_hertz.csv"),
        &[
            "a_over_h",
            "unknowns",
            "force_n",
            "error_percent",
            "edge_over_a",
            "time_s",
        ],
        &rows,
    )
}

fn config(insert: &str) -> Configuration {
    Configuration {
        core: "psc1".into(),
        case: LoadCase::I,
        insert: Some(insert.into()),
    }
}

/// Forces of the K(F) curves, N: log-spaced from 0.05 to 50 N.
fn forces(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 0.05 * f64::powf(1000.0, i as f64 / (n - 1) as f64))
        .collect()
}

fn curves(design: &Design, out: &Path, quick: bool, cache: &GeometryCache) -> Result<()> {
    let m = design.module.as_ref().context("module")?;
    let fs = forces(if quick { 12 } else { 31 });
    let levels: Vec<Option<u32>> = if quick {
        vec![Some(0), None]
    } else {
        vec![Some(0), Some(1), Some(2), None]
    };
    let mut rows = Vec::new();
    let mut knees = Vec::new();
    let mut chart = Chart::new(
        "Unilateral contact, 34 mm module, PSC 1, Case I: Δλ(F) of λ11",
        "apex force F (N)",
        "Δλ (pm)",
    );
    let mut tangent_chart = Chart::new(
        "Unilateral contact: tangent sensitivity dΔλ/dF of λ11",
        "apex force F (N)",
        "K = dΔλ/dF (pm/N)",
    );
    tangent_chart.x_log = true;
    println!("\nUnilateral contact (printed dome clearance {} mm, cylinders sliding above the clip), PSC 1 Case I, λ11:", m.dome_clearance_mm());
    println!(
        "{:<12} {:<9} {:>9} {:>10} {:>10} {:>10} {:>10} {:>10} {:>8}",
        "insert", "mesh", "knee N", "K open", "Kt 2 N", "Kt 10 N", "Ks 10 N", "Kt 50 N", "touch"
    );
    for insert in ["blue", "light_green"] {
        for level in &levels {
            let base = match level {
                Some(l) => FemOptions::level(*l),
                None => FemOptions::default(),
            };
            let opt = base.with_reading(m, ContactReading::Unilateral, LoadCase::I);
            let r = solve_response(design, &config(insert), &opt, &fs, cache)?;
            let shift = r.shift_pm(&design.fiber, 0);
            let mesh = level.map_or("default".to_string(), |l| format!("level {l}"));
            let tangent: Vec<(f64, f64)> = fs
                .windows(2)
                .zip(shift.windows(2))
                .map(|(f, s)| (0.5 * (f[0] + f[1]), (s[1] - s[0]) / (f[1] - f[0])))
                .collect();
            let at = |f0: f64| -> f64 {
                tangent
                    .iter()
                    .min_by(|a, b| (a.0 - f0).abs().total_cmp(&(b.0 - f0).abs()))
                    .map_or(f64::NAN, |t| t.1)
            };
            let secant = |f0: f64| -> f64 {
                let i = fs
                    .iter()
                    .enumerate()
                    .min_by(|a, b| (a.1 - f0).abs().total_cmp(&(b.1 - f0).abs()))
                    .map_or(0, |(i, _)| i);
                shift[i] / fs[i]
            };
            let knee = r.knee_force_n.unwrap_or(f64::NAN);
            println!(
                "{insert:<12} {mesh:<9} {knee:>9.3} {:>+10.1} {:>+10.2} {:>+10.2} {:>+10.2} {:>+10.2} {:>8}",
                shift[0] / fs[0],
                at(2.0),
                at(10.0),
                secant(10.0),
                at(50.0),
                r.active_pairs.last().copied().unwrap_or(0)
            );
            knees.push(vec![
                insert.to_string(),
                mesh.clone(),
                knee.to_string(),
                (shift[0] / fs[0]).to_string(),
                at(2.0).to_string(),
                at(10.0).to_string(),
                secant(10.0).to_string(),
                at(50.0).to_string(),
            ]);
            for (i, f) in fs.iter().enumerate() {
                rows.push(vec![
                    insert.to_string(),
                    mesh.clone(),
                    f.to_string(),
                    shift[i].to_string(),
                    r.active_pairs[i].to_string(),
                    r.active_cylinder_pairs[i].to_string(),
                ]);
            }
            if level.is_none() {
                chart = chart.with(Series::new(
                    insert.to_string(),
                    fs.iter().copied().zip(shift.iter().copied()).collect(),
                    Mark::LinePoints,
                ));
                tangent_chart =
                    tangent_chart.with(Series::new(insert.to_string(), tangent, Mark::LinePoints));
            }
        }
    }
    write_csv(
        &out.join("contact_curve.csv"),
        &[
            "insert",
            "mesh",
            "force_n",
            "shift_pm",
            "touching_pairs",
            "touching_pairs_on_cylinders",
        ],
        &rows,
    )?;
    write_csv(
        &out.join("contact_knee.csv"),
        &[
            "insert",
            "mesh",
            "knee_force_n",
            "k_open_pm_per_n",
            "k_tangent_2n",
            "k_tangent_10n",
            "k_secant_10n",
            "k_tangent_50n",
        ],
        &knees,
    )?;
    chart.write_svg(&out.join("contact_curve.svg"))?;
    tangent_chart.write_svg(&out.join("contact_tangent.svg"))
}

fn timing(design: &Design, quick: bool, cache: &GeometryCache) -> Result<()> {
    let m = design.module.as_ref().context("module")?;
    let opt = FemOptions::default().with_reading(m, ContactReading::Unilateral, LoadCase::I);
    let fs = forces(31);
    let repeats = if quick { 1 } else { 5 };
    let mut times = Vec::new();
    for _ in 0..repeats {
        let t = Instant::now();
        let r = solve_response(design, &config("blue"), &opt, &fs, cache)?;
        times.push(t.elapsed().as_secs_f64());
        std::hint::black_box(r);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "\nnon-linear Case I solve (34 mm, blue, default mesh: level 1 + level 0, 31 forces, {} threads available): best {:.3} s, median {:.3} s over {repeats} runs",
        rayon::current_num_threads(),
        times[0],
        times[times.len() / 2]
    );
    Ok(())
}

fn k_of(design: &Design, insert: &str, opt: &FemOptions, cache: &GeometryCache) -> Result<f64> {
    let r = solve_configuration(design, &config(insert), opt, cache)?;
    let (_, lambda, e) = r.strain_per_n.first().cloned().context("grating")?;
    Ok(design.fiber.shift_pm(lambda, e, 0.0))
}

fn readings(design: &Design, out: &Path, quick: bool, cache: &GeometryCache) -> Result<()> {
    let m = design.module.as_ref().context("module")?;
    let max = if quick { 1 } else { 2 };
    println!("\nConvergence of the contact readings, PSC 1 Case I, λ11, K in pm/N:");
    let mut rows = Vec::new();
    for reading in [
        ContactReading::Design,
        ContactReading::BondedPillars,
        ContactReading::SlidingApexPatch,
    ] {
        for insert in ["blue", "light_green"] {
            let mut line = format!("{reading:?} {insert}:");
            let mut ks = Vec::new();
            for level in 0..=max {
                let t = Instant::now();
                let opt = FemOptions::level(level).with_reading(m, reading, LoadCase::I);
                let k = k_of(design, insert, &opt, cache)?;
                line += &format!(" L{level} {k:+.3} ({:.2} s)", t.elapsed().as_secs_f64());
                ks.push(k);
                rows.push(vec![
                    format!("{reading:?}"),
                    insert.to_string(),
                    level.to_string(),
                    k.to_string(),
                ]);
            }
            let opt = FemOptions::default().with_reading(m, reading, LoadCase::I);
            let k = k_of(design, insert, &opt, cache)?;
            rows.push(vec![
                format!("{reading:?}"),
                insert.to_string(),
                "default".into(),
                k.to_string(),
            ]);
            line += &format!(" default {k:+.3}");
            if ks.len() >= 3 {
                let (a, b, c) = (ks[ks.len() - 3], ks[ks.len() - 2], ks[ks.len() - 1]);
                let p = ((a - b) / (b - c)).abs().log2();
                let extrapolated = c + (c - b) / (2f64.powf(p) - 1.0);
                line += &format!(
                    "; order {p:.2}, extrapolated {extrapolated:+.3}, default off by {:+.2} %",
                    100.0 * (k / extrapolated - 1.0)
                );
            }
            println!("{line}");
        }
    }
    write_csv(
        &out.join("contact_readings.csv"),
        &["reading", "insert", "level", "k_pm_per_n"],
        &rows,
    )
}

fn window(design: &Design, out: &Path, quick: bool, cache: &GeometryCache) -> Result<()> {
    let m = design.module.as_ref().context("module")?;
    let k_ii = fbgforge::model::sensitivity_pm_per_n(design, LoadCase::II, None, "lambda_21")?;
    let paper_model =
        fbgforge::model::sensitivity_pm_per_n(design, LoadCase::I, Some("blue"), "lambda_11")?;
    let radii: Vec<f64> = if quick {
        vec![1.6, 1.72, 1.9]
    } else {
        (0..=20).map(|i| 1.5 + 0.025 * i as f64).collect()
    };
    println!(
        "\nContact radius against the paper's Case I statements (K_II = {k_ii:.2} pm/N, λ21, closed form; the paper's model for blue {paper_model:.2} pm/N; λ11, default mesh):"
    );
    println!(
        "{:>8} {:>7} {:>9} {:>9} {:>9} {:>7} {:>7} {:>7} {:>7} {:>8}",
        "r mm",
        "r/patch",
        "K blue",
        "K green",
        "K lt grn",
        "II/b",
        "II/g",
        "II/lg",
        "rising",
        "blue 8 %"
    );
    let mut rows = Vec::new();
    for &a in &radii {
        let d = fbgforge::prediction::with_contact_radius(design, a);
        let dm = d.module.as_ref().context("module")?;
        let opt = FemOptions::default().with_reading(dm, ContactReading::Design, LoadCase::I);
        let ks: Vec<f64> = ["blue", "green", "light_green"]
            .iter()
            .map(|i| k_of(&d, i, &opt, cache))
            .collect::<Result<_>>()?;
        let ratios: Vec<f64> = ks.iter().map(|k| k_ii.abs() / k).collect();
        let rising = ks[0] < ks[1] && ks[1] < ks[2];
        let within = (ks[0] / paper_model - 1.0).abs() <= 0.08;
        let all_ok = ratios.iter().all(|r| *r > 1.0 && *r <= 2.0) && rising;
        println!(
            "{a:>8.3} {:>7.3} {:>+9.2} {:>+9.2} {:>+9.2} {:>7.3} {:>7.3} {:>7.3} {:>7} {:>8}{}",
            a / m.apex_patch_radius_mm(),
            ks[0],
            ks[1],
            ks[2],
            ratios[0],
            ratios[1],
            ratios[2],
            rising,
            within,
            if all_ok { "  ✓" } else { "" }
        );
        rows.push(vec![
            a.to_string(),
            ks[0].to_string(),
            ks[1].to_string(),
            ks[2].to_string(),
            ratios[0].to_string(),
            ratios[1].to_string(),
            ratios[2].to_string(),
            rising.to_string(),
            within.to_string(),
        ]);
    }
    write_csv(
        &out.join("contact_window.csv"),
        &[
            "dome_contact_radius_mm",
            "k_blue_pm_per_n",
            "k_green_pm_per_n",
            "k_light_green_pm_per_n",
            "k_ii_over_blue",
            "k_ii_over_green",
            "k_ii_over_light_green",
            "rising_as_insert_softens",
            "blue_within_8_percent_of_paper_model",
        ],
        &rows,
    )
}
