//! The schedule of a calibration run: what the lab says it put where and when, read
//! from a CSV and turned into the sequence of load states the data must show.
//!
//! One line per load resting on one cell, `start_s,end_s,cell,load_g`, times in s from
//! the log's first row (the schedule's clock, a hint: the data's own load changes are
//! what counts). A staircase is a run of contiguous lines on one cell (the load is the
//! total mass on the cell during that line); lines on different cells may overlap
//! (simultaneous loads, as in an additivity test); lines on one cell may not.

use crate::logs::{csv_table, num};
use crate::profile::cell_label;
use anyhow::{bail, Context, Result};
use serde::Serialize;
use std::path::Path;

/// One load on one cell, as the schedule lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Loading {
    /// Start, s from the log's first row.
    pub start_s: f64,
    /// End, s.
    pub end_s: f64,
    /// Cell index (A = 0).
    pub cell: usize,
    /// Load, g.
    pub load_g: f64,
}

/// Read a schedule CSV, checking cell labels against the design.
pub fn read_schedule(path: &Path, n_cells: usize) -> Result<Vec<Loading>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the schedule {}", path.display()))?;
    parse_schedule(&text, path, n_cells)
}

fn check_header(fields: &[String], path: &Path, line: u64) -> Result<()> {
    let want = ["start_s", "end_s", "cell", "load_g"];
    if fields.len() != 4
        || !fields
            .iter()
            .zip(want)
            .all(|(f, w)| f.eq_ignore_ascii_case(w))
    {
        bail!(
            "{}:{line}: expected the header `start_s,end_s,cell,load_g`",
            path.display()
        );
    }
    Ok(())
}

/// Parse a schedule from text (a CSV: quoted fields, `#` comments and blank lines
/// allowed). Lines come back sorted by start time.
pub fn parse_schedule(text: &str, path: &Path, n_cells: usize) -> Result<Vec<Loading>> {
    let labels: Vec<String> = (0..n_cells).map(cell_label).collect();
    let mut out = Vec::new();
    let records = csv_table::records(text, b',', path)?;
    let mut records = records.iter();
    if let Some(header) = records.next() {
        check_header(&header.fields, path, header.line)?;
    }
    for rec in records {
        let f = &rec.fields;
        let at = || format!("{}:{}", path.display(), rec.line);
        if f.len() != 4 {
            bail!(
                "{}: expected 4 fields `start_s,end_s,cell,load_g`, got {}",
                at(),
                f.len()
            );
        }
        let num = |s: &str, what: &str| -> Result<f64> {
            num::parse_f64(s.as_bytes(), false)
                .filter(|v| v.is_finite())
                .with_context(|| format!("{}: {what} `{s}` is not a number", at()))
        };
        let (a, b, g) = (
            num(&f[0], "start_s")?,
            num(&f[1], "end_s")?,
            num(&f[3], "load_g")?,
        );
        if b <= a {
            bail!("{}: end_s {b} is not after start_s {a}", at());
        }
        if g <= 0.0 {
            bail!("{}: load_g must be positive, got {g}", at());
        }
        let cell = labels
            .iter()
            .position(|c| c.eq_ignore_ascii_case(&f[2]))
            .with_context(|| {
                format!(
                    "{}: unknown cell `{}`; the design has cells {}",
                    at(),
                    f[2],
                    labels.join(", ")
                )
            })?;
        out.push(Loading {
            start_s: a,
            end_s: b,
            cell,
            load_g: g,
        });
    }
    if out.is_empty() {
        bail!("{}: the schedule lists no loadings", path.display());
    }
    out.sort_by(|x, y| x.start_s.total_cmp(&y.start_s));
    for (i, l) in out.iter().enumerate() {
        if let Some(o) = out[i + 1..]
            .iter()
            .find(|o| o.cell == l.cell && o.start_s < l.end_s - 1e-9)
        {
            bail!(
                "{}: two loads on cell {} overlap ({}–{} s and {}–{} s); a staircase lists the total mass of each step on its own line",
                path.display(),
                cell_label(l.cell),
                l.start_s,
                l.end_s,
                o.start_s,
                o.end_s
            );
        }
    }
    Ok(out)
}

/// One stretch of the run in which the loads stay the same.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoadState {
    /// Start by the schedule's clock, s.
    pub start_s: f64,
    /// End by the schedule's clock, s.
    pub end_s: f64,
    /// Load on every cell, g (0 = unloaded).
    pub loads_g: Vec<f64>,
}

