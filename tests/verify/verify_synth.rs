//! End-to-end recovery of known values from synthetic logs, in every format.

use crate::common;
use fbgforge::logs::{self, ForceReadOptions, LogFormat, ReadOptions};
use fbgforge::synth::module_log::{self as synth, LogStyle, SynthConfig, SynthTruth};
use fbgforge::verify::analysis::{analyse, AnalysisOptions, BoundKind, Measurement};

fn design() -> fbgforge::spec::Design {
    common::shipped("clip-on-34mm.toml")
}

fn run(
    format: LogFormat,
    cfg: &SynthConfig,
    style: &LogStyle,
    core: Option<&str>,
) -> (Measurement, SynthTruth) {
    run_offset(format, cfg, style, core, None)
}

/// [`run`] with the clock offset given (absolute lags, Q given) or estimated.
fn run_offset(
    format: LogFormat,
    cfg: &SynthConfig,
    style: &LogStyle,
    core: Option<&str>,
    clock_offset_s: Option<f64>,
) -> (Measurement, SynthTruth) {
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let (log, force, truth) = synth::generate(&d, cfg).unwrap();
    let lp = dir.path().join(format!("log.{}", synth::extension(format)));
    let fp = dir.path().join("force.csv");
    synth::write_log(&lp, format, &log, cfg, style).unwrap();
    synth::write_force_csv(&fp, &force).unwrap();
    let pl = logs::read_peak_log(&lp, &ReadOptions::default()).unwrap();
    assert_eq!(pl.format, format, "detected format");
    let fl = logs::read_force_log(&fp, &ForceReadOptions::default()).unwrap();
    let opts = AnalysisOptions {
        core: core.map(String::from),
        clock_offset_s,
        ..Default::default()
    };
    let (m, _) = analyse(&d, &pl, &fl, &opts).unwrap();
    (m, truth)
}

fn check(format: LogFormat, m: &Measurement, truth: &SynthTruth, cfg: &SynthConfig) {
    let dt = truth.sample_period_s;
    let want_off = synth::reported_offset_s(cfg, format);
    assert!(
        (m.clock_offset_s - want_off).abs() <= dt,
        "{format:?}: offset {} vs {want_off}",
        m.clock_offset_s
    );
    assert!(
        (m.force_log_start_s - cfg.force_start_s).abs() <= dt,
        "{format:?}: force start {}",
        m.force_log_start_s
    );
    let strain: Vec<_> = truth.gratings.iter().filter(|g| !g.reference).collect();
    assert_eq!(m.gratings.len(), strain.len());
    for (g, t) in m.gratings.iter().zip(strain) {
        assert_eq!(g.grating, t.name);
        let k_err =
            (g.sensitivity_pm_per_n - t.sensitivity_pm_per_n).abs() / t.sensitivity_pm_per_n.abs();
        assert!(
            k_err <= 0.01,
            "{format:?} {}: K {} vs {} ({:.3} %)",
            g.grating,
            g.sensitivity_pm_per_n,
            t.sensitivity_pm_per_n,
            100.0 * k_err
        );
        assert_eq!(g.pulses.len(), t.lags_s.len(), "{format:?}: pulses");
        for (p, &lag) in g.pulses.iter().zip(&t.lags_s) {
            assert!(
                (p.lag_s - lag).abs() <= dt,
                "{format:?} {} pulse {}: lag {} vs {lag}",
                g.grating,
                p.index,
                p.lag_s
            );
        }
        assert!(
            (g.max_lag_s - t.max_lag_s).abs() <= dt,
            "{format:?}: max lag {} vs {}",
            g.max_lag_s,
            t.max_lag_s
        );
        assert!(
            (g.r_squared - t.r_squared_expected).abs() <= 0.01,
            "{format:?}: R² {} vs {}",
            g.r_squared,
            t.r_squared_expected
        );
        assert!(
            (g.sls_time_constant_s - truth.sls_time_constant_s).abs()
                <= 0.1 * truth.sls_time_constant_s,
            "{format:?}: τ {}",
            g.sls_time_constant_s
        );
        let tol = 0.01 + 0.01 + dt / t.max_lag_s;
        if m.lag_is_relative {
            // An estimated offset leaves relative lags: Q is withheld, with an upper
            // bound the truth does not exceed.
            assert!(g.quality_q_pm_per_n_s.is_none(), "{format:?}: Q given");
            let b = g.quality_q_bound.expect("an upper bound on Q");
            assert_eq!(b.kind, BoundKind::Upper);
            assert!(
                b.value_pm_per_n_s >= t.quality_q_expected * (1.0 - tol),
                "{format:?}: Q bound {} vs truth {}",
                b.value_pm_per_n_s,
                t.quality_q_expected
            );
            assert!(g.quality_q_note.as_deref().unwrap().contains("estimated"));
            continue;
        }
        let q = g.quality_q_pm_per_n_s.unwrap();
        // Q is computed from the reported K, R² and Δt_max ...
        assert!((q - g.sensitivity_pm_per_n.abs() * g.r_squared / g.max_lag_s).abs() < 1e-9 * q);
        // ... and agrees with the truth within the propagated tolerances.
        assert!(
            (q - t.quality_q_expected).abs() <= tol * t.quality_q_expected,
            "{format:?}: Q {q} vs {}",
            t.quality_q_expected
        );
    }
}

