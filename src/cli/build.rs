//! `fbgforge build`: design spec to STL, STEP and manifest.

use clap::Args;

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct BuildArgs {}

/// Placeholder: this subcommand is being built.
pub fn run(_a: BuildArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run` is not available in this build yet")
}

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct BenchBuildArgs {}

/// Placeholder: this subcommand is being built.
pub fn bench(_a: BenchBuildArgs) -> anyhow::Result<()> {
    anyhow::bail!("`bench` is not available in this build yet")
}

/// `fbgforge` with no arguments: build the shipped default designs into `out/`.
pub fn run_default() -> anyhow::Result<()> {
    anyhow::bail!("building is not available in this build yet")
}
