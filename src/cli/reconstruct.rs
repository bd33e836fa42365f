//! `fbgforge reconstruct`: cell loads from grating shifts.

use clap::Args;

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct ReconstructArgs {}

/// Placeholder: this subcommand is being built.
pub fn run(_a: ReconstructArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run` is not available in this build yet")
}

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct BenchReconstructArgs {}

/// Placeholder: this subcommand is being built.
pub fn bench(_a: BenchReconstructArgs) -> anyhow::Result<()> {
    anyhow::bail!("`bench` is not available in this build yet")
}

