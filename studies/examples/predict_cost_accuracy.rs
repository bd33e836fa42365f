//! Issue 38: what each FE answer `predict` could give costs, against how accurate it
//! is — the chart behind "the cheapest model meeting the stated accuracy is the
//! default". For each shipped design given, every variant's Case I rows (the rows the
//! policy sends to the FE) are timed on one thread from a cold geometry cache (what a
//! fresh process pays) and compared with the finest policy reading (level 3,
//! Richardson-extrapolated from level 2): the error it *has* against that reference,
//! and the error it *states* (`model_error_fraction`, whose cap is 15 %).
//!
//! The goal is stated on whole processes (docs/fem.md §5.3: `perf stat -e task-clock`
//! of `fbgforge predict D --no-spectrum` against the fast path `… --fidelity
//! closed-form --no-band --no-spectrum`, about 2 ms, mostly process start). A
//! variant's process cost is its in-process time plus that fast path's, so its ratio
//! is (t + B) / B with B the fast path's measured process CPU, given in ms.
//!
//! `cargo run --release -p fbgforge-studies --example predict_cost_accuracy -- 2.0 designs/clip-on-34mm.toml designs/clip-on-10mm.toml`

use fbgforge::fem::cache::GeometryCache;
use fbgforge::fem::FemOptions;
use fbgforge::model::LoadCase;
use fbgforge::prediction::{
    predict, Fidelity, FidelityChoice, ModelledPrediction, PredictionRequest,
};
use std::time::Instant;

/// One way `predict` could answer.
struct Variant {
    name: &'static str,
    fidelity: FidelityChoice,
    fem: FemOptions,
    refine: Option<u32>,
    band: bool,
}

fn variants() -> Vec<Variant> {
    let alone = |k| FemOptions {
        richardson_order: None,
        ..FemOptions::mesh_level(k)
    };
    let v = |name, fem, refine, band| Variant {
        name,
        fidelity: FidelityChoice::Auto,
        fem,
        refine,
        band,
    };
    vec![
        Variant {
            name: "closed form (the fast path)",
            fidelity: FidelityChoice::ClosedForm,
            fem: FemOptions::default(),
            refine: None,
            band: false,
        },
        v("FE level 0 alone, nominal", alone(0), None, false),
        v("FE level 0 alone, band and interval", alone(0), None, true),
        v("FE level 1 alone, nominal", alone(1), None, false),
        v(
            "FE level 1 + level 0 (Richardson), nominal (`--no-band`)",
            FemOptions::mesh_level(1),
            None,
            false,
        ),
        v(
            "default: level 1 + 0, band and interval, refined to ≤ 3",
            FemOptions::mesh_level(1),
            Some(FemOptions::AUTO_FINEST_MESH_LEVEL),
            true,
        ),
        v(
            "level 2 + 1, band and interval (`--mesh-level 2`)",
            FemOptions::mesh_level(2),
            None,
            true,
        ),
    ]
}

fn request(v: &Variant, cache: &GeometryCache) -> PredictionRequest {
    PredictionRequest {
        fidelity: v.fidelity,
        band: v.band,
        design_interval: v.band,
        fem_options: v.fem,
        refine_to_level: v.refine,
        cache: cache.clone(),
        ..PredictionRequest::default()
    }
}

/// A Case I row: (core, insert, grating), K in pm/N, its stated error, whether FE.
type Row = ((String, Option<String>, String), f64, Option<f64>, bool);

/// Case I rows, keyed by (core, insert, grating).
fn case_i(rows: &[ModelledPrediction]) -> Vec<Row> {
    rows.iter()
        .filter(|r| r.detail.prediction.case == LoadCase::I)
        .map(|r| {
            let p = &r.detail.prediction;
            (
                (p.core.clone(), p.insert.clone(), p.grating.clone()),
                p.sensitivity_pm_per_n,
                r.model_error_fraction,
                r.model == Fidelity::Fem,
            )
        })
        .collect()
}

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let process_ms: f64 = args
        .next()
        .ok_or_else(|| {
            anyhow::anyhow!("usage: predict_cost_accuracy FAST_PATH_PROCESS_MS DESIGN...")
        })?
        .parse()?;
    let designs: Vec<String> = args.collect();
    let runs = 3;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    for path in &designs {
        let design = fbgforge::design::load(std::path::Path::new(path))?;
        let reference = pool.install(|| {
            let fine = Variant {
                name: "reference",
                fidelity: FidelityChoice::Fem,
                fem: FemOptions::mesh_level(3),
                refine: None,
                band: false,
            };
            predict(&design, &request(&fine, &GeometryCache::default()))
        })?;
        let reference = case_i(&reference);
        println!(
            "\n{path} (Case I rows: {}; reference: level 3 + 2, Richardson)\n",
            reference.len()
        );
        println!("| variant | CPU ms (1 thread, median of {runs}) | process ratio to the fast path | error against the reference: max (median) | stated error: max |");
        println!("|---|---|---|---|---|");
        for v in variants() {
            let mut t = Vec::new();
            let mut rows = Vec::new();
            for _ in 0..runs {
                let cache = GeometryCache::default();
                let start = Instant::now();
                rows = pool.install(|| predict(&design, &request(&v, &cache)))?;
                t.push(start.elapsed().as_secs_f64() * 1e3);
            }
            let ms = median(t);
            let rows = case_i(&rows);
            let mut err: Vec<f64> = rows
                .iter()
                .filter_map(|(key, k, _, _)| {
                    let (_, r, _, _) = reference.iter().find(|(rk, ..)| rk == key)?;
                    Some((k - r).abs() / r.abs())
                })
                .collect();
            let stated = rows
                .iter()
                .filter(|(.., fe)| *fe)
                .filter_map(|(_, _, e, _)| *e)
                .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.max(e))));
            let max_err = err.iter().copied().fold(0.0, f64::max);
            let med_err = median(std::mem::take(&mut err));
            println!(
                "| {} | {:.1} | {:.1}× | {:.1} % ({:.1} %) | {} |",
                v.name,
                ms,
                (ms + process_ms) / process_ms,
                100.0 * max_err,
                100.0 * med_err,
                stated.map_or("none stated".to_string(), |s| format!("{:.1} %", 100.0 * s)),
            );
        }
    }
    Ok(())
}
