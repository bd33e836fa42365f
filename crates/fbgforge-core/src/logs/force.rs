//! Force-stand logs (a CSV of time and force, as Instron Bluehill, ZwickRoell and
//! Mark-10 export it), read into a [`ForceLog`]: the time and force columns found by
//! name (or named by the user), their units from the names or a units row, dates
//! resolved to wall-clock time. Also the force CSVs the project writes for synthetic
//! runs.

use super::num::{self, trim, DateOrder};
use super::rows::{
    fields, guess_delimiter, is_time_field, lines_with_offsets, parse_time_field, strip_bom,
    unquote,
};
use super::time::{dequantize, require_rows, TimeAcc, NO_DATE};
use super::{at, Clock, LogWarnings};
use anyhow::{anyhow, bail, Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// A force-stand log: time and force.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceLog {
    /// The file read.
    pub source: PathBuf,
    /// Time of each sample, s, ascending.
    pub time_s: Vec<f64>,
    /// Absolute wall-clock or relative times.
    pub clock: Clock,
    /// Force, N (compression positive as the stand reports it).
    pub force_n: Vec<f64>,
    /// Name of the time column used.
    pub time_column: String,
    /// Name of the force column used.
    pub force_column: String,
    /// Factor applied to reach N (from the column's unit).
    pub scale_to_n: f64,
    /// Bound on the error of each sample's absolute time, s (see
    /// [`PeakLog::time_uncertainty_s`]).
    pub time_uncertainty_s: f64,
    /// Counted problems.
    pub warnings: LogWarnings,
}

/// How to read a force-stand CSV: which columns hold time and force, their unit and
/// the order of day and month.
#[derive(Debug, Clone, Default)]
pub struct ForceReadOptions {
    /// Time column name (default: the first of `time_s`, `RelTime`, `time`, `t`,
    /// `AbsTime`, `Timestamp`, matched without case).
    pub time: Option<String>,
    /// Force column name (default: the first of `force_N`, `force`, `F`, `load`).
    pub force: Option<String>,
    /// Factor to N; default from the unit in the column name (`_N`, `[kN]`, `(g)`, …)
    /// or in a units row under the header (`(s),(mm),(kN)`, as Bluehill writes it).
    pub scale_to_n: Option<f64>,
    /// Order of day and month in slash dates (detected when the file tells, else
    /// day first).
    pub date_order: Option<num::DateOrder>,
}

/// Read a force-stand CSV.
pub fn read_force_log(path: &Path, cols: &ForceReadOptions) -> Result<ForceLog> {
    let bytes = std::fs::read(path)
        .with_context(|| format!("cannot read the force log {}", path.display()))?;
    parse_force_bytes(&bytes, path, cols)
}

/// Factor to N from a force column name's unit, if it names one.
pub fn force_unit_scale(name: &str) -> Option<f64> {
    let lower = name.to_ascii_lowercase();
    let unit = lower
        .rsplit(['_', '[', '(', ' ', '/'])
        .next()
        .unwrap_or("")
        .trim_end_matches([']', ')'])
        .trim();
    match unit {
        "n" => Some(1.0),
        "kn" => Some(1000.0),
        "mn" => Some(1e-3),
        "g" | "gf" => Some(9.80665e-3),
        "kg" | "kgf" => Some(9.80665),
        "lbf" => Some(4.448_221_615),
        "ozf" => Some(0.278_013_850_953_78),
        _ => None,
    }
}

/// Factor to N of a unit written in a force log's units column (`N`, `lbF`, `kgF`,
/// `gF`, `ozF`, `kN`, `mN`, as a Mark-10 gauge writes them in every row), if known.
pub fn row_unit_scale(unit: &str) -> Option<f64> {
    match unit.trim().to_ascii_lowercase().as_str() {
        "lb" => Some(4.448_221_615),
        "oz" => Some(0.278_013_850_953_78),
        u => force_unit_scale(&format!("_{u}")),
    }
}

/// A column that holds the force's unit in every row: named `unit` or `units`.
fn units_column(names: &[String]) -> Option<usize> {
    names
        .iter()
        .position(|h| matches!(h.trim().to_ascii_lowercase().as_str(), "unit" | "units"))
}

