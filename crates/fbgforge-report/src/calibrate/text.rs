//! The calibration as text for the terminal: how the steps were found, the faults
//! first, the matrix with each entry's scatter, the paper's Table 2 for every
//! staircase, the additivity tests, the verdicts against the model, the files.

use crate::array::calibrate::compare::Judgement;
use crate::array::calibrate::{Calibration, CalibrationFiles, Severity};
use crate::array::sheet::fit::SheetFit;
use crate::logs::LogWarnings;
use std::fmt::Write as _;
use std::path::Path;

/// How the steps were found.
fn steps(c: &Calibration) -> String {
    let s = &c.steps;
    format!(
        "steps: {} of {} scheduled load changes found in the data ({} detected; clock {:+.2} s from the schedule's, spread {:.2} s; test window {} samples)\n",
        s.matched_changes,
        s.scheduled_changes,
        s.detected_changes,
        s.clock_offset_s,
        s.clock_spread_s,
        s.test_window_samples
    )
}

/// The faults, unusable ones first.
fn faults(c: &Calibration) -> String {
    let mut s = String::new();
    for (sev, head) in [
        (
            Severity::Unusable,
            "FAULTS: the matrix is unusable (exit 3)",
        ),
        (Severity::Warning, "warnings"),
    ] {
        let of: Vec<_> = c.faults.iter().filter(|f| f.severity == sev).collect();
        if of.is_empty() {
            continue;
        }
        let _ = writeln!(s, "{head}:");
        for f in of {
            let names: Vec<&str> = f
                .gratings
                .iter()
                .chain(&f.cells)
                .map(String::as_str)
                .collect();
            let _ = writeln!(
                s,
                "  {} [{}]: {}",
                f.kind.name(),
                names.join(", "),
                f.reason
            );
        }
    }
    s
}

/// Columns of one matrix entry, and how many entries fit beside the grating's name
/// in 80 columns: a wider array's matrix is printed in blocks of cells, as numpy
/// prints a wide array.
const ENTRY: usize = 9;
const PER_BLOCK: usize = (crate::terminal::WIDTH - 8) / ENTRY;

/// The matrix, one row per grating (pm/g), each entry's standard deviation under it;
/// in blocks of [`PER_BLOCK`] cells.
pub(crate) fn matrix(c: &Calibration) -> String {
    let mut s = String::from("measured matrix, pm/g (± sd under each entry):\n");
    let blocks = c.cells.len().div_ceil(PER_BLOCK).max(1);
    for b in 0..blocks {
        let cols = b * PER_BLOCK..((b + 1) * PER_BLOCK).min(c.cells.len());
        if blocks > 1 {
            let _ = writeln!(
                s,
                "cells {}–{} of {}:",
                cols.start + 1,
                cols.end,
                c.cells.len()
            );
        }
        let _ = write!(s, "{:<8}", "pm/g");
        for cell in &c.cells[cols.clone()] {
            let _ = write!(s, "{cell:>ENTRY$}");
        }
        s.push('\n');
        for (g, name) in c.gratings.iter().enumerate() {
            let _ = write!(s, "{name:<8}");
            for v in &c.matrix_pm_per_g[g][cols.clone()] {
                match v {
                    Some(v) => write!(s, "{v:>ENTRY$.5}"),
                    None => write!(s, "{:>ENTRY$}", "—"),
                }
                .ok();
            }
            let _ = write!(s, "\n{:<8}", "");
            for v in &c.matrix_sd_pm_per_g[g][cols.clone()] {
                match v {
                    Some(v) => write!(s, "{:>ENTRY$}", format!("±{v:.5}")),
                    None => write!(s, "{:>ENTRY$}", ""),
                }
                .ok();
            }
            s.push('\n');
        }
    }
    s
}