#[test]
fn every_format_recovers_k_lag_offset_r2_and_q() {
    let cfg = SynthConfig::default();
    for format in LogFormat::ALL {
        let (m, truth) = run(format, &cfg, &LogStyle::default(), None);
        check(format, &m, &truth, &cfg);
        // With the offset given the lags are absolute and Q is given (the formats
        // whose written clock reproduces the offset exactly: the straight-line R²
        // moves with an offset off by a fraction of a row).
        if format == LogFormat::Imon {
            continue;
        }
        let given = synth::reported_offset_s(&cfg, format);
        let (m, truth) = run_offset(format, &cfg, &LogStyle::default(), None, Some(given));
        assert!(!m.lag_is_relative);
        check(format, &m, &truth, &cfg);
    }
}

#[test]
fn a_temperature_ramp_is_removed_by_the_reference_grating_in_every_format() {
    // 0.1 K/s up for half the run and back down: ≈ 33 pm of thermal shift, more than
    // the 10 N pulse produces, and not a straight line in time.
    let cfg = SynthConfig {
        temperature_ramp_k_per_s: 0.1,
        dropout_fraction: 0.03,
        seed: 7,
        ..Default::default()
    };
    for format in LogFormat::ALL {
        let style = LogStyle {
            decimal_comma: format != LogFormat::Imon,
            bom: true,
            metadata_lines: 104,
            twelve_hour: format == LogFormat::EnlightPeaks,
            ..Default::default()
        };
        let (m, truth) = run(format, &cfg, &style, Some("psc1"));
        assert_eq!(m.reference_grating.as_deref(), Some("lambda_temp"));
        check(format, &m, &truth, &cfg);
    }
}

#[test]
fn without_the_reference_grating_the_ramp_spoils_k() {
    // Control for the test above: the same log analysed with a design that has no
    // reference grating gives a K off by more than the 1 % tolerance.
    let cfg = SynthConfig {
        temperature_ramp_k_per_s: 0.1,
        seed: 7,
        ..Default::default()
    };
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let (log, force, truth) = synth::generate(&d, &cfg).unwrap();
    let (lp, fp) = (dir.path().join("log.csv"), dir.path().join("force.csv"));
    synth::write_log(&lp, LogFormat::Csv, &log, &cfg, &LogStyle::default()).unwrap();
    synth::write_force_csv(&fp, &force).unwrap();
    let mut no_ref = d.clone();
    no_ref
        .module
        .as_mut()
        .unwrap()
        .gratings
        .retain(|g| g.role == fbgforge::spec::GratingRole::Strain);
    let pl = logs::read_peak_log(&lp, &ReadOptions::default()).unwrap();
    let fl = logs::read_force_log(&fp, &ForceReadOptions::default()).unwrap();
    let (m, _) = analyse(&no_ref, &pl, &fl, &AnalysisOptions::default()).unwrap();
    assert_eq!(m.warnings.count("reference_missing"), 1);
    let err = (m.gratings[0].sensitivity_pm_per_n - truth.gratings[0].sensitivity_pm_per_n).abs()
        / truth.gratings[0].sensitivity_pm_per_n;
    assert!(err > 0.01, "K error without reference only {err}");
}

#[test]
fn case_ii_blue_shift_at_the_sm125_rate() {
    // 2 Hz like the SM125, a negative K (Case II, hollow core), slower pulses.
    let cfg = SynthConfig {
        core: Some("psc2".into()),
        sensitivity_pm_per_n: -20.0,
        sample_rate_hz: 2.0,
        force_rate_hz: 50.0,
        pulses: synth::pulse_train(&[10.0, 30.0, 50.0, 20.0, 40.0], 10.0, 15.0, 10.0),
        duration_s: 140.0,
        tau_s: 1.5,
        instant_fraction: 0.4,
        force_start_s: 3.3,
        ..Default::default()
    };
    for format in [LogFormat::EnlightPeaks, LogFormat::Imon] {
        let (m, truth) = run(format, &cfg, &LogStyle::default(), Some("psc2"));
        assert!(m.gratings.iter().all(|g| g.sensitivity_pm_per_n < 0.0));
        check(format, &m, &truth, &cfg);
    }
}

