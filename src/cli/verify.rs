//! `fbgforge verify`, `synth-log` and `calibrate-array`: logs to verdicts.

use clap::Args;

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct VerifyArgs {}

/// Placeholder: this subcommand is being built.
pub fn run_verify(_a: VerifyArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run_verify` is not available in this build yet")
}

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct SynthLogArgs {}

/// Placeholder: this subcommand is being built.
pub fn run_synth_log(_a: SynthLogArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run_synth_log` is not available in this build yet")
}

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct CalibrateArrayArgs {}

/// Placeholder: this subcommand is being built.
pub fn run_calibrate_array(_a: CalibrateArrayArgs) -> anyhow::Result<()> {
    anyhow::bail!("`run_calibrate_array` is not available in this build yet")
}

/// Arguments (placeholder until this subcommand lands).
#[derive(Debug, Args)]
pub struct BenchVerifyArgs {}

/// Placeholder: this subcommand is being built.
pub fn bench(_a: BenchVerifyArgs) -> anyhow::Result<()> {
    anyhow::bail!("`bench` is not available in this build yet")
}

