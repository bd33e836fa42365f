//! `fbgforge bench …`: benchmarks that print a table and write charts; speed goals
//! live here, not in timed unit tests.

use clap::{Args, Subcommand};

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
    /// Optimiser convergence time.
    Optimize(super::optimize::BenchOptimizeArgs),
}

/// Run a benchmark.
pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    match a.target {
        BenchTarget::Optimize(b) => super::optimize::bench(b),
    }
}
