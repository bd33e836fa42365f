//! Criterion time per frame of every reconstruction method on the paper's 6 × 8 array
//! (model matrix of `designs/tactile-array-60x80.toml`, two loads of 100 g, noise-free):
//! what one frame costs once the reconstructor is built; and the methods that scale on
//! a 16 × 64 grid array (issue 14's goal for `bnb`: ≤ 100 µs per frame at exact
//! accuracy) with one 4-load frame. Run with `cargo bench --bench reconstruct`.

use criterion::{criterion_group, criterion_main, Criterion};
use fbgforge::array::kernel::matrix_from_design;
use fbgforge::array::methods::{self, Method, MethodSettings};
use fbgforge::array::problem::SensingProblem;
use std::path::Path;

fn per_frame(c: &mut Criterion) {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("designs/tactile-array-60x80.toml");
    let design = fbgforge::design::load(&p).expect("shipped design loads");
    let (m, ulimit_g) = matrix_from_design(&design).unwrap();
    let a = &m.sensitivity_pm_per_g;
    let mut x = vec![0.0; m.n_cells()];
    x[1] = 100.0;
    x[6] = 100.0;
    let y: Vec<f64> = (a * nalgebra::DVector::from_vec(x))
        .iter()
        .copied()
        .collect();
    let problem = SensingProblem::new(a.clone(), ulimit_g, true).unwrap();
    let mut g = c.benchmark_group("reconstruct per frame (6 × 8)");
    for method in Method::ALL.into_iter().filter(|m| *m != Method::De) {
        let r = methods::build(&problem, &MethodSettings::for_method(method)).unwrap();
        g.bench_function(method.name(), |b| {
            b.iter(|| r.reconstruct(std::hint::black_box(&y)))
        });
    }
    g.sample_size(10);
    let r = methods::build(&problem, &MethodSettings::for_method(Method::De)).unwrap();
    g.bench_function("de", |b| b.iter(|| r.reconstruct(std::hint::black_box(&y))));
    g.finish();
}

fn per_frame_16x64(c: &mut Criterion) {
    use fbgforge::array::kernel::{fiber_grid_layout, matrix_from_positions, DistanceKernel};
    let (cells, gratings) = fiber_grid_layout(8, 8, 4, 4);
    let a = matrix_from_positions(&cells, &gratings, &DistanceKernel::table1_power_law(3.0));
    let mut x = vec![0.0; 64];
    for (j, load) in [(9, 100.0), (22, 50.0), (45, 200.0), (51, 100.0)] {
        x[j] = load;
    }
    // 2 % relative error, alternating in sign: a frame that is not noise-free.
    let y: Vec<f64> = (&a * nalgebra::DVector::from_vec(x))
        .iter()
        .enumerate()
        .map(|(i, v)| v * if i % 2 == 0 { 1.02 } else { 0.98 })
        .collect();
    let problem = SensingProblem::new(a, 250.0, true).unwrap();
    let mut g = c.benchmark_group("reconstruct per frame (16 × 64, 4 loads)");
    for method in [
        Method::BranchAndBound,
        Method::Lasso,
        Method::Omp,
        Method::Nnls,
    ] {
        let r = methods::build(&problem, &MethodSettings::for_method(method)).unwrap();
        g.bench_function(method.name(), |b| {
            b.iter(|| r.reconstruct(std::hint::black_box(&y)))
        });
    }
    g.finish();
}

criterion_group!(benches, per_frame, per_frame_16x64);
criterion_main!(benches);
