//! Criterion timing of the closed-form model: one sensitivity K from prepared
//! parameters (what the optimiser's inner loop pays), and one policy prediction of a
//! whole design (`prediction::predict`, closed form). Run with `cargo bench --bench model`.

use criterion::{criterion_group, criterion_main, Criterion};
use fbgforge::model::{closed_form, LoadCase, ModuleModelParams};
use fbgforge::prediction::{FidelityChoice, PredictionRequest};
use std::path::Path;

fn closed_form_k(c: &mut Criterion) {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("designs/clip-on-34mm.toml");
    let design = fbgforge::design::load(&p).expect("shipped design loads");
    let case_i = ModuleModelParams::from_design(&design, "psc1", Some("blue")).unwrap();
    let case_ii = ModuleModelParams::from_design(&design, "psc2", None).unwrap();
    let optics = design.fiber;
    let mut g = c.benchmark_group("model");
    g.bench_function("closed-form K, Case I", |b| {
        b.iter(|| {
            closed_form::sensitivity_pm_per_n(
                std::hint::black_box(&case_i),
                LoadCase::I,
                1546.295,
                &optics,
            )
        })
    });
    g.bench_function("closed-form K, Case II", |b| {
        b.iter(|| {
            closed_form::sensitivity_pm_per_n(
                std::hint::black_box(&case_ii),
                LoadCase::II,
                1540.06,
                &optics,
            )
        })
    });
    let req = PredictionRequest {
        fidelity: FidelityChoice::ClosedForm,
        ..PredictionRequest::default()
    };
    g.bench_function("predict clip-on-34mm (closed form)", |b| {
        b.iter(|| fbgforge::prediction::predict(std::hint::black_box(&design), &req).unwrap())
    });
    g.finish();
}

criterion_group!(benches, closed_form_k);
criterion_main!(benches);