/// Model predictions that agree exactly with whatever K was measured: without a
/// response gate, every grating of any log would PASS against them.
fn flattering_predictions(m: &Measurement) -> Vec<fbgforge::model::GratingPrediction> {
    m.gratings
        .iter()
        .map(|g| fbgforge::model::GratingPrediction {
            grating: g.grating.clone(),
            core: g.core.clone().unwrap_or_default(),
            case: fbgforge::model::LoadCase::II,
            insert: None,
            sensitivity_pm_per_n: g.sensitivity_pm_per_n,
            shift_pm: 0.0,
            strain: 0.0,
            warnings: vec![],
        })
        .collect()
}

fn verdict_of(m: &Measurement) -> fbgforge::verify::verdict::Verdict {
    let preds = flattering_predictions(m);
    fbgforge::verify::verdict::verdicts(
        m,
        Ok(&preds),
        fbgforge::model::LoadCase::II,
        None,
        fbgforge::verify::verdict::DEFAULT_TOLERANCE,
    )
}

#[test]
fn an_unloaded_sensor_never_passes_whatever_the_model_says() {
    use fbgforge::verify::verdict::Status;
    // No response at all: the wavelength wanders (drift, a temperature ramp the
    // reference does not see) while the force log has its pulses.
    for (seed, drift) in [(1u64, 0.05), (2, 0.5), (3, -0.3)] {
        let cfg = SynthConfig {
            sensitivity_pm_per_n: 0.0,
            noise_pm: 0.5,
            drift_pm_per_s: drift,
            seed,
            ..SynthConfig::default()
        };
        let (m, _) = run(LogFormat::EnlightPeaks, &cfg, &LogStyle::default(), None);
        let v = verdict_of(&m);
        assert_eq!(v.overall, Status::NoResponse, "seed {seed}: {v:?}");
        for g in &v.gratings {
            assert_eq!(g.status, Status::NoResponse, "{g:?}");
            assert!(g.reason.as_deref().is_some_and(|r| !r.is_empty()));
        }
    }
}

#[test]
fn a_log_against_an_unrelated_force_log_is_not_judged() {
    use fbgforge::verify::verdict::Status;
    // The sensor responded, but to other pulses than the force log holds.
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let cfg = SynthConfig::default();
    let other = SynthConfig {
        pulses: synth::pulse_train(&[30.0, 10.0, 50.0], 3.0, 14.0, 9.0),
        seed: 9,
        ..SynthConfig::default()
    };
    let (log, _, _) = synth::generate(&d, &cfg).unwrap();
    let (_, force, _) = synth::generate(&d, &other).unwrap();
    let lp = dir.path().join("log.txt");
    let fp = dir.path().join("force.csv");
    synth::write_log(
        &lp,
        LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &LogStyle::default(),
    )
    .unwrap();
    synth::write_force_csv(&fp, &force).unwrap();
    let pl = logs::read_peak_log(&lp, &ReadOptions::default()).unwrap();
    let fl = logs::read_force_log(&fp, &ForceReadOptions::default()).unwrap();
    let opts = AnalysisOptions {
        clock_offset_s: Some(synth::reported_offset_s(&cfg, LogFormat::EnlightPeaks)),
        ..Default::default()
    };
    let (m, _) = analyse(&d, &pl, &fl, &opts).unwrap();
    let v = verdict_of(&m);
    assert_ne!(v.overall, Status::Pass, "{v:?}");
    // Silent against this force log, but the shift shows a press where it rests: NOT
    // JUDGED (unexplained: another run's force, or a wrong offset), not NO RESPONSE.
    assert_eq!(v.overall, Status::NotJudged, "{v:?}");
    for g in &v.gratings {
        assert_eq!(g.status, Status::NotJudged, "{v:?}");
        assert_eq!(
            g.reason_code,
            Some(fbgforge::verify::verdict::ReasonCode::Unexplained),
            "{v:?}"
        );
        assert!(
            g.reason
                .as_deref()
                .unwrap()
                .contains("is at rest or has no samples"),
            "{v:?}"
        );
    }
}