/// Factor to seconds from a time column name's unit (`time_ms`, `Time [ms]`, `(s)`),
/// if it names one.
pub fn time_unit_scale(name: &str) -> Option<f64> {
    let lower = name.to_lowercase();
    let unit = lower
        .rsplit(['_', '[', '(', ' ', '/'])
        .next()
        .unwrap_or("")
        .trim_end_matches([']', ')'])
        .trim();
    match unit {
        "s" | "sec" | "secs" | "seconds" => Some(1.0),
        "ms" | "msec" => Some(1e-3),
        "us" | "µs" | "μs" => Some(1e-6),
        "min" => Some(60.0),
        "h" | "hr" => Some(3600.0),
        _ => None,
    }
}

/// A units row under a force log's header: every field a unit in brackets, like
/// `(s),(mm),(kN)`.
fn is_units_row(line: &[u8], delim: u8) -> bool {
    let fs = fields(line, delim);
    fs.iter().any(|f| !f.is_empty())
        && fs.iter().all(|f| {
            f.is_empty()
                || (f.starts_with('(') && f.ends_with(')'))
                || (f.starts_with('[') && f.ends_with(']'))
        })
}

/// A time for a message: plain decimals, scientific notation when absurdly large.
fn readable_s(t: f64) -> String {
    if t.abs() < 1e9 {
        format!("{t}")
    } else {
        format!("{t:e}")
    }
}

/// Refuse a force log whose time column runs backwards, naming the first lines where it
/// does.
fn check_force_times_increase(path: &Path, time_s: &[f64], line_nos: &[u32]) -> Result<()> {
    let backward: Vec<usize> = (1..time_s.len())
        .filter(|&i| time_s[i] < time_s[i - 1])
        .collect();
    if let Some(&i) = backward.first() {
        let lines: Vec<String> = backward
            .iter()
            .take(5)
            .map(|&k| line_nos[k].to_string())
            .collect();
        bail!(
            "{}: the force log's time runs backwards ({} s after {} s{}) at {} of its {} rows (lines {}{}); a force log's times must increase: fix or remove those rows",
            at(path, line_nos[i] as usize),
            readable_s(time_s[i]),
            readable_s(time_s[i - 1]),
            if time_s[i - 1] - time_s[i] >= 1.0 {
                ": the clock set back? a daylight-saving change or an NTP step makes a wall clock jump"
            } else {
                ""
            },
            backward.len(),
            time_s.len(),
            lines.join(", "),
            if backward.len() > 5 { ", …" } else { "" }
        );
    }
    // A corrupted time at either end cannot run backwards, but it stretches the log:
    // a first or last step a hundred times longer than all the other samples span.
    let n = time_s.len();
    if n >= 4 {
        let inner = time_s[n - 2] - time_s[1];
        for (odd, step) in [
            (0, time_s[1] - time_s[0]),
            (n - 1, time_s[n - 1] - time_s[n - 2]),
        ] {
            if inner > 0.0 && step > 100.0 * inner {
                bail!(
                    "{}: the force log's time jumps by {} s to this sample, while the other {} samples span {} s: a corrupted time? fix or remove that row",
                    at(path, line_nos[odd] as usize),
                    readable_s(step),
                    n - 1,
                    readable_s(inner)
                );
            }
        }
    }
    Ok(())
}

/// A force log's header line: where it is, its delimiter and its column names.
struct ForceHeader<'a> {
    /// Index of the header line (0-based).
    idx: usize,
    line: &'a [u8],
    names: Vec<String>,
    /// True when the first line is already data (no header).
    headerless: bool,
}

impl ForceHeader<'_> {
    /// The column holding `what`: the one named by the user, else a default name, else a
    /// default with a unit suffix (`force [N]`, `Time (s)`); columns 1 and 2 without a
    /// header.
    fn column(
        &self,
        wanted: &Option<String>,
        defaults: &[&str],
        what: &str,
        path: &Path,
    ) -> Result<usize> {
        let header = &self.names;
        if self.headerless {
            return Ok(if what == "time" { 0 } else { 1 });
        }
        if let Some(w) = wanted {
            return header
                .iter()
                .position(|h| h.eq_ignore_ascii_case(w))
                .ok_or_else(|| {
                    anyhow!(
                        "{}: no {what} column named `{w}`; the header has: {}",
                        at(path, self.idx + 1),
                        header.join(", ")
                    )
                });
        }
        for d in defaults {
            if let Some(i) = header.iter().position(|h| h.eq_ignore_ascii_case(d)) {
                return Ok(i);
            }
        }
        for d in defaults {
            if let Some(i) = header.iter().position(|h| {
                let l = h.to_ascii_lowercase();
                l.starts_with(&d.to_ascii_lowercase())
                    && l[d.len()..].starts_with([' ', '_', '[', '('])
            }) {
                return Ok(i);
            }
        }
        let field = if what == "time" {
            "ForceReadOptions.time"
        } else {
            "ForceReadOptions.force"
        };
        bail!(
            "{}: cannot tell which column holds {what}; the header has: {}; name it with {field}",
            at(path, self.idx + 1),
            header.join(", ")
        )
    }
}

