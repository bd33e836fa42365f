//! Criterion timing of the finite-element solve's linear algebra on the module's own
//! matrices (the paper's 34 mm design, default level 1 mesh): the interchangeable
//! sparse Cholesky solvers of `fem::linear` (faer's with AMD, with its supernodal kernel
//! and with its own kernel choice, and the hand-written envelope after RCM), each in
//! its two phases:
//! - `structure`: what a new geometry costs once (numbering, pattern, element stiffness
//!   per unit modulus, the solver's symbolic analysis);
//! - `factor+solve`: what every further problem on that geometry costs (another core,
//!   insert or modulus: assembly from the stored parts, numeric factorisation, one solve).
//!
//! The default solver (`SolverKind::Faer`: faer's supernodal kernel) is the fastest
//! here; faer's own kernel choice (`Auto`) is timed beside it (docs/fem.md §5.1–5.2).
//! Run with `cargo bench --bench fem`.

use criterion::{criterion_group, criterion_main, Criterion};
use fbgforge::fem::linear::{EnvelopeCholesky, LinearSolver, SparseLlt};
use fbgforge::fem::{self, ContactReading, FemOptions};
use fbgforge::model::LoadCase;
use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

fn solvers(c: &mut Criterion) {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("designs/clip-on-34mm.toml");
    let design = fbgforge::design::load(&p).expect("shipped design loads");
    let m = design.module.as_ref().expect("a module design");
    let linear: [&dyn LinearSolver; 3] = [
        &SparseLlt {
            kernel: fem::linear::LltKernel::Supernodal,
        },
        &SparseLlt {
            kernel: fem::linear::LltKernel::Auto,
        },
        &EnvelopeCholesky,
    ];
    for (label, case, insert, reading) in [
        (
            "Case I, design contact",
            LoadCase::I,
            Some("blue"),
            ContactReading::Design,
        ),
        (
            "Case II, bonded pillars",
            LoadCase::II,
            None,
            ContactReading::BondedPillars,
        ),
    ] {
        let opt = FemOptions::level(1).with_reading(m, reading, case);
        let core = &m.cores[0].material;
        let insert_material = insert.map(|name| {
            m.inserts
                .iter()
                .find(|i| i.name == name)
                .expect("the shipped design has this insert")
                .material
                .clone()
        });
        let model = fem::module::build(&design, core, insert_material.as_deref(), case, &opt)
            .expect("the module meshes");
        let problem = &model.problem;
        let mut g = c.benchmark_group(format!("fem {label}"));
        g.sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3));
        for solver in linear {
            g.bench_function(format!("structure, {}", solver.name()), |b| {
                b.iter(|| problem.structure(black_box(solver)).unwrap())
            });
            let structure = Arc::new(problem.structure(solver).unwrap());
            g.bench_function(format!("factor+solve, {}", solver.name()), |b| {
                b.iter(|| {
                    structure
                        .factor(black_box(&problem.materials))
                        .unwrap()
                        .solve_loads(&problem.loads)
                        .unwrap()
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, solvers);
criterion_main!(benches);
