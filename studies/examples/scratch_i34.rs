use fbgforge::array::calibrate::{self, analyse, AnalysisInputs, RunData, Loading};
use fbgforge::array::kernel::model_matrix;
use fbgforge::synth::array_log::{self, ArrayRunSettings};
fn run(d: &fbgforge::spec::Design, events: &[Loading], sched: &[Loading], s: &ArrayRunSettings) -> calibrate::Calibration {
    let truth = calibrate::power_law_matrix(d).unwrap();
    let log = array_log::synth_array_run(d, &truth, events, s).unwrap();
    let g = log.names.len();
    let a = d.array.as_ref().unwrap();
    let data = RunData { time_s: log.time_s.clone(), shifts_pm: (0..g).map(|k| log.wavelength_nm.iter().map(|r| (r[k] - a.gratings[k].bragg_wavelength_nm) * 1e3).collect()).collect() };
    let p = model_matrix(d, None).unwrap();
    let cells: Vec<String> = p.matrix.cells.clone();
    analyse(&AnalysisInputs { gratings: &log.names, cells: &cells, data: &data, schedule: sched, predicted: &p.matrix.sensitivity_pm_per_g, model: &p.description, resolution_pm: 0.5, tolerance: 0.4 }).unwrap()
}
fn show(name: &str, c: &calibrate::Calibration) {
    println!("== {name}: usable {} complete {} steps {}/{} det {} off {:.2} spread {:.2} w {}", c.usable, c.complete, c.steps.matched_changes, c.steps.scheduled_changes, c.steps.detected_changes, c.steps.clock_offset_s, c.steps.clock_spread_s, c.steps.test_window_samples);
    for f in &c.faults { println!("  fault {} {:?} {:?}{:?}: {}", f.kind.name(), f.severity, f.gratings, f.cells, f.reason); }
    for v in &c.comparison.gratings { print!(" {}:{}", v.grating, v.status.label()); } println!(" level {:.2}", c.comparison.level_ratio);
}
fn main() {
    let d = fbgforge::design::load(std::path::Path::new("designs/tactile-array-60x80.toml")).unwrap();
    let truth = calibrate::power_law_matrix(&d).unwrap();
    // clean matrix run
    let ev = array_log::cell_by_cell(&[0,1,2,3,4,5,6,7], 200.0, 10.0, 10.0, 10.0);
    let s = ArrayRunSettings { noise_pm: 0.5, sample_rate_hz: 10.0, ..Default::default() };
    let c = run(&d, &ev, &ev, &s); show("clean", &c);
    let mut err = 0.0f64; for g in 0..6 { for k in 0..8 { let m = c.matrix_pm_per_g[g][k].unwrap(); err = err.max((m - truth.sensitivity_pm_per_g[(g,k)]).abs()); } } println!("  max abs err {err:.5}");
    // late schedule
    let late: Vec<Loading> = ev.iter().map(|l| Loading { start_s: l.start_s - 4.0, end_s: l.end_s - 4.0, ..l.clone() }).collect();
    show("late", &run(&d, &ev, &late, &s));
    // swapped
    show("swapped", &run(&d, &ev, &ev, &ArrayRunSettings { swapped: Some((1, 2)), ..s.clone() }));
    // drift
    show("drift", &run(&d, &ev, &ev, &ArrayRunSettings { grating_drift_pm: vec![(2, 6.0)], ..s.clone() }));
    // B twice C never
    let mut ev2 = ev.clone(); ev2[2].cell = 1;
    show("BtwiceCnever", &run(&d, &ev2, &ev, &s));
    // staircase
    let st = array_log::staircase(2, 25.0, 250.0, 5.0, 3, 10.0);
    let s3 = ArrayRunSettings { noise_pm: 0.5, sample_rate_hz: 3.0, linearity_frac: 0.03, hysteresis_frac: 0.04, creep_frac: 0.02, creep_tau_s: 0.3, ..Default::default() };
    let c = run(&d, &st, &st, &s3); show("staircase", &c);
    for m in &c.metrology { println!("  {} {} s {:.4}±{:?} R {:.4} res {:.2} lin {:.2} hys {:.2} cyc {}", m.cell, m.grating, m.sensitivity_pm_per_g, m.sensitivity_sem_pm_per_g, m.r, m.resolution_g, m.linearity_percent_span, m.hysteresis_percent_span, m.cycles); }
    println!("  truth C col: {:?}", truth.sensitivity_pm_per_g.column(2).iter().collect::<Vec<_>>());
}
