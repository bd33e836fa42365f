//! The paper's Table 2 from a synthetic dead-weight staircase whose Table 2 is known:
//! 25 g steps to 250 g about every 5 s, 15 acquisitions per step, three up-and-down
//! cycles, on one cell only (a valid run), the steps put on by hand (±0.8 s from the
//! schedule's times) on a sheet with a bow, hysteresis and creep.

use crate::calibrate_runs::{analysed, truth};
use fbgforge::array::calibrate::Loading;
use fbgforge::synth::array_log::{staircase, ArrayRunSettings};
use rand::{Rng, SeedableRng};

/// The grating right above the staircase's cell (fbg4 over cell C in the shipped
/// layout) reads 0.371 pm/g like Table 2's grating.
const DIRECT: (usize, usize) = (3, 2);

/// Table 2 by its definitions on the noiseless, creep-free points of one cycle
/// (independent of the library: the least-squares line through every point, the
/// largest |deviation| and the largest sum of |deviations| at one mass, % of span).
fn known_table2(s: &ArrayRunSettings, a: f64) -> (f64, f64, f64) {
    let mut pts = vec![(0.0, 0.0)];
    pts.extend((1..=10).map(|k| (25.0 * k as f64, a * s.transmitted_g(25.0 * k as f64, true))));
    pts.extend(
        (1..10)
            .rev()
            .map(|k| (25.0 * k as f64, a * s.transmitted_g(25.0 * k as f64, false))),
    );
    pts.push((0.0, 0.0));
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    let dev: Vec<(f64, f64)> = pts
        .iter()
        .map(|p| (p.0, p.1 - (my + slope * (p.0 - mx))))
        .collect();
    let span = slope * 250.0;
    let lin = dev.iter().map(|d| d.1.abs()).fold(0.0, f64::max);
    let hys = dev
        .iter()
        .map(|d| {
            dev.iter()
                .filter(|e| e.0 == d.0)
                .map(|e| e.1.abs())
                .sum::<f64>()
        })
        .fold(0.0, f64::max);
    (slope, 100.0 * lin / span, 100.0 * hys / span)
}

#[test]
fn a_dead_weight_staircase_reproduces_its_known_table2() {
    let sheet = ArrayRunSettings {
        sample_rate_hz: 3.0,
        noise_pm: 0.5,
        linearity_frac: 0.007,
        hysteresis_frac: 0.0433,
        creep_frac: 0.02,
        creep_tau_s: 0.3,
        seed: 11,
        ..Default::default()
    };
    let mut a = truth();
    let scale = 0.371 / sheet.transmitted_g(250.0, true) * 250.0 / a.sensitivity_pm_per_g[DIRECT];
    let mut col = a.sensitivity_pm_per_g.column_mut(DIRECT.1);
    col *= scale;
    let (slope, lin, hys) = known_table2(&sheet, a.sensitivity_pm_per_g[DIRECT]);
    // The scenario is the paper's Table 2: 0.371 pm/g, ±2.42 % and ±4.33 % of span.
    assert!(
        (slope - 0.371).abs() < 0.002 && (lin - 2.42).abs() < 0.3 && (hys - 4.33).abs() < 0.3,
        "{slope} {lin} {hys}"
    );
    let schedule = staircase(DIRECT.1, 25.0, 250.0, 5.0, 3, 10.0);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let mut events: Vec<Loading> = schedule.clone();
    let mut shift = 0.0;
    for e in &mut events {
        let jitter = rng.random_range(-0.8..0.8);
        e.start_s += shift;
        shift += jitter;
        e.end_s += shift;
    }
    let c = analysed(&a, &events, &schedule, &sheet);
    assert!(
        c.faults
            .iter()
            .all(|f| f.kind.name() == "schedule_misaligned"
                && f.severity == fbgforge::array::calibrate::Severity::Warning),
        "{:#?}",
        c.faults
    );
    assert!(c.usable && !c.complete);
    assert_eq!(c.steps.matched_changes, c.steps.scheduled_changes);
    // Table 2 of every grating on cell C; the direct one against the known values.
    assert_eq!(c.metrology.len(), 6);
    let m = c.metrology.iter().find(|m| m.grating == "fbg4").unwrap();
    assert_eq!(
        (m.cell.as_str(), m.cycles, m.measuring_interval_g),
        ("C", 3, [0.0, 250.0])
    );
    assert!(
        (m.sensitivity_pm_per_g / slope - 1.0).abs() < 0.01,
        "{} vs {slope}",
        m.sensitivity_pm_per_g
    );
    assert!(
        (m.linearity_percent_span - lin).abs() < 1.0,
        "{} vs {lin}",
        m.linearity_percent_span
    );
    assert!(
        (m.hysteresis_percent_span - hys).abs() < 1.0,
        "{} vs {hys}",
        m.hysteresis_percent_span
    );
    // Resolution = 0.5 pm / sensitivity: Table 2's 1.35 g.
    assert!(
        (m.resolution_g - 0.5 / m.sensitivity_pm_per_g).abs() < 1e-12
            && (m.resolution_g - 1.35).abs() < 0.02
    );
    // The SEM over three cycles is small and R the paper's 0.99 or better.
    let sem = m.sensitivity_sem_pm_per_g.unwrap();
    assert!(sem > 0.0 && sem < 0.003, "{sem}");
    assert!(m.r > 0.99, "{}", m.r);
    // The matrix has column C only, its fbg4 entry the slope through the origin.
    assert!(c
        .matrix_pm_per_g
        .iter()
        .all(|row| row.iter().enumerate().all(|(k, v)| v.is_some() == (k == 2))));
    let entry = c.matrix_pm_per_g[3][2].unwrap();
    assert!((entry / slope - 1.0).abs() < 0.02, "{entry}");
}
