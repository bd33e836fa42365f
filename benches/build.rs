//! Criterion timing of a design build: every part of the 34 mm module (B-rep, mesh,
//! checks) at the printer's default tolerance. Run with `cargo bench --bench build`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;

fn shipped(name: &str) -> fbgforge::spec::Design {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("designs")
        .join(name);
    fbgforge::design::load(&p).expect("shipped design loads")
}

fn build_module(c: &mut Criterion) {
    let design = shipped("clip-on-34mm.toml");
    let array = shipped("tactile-array-60x80.toml");
    let mut g = c.benchmark_group("build");
    g.sample_size(20);
    g.bench_function("clip-on-34mm all parts", |b| {
        b.iter(|| fbgforge::geometry::build_parts(&design, None, None).unwrap())
    });
    g.bench_function("tactile-array-60x80 mold", |b| {
        b.iter(|| fbgforge::geometry::build_parts(&array, None, None).unwrap())
    });
    g.finish();
}

criterion_group!(benches, build_module);
criterion_main!(benches);
