//! The `fbgforge` command: a thin layer over the library's modules.

use clap::Parser;
use fbgforge::cli::{Cli, Command};

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        None => fbgforge::cli::build::run_default(),
        Some(cmd) => run(cmd),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cmd: Command) -> anyhow::Result<()> {
    use fbgforge::cli::*;
    match cmd {
        Command::Build(a) => build::run(a),
        Command::Predict(a) => predict::run_predict(a),
        Command::Sweep(a) => predict::run_sweep(a),
        Command::Reconstruct(a) => reconstruct::run(a),
        Command::Verify(a) => verify::run_verify(a),
        Command::SynthLog(a) => verify::run_synth_log(a),
        Command::CalibrateArray(a) => verify::run_calibrate_array(a),
        Command::Optimize(a) => optimize::run_optimize(a),
        Command::Place(a) => optimize::run_place(a),
        Command::Bench(a) => bench::run(a),
    }
}