#[test]
fn a_real_response_passes_the_gate_and_is_judged() {
    use fbgforge::verify::verdict::Status;
    let cfg = SynthConfig::default();
    let (m, _) = run(LogFormat::EnlightPeaks, &cfg, &LogStyle::default(), None);
    let v = verdict_of(&m);
    assert_eq!(v.overall, Status::Pass, "{v:?}");
    for g in &m.gratings {
        // Autocorrelated residuals widen the standard error, never narrow it.
        assert!(g.sensitivity_std_error_effective_pm_per_n >= g.sensitivity_std_error_pm_per_n);
        assert!(g.effective_samples >= 2.0);
    }
}

fn analyse_with(cfg: &SynthConfig, opts: &AnalysisOptions) -> Measurement {
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let (log, force, _) = synth::generate(&d, cfg).unwrap();
    let lp = dir.path().join("log.txt");
    let fp = dir.path().join("force.csv");
    synth::write_log(
        &lp,
        LogFormat::EnlightPeaks,
        &log,
        cfg,
        &LogStyle::default(),
    )
    .unwrap();
    synth::write_force_csv(&fp, &force).unwrap();
    let pl = logs::read_peak_log(&lp, &ReadOptions::default()).unwrap();
    let fl = logs::read_force_log(&fp, &ForceReadOptions::default()).unwrap();
    analyse(&d, &pl, &fl, opts).unwrap().0
}

#[test]
fn the_offset_search_stays_inside_max_offset_and_estimated_lags_are_marked_relative() {
    let cfg = SynthConfig::default();
    let free = analyse_with(&cfg, &AnalysisOptions::default());
    assert!(
        free.lag_is_relative,
        "an estimated offset leaves relative lags"
    );
    // The true offset (-1.7 s) lies outside ±0.05 s: the estimate stops at the bound
    // and says so.
    let bounded = analyse_with(
        &cfg,
        &AnalysisOptions {
            max_clock_offset_s: 0.05,
            ..Default::default()
        },
    );
    // The residual offset searched around the logs' own start times is the force log's
    // start on the wavelength clock, which the truth puts at -1.7 s.
    assert!(
        (free.force_log_start_s + 1.7).abs() <= 0.05,
        "{}",
        free.force_log_start_s
    );
    assert!(
        bounded.force_log_start_s.abs() <= 0.05 + 1e-9,
        "{}",
        bounded.force_log_start_s
    );
    assert_eq!(bounded.warnings.count("clock_offset_at_limit"), 1);
    // A given offset gives absolute lags.
    let given = analyse_with(
        &cfg,
        &AnalysisOptions {
            clock_offset_s: Some(synth::reported_offset_s(&cfg, LogFormat::EnlightPeaks)),
            ..Default::default()
        },
    );
    assert!(!given.lag_is_relative);
    let report = fbgforge::verify::report::VerifyReport {
        design: "d".into(),
        verdict: fbgforge::verify::verdict::verdicts(
            &free,
            Err("none".into()),
            fbgforge::model::LoadCase::II,
            None,
            0.08,
        ),
        measurement: free,
    };
    assert!(fbgforge::report::verify::summary(&report).contains("RELATIVE"));
}

#[test]
fn the_chart_fit_line_shows_the_table_k() {
    let d = design();
    let cfg = SynthConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let (log, force, _) = synth::generate(&d, &cfg).unwrap();
    let lp = dir.path().join("log.txt");
    let fp = dir.path().join("force.csv");
    synth::write_log(
        &lp,
        LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &LogStyle::default(),
    )
    .unwrap();
    synth::write_force_csv(&fp, &force).unwrap();
    let pl = logs::read_peak_log(&lp, &ReadOptions::default()).unwrap();
    let fl = logs::read_force_log(&fp, &ForceReadOptions::default()).unwrap();
    let (m, series) = analyse(&d, &pl, &fl, &AnalysisOptions::default()).unwrap();
    assert_eq!(series.fit.len(), m.gratings.len());
    for (g, (name, k, _)) in m.gratings.iter().zip(&series.fit) {
        assert_eq!(&g.grating, name);
        assert_eq!(*k, g.sensitivity_pm_per_n);
    }
}