/// Which columns of a force log hold time and force, and how to read them.
struct ForceLayout {
    delim: u8,
    /// Numbers use a decimal comma (any delimiter but a comma).
    dc: bool,
    ti: usize,
    fi: usize,
    /// The column naming the force's unit in every row (Mark-10 style), if any.
    ui: Option<usize>,
    time_column: String,
    force_column: String,
}

impl ForceLayout {
    /// The time column's factor to seconds and the force column's to newtons, from
    /// their names or the units row (`(s),(mm),(kN)`); newtons assumed, with a warning,
    /// when nothing names the force's unit.
    fn scales(
        &self,
        units: &[String],
        cols: &ForceReadOptions,
        path: &Path,
        warnings: &mut LogWarnings,
    ) -> (f64, f64) {
        let unit_of = |i: usize, name: &str| {
            units
                .get(i)
                .filter(|u| !u.is_empty())
                .map(|u| format!("{name} {u}"))
                .unwrap_or_else(|| name.to_string())
        };
        let time_named = unit_of(self.ti, &self.time_column);
        let force_named = unit_of(self.fi, &self.force_column);
        let time_scale_s = time_unit_scale(&time_named).unwrap_or(1.0);
        if self.ui.is_some() {
            // Each row names its own unit (read with the row).
            return (time_scale_s, 1.0);
        }
        let scale = match (cols.scale_to_n, force_unit_scale(&force_named)) {
            (Some(s), _) => s,
            (None, Some(s)) => s,
            (None, None) => {
                let force_column = &self.force_column;
                warnings.add("force_unit_assumed", || {
                    format!(
                        "{}: force column `{force_column}` names no unit; newtons assumed",
                        path.display()
                    )
                });
                1.0
            }
        };
        (time_scale_s, scale)
    }
}

/// The readable rows of a force log.
struct ForceRows {
    times: TimeAcc,
    /// Force, N.
    force: Vec<f64>,
    /// File line of each row.
    line_nos: Vec<u32>,
    /// The factors to N the units column named, in the order first met.
    row_scales: Vec<f64>,
}