/// The paper's Table 2 for every staircase-loaded cell.
pub(crate) fn table2(c: &Calibration) -> String {
    let mut s = String::new();
    let mut cells: Vec<&str> = c.metrology.iter().map(|m| m.cell.as_str()).collect();
    cells.dedup();
    for cell in cells {
        let rows: Vec<_> = c.metrology.iter().filter(|m| m.cell == cell).collect();
        let m0 = rows[0];
        let _ = writeln!(
            s,
            "Table 2, staircase on cell {cell}: {} cycles, measuring interval {}–{} g, interrogator resolution {} pm",
            m0.cycles, m0.measuring_interval_g[0], m0.measuring_interval_g[1], c.resolution_pm
        );
        let _ = writeln!(
            s,
            "{:<8}{:>7}{:>19}{:>13}{:>13}{:>14}",
            "grating", "R", "sensitivity pm/g", "resolution g", "linearity %", "hysteresis %"
        );
        for m in rows {
            let sens = match m.sensitivity_sem_pm_per_g {
                Some(e) => format!("{:.4} ± {e:.4}", m.sensitivity_pm_per_g),
                None => format!("{:.4}", m.sensitivity_pm_per_g),
            };
            let _ = writeln!(
                s,
                "{:<8}{:>7.4}{:>19}{:>13.2}{:>13}{:>14}",
                m.grating,
                m.r,
                sens,
                m.resolution_g,
                format!("± {:.2}", m.linearity_percent_span),
                format!("± {:.2}", m.hysteresis_percent_span)
            );
        }
    }
    s
}

/// The additivity tests.
pub(crate) fn additivity(c: &Calibration) -> String {
    let mut s = String::new();
    for t in &c.additivity {
        let loads: Vec<String> = t
            .cells
            .iter()
            .zip(&t.loads_g)
            .map(|(c, l)| format!("{l} g on {c}"))
            .collect();
        let _ = writeln!(
            s,
            "additivity, {} ({} repeats):",
            loads.join(" + "),
            t.repeats
        );
        let _ = write!(s, "{:<8}", "grating");
        for cell in &t.cells {
            let _ = write!(s, "{:>10}", format!("{cell} pm"));
        }
        let _ = writeln!(s, "{:>10}{:>12}{:>10}", "sum pm", "together pm", "error %");
        for g in &t.gratings {
            let _ = write!(s, "{:<8}", g.grating);
            for v in &g.individual_pm {
                let _ = write!(s, "{v:>10.2}");
            }
            let _ = writeln!(
                s,
                "{:>10.2}{:>12.2}{:>10}",
                g.sum_pm,
                g.simultaneous_pm,
                format!(
                    "{:+.1}{}",
                    g.error_percent,
                    if g.significant { "" } else { "*" }
                )
            );
        }
        let _ = writeln!(s, "  (* within the readings' noise)");
    }
    s
}

/// The verdicts against the model.
fn verdicts(c: &Calibration) -> String {
    let cmp = &c.comparison;
    let mut s = format!(
        "against the model ({}; band ±{:.0} %): level measured/predicted {:.2}\n",
        cmp.model,
        100.0 * cmp.tolerance,
        cmp.level_ratio
    );
    for v in &cmp.gratings {
        let _ = writeln!(
            s,
            "  {:<8}{:<11}{} entries judged{}",
            v.grating,
            v.status.label(),
            v.judged_entries,
            v.reason
                .as_ref()
                .filter(|_| v.status != Judgement::Pass)
                .map_or(String::new(), |r| format!(": {r}"))
        );
    }
    s
}

/// Everything above, the log's warnings and the files written.
pub(crate) fn calibration_text(
    c: &Calibration,
    warnings: &LogWarnings,
    files: &CalibrationFiles,
) -> String {
    let mut s = steps(c);
    s += &faults(c);
    s += &matrix(c);
    s += &table2(c);
    s += &additivity(c);
    s += &verdicts(c);
    for (k, w) in &warnings.counts {
        let _ = writeln!(s, "warning {k} ×{}: {}", w.count, w.first);
    }
    let wrote = |s: &mut String, p: &Option<std::path::PathBuf>| {
        if let Some(p) = p {
            let _ = writeln!(s, "wrote {}", p.display());
        }
    };
    wrote(&mut s, &files.matrix);
    wrote(&mut s, &files.matrix_sd);
    wrote(&mut s, &files.faulty_matrix);
    wrote(&mut s, &files.json);
    if let (Some(out), None) = (&files.requested, &files.matrix) {
        let why = if c.usable {
            "some cells were never loaded alone"
        } else {
            "unusable faults"
        };
        let _ = writeln!(s, "nothing written to {} ({why})", out.display());
    }
    s
}

/// The sheet fit.
pub(crate) fn sheet_fit_text(f: &SheetFit, path: Option<&Path>) -> String {
    let mut s = format!("sheet fit: {}\n", f.summary);
    for p in &f.parameters {
        let _ = writeln!(s, "  {}: {}", p.name, p.words);
    }
    if let Some(p) = path {
        let _ = writeln!(s, "wrote {}", p.display());
    }
    s
}
