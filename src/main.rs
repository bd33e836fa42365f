//! The `fbgforge` command: parse the flags, call one library use case, print, and
//! return an exit code. Everything else lives in the library (`fbgforge::…`).

mod cli;

use clap::Parser;
use cli::{Cli, Command};
use std::process::ExitCode;

fn main() -> ExitCode {
    restore_default_sigpipe();
    let cli = Cli::parse();
    let result = match cli.command {
        None => cli::build::run_default().map(|()| ExitCode::SUCCESS),
        Some(cmd) => run(cmd),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", cli::hiargs::in_flag_words(&format!("{e:#}")));
            ExitCode::FAILURE
        }
    }
}

/// Output to a closed pipe (`fbgforge predict … | head`) ends the process quietly, as
/// it does other Unix tools; Rust ignores SIGPIPE, so `println!` would panic instead.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: sets a signal's disposition once, at start-up, before any thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Dispatch one subcommand. A subcommand that has more to say than success or
/// failure (verify: a FAIL verdict) returns its own code.
fn run(cmd: Command) -> anyhow::Result<ExitCode> {
    let ok = |r: anyhow::Result<()>| r.map(|()| ExitCode::SUCCESS);
    match cmd {
        Command::Build(a) => ok(cli::build::run(a)),
        Command::Predict(a) => ok(cli::predict::run_predict(a)),
        Command::Sweep(a) => ok(cli::predict::run_sweep(a)),
        Command::Reconstruct(a) => ok(cli::reconstruct::run(a)),
        Command::Verify(a) => cli::verify::run_verify(a),
        Command::SynthLog(a) => ok(cli::verify::run_synth_log(a)),
        Command::Peaks(a) => ok(cli::peaks::run(a)),
        Command::CalibrateArray(a) => cli::verify::run_calibrate_array(a),
        Command::Optimize(a) => ok(cli::optimize::run_optimize(a)),
        Command::Place(a) => ok(cli::optimize::run_place(a)),
        Command::Live(a) => cli::live::run_live(a),
        Command::SynthStream(a) => cli::live::run_synth_stream(a),
    }
}
