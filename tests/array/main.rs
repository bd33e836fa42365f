//! Integration tests: Sensing matrices, reconstruction methods and their scaling, the array CLI, the live mode.
//!
//! One test binary per area (issue 26: few binaries, one link each); each file below
//! is one concern.

#[path = "../common/chromium.rs"]
mod chromium;
#[path = "../common/mod.rs"]
mod common;

mod array;
mod array_cli;
mod array_exact;
mod array_faults;
mod array_flag_size;
mod array_scaling;
mod array_stream;
mod array_trust;
mod calibrate_additivity;
mod calibrate_cli;
mod calibrate_faults;
mod calibrate_fit;
mod calibrate_runs;
mod calibrate_table2;
mod live;
mod live_end;
mod live_publish;
mod live_record;
mod live_stop;
mod live_tare;
mod sheet_cli;
mod sheet_exact;
mod sheet_paper;
mod sheet_spectrum;
