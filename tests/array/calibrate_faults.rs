//! Faults at calibration time (issue 34): a clean six-grating, eight-cell run gives the
//! true matrix and no fault; a run of each kind of fault is named with its gratings or
//! cells, and the matrix is marked unusable (a late clock alone is a warning: the
//! steps found in the data replace it).

use crate::calibrate_runs::{analysed, cell_by_cell, kinds, lab, truth};
use fbgforge::array::calibrate::{Calibration, FaultKind, Loading, Severity};
use fbgforge::synth::array_log::ArrayRunSettings;

fn faults_of(c: &Calibration, kind: FaultKind) -> Vec<&fbgforge::array::calibrate::Fault> {
    c.faults.iter().filter(|f| f.kind == kind).collect()
}

#[test]
fn a_clean_run_gives_the_true_matrix_its_scatter_and_no_fault() {
    let a = truth();
    let ev = cell_by_cell();
    let c = analysed(&a, &ev, &ev, &lab());
    assert!(c.faults.is_empty(), "{:#?}", c.faults);
    assert!(c.usable && c.complete);
    assert_eq!(c.steps.matched_changes, c.steps.scheduled_changes);
    for g in 0..6 {
        for k in 0..8 {
            let (m, t) = (
                c.matrix_pm_per_g[g][k].unwrap(),
                a.sensitivity_pm_per_g[(g, k)],
            );
            let sd = c.matrix_sd_pm_per_g[g][k].unwrap();
            // 0.5 pm noise averaged over ~80 samples at 200 g: a few 1e-4 pm/g.
            assert!((m - t).abs() < 0.002, "fbg{} {k}: {m} vs {t}", g + 1);
            // One 200 g reading per cell claims no better than one resolution over
            // the load: 0.5 pm / 200 g.
            assert!((sd - 0.0025).abs() < 1e-9, "sd {sd}");
        }
    }
    // Every grating judged against the prediction: none FAILs on its own sheet.
    assert_eq!(c.comparison.gratings.len(), 6);
    assert!(
        c.comparison
            .gratings
            .iter()
            .all(|v| v.status.label() != "FAIL"),
        "{:?}",
        c.comparison.gratings
    );
}

#[test]
fn two_gratings_in_each_others_slits_are_named_swapped() {
    let ev = cell_by_cell();
    let s = ArrayRunSettings {
        swapped: Some((1, 2)),
        ..lab()
    };
    let c = analysed(&truth(), &ev, &ev, &s);
    let f = faults_of(&c, FaultKind::SwappedGratings);
    assert_eq!(f.len(), 1, "{:#?}", c.faults);
    assert_eq!(f[0].gratings, vec!["fbg2", "fbg3"]);
    assert!(!c.usable);
}

#[test]
fn a_grating_drifting_6_pm_over_the_run_is_named() {
    let ev = cell_by_cell();
    let s = ArrayRunSettings {
        grating_drift_pm: vec![(2, 6.0)],
        ..lab()
    };
    let c = analysed(&truth(), &ev, &ev, &s);
    let f = faults_of(&c, FaultKind::Drift);
    assert!(!f.is_empty(), "{:#?}", c.faults);
    assert!(f.iter().all(|f| f.gratings == vec!["fbg3"]), "{f:#?}");
    assert!(!c.usable);
}

#[test]
fn cell_b_loaded_twice_and_c_never_is_named_collinear_and_unloaded() {
    let sched = cell_by_cell();
    let mut ev = sched.clone();
    ev[2].cell = 1;
    let c = analysed(&truth(), &ev, &sched, &lab());
    let k = kinds(&c);
    assert!(
        k.contains(&"unloaded_cell") || k.contains(&"collinear_cells"),
        "{:#?}",
        c.faults
    );
    let named: Vec<&String> = c.faults.iter().flat_map(|f| f.cells.iter()).collect();
    assert!(named.iter().any(|c| c.as_str() == "C"), "{:#?}", c.faults);
    assert!(!c.usable);
}

#[test]
fn a_schedule_4_s_late_is_a_warning_and_the_matrix_stays_right() {
    let a = truth();
    let ev = cell_by_cell();
    let late: Vec<Loading> = ev
        .iter()
        .map(|l| Loading {
            start_s: l.start_s - 4.0,
            end_s: l.end_s - 4.0,
            ..l.clone()
        })
        .collect();
    let c = analysed(&a, &ev, &late, &lab());
    let f = faults_of(&c, FaultKind::ScheduleMisaligned);
    assert_eq!(f.len(), 1, "{:#?}", c.faults);
    assert_eq!(f[0].severity, Severity::Warning);
    assert!(
        (c.steps.clock_offset_s - 4.0).abs() < 0.5,
        "{}",
        c.steps.clock_offset_s
    );
    assert!(c.usable && c.complete);
    for g in 0..6 {
        for k in 0..8 {
            let (m, t) = (
                c.matrix_pm_per_g[g][k].unwrap(),
                a.sensitivity_pm_per_g[(g, k)],
            );
            assert!((m - t).abs() < 0.003, "fbg{} {k}: {m} vs {t}", g + 1);
        }
    }
}

#[test]
fn a_step_missing_from_the_data_is_schedule_misaligned() {
    let sched = cell_by_cell();
    let ev: Vec<Loading> = sched.iter().filter(|l| l.cell != 5).cloned().collect();
    let c = analysed(&truth(), &ev, &sched, &lab());
    let bad: Vec<_> = c
        .faults
        .iter()
        .filter(|f| f.severity == Severity::Unusable)
        .collect();
    assert!(!bad.is_empty(), "{:#?}", c.faults);
    assert!(
        bad.iter().any(|f| matches!(
            f.kind,
            FaultKind::ScheduleMisaligned | FaultKind::UnloadedCell
        ) && f.cells.iter().any(|c| c == "F")),
        "{:#?}",
        c.faults
    );
    assert!(!c.usable);
}

#[test]
fn an_entry_below_zero_beyond_noise_is_named_negative() {
    let mut a = truth();
    // fbg1 pulls away when cell H (far corner) is pressed: −0.05 pm/g, 25 σ below zero.
    a.sensitivity_pm_per_g[(0, 7)] = -0.05;
    let ev = cell_by_cell();
    let c = analysed(&a, &ev, &ev, &lab());
    let f = faults_of(&c, FaultKind::NegativeEntry);
    assert_eq!(f.len(), 1, "{:#?}", c.faults);
    assert_eq!(
        (f[0].gratings.clone(), f[0].cells.clone()),
        (vec!["fbg1".to_string()], vec!["H".to_string()])
    );
    assert!(!c.usable);
}
