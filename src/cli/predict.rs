//! `fbgforge predict` and `fbgforge sweep`: the opto-mechanical model from the command line.

use clap::Args;

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct PredictArgs {}

/// Placeholder: this subcommand is being built.
pub fn run_predict(_a: PredictArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run_predict` is not available in this build yet")
}

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct SweepArgs {}

/// Placeholder: this subcommand is being built.
pub fn run_sweep(_a: SweepArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run_sweep` is not available in this build yet")
}

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct BenchPredictArgs {}

/// Placeholder: this subcommand is being built.
pub fn bench(_a: BenchPredictArgs) -> anyhow::Result<()> {
    anyhow::bail!("`bench` is not available in this build yet")
}

