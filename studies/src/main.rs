//! `fbgforge-studies <study>`: run one study of the project (benchmarks with tables
//! and charts, paper reproductions, failure studies). The README's measured tables
//! name the study that produced them.

use clap::{Parser, Subcommand};
use fbgforge_studies as studies;
use std::process::ExitCode;

/// Benchmarks, paper reproductions and failure studies of fbgforge.
#[derive(Debug, Parser)]
#[command(name = "fbgforge-studies", version, about)]
struct Cli {
    #[command(subcommand)]
    study: Study,
}

/// One study each; `--quick` gives its smoke form.
#[derive(Debug, Subcommand)]
enum Study {
    /// Meshing tolerance against triangles, time and volume error; build timings.
    Build(studies::build::BuildStudyArgs),
    /// The array's calibration: confidently wrong matrices, missed and false faults.
    Calibrate(studies::calibrate::CalibrateStudyArgs),
    /// Time of the FE-backed commands (predict, a Case I sweep) from a cold cache.
    FeSpeed(studies::fe_speed::FeSpeedArgs),
    /// Finite-element convergence, time against error, and closed form against FE.
    Fem(studies::fem::FemStudyArgs),
    /// Contact readings of the module and the unilateral contact solver: Hertz, K(F)
    /// and the knee, timing, the contact radii consistent with the paper.
    Contact(studies::fem_contact::ContactStudyArgs),
    /// Live starts at any moment of a load script: confidently wrong loads shown by
    /// the tare at rest, the tare of the first 50 frames and an oracle tare.
    LiveStarts(studies::live_starts::LiveStartsArgs),
    /// The model's stated error on random valid designs (containment in the widened
    /// bounding readings) and the margins of the designs optimize writes under it.
    ModelError(studies::model_error::ModelErrorArgs),
    /// Optimiser convergence time per design and solver.
    Optimize(studies::optimize::BenchOptimizeArgs),
    /// Closed-form prediction time per design.
    Predict(studies::predict::BenchPredictArgs),
    /// Reconstruction protocol: every method, speed against accuracy, failure studies.
    Reconstruct(studies::reconstruct::BenchOptions),
    /// The array's sheet model: Tables 1–2, its fitted constants, speed against
    /// accuracy, trends with the design.
    Sheet(studies::sheet::SheetStudyArgs),
    /// Peak finding on random spectra: confidently wrong peaks (error > 3× the
    /// standard error, no flag) over SNR, width, line shape, neighbours, tilt and
    /// saturation.
    Spectra(studies::spectra::SpectraStudyArgs),
    /// The spectrum a design will make: predict's "one clean peak over the force
    /// range" on random long, strong, apodised gratings against a dense scan.
    SpectrumForward(studies::spectrum_forward::SpectrumForwardArgs),
    /// Print files over random designs wider than the held-out proptest: builds that
    /// exit 0 with an overlap, a passage under the printer's floor, a meshed gap under
    /// 80 %, a mesh not watertight; refusals naming no field.
    PrintFiles(studies::print_files::PrintFilesArgs),
    /// Log parsing throughput and end-to-end verification time.
    Verify(studies::verify::BenchVerifyArgs),
    /// Verdicts against their alternatives: random scenarios with known truth,
    /// the confusion table (expected × given).
    Verdicts(studies::verdicts::VerdictStudyArgs),
}

fn main() -> ExitCode {
    let result = match Cli::parse().study {
        Study::Build(a) => studies::build::run(&a),
        Study::Calibrate(a) => studies::calibrate::run(&a),
        Study::FeSpeed(a) => studies::fe_speed::run(&a),
        Study::Fem(a) => studies::fem::run(&a),
        Study::Contact(a) => studies::fem_contact::run(&a),
        Study::LiveStarts(a) => studies::live_starts::run(&a),
        Study::ModelError(a) => studies::model_error::run(&a).map(|_| ()),
        Study::Optimize(a) => studies::optimize::run(&a),
        Study::Predict(a) => studies::predict::run(&a),
        Study::PrintFiles(a) => studies::print_files::run(&a),
        Study::Reconstruct(a) => studies::reconstruct::run(&a),
        Study::Sheet(a) => studies::sheet::run(&a),
        Study::Spectra(a) => studies::spectra::run(&a),
        Study::SpectrumForward(a) => studies::spectrum_forward::run(&a),
        Study::Verify(a) => studies::verify::run(&a),
        Study::Verdicts(a) => studies::verdicts::run(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
