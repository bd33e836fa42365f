//! One calibration run analysed in memory: the steps found in the data and matched to
//! the schedule, each state's levels and the baselines, the matrix with its scatter,
//! Table 2 of the staircases, additivity, every fault, and the comparison with the
//! prediction. [`analyse`] is what `run` calls after reading the files, and what the
//! studies call on shifts they made themselves.

use super::additivity::additivity;
use super::compare::{compare, CompareInputs};
use super::drift::drift_faults;
use super::levels::{state_levels, Baseline, StateLevels};
use super::matching::{align, state_starts, Alignment, Transition};
use super::matrix::{measure, Entries};
use super::metrology::metrology;
use super::schedule::{load_states, LoadState, Loading};
use super::steps::{detect, Detection};
use super::{faults, Calibration, Fault, FaultKind, Severity, StateSpan, StepSummary};
use anyhow::{bail, Result};
use nalgebra::DMatrix;
use std::collections::BTreeMap;

/// A run's shifts in memory.
#[derive(Debug, Clone)]
pub struct RunData {
    /// Time of each row, s from the first row.
    pub time_s: Vec<f64>,
    /// Shift of each grating from its nominal wavelength, pm, one series per grating
    /// (NaN where it had no peak).
    pub shifts_pm: Vec<Vec<f64>>,
}

/// Everything [`analyse`] reads.
pub struct AnalysisInputs<'a> {
    /// Grating names (rows), in the shifts' order.
    pub gratings: &'a [String],
    /// Cell labels (columns).
    pub cells: &'a [String],
    /// The shifts.
    pub data: &'a RunData,
    /// The schedule.
    pub schedule: &'a [Loading],
    /// The design's predicted matrix, pm/g.
    pub predicted: &'a DMatrix<f64>,
    /// The model that predicted it, in words.
    pub model: &'a str,
    /// The interrogator's resolution, pm.
    pub resolution_pm: f64,
    /// The model's relative band.
    pub tolerance: f64,
}

/// Samples on each side of the change test: 40 % of the shortest state the schedule
/// lists (ignoring slivers under a quarter of the median), 1 to 50.
fn test_window(states: &[LoadState], sample_s: f64) -> usize {
    let mut d: Vec<f64> = states.iter().map(|s| s.end_s - s.start_s).collect();
    let med = super::steps::median(&mut d.clone());
    d.retain(|&x| x >= 0.25 * med);
    let shortest = d.iter().copied().fold(f64::INFINITY, f64::min);
    ((0.4 * shortest / sample_s).floor() as usize).clamp(1, 50)
}

/// The typical interval between rows, s.
fn sample_interval(time_s: &[f64]) -> f64 {
    let mut d: Vec<f64> = time_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|x| *x > 0.0)
        .collect();
    let m = super::steps::median(&mut d);
    if m.is_finite() {
        m
    } else {
        1.0
    }
}

