//! Command-line interface: argument types and the glue from each subcommand to the
//! library. One file per area; each owns its subcommands' arguments.

pub mod build;
pub mod designs;
pub mod hiargs;
pub mod live;
pub mod log_args;
pub mod optimize;
pub mod peaks;
pub mod predict;
pub mod progress;
pub mod reconstruct;
pub mod verify;

use clap::{Parser, Subcommand};

/// fbgforge: design, build, model and verify fiber Bragg grating tactile sensors.
///
/// With no subcommand, builds the shipped default designs into `out/`.
#[derive(Debug, Parser)]
#[command(name = "fbgforge", version, about, long_about = None)]
pub struct Cli {
    /// What to do; none builds the shipped designs.
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Build the printable parts of a design as STL, STEP and 3MF, with previews and a manifest.
    Build(build::BuildArgs),
    /// Predict each grating's sensitivity K (pm/N) from a design.
    Predict(predict::PredictArgs),
    /// Sweep one design parameter and chart the predicted shift.
    Sweep(predict::SweepArgs),
    /// Reconstruct cell loads of a flat array from grating shifts (y = A x).
    Reconstruct(reconstruct::ReconstructArgs),
    /// Verify a printed part: fit K, R², lag and Q from logs and compare with the model.
    Verify(verify::VerifyArgs),
    /// Write a synthetic interrogator log with known K, lag, noise and drift.
    SynthLog(verify::SynthLogArgs),
    /// Find the peaks of a spectrum file (ENLIGHT / Hyperion export, I-MON log with
    /// pixels, OSA CSV), each with its standard error, bound, FWHM, SNR and flags.
    Peaks(peaks::PeaksArgs),
    /// Build a measured sensing matrix A from an array calibration log.
    CalibrateArray(verify::CalibrateArrayArgs),
    /// Optimise a module design for Q or sensitivity.
    Optimize(optimize::OptimizeArgs),
    /// Optimise grating placement in a flat array.
    Place(optimize::PlaceArgs),
    /// Read a running interrogator stream: cell loads (array) or force per grating (module).
    Live(live::LiveArgs),
    /// Serve a simulated Hyperion peak stream on 127.0.0.1 from a design and a load script.
    SynthStream(live::SynthStreamArgs),
}
