//! The files a scenario's run leaves: the wavelength log in one of the formats labs
//! export (CSV with relative or ISO times, an ENLIGHT Peaks export, an I-MON log with
//! whole-second times), the force log in its units (named, unnamed, or a units column
//! in every row, Mark-10 style) and clock, the design (with or without its reference
//! grating), and the clock offset between the two logs (force clock − wavelength
//! clock at the force log's first sample) for the runs given it. Written by the study
//! itself, not by the project's log writers.

use super::forward::{ForceRecord, WavelengthRecord};
use super::space::{ForceUnits, Scenario, WlClock};
use anyhow::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Wall-clock time of the run's t = 0: 2025-04-17 15:44:56 on the lab PC.
pub const EPOCH_S: f64 = 20_195.0 * 86_400.0 + 56_696.0;

/// (year, month, day) of a day count since 1970-01-01 (proleptic Gregorian).
fn civil(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// Split a wall-clock time into its date and its hour, minute and (fractional) second.
fn split(t: f64) -> ((i64, u32, u32), u32, u32, f64) {
    let days = (t / 86_400.0).floor();
    let sod = t - days * 86_400.0;
    let h = (sod / 3600.0).floor();
    let mi = ((sod - h * 3600.0) / 60.0).floor();
    (
        civil(days as i64),
        h as u32,
        mi as u32,
        sod - h * 3600.0 - mi * 60.0,
    )
}

/// `2025-04-17 15:44:56.123`.
fn iso(t: f64) -> String {
    let t = (t * 1000.0).round() / 1000.0;
    let ((y, m, d), h, mi, s) = split(t);
    format!("{y:04}-{m:02}-{d:02} {h:02}:{mi:02}:{s:06.3}")
}

/// `17/04/2025 15:44:56.123456`.
fn enlight(t: f64) -> String {
    let t = (t * 1e6).round() / 1e6;
    let ((y, m, d), h, mi, s) = split(t);
    format!("{d:02}/{m:02}/{y:04} {h:02}:{mi:02}:{s:09.6}")
}

/// `4/17/2025<TAB>3:44:56 PM`, the second floored.
fn imon(t: f64) -> String {
    let ((y, m, d), h, mi, s) = split(t.floor());
    let (h12, ampm) = match h {
        0 => (12, "AM"),
        1..=11 => (h, "AM"),
        12 => (12, "PM"),
        _ => (h - 12, "PM"),
    };
    format!("{m}/{d}/{y}\t{h12}:{mi:02}:{:02} {ampm}", s.floor() as u32)
}

/// The wavelength clock's reading at true time `t` (before any jump).
fn wl_clock(s: &Scenario, first_row_t: f64, t: f64) -> f64 {
    match s.wl_clock {
        WlClock::Relative => t - first_row_t,
        _ => EPOCH_S + t,
    }
}

/// The force clock's reading at true time `t`.
fn force_clock(s: &Scenario, first_t: f64, t: f64) -> f64 {
    let run = (t - first_t) * (1.0 + s.force_skew_ppm * 1e-6);
    match s.force_wall_clock {
        Some(pc) => EPOCH_S + first_t + pc + run,
        None => run,
    }
}

/// The files of one run.
pub struct RunFiles {
    /// The design.
    pub design: PathBuf,
    /// The wavelength log.
    pub log: PathBuf,
    /// The force log.
    pub force: PathBuf,
    /// Force clock − wavelength clock at the force log's first sample, s.
    pub offset_s: f64,
}

/// Write the run's files into `dir`: `design_with` / `design_without` is the design
/// with and without its reference grating (written once by the study).
pub fn write_run(
    dir: &Path,
    s: &Scenario,
    wl: &WavelengthRecord,
    force: &ForceRecord,
    designs: (&Path, &Path),
) -> Result<RunFiles> {
    std::fs::create_dir_all(dir)?;
    let t_w0 = wl.t.first().copied().unwrap_or(0.0);
    let t_f0 = force.t.first().copied().unwrap_or(0.0);
    let log = dir.join(match s.wl_clock {
        WlClock::Enlight | WlClock::ImonWholeSeconds => "log.txt",
        _ => "log.csv",
    });
    std::fs::write(&log, wavelength_text(s, wl, t_w0))?;
    let force_path = dir.join("force.csv");
    std::fs::write(&force_path, force_text(s, force, t_f0))?;
    Ok(RunFiles {
        design: if s.reference { designs.0 } else { designs.1 }.to_path_buf(),
        log,
        force: force_path,
        offset_s: force_clock(s, t_f0, t_f0) - wl_clock(s, t_w0, t_f0),
    })
}

/// The wavelength log's text.
fn wavelength_text(s: &Scenario, wl: &WavelengthRecord, t_w0: f64) -> String {
    let cols = if s.reference { 3 } else { 2 };
    let mut out = String::with_capacity(wl.t.len() * 48);
    match s.wl_clock {
        WlClock::Relative => out.push_str("time_s,lambda_21,lambda_22,lambda_temp\n"),
        WlClock::Iso => out.push_str("timestamp,lambda_21,lambda_22,lambda_temp\n"),
        WlClock::Enlight => out.push_str(
            "Date:\t17/04/2025\nModule Type:\tsm130\nTimestamp Format: Full\nTimestamp\t# CH 1\tWavelengths (nm)\n",
        ),
        WlClock::ImonWholeSeconds => out.push_str("Date\tTime\tWavelength 1 [nm]\t\n\n"),
    }
    let header_cols = if s.reference { 3 } else { 2 };
    for (t, row) in wl.t.iter().zip(&wl.nm) {
        let jump = s
            .wl_jump
            .map_or(0.0, |(at, j)| if *t >= at { j } else { 0.0 });
        let clock = wl_clock(s, t_w0, *t) + jump;
        let peaks: Vec<f64> = row[..cols]
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect();
        match s.wl_clock {
            WlClock::Relative | WlClock::Iso => {
                if s.wl_clock == WlClock::Relative {
                    let _ = write!(out, "{clock:.6}");
                } else {
                    out.push_str(&iso(clock));
                }
                for v in &row[..header_cols] {
                    if v.is_finite() {
                        let _ = write!(out, ",{v:.6}");
                    } else {
                        out.push(',');
                    }
                }
                if !s.reference {
                    out.push(',');
                }
            }
            WlClock::Enlight => {
                let _ = write!(out, "{}\t{}", enlight(clock), peaks.len());
                for v in &peaks {
                    let _ = write!(out, "\t{v:.6}");
                }
            }
            WlClock::ImonWholeSeconds => {
                out.push_str(&imon(clock));
                let mut sorted = peaks.clone();
                sorted.sort_by(f64::total_cmp);
                for v in sorted {
                    let _ = write!(out, "\t{:.7}E+3", v / 1e3);
                }
                out.push('\t');
            }
        }
        out.push('\n');
    }
    out
}

/// The force log's text, in its units and clock.
fn force_text(s: &Scenario, force: &ForceRecord, t_f0: f64) -> String {
    let per_unit = s.force_units.n_per_unit();
    let sign = if s.force_negative { -1.0 } else { 1.0 };
    let wall = s.force_wall_clock.is_some();
    let time_col = if wall { "Timestamp" } else { "time_s" };
    let mut out = String::with_capacity(force.t.len() * 24);
    let column = match s.force_units {
        ForceUnits::NewtonNamed => "force_N",
        ForceUnits::LbfNamed => "force_lbf",
        ForceUnits::KgfNamed => "force_kgf",
        ForceUnits::GfNamed => "force_gf",
        ForceUnits::LbfUnnamed | ForceUnits::KgfUnnamed => "force",
        ForceUnits::UnitColumn(_) => "Load",
    };
    let unit_word = match s.force_units {
        ForceUnits::UnitColumn(true) => "lbF",
        _ => "N",
    };
    let unit_column = matches!(s.force_units, ForceUnits::UnitColumn(_));
    if unit_column {
        let _ = writeln!(out, "Reading,{time_col},{column},Unit");
    } else {
        let _ = writeln!(out, "{time_col},{column}");
    }
    for (i, (t, f)) in force.t.iter().zip(&force.n).enumerate() {
        let clock = force_clock(s, t_f0, *t);
        let time = if wall {
            iso(clock)
        } else {
            format!("{clock:.6}")
        };
        let value = sign * f / per_unit;
        if unit_column {
            let _ = writeln!(out, "{},{time},{value:.5},{unit_word}", i + 1);
        } else {
            let _ = writeln!(out, "{time},{value:.6}");
        }
    }
    out
}
