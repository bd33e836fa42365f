//! `fbgforge bench …`: benchmarks that print a table and write charts; speed goals
//! live here, not in timed unit tests.

use clap::{Args, Subcommand};
use std::path::PathBuf;

/// Arguments of `fbgforge bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Which benchmark.
    #[command(subcommand)]
    pub target: BenchTarget,
}

/// Benchmarks.
#[derive(Debug, Subcommand)]
pub enum BenchTarget {
    /// Closed-form prediction time per design.
    Predict(super::predict::BenchPredictArgs),
    /// Reconstruction protocol: every method, speed against accuracy.
    Reconstruct(super::reconstruct::BenchReconstructArgs),
    /// Log parsing throughput and end-to-end verification time.
    Verify(super::verify::BenchVerifyArgs),
    /// Optimiser convergence time.
    Optimize(super::optimize::BenchOptimizeArgs),
    /// Finite-element convergence, time against error, and closed form against FE.
    Fem(BenchFemArgs),
}

/// Arguments of `fbgforge bench fem`.
#[derive(Debug, Args)]
pub struct BenchFemArgs {
    /// Output folder for the CSV, Markdown and SVG files.
    #[arg(long, default_value = "out/fem")]
    pub out: PathBuf,
    /// Smoke run: one refinement level fewer and a 3 × 3 comparison grid (about 30 s
    /// instead of 2 min in a release build; quote the full run).
    #[arg(long)]
    pub quick: bool,
}

/// Run a benchmark.
pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    match a.target {
        BenchTarget::Predict(b) => super::predict::bench(b),
        BenchTarget::Reconstruct(b) => super::reconstruct::bench(b),
        BenchTarget::Verify(b) => super::verify::bench(b),
        BenchTarget::Optimize(b) => super::optimize::bench(b),
        BenchTarget::Fem(b) => fbgforge::fem::bench::run_bench_with(&b.out, b.quick),
    }
}