/// Analyse one run: steps, levels, the matrix with its scatter, Table 2, additivity,
/// faults and the comparison with `predicted`.
///
/// ```
/// use fbgforge_array::calibrate::{analyse, AnalysisInputs, Loading, RunData};
/// // Two gratings over two cells; 200 g on A from 10 s to 20 s, then on B.
/// let a = nalgebra::dmatrix![0.40, 0.05; 0.06, 0.30];
/// let on = |start_s: f64, cell| Loading { start_s, end_s: start_s + 10.0, cell, load_g: 200.0 };
/// let schedule = vec![on(10.0, 0), on(30.0, 1)];
/// let time_s: Vec<f64> = (0..500).map(|k| f64::from(k) * 0.1).collect();
/// let load = |t: f64, c: usize| -> f64 {
///     schedule.iter().filter(|l| l.cell == c && t >= l.start_s && t < l.end_s).map(|l| l.load_g).sum()
/// };
/// let shifts_pm = (0..2)
///     .map(|g| time_s.iter().map(|&t| a[(g, 0)] * load(t, 0) + a[(g, 1)] * load(t, 1)).collect())
///     .collect();
/// let c = analyse(&AnalysisInputs {
///     gratings: &["fbg1".into(), "fbg2".into()],
///     cells: &["A".into(), "B".into()],
///     data: &RunData { time_s, shifts_pm },
///     schedule: &schedule,
///     predicted: &a,
///     model: "the truth",
///     resolution_pm: 0.5,
///     tolerance: 0.4,
/// })?;
/// assert!(c.usable && c.complete && c.faults.is_empty());
/// assert!((c.matrix_pm_per_g[0][0].unwrap() - 0.40).abs() < 1e-3);
/// assert!((c.matrix_pm_per_g[1][1].unwrap() - 0.30).abs() < 1e-3);
/// # anyhow::Ok(())
/// ```
pub fn analyse(i: &AnalysisInputs) -> Result<Calibration> {
    let n_cells = i.cells.len();
    let t = &i.data.time_s;
    if t.len() < 4 {
        bail!("the log has {} rows: too few for a calibration", t.len());
    }
    let end = t[t.len() - 1];
    let states = load_states(i.schedule, n_cells, end);
    let dt = sample_interval(t);
    let window = test_window(&states, dt);
    let detection = detect(t, &i.data.shifts_pm, window, 0.25 * i.resolution_pm);
    let transitions: Vec<Transition> = (1..states.len())
        .map(|k| {
            let dx: Vec<f64> = (0..n_cells)
                .map(|c| states[k].loads_g[c] - states[k - 1].loads_g[c])
                .collect();
            Transition {
                time_s: states[k].start_s,
                expected_pm: Some(
                    (i.predicted * nalgebra::DVector::from_vec(dx))
                        .iter()
                        .copied()
                        .collect(),
                ),
            }
        })
        .collect();
    let alignment = align(&transitions, &detection.changes, dt, end - t[0]);
    let starts = state_starts(&alignment, &transitions, &detection.changes, t);
    let levels = state_levels(t, &i.data.shifts_pm, &detection.noise_pm, &starts);
    let baselines: Vec<Baseline> = (0..i.gratings.len())
        .map(|g| {
            Baseline::new(
                states
                    .iter()
                    .zip(&levels)
                    .filter(|(s, l)| s.is_unloaded() && l.used > 0)
                    .map(|(_, l)| (l.time_s, l.gratings[g].shift_pm, l.gratings[g].sem_pm))
                    .collect(),
            )
        })
        .collect();
    if baselines.iter().all(Baseline::is_empty) {
        bail!("the run has no unloaded stretch to take a baseline from: start the log before the first load");
    }
    let entries = measure(&states, &levels, &baselines, n_cells, i.resolution_pm);
    let mut faults = schedule_faults(i, &states, &transitions, &alignment, &detection);
    faults.extend(drift_faults(&states, &levels, i.gratings, i.resolution_pm));
    let found = faults::check(&faults::Inputs {
        measured: &entries.value,
        sd: &entries.sd,
        predicted: i.predicted,
        tolerance: i.tolerance,
        gratings: i.gratings,
        cells: i.cells,
    });
    faults.extend(found.faults);
    let max_load_g: Vec<f64> = (0..n_cells)
        .map(|c| states.iter().map(|s| s.loads_g[c]).fold(0.0, f64::max))
        .collect();
    let comparison = compare(
        &CompareInputs {
            measured: &entries.value,
            sd: &entries.sd,
            predicted: i.predicted,
            max_load_g: &max_load_g,
            gratings: i.gratings,
            cells: i.cells,
            tolerance: i.tolerance,
            resolution_pm: i.resolution_pm,
        },
        &faults,
        i.model,
    );
    Ok(assemble(
        i,
        Parts {
            states: &states,
            levels: &levels,
            baselines: &baselines,
            alignment: &alignment,
            detection: &detection,
        },
        entries,
        faults,
        comparison,
    ))
}

/// What the analysis found on the way, for the summary.
struct Parts<'a> {
    states: &'a [LoadState],
    levels: &'a [StateLevels],
    baselines: &'a [Baseline],
    alignment: &'a Alignment,
    detection: &'a Detection,
}

fn assemble(
    i: &AnalysisInputs,
    p: Parts,
    entries: Entries,
    faults: Vec<Fault>,
    comparison: super::compare::Comparison,
) -> Calibration {
    let (states, levels, alignment, detection) = (p.states, p.levels, p.alignment, p.detection);
    let t = &i.data.time_s;
    let opt = |m: &DMatrix<f64>| -> Vec<Vec<Option<f64>>> {
        (0..m.nrows())
            .map(|g| {
                m.row(g)
                    .iter()
                    .map(|v| v.is_finite().then_some(*v))
                    .collect()
            })
            .collect()
    };
    let spans = states
        .iter()
        .zip(levels)
        .map(|(s, l)| StateSpan {
            schedule_start_s: s.start_s,
            data_start_s: t.get(l.samples.0).copied().unwrap_or(f64::NAN),
            data_end_s: t
                .get(l.samples.1.saturating_sub(1))
                .copied()
                .unwrap_or(f64::NAN),
            samples_used: l.used,
            loads_g: s
                .loaded_cells()
                .into_iter()
                .map(|c| (i.cells[c].clone(), s.loads_g[c]))
                .collect(),
        })
        .collect();
    let usable = !faults.iter().any(|f| f.severity == Severity::Unusable);
    Calibration {
        gratings: i.gratings.to_vec(),
        cells: i.cells.to_vec(),
        matrix_pm_per_g: opt(&entries.value),
        matrix_sd_pm_per_g: opt(&entries.sd),
        usable,
        complete: entries.readings.iter().all(|&r| r > 0),
        readings_per_cell: entries.readings.clone(),
        faults,
        metrology: metrology(states, levels, i.gratings, i.resolution_pm),
        additivity: additivity(states, levels, p.baselines, i.gratings, i.resolution_pm),
        comparison,
        steps: StepSummary {
            scheduled_changes: states.len().saturating_sub(1),
            detected_changes: detection.changes.len(),
            matched_changes: alignment.change_of.iter().flatten().count(),
            clock_offset_s: alignment.clock_offset_s,
            clock_spread_s: alignment.clock_spread_s,
            test_window_samples: detection.window,
            noise_pm: detection.noise_pm.clone(),
            transients_s: detection.transients_s.clone(),
            states: spans,
        },
        resolution_pm: i.resolution_pm,
    }
}