#[test]
fn force_start_read_off_the_wall_clock_gives_the_true_offset_and_absolute_lags() {
    let d = common::shipped_path("clip-on-34mm.toml");
    let design = design();
    let cfg = SynthConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let (log, force, _) = synth::generate(&design, &cfg).unwrap();
    let lp = dir.path().join("log.txt");
    let fp = dir.path().join("force.csv");
    synth::write_log(
        &lp,
        LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &LogStyle::default(),
    )
    .unwrap();
    synth::write_force_csv(&fp, &force).unwrap();
    // The wavelength log starts at 17/04/2025 15:44:56; the force recording started
    // 1.7 s earlier.
    let mut req = fbgforge::verify::VerifyRequest::new(d.clone(), lp.clone(), fp.clone());
    req.force_start = Some("2025-04-17 15:44:54.3".into());
    let m = fbgforge::verify::run(&req).unwrap().report.measurement;
    let truth = synth::reported_offset_s(&cfg, LogFormat::EnlightPeaks);
    assert!(
        (m.clock_offset_s - truth).abs() < 1e-6,
        "{} vs {truth}",
        m.clock_offset_s
    );
    assert!(!m.lag_is_relative);
    assert!((m.force_log_start_s + 1.7).abs() < 1e-6);
    // With a wavelength log on a relative clock there is no wall clock to read it off.
    let cp = dir.path().join("log.csv");
    synth::write_log(&cp, LogFormat::Csv, &log, &cfg, &LogStyle::default()).unwrap();
    let mut req = fbgforge::verify::VerifyRequest::new(d, cp, fp);
    req.force_start = Some("2025-04-17 15:44:54.3".into());
    let e = format!("{:#}", fbgforge::verify::run(&req).unwrap_err());
    assert!(e.contains("VerifyRequest.force_start needs"), "{e}");
}

#[test]
fn a_handed_over_log_and_decimated_plots_give_the_same_answers() {
    // The memory goal of issue #33: `run` hands the logs over (the peaks freed once
    // assigned to gratings, the two logs' times shifted in place into the analysis's
    // time bases), the shifts are rebuilt per grating, and the plots keep
    // each bucket's first row and extremes. On a 32 500-row log (decimated: more than
    // 20 000 rows) the report equals the borrowed path's field for field (K, R², Δt_max,
    // verdict, warnings), and the plots keep the largest force the analysis saw.
    use fbgforge::verify::run::{judge, read_inputs};
    use fbgforge::verify::{run, VerifyRequest};
    let cfg = SynthConfig {
        sample_rate_hz: 500.0,
        force_rate_hz: 500.0,
        ..SynthConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let (log, force, _) = synth::generate(&design(), &cfg).unwrap();
    let lp = dir.path().join("log.txt");
    let fp = dir.path().join("force.csv");
    synth::write_log(
        &lp,
        LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &LogStyle::default(),
    )
    .unwrap();
    synth::write_force_csv(&fp, &force).unwrap();
    let req = VerifyRequest::new(common::shipped_path("clip-on-34mm.toml"), lp, fp);
    let handed = run(&req).unwrap();
    let inputs = read_inputs(&req).unwrap();
    let rows = inputs.log.rows();
    assert!(rows > 30_000, "{rows}");
    let borrowed = judge(&req, &inputs).unwrap();
    let json = |r| serde_json::to_value(r).unwrap();
    assert_eq!(json(&handed.report), json(&borrowed.report));
    // The path of a long log (its peaks assigned to the gratings as it was read, the
    // logs handed over with the tracks, their times shifted in place): the borrowed
    // path's measurement and plots, bit for bit.
    use fbgforge::verify::analysis::{analyse, analyse_assigned, grating_windows};
    let (design, opts) = (&inputs.design, &req.analysis);
    let tracks =
        fbgforge::logs::assign::assign(&inputs.log, &grating_windows(design, opts).unwrap());
    let mut peakless = inputs.log.clone();
    peakless.drop_peaks();
    let (m, s) = analyse_assigned(design, peakless, tracks, inputs.force.clone(), opts).unwrap();
    let (mb, sb) = analyse(design, &inputs.log, &inputs.force, opts).unwrap();
    let value = |m| serde_json::to_value(m).unwrap();
    assert_eq!(value(&m), value(&mb));
    assert_eq!(format!("{s:?}"), format!("{sb:?}"));
    let series = &handed.series;
    assert!(series.time_s.len() < rows / 2, "{}", series.time_s.len());
    let t0 = inputs.log.time_s[0];
    let times: std::collections::HashSet<u64> = inputs
        .log
        .time_s
        .iter()
        .map(|t| (t - t0).to_bits())
        .collect();
    assert!(series.time_s.iter().all(|t| times.contains(&t.to_bits())));
    let top = series.force_n.iter().copied().fold(f64::NAN, f64::max);
    assert_eq!(top, handed.report.measurement.peak_force_n);
    for (name, v) in &series.shift_pm {
        assert_eq!(v.len(), series.time_s.len(), "{name}");
    }
}
