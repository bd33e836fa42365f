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
}

fn main() -> ExitCode {
    let result = match Cli::parse().study {
        Study::Build(a) => studies::build::run(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
