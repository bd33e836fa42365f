//! `fbgforge optimize` and `fbgforge place`: design optimisation.

use clap::Args;

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct OptimizeArgs {}

/// Placeholder: this subcommand is being built.
pub fn run_optimize(_a: OptimizeArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run_optimize` is not available in this build yet")
}

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct PlaceArgs {}

/// Placeholder: this subcommand is being built.
pub fn run_place(_a: PlaceArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run_place` is not available in this build yet")
}

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct BenchOptimizeArgs {}

/// Placeholder: this subcommand is being built.
pub fn bench(_a: BenchOptimizeArgs) -> anyhow::Result<()> {
    anyhow::bail!("`bench` is not available in this build yet")
}