/// Describe the load change into state `k`.
fn change_words(states: &[LoadState], cells: &[String], k: usize) -> (String, Vec<String>) {
    let (a, b) = (&states[k - 1].loads_g, &states[k].loads_g);
    let changed: Vec<usize> = (0..a.len()).filter(|&c| a[c] != b[c]).collect();
    let words = changed
        .iter()
        .map(|&c| format!("cell {} {} → {} g", cells[c], a[c], b[c]))
        .collect::<Vec<_>>()
        .join(", ");
    (words, changed.iter().map(|&c| cells[c].clone()).collect())
}

/// Faults of the schedule against the data's changes.
fn schedule_faults(
    i: &AnalysisInputs,
    states: &[LoadState],
    transitions: &[Transition],
    al: &Alignment,
    det: &Detection,
) -> Vec<Fault> {
    let mut out = Vec::new();
    for (k, m) in al.change_of.iter().enumerate() {
        if m.is_some() {
            continue;
        }
        let (words, cells) = change_words(states, i.cells, k + 1);
        out.push(Fault {
            kind: FaultKind::ScheduleMisaligned,
            severity: Severity::Unusable,
            gratings: Vec::new(),
            cells,
            reason: format!(
                "the schedule's change at {:.1} s ({words}) has no load change in the data near {:.1} s: a step missed, a weight that did not land, or a schedule that does not describe this run",
                transitions[k].time_s,
                transitions[k].time_s + al.clock_offset_s
            ),
            evidence: BTreeMap::from([("schedule_time_s".to_string(), transitions[k].time_s)]),
        });
    }
    let typical = al.typical_score.max(det.threshold);
    for &m in &al.unexplained {
        let c = &det.changes[m];
        if c.score < 0.1 * typical {
            continue;
        }
        let (g, j) = c
            .jump_pm
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map_or((0, 0.0), |x| (x.0, *x.1));
        out.push(Fault {
            kind: FaultKind::ScheduleMisaligned,
            severity: Severity::Unusable,
            gratings: vec![i.gratings[g].clone()],
            cells: Vec::new(),
            reason: format!(
                "a load change at {:.1} s ({} moved {j:+.2} pm) that the schedule does not list: an extra step, a weight knocked, or a schedule that does not describe this run",
                c.time_s, i.gratings[g]
            ),
            evidence: BTreeMap::from([
                ("time_s".to_string(), c.time_s),
                ("score_over_typical".to_string(), c.score / typical),
            ]),
        });
    }
    if out.is_empty() {
        out.extend(clock_warning(states, al));
    }
    out
}

/// A schedule whose clock is off but whose order the data follow: a warning (the
/// matrix uses the data's times).
fn clock_warning(states: &[LoadState], al: &Alignment) -> Option<Fault> {
    let mut d: Vec<f64> = states.iter().map(|s| s.end_s - s.start_s).collect();
    let shortest = d.iter().copied().fold(f64::INFINITY, f64::min);
    let med = super::steps::median(&mut d);
    let limit = 0.25 * shortest.max(0.25 * med);
    let off = al.clock_offset_s.abs().max(al.clock_spread_s);
    (off > limit).then(|| Fault {
        kind: FaultKind::ScheduleMisaligned,
        severity: Severity::Warning,
        gratings: Vec::new(),
        cells: Vec::new(),
        reason: format!(
            "the data's load changes come {:+.2} s from the schedule's clock (median; up to {:.2} s more or less from step to step), more than a quarter of the shortest state ({:.2} s): the schedule's times would have read the wrong stretches; every change was found in the data in the schedule's order, and the matrix uses the data's times",
            al.clock_offset_s, al.clock_spread_s, shortest
        ),
        evidence: BTreeMap::from([
            ("clock_offset_s".to_string(), al.clock_offset_s),
            ("clock_spread_s".to_string(), al.clock_spread_s),
        ]),
    })
}