/// Read the force log's rows; an unreadable line is counted and named, and more than
/// half of them unreadable (or none readable) is an error.
fn read_force_rows<'a>(
    b: &[u8],
    body: impl Iterator<Item = (usize, (usize, &'a [u8]))>,
    lay: &ForceLayout,
    scale: f64,
    path: &Path,
    warnings: &mut LogWarnings,
) -> Result<ForceRows> {
    let (time_column, force_column) = (&lay.time_column, &lay.force_column);
    let mut rows = ForceRows {
        times: TimeAcc::default(),
        force: Vec::new(),
        line_nos: Vec::new(),
        row_scales: Vec::new(),
    };
    let mut bad = 0usize;
    let mut total = 0usize;
    let mut first_bad = None;
    let unterminated = !b.ends_with(b"\n");
    let n_lines = memchr::memchr_iter(b'\n', b).count() + usize::from(unterminated);
    for (idx, (_, line)) in body {
        total += 1;
        let parts: Vec<&[u8]> = line
            .split(|&c| c == lay.delim)
            .map(|f| unquote(trim(f)))
            .collect();
        let t = parts.get(lay.ti).and_then(|f| parse_time_field(f, lay.dc));
        let f = parts
            .get(lay.fi)
            .and_then(|f| num::parse_f64(f, lay.dc))
            .filter(|v| v.is_finite());
        if let (Some(t), Some(f)) = (t, f) {
            // A readable row's unit must be one: a row in other units would be read
            // as newtons (4.45 times off for lbF).
            let row_scale = match lay.ui {
                None => scale,
                Some(ui) => row_unit(&parts, ui, path, idx)?,
            };
            if lay.ui.is_some() && !rows.row_scales.contains(&row_scale) {
                rows.row_scales.push(row_scale);
            }
            rows.times.push(t);
            rows.force.push(f * row_scale);
            rows.line_nos.push((idx + 1) as u32);
            continue;
        }
        let kind = if unterminated && idx + 1 == n_lines {
            "truncated_last_line"
        } else {
            "unreadable_line"
        };
        if kind == "unreadable_line" {
            bad += 1;
        }
        let msg = format!(
            "{}: expected a time in `{time_column}` and a number in `{force_column}`",
            at(path, idx + 1)
        );
        if first_bad.is_none() {
            first_bad = Some(msg.clone());
        }
        warnings.add(kind, || msg);
    }
    if rows.force.is_empty() || bad * 2 > total {
        bail!(
            "{}: {bad} of {total} rows are unreadable{}",
            path.display(),
            first_bad
                .map(|m| format!("; first: {m}"))
                .unwrap_or_default()
        );
    }
    Ok(rows)
}

/// With a units column: say so (and that the unit changes, when it does); the first
/// row's factor to N.
fn per_row_units(
    rows: &ForceRows,
    lay: &ForceLayout,
    names: &[String],
    path: &Path,
    warnings: &mut LogWarnings,
) -> Option<f64> {
    let ui = lay.ui?;
    let column = names.get(ui).map_or("unit", String::as_str);
    let first = *rows.row_scales.first()?;
    warnings.add("force_unit_per_row", || {
        format!(
            "{}: the force's unit is read from column `{column}` in every row ({} N per unit{})",
            path.display(),
            first,
            if rows.row_scales.len() > 1 {
                format!(
                    ", and it changes within the log: {} units",
                    rows.row_scales.len()
                )
            } else {
                String::new()
            }
        )
    });
    Some(first)
}

/// The factor to N of one row's unit (column `ui`), or an error naming the line, the
/// column and what was expected.
fn row_unit(parts: &[&[u8]], ui: usize, path: &Path, idx: usize) -> Result<f64> {
    let text = parts
        .get(ui)
        .map(|u| String::from_utf8_lossy(u).trim().to_string())
        .unwrap_or_default();
    row_unit_scale(&text).ok_or_else(|| {
        anyhow!(
            "{}: the units column (column {}) says `{text}`: expected a force unit (N, kN, mN, gF, kgF, lbF, ozF)",
            at(path, idx + 1),
            ui + 1
        )
    })
}

/// The force log's times in seconds and their clock: plain numbers in the column's
/// unit (`time_ms`, `Time [ms]`, a units row), or dates resolved to wall-clock time.
fn force_times(
    times: &TimeAcc,
    time_scale_s: f64,
    date_order: Option<DateOrder>,
    path: &Path,
) -> Result<(Vec<f64>, Clock)> {
    if times.dates.is_empty() {
        let sec: Vec<f64> = times.sec.iter().map(|t| t * time_scale_s).collect();
        let clock = if sec[0] > 1e8 {
            Clock::Absolute
        } else {
            Clock::Relative
        };
        return Ok((sec, clock));
    }
    if times.date_of_row.contains(&NO_DATE) {
        bail!(
            "{}: the time column mixes dates and plain numbers",
            path.display()
        );
    }
    let order = match date_order {
        Some(o) => o,
        None => num::resolve_order(&times.dates, DateOrder::DayMonthYear)
            .map_err(|e| anyhow!("{}: {e}", path.display()))?,
    };
    let days: Vec<i64> = times
        .dates
        .iter()
        .map(|d| num::date_to_days(d, order).map_err(|e| anyhow!("{}: {e}", path.display())))
        .collect::<Result<_>>()?;
    let t = times
        .date_of_row
        .iter()
        .zip(&times.sec)
        .map(|(&d, &s)| days[d as usize] as f64 * 86400.0 + s)
        .collect();
    Ok((t, Clock::Absolute))
}

/// Parse a force-stand CSV held in memory.
pub fn parse_force_bytes(bytes: &[u8], path: &Path, cols: &ForceReadOptions) -> Result<ForceLog> {
    let (b, _) = strip_bom(bytes);
    let mut lines = lines_with_offsets(b).enumerate().filter(|(_, (_, l))| {
        let t = trim(l);
        !t.is_empty() && !t.starts_with(b"#")
    });
    let Some((h_idx, (_, header_line))) = lines.next() else {
        bail!("{}: the force log is empty", path.display());
    };
    let delim = guess_delimiter(header_line);
    let header = ForceHeader {
        idx: h_idx,
        line: header_line,
        names: fields(header_line, delim),
        headerless: header_line.split(|&c| c == delim).all(is_time_field),
    };
    let mut warnings = LogWarnings::default();
    let time_defaults = ["time_s", "RelTime", "time", "t", "AbsTime", "Timestamp"];
    let ti = header.column(&cols.time, &time_defaults, "time", path)?;
    let fi = header.column(
        &cols.force,
        &["force_N", "force", "F", "load"],
        "force",
        path,
    )?;
    let name_of = |i: usize, fallback: &str| {
        header
            .names
            .get(i)
            .cloned()
            .unwrap_or_else(|| fallback.into())
    };
    let ui = if header.headerless {
        None
    } else {
        units_column(&header.names)
    };
    if let (Some(u), Some(f)) = (ui, cols.scale_to_n) {
        bail!(
            "{}: the force log names the unit in every row (column `{}`), so ForceReadOptions.scale_to_n ({f}) would convert it twice: drop ForceReadOptions.scale_to_n",
            at(path, header.idx + 1),
            header.names[u]
        );
    }
    let lay = ForceLayout {
        delim,
        dc: delim != b',',
        ti,
        fi,
        ui,
        time_column: name_of(ti, "column 1"),
        force_column: name_of(fi, "column 2"),
    };
    let mut lines = lines.peekable();
    // A units row (`(s),(mm),(kN)`) names the units the header leaves out.
    let units: Vec<String> = match lines.peek() {
        Some((_, (_, l))) if !header.headerless && is_units_row(l, delim) => {
            let u = fields(l, delim);
            lines.next();
            u
        }
        _ => Vec::new(),
    };
    let (time_scale_s, scale) = lay.scales(&units, cols, path, &mut warnings);
    type Lines<'a> = Box<dyn Iterator<Item = (usize, (usize, &'a [u8]))> + 'a>;
    let body: Lines = if header.headerless {
        Box::new(std::iter::once((header.idx, (0, header.line))).chain(lines))
    } else {
        Box::new(lines)
    };
    let rows = read_force_rows(b, body, &lay, scale, path, &mut warnings)?;
    let scale = per_row_units(&rows, &lay, &header.names, path, &mut warnings).unwrap_or(scale);
    require_rows(path, rows.force.len(), "the force log")?;
    let (mut time_s, clock) = force_times(&rows.times, time_scale_s, cols.date_order, path)?;
    // A force stand writes its samples in time order: a time that runs backwards is a
    // corrupted or mis-parsed value, and sorting it in would stretch the log over the
    // wrong span (one time of -1e308 among 1836 samples gave K = -13 867 pm/N).
    check_force_times_increase(path, &time_s, &rows.line_nos)?;
    let time_uncertainty_s = dequantize(path, &mut time_s, &mut warnings);
    // The column grew row by row: its spare capacity (up to as much again) freed.
    let mut force_n = rows.force;
    force_n.shrink_to_fit();
    Ok(ForceLog {
        source: path.to_path_buf(),
        time_s,
        clock,
        force_n,
        time_column: lay.time_column,
        force_column: lay.force_column,
        scale_to_n: scale,
        time_uncertainty_s,
        warnings,
    })
}