impl LoadState {
    /// The cells loaded in this state.
    pub fn loaded_cells(&self) -> Vec<usize> {
        (0..self.loads_g.len())
            .filter(|&c| self.loads_g[c] > 0.0)
            .collect()
    }

    /// Nothing on the sheet.
    pub fn is_unloaded(&self) -> bool {
        self.loads_g.iter().all(|&l| l <= 0.0)
    }

    /// The one loaded cell and its load, when exactly one cell is loaded.
    pub fn single(&self) -> Option<(usize, f64)> {
        match self.loaded_cells().as_slice() {
            [c] => Some((*c, self.loads_g[*c])),
            _ => None,
        }
    }
}

/// The schedule as states from the log's start to `end_s`: an unloaded state before
/// the first line and after the last one, and one state per stretch between two
/// consecutive start or end times (equal neighbours merged, so a load change is always
/// the boundary between two states).
pub fn load_states(schedule: &[Loading], n_cells: usize, end_s: f64) -> Vec<LoadState> {
    let mut cuts: Vec<f64> = vec![0.0];
    for l in schedule {
        cuts.push(l.start_s);
        cuts.push(l.end_s);
    }
    let last = schedule.iter().map(|l| l.end_s).fold(0.0, f64::max);
    cuts.push(end_s.max(last));
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let mut states: Vec<LoadState> = Vec::new();
    for w in cuts.windows(2) {
        let mid = 0.5 * (w[0] + w[1]);
        let mut loads_g = vec![0.0; n_cells];
        for l in schedule
            .iter()
            .filter(|l| l.start_s <= mid && mid < l.end_s)
        {
            loads_g[l.cell] += l.load_g;
        }
        match states.last_mut() {
            Some(s) if s.loads_g == loads_g => s.end_s = w[1],
            _ => states.push(LoadState {
                start_s: w[0],
                end_s: w[1],
                loads_g,
            }),
        }
    }
    // A state of (almost) no length at the very start (the schedule starts at 0).
    if states.len() > 1 && states[0].end_s - states[0].start_s < 1e-9 {
        states.remove(0);
    }
    states
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quoted_schedule_reads_as_a_plain_one() {
        let p = Path::new("sched.csv");
        let plain = parse_schedule("start_s,end_s,cell,load_g\n0,10,A,200\n", p, 8).unwrap();
        let quoted = parse_schedule(
            "\"start_s\",\"end_s\",\"cell\",\"load_g\"\r\n\"0\",\"10\",\"A\",\"200\"\r\n",
            p,
            8,
        )
        .unwrap();
        assert_eq!(quoted, plain);
        // Errors keep the file, the line and the field, quoted or not.
        let e = parse_schedule(
            "# loads\n\"start_s\",\"end_s\",\"cell\",\"load_g\"\n\"0\",\"1,5\",\"A\",\"200\"\n",
            p,
            8,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("sched.csv:3") && e.contains("end_s `1,5` is not a number"),
            "{e}"
        );
        let e = parse_schedule("\"start_s\",\"end\"\n", p, 8)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("sched.csv:1") && e.contains("start_s,end_s,cell,load_g"),
            "{e}"
        );
    }

    #[test]
    fn simultaneous_loads_on_two_cells_are_states_and_one_cell_may_not_overlap() {
        let p = Path::new("s.csv");
        let s = parse_schedule(
            "start_s,end_s,cell,load_g\n10,20,A,25\n20,30,A,50\n40,60,B,200\n50,60,C,100\n",
            p,
            8,
        )
        .unwrap();
        let st = load_states(&s, 8, 70.0);
        let summary: Vec<(f64, f64, Vec<usize>)> = st
            .iter()
            .map(|x| (x.start_s, x.end_s, x.loaded_cells()))
            .collect();
        assert_eq!(
            summary,
            vec![
                (0.0, 10.0, vec![]),
                (10.0, 20.0, vec![0]),
                (20.0, 30.0, vec![0]),
                (30.0, 40.0, vec![]),
                (40.0, 50.0, vec![1]),
                (50.0, 60.0, vec![1, 2]),
                (60.0, 70.0, vec![]),
            ]
        );
        assert_eq!(st[2].single(), Some((0, 50.0)));
        assert_eq!(st[5].single(), None);
        let e = parse_schedule("start_s,end_s,cell,load_g\n0,10,A,25\n5,15,A,50\n", p, 8)
            .unwrap_err()
            .to_string();
        assert!(e.contains("cell A overlap"), "{e}");
    }
}