/// Write a force log as `time_s,force_N` (times in s from the log's start, force in N).
pub fn write_force_csv(w: &mut dyn Write, time_s: &[f64], force_n: &[f64]) -> std::io::Result<()> {
    writeln!(w, "time_s,force_N")?;
    for (t, f) in time_s.iter().zip(force_n) {
        writeln!(w, "{t:.6},{f:.5}")?;
    }
    Ok(())
}

/// Write a force log as a force stand with a wall clock does:
/// `AbsTime,RelTime,position,force,stress`, AbsTime in `dd/mm/yyyy HH:MM:SS.ffffff`
/// from `start_epoch_s` (the wall-clock time of the first sample, s since 1970).
pub fn write_force_stand_csv(
    w: &mut dyn Write,
    time_s: &[f64],
    force_n: &[f64],
    start_epoch_s: f64,
) -> std::io::Result<()> {
    writeln!(w, "AbsTime,RelTime,position,force,stress")?;
    for (t, f) in time_s.iter().zip(force_n) {
        let abs = num::format_dmy_24h(start_epoch_s + t);
        // Position and stress of a linear stand, for realism only.
        writeln!(w, "{abs},{t:.6},{:.5},{f:.5},{:.5}", f * 0.01, f / 78.5)?;
    }
    Ok(())
}
