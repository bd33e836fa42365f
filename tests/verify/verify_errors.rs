//! Bad inputs to the verifier: clear errors or counted warnings, never a panic; and
//! the verdict rule applied to model predictions.

use crate::common;
use fbgforge::logs::{self, ForceReadOptions, LogFormat, ReadOptions};
use fbgforge::model::{GratingPrediction, LoadCase};
use fbgforge::synth::module_log::{self as synth, LogStyle, SynthConfig};
use fbgforge::verify::analysis::{analyse, AnalysisOptions};
use fbgforge::verify::verdict::{verdicts, Status};
use std::path::Path;

fn design() -> fbgforge::spec::Design {
    common::shipped("clip-on-34mm.toml")
}

/// Write a synthetic log as an ENLIGHT Peaks export with the default style.
fn write_peaks(path: &Path, log: &synth::SynthLog, cfg: &SynthConfig) {
    synth::write_log(
        path,
        LogFormat::EnlightPeaks,
        log,
        cfg,
        &LogStyle::default(),
    )
    .unwrap();
}

/// Read a wavelength log and a `time_s,force_N` force log with default options.
fn read_pair(lp: &Path, fp: &Path) -> anyhow::Result<(logs::PeakLog, logs::ForceLog)> {
    Ok((
        logs::read_peak_log(lp, &ReadOptions::default())?,
        logs::read_force_log(fp, &ForceReadOptions::default())?,
    ))
}

/// Write a synthetic pair after `edit` has changed the log, and analyse it.
fn analyse_edited(
    cfg: &SynthConfig,
    edit: impl FnOnce(&mut synth::SynthLog),
    opts: &AnalysisOptions,
) -> anyhow::Result<fbgforge::verify::analysis::Measurement> {
    let d = design();
    let dir = tempfile::tempdir().unwrap();
    let (mut log, force, _) = synth::generate(&d, cfg).unwrap();
    edit(&mut log);
    let (lp, fp) = (dir.path().join("log.txt"), dir.path().join("force.csv"));
    write_peaks(&lp, &log, cfg);
    synth::write_force_csv(&fp, &force).unwrap();
    let (pl, fl) = read_pair(&lp, &fp)?;
    analyse(&d, &pl, &fl, opts).map(|(m, _)| m)
}

#[test]
fn a_force_log_that_does_not_overlap_is_an_error_naming_both_files() {
    // Both logs on wall clocks; the force recording starts 500 s after the wavelength
    // log ended.
    let d = design();
    let cfg = SynthConfig {
        force_start_s: 565.0,
        ..Default::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let (log, force, _) = synth::generate(&d, &cfg).unwrap();
    let (lp, fp) = (dir.path().join("log.txt"), dir.path().join("stand.csv"));
    write_peaks(&lp, &log, &cfg);
    synth::write_force_stand_csv(&fp, &force, cfg.start_epoch_s + cfg.force_start_s).unwrap();
    let pl = logs::read_peak_log(&lp, &ReadOptions::default()).unwrap();
    let cols = ForceReadOptions {
        time: Some("AbsTime".into()),
        ..Default::default()
    };
    let fl = logs::read_force_log(&fp, &cols).unwrap();
    assert_eq!(fl.clock, logs::Clock::Absolute);
    let e = analyse(&d, &pl, &fl, &AnalysisOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("does not overlap")
            && e.contains("stand.csv")
            && e.contains("log.txt")
            && e.contains("AnalysisOptions.max_clock_offset_s"),
        "{e}"
    );
    // With both logs on relative clocks the starts are aligned, so the same force log
    // overlaps unless the user states the true offset, which then is checked too.
    let opts = AnalysisOptions {
        clock_offset_s: Some(-1.0e6),
        ..Default::default()
    };
    let e = analyse_edited(&SynthConfig::default(), |_| {}, &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("does not overlap"), "{e}");
}

#[test]
fn a_missing_grating_is_an_error_for_its_core_and_a_warning_otherwise() {
    let drop_l12 = |log: &mut synth::SynthLog| {
        let k = log.names.iter().position(|n| n == "lambda_12").unwrap();
        for row in &mut log.wavelength_nm {
            row[k] = f64::NAN;
        }
    };
    let opts = AnalysisOptions {
        core: Some("psc1".into()),
        ..Default::default()
    };
    let e = analyse_edited(&SynthConfig::default(), drop_l12, &opts)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("lambda_12") && e.contains("channel connected"),
        "{e}"
    );
    // Without --core: lambda_12 (its core, psc1, is in the log) is counted as missing;
    // the psc2 gratings are not, since no psc2 grating is in the log (psc2 is not the
    // core under test: issue 12); lambda_11 is still measured.
    let m = analyse_edited(
        &SynthConfig::default(),
        drop_l12,
        &AnalysisOptions::default(),
    )
    .unwrap();
    assert_eq!(m.warnings.count("grating_missing"), 1, "{:?}", m.warnings);
    assert!(m.warnings.counts["grating_missing"]
        .first
        .contains("lambda_12"));
    assert_eq!(m.gratings.len(), 1);
    assert!((m.gratings[0].sensitivity_pm_per_n - 12.0).abs() < 0.12);
}

#[test]
fn an_unknown_core_or_a_log_without_pulses_is_reported() {
    let opts = AnalysisOptions {
        core: Some("psc9".into()),
        ..Default::default()
    };
    let e = analyse_edited(&SynthConfig::default(), |_| {}, &opts)
        .unwrap_err()
        .to_string();
    assert!(e.contains("psc9") && e.contains("psc1, psc2"), "{e}");
    // A force log with no pulses (only noise) is an error that says so.
    let d = design();
    let cfg = SynthConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let (log, mut force, _) = synth::generate(&d, &cfg).unwrap();
    for (i, f) in force.force_n.iter_mut().enumerate() {
        *f = 0.01 * ((i * 7919) % 13) as f64;
    }
    let (lp, fp) = (dir.path().join("log.txt"), dir.path().join("force.csv"));
    write_peaks(&lp, &log, &cfg);
    synth::write_force_csv(&fp, &force).unwrap();
    let (pl, fl) = read_pair(&lp, &fp).unwrap();
    let e = analyse(&d, &pl, &fl, &AnalysisOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no loading pulse"), "{e}");
    // A profile without pulses cannot even be synthesised.
    let cfg = SynthConfig {
        pulses: vec![],
        ..Default::default()
    };
    assert!(synth::generate(&d, &cfg).is_err());
}

#[test]
fn garbage_lines_inside_a_synthetic_log_are_counted_in_the_report() {
    let d = design();
    let cfg = SynthConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let (log, force, truth) = synth::generate(&d, &cfg).unwrap();
    let (lp, fp) = (dir.path().join("log.txt"), dir.path().join("force.csv"));
    write_peaks(&lp, &log, &cfg);
    synth::write_force_csv(&fp, &force).unwrap();
    let mut text = std::fs::read_to_string(&lp).unwrap();
    let at = text.len() / 2;
    let nl = at + text[at..].find('\n').unwrap() + 1;
    text.insert_str(
        nl,
        "*** interrogator reconnected ***\n\u{0}\u{1}binary junk\n",
    );
    text.push_str("17/04/2025 15:46:0");
    std::fs::write(&lp, text).unwrap();
    let (pl, fl) = read_pair(&lp, &fp).unwrap();
    let (m, _) = analyse(&d, &pl, &fl, &AnalysisOptions::default()).unwrap();
    assert_eq!(m.warnings.count("unreadable_line"), 2);
    assert_eq!(m.warnings.count("truncated_last_line"), 1);
    let k = truth.gratings[0].sensitivity_pm_per_n;
    assert!((m.gratings[0].sensitivity_pm_per_n - k).abs() / k < 0.01);
}

fn prediction(grating: &str, case: LoadCase, insert: Option<&str>, k: f64) -> GratingPrediction {
    GratingPrediction {
        grating: grating.into(),
        core: "psc1".into(),
        case,
        insert: insert.map(String::from),
        sensitivity_pm_per_n: k,
        shift_pm: 10.0 * k,
        strain: 0.0,
        warnings: vec![],
    }
}

#[test]
fn verdict_picks_the_prediction_for_grating_case_and_insert() {
    let m = analyse_edited(
        &SynthConfig::default(),
        |_| {},
        &AnalysisOptions {
            core: Some("psc1".into()),
            ..Default::default()
        },
    )
    .unwrap();
    let k11 = m.gratings[0].sensitivity_pm_per_n;
    let k12 = m.gratings[1].sensitivity_pm_per_n;
    let preds = vec![
        prediction("lambda_11", LoadCase::I, Some("blue"), k11 / 1.0774), // measured 7.74 % high
        prediction("lambda_12", LoadCase::I, Some("blue"), k12 / 1.061),
        prediction("lambda_11", LoadCase::I, Some("light_green"), k11 / 1.2),
        prediction("lambda_12", LoadCase::I, Some("light_green"), k12),
        prediction("lambda_11", LoadCase::II, None, 2.0 * k11),
    ];
    let v = verdicts(&m, Ok(&preds), LoadCase::I, Some("blue"), 0.08);
    assert_eq!(v.overall, Status::Pass);
    assert!((v.gratings[0].relative_error.unwrap() - 0.0774).abs() < 1e-9);
    let v = verdicts(&m, Ok(&preds), LoadCase::I, Some("light_green"), 0.08);
    assert_eq!(
        (v.gratings[0].status, v.gratings[1].status, v.overall),
        (Status::Fail, Status::Pass, Status::Fail)
    );
    // Case II has a prediction for lambda_11 only: lambda_12 is not judged, the run fails.
    let v = verdicts(&m, Ok(&preds), LoadCase::II, None, 0.08);
    assert_eq!(
        (v.gratings[0].status, v.gratings[1].status),
        (Status::Fail, Status::NotJudged)
    );
    // Case I without the insert cannot be judged, and says why.
    let v = verdicts(&m, Ok(&preds), LoadCase::I, None, 0.08);
    assert_eq!(v.overall, Status::NotJudged);
    assert!(v.gratings[0]
        .reason
        .as_deref()
        .unwrap()
        .contains("VerifyRequest.insert"));
    // No model available: not judged, with the model's message.
    let v = verdicts(
        &m,
        Err("the model is not available".into()),
        LoadCase::II,
        None,
        0.08,
    );
    assert_eq!(v.overall, Status::NotJudged);
    assert!(v.gratings[1]
        .reason
        .as_deref()
        .unwrap()
        .contains("not available"));
}

mod never_panics {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(
            std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(24)
        ))]
        /// Whole runs with corrupted lines, wild values and truncation: the analysis
        /// answers Ok or Err, never panics.
        #[test]
        fn corrupted_runs_are_analysed_or_rejected(
            edits in prop::collection::vec((any::<prop::sample::Index>(), 0u8..4), 1..40),
            cut in 0.2f64..1.0,
        ) {
            let d = design();
            let cfg = SynthConfig { duration_s: 30.0, pulses: synth::pulse_train(&[20.0, 40.0], 4.0, 6.0, 5.0), ..Default::default() };
            let dir = tempfile::tempdir().unwrap();
            let (log, force, _) = synth::generate(&d, &cfg).unwrap();
            let (lp, fp) = (dir.path().join("log.csv"), dir.path().join("force.csv"));
            synth::write_log(&lp, LogFormat::Csv, &log, &cfg, &LogStyle::default()).unwrap();
            synth::write_force_csv(&fp, &force).unwrap();
            let text = std::fs::read_to_string(&lp).unwrap();
            let mut lines: Vec<String> = text.lines().map(String::from).collect();
            for (at, kind) in edits {
                let i = 1 + at.index(lines.len() - 1);
                lines[i] = match kind {
                    0 => "garbage,,,".to_string(),
                    1 => lines[i].replace("154", "99"),
                    2 => lines[i].replacen(',', ",1e300,", 1),
                    _ => lines[lines.len() - i].clone(),
                };
            }
            let keep = ((lines.len() as f64) * cut) as usize;
            std::fs::write(&lp, lines[..keep.max(2)].join("\n")).unwrap();
            let Ok(pl) = logs::read_peak_log(&lp, &ReadOptions::default()) else { return Ok(()) };
            let fl = logs::read_force_log(&fp, &ForceReadOptions::default()).unwrap();
            let _ = analyse(&d, &pl, &fl, &AnalysisOptions::default());
        }
    }
}

mod never_panics_on_force_logs_and_options {
    use super::*;
    use proptest::prelude::*;

    /// Values that have broken number handling before.
    fn wild() -> impl Strategy<Value = f64> {
        prop_oneof![
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(1e308),
            Just(-1e308),
            Just(-9e307),
            Just(0.0),
            Just(-1.0),
            Just(5e-324),
            -1e3f64..1e3,
        ]
    }

    /// Mostly the default (so that most runs reach the analysis), sometimes wild.
    fn opt_wild() -> impl Strategy<Value = Option<f64>> {
        prop_oneof![4 => Just(None), 1 => wild().prop_map(Some)]
    }

    fn or_wild(default: f64) -> impl Strategy<Value = f64> {
        prop_oneof![4 => Just(default), 1 => wild()]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(
            std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(24)
        ))]
        /// A force log with corrupted times and forces (NaN, ±1e308, −9e307, text,
        /// swapped and cut lines) and wild options: the verifier answers Ok or Err,
        /// never panics.
        #[test]
        fn mutated_force_logs_and_options_are_verified_or_refused(
            edits in prop::collection::vec((any::<prop::sample::Index>(), 0u8..6, wild()), 0..8),
            cut in 0.05f64..1.0,
            clock_offset in opt_wild(),
            max_offset in or_wild(60.0),
            window in opt_wild(),
            resolution in opt_wild(),
            tolerance in or_wild(0.08),
            scale in opt_wild(),
        ) {
            let d = common::shipped_path("clip-on-34mm.toml");
            let design = design();
            let cfg = SynthConfig { duration_s: 30.0, pulses: synth::pulse_train(&[20.0, 40.0], 4.0, 6.0, 5.0), ..Default::default() };
            let dir = tempfile::tempdir().unwrap();
            let (log, force, _) = synth::generate(&design, &cfg).unwrap();
            let (lp, fp) = (dir.path().join("log.txt"), dir.path().join("force.csv"));
            write_peaks(&lp, &log, &cfg);
            synth::write_force_csv(&fp, &force).unwrap();
            let text = std::fs::read_to_string(&fp).unwrap();
            let mut lines: Vec<String> = text.lines().map(String::from).collect();
            for (at, kind, v) in edits {
                let i = 1 + at.index(lines.len() - 1);
                let (t, f) = lines[i].split_once(',').map(|(a, b)| (a.to_string(), b.to_string())).unwrap_or_default();
                lines[i] = match kind {
                    0 => format!("{v},{f}"),
                    1 => format!("{t},{v}"),
                    2 => format!("{v},{v}"),
                    3 => "garbage,text".to_string(),
                    4 => lines[lines.len() - i].clone(),
                    _ => String::new(),
                };
            }
            let keep = ((lines.len() as f64) * cut) as usize;
            std::fs::write(&fp, lines[..keep.max(1)].join("\n")).unwrap();
            let mut req = fbgforge::verify::VerifyRequest::new(d, lp, fp);
            req.analysis.clock_offset_s = clock_offset;
            req.analysis.max_clock_offset_s = max_offset;
            req.analysis.window_half_width_nm = window;
            req.analysis.resolution_pm = resolution;
            req.k_tolerance = tolerance;
            req.force_read.scale_to_n = scale;
            // Outputs of an answered run are written too (no panic in the report).
            if let Ok(out) = fbgforge::verify::run(&req) {
                let _ = fbgforge::report::verify::summary(&out.report);
                fbgforge::report::verify::write_report(&dir.path().join("r"), &out.report, &out.series).unwrap();
            }
        }
    }
}

#[test]
fn a_corrupted_time_at_either_end_of_the_force_log_is_refused_naming_its_line() {
    // Neither runs backwards, but either would stretch the log over an absurd span
    // (-9e307 as the first time panicked in the fit before).
    let d = common::shipped_path("clip-on-34mm.toml");
    let design = design();
    let cfg = SynthConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let (log, force, _) = synth::generate(&design, &cfg).unwrap();
    let lp = dir.path().join("log.txt");
    write_peaks(&lp, &log, &cfg);
    let fp = dir.path().join("force.csv");
    synth::write_force_csv(&fp, &force).unwrap();
    let text = std::fs::read_to_string(&fp).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let n = lines.len();
    for (line, value) in [(2usize, "-9e307"), (n, "1e308"), (n, "1e6")] {
        let mut edited: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        let rest = edited[line - 1].split_once(',').unwrap().1.to_string();
        edited[line - 1] = format!("{value},{rest}");
        let bad = dir.path().join("bad.csv");
        std::fs::write(&bad, edited.join("\n")).unwrap();
        let req = fbgforge::verify::VerifyRequest::new(d.clone(), lp.clone(), bad);
        let e = format!("{:#}", fbgforge::verify::run(&req).unwrap_err());
        assert!(
            e.contains(&format!("bad.csv:{line}:")) && e.contains("corrupted time"),
            "{value} at line {line}: {e}"
        );
    }
}

#[test]
fn compression_logged_as_negative_force_is_flipped_and_counted() {
    let d = design();
    let cfg = SynthConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let (log, mut force, truth) = synth::generate(&d, &cfg).unwrap();
    force.force_n.iter_mut().for_each(|f| *f = -*f);
    let (lp, fp) = (dir.path().join("log.txt"), dir.path().join("force.csv"));
    write_peaks(&lp, &log, &cfg);
    synth::write_force_csv(&fp, &force).unwrap();
    let (pl, fl) = read_pair(&lp, &fp).unwrap();
    let (m, _) = analyse(&d, &pl, &fl, &AnalysisOptions::default()).unwrap();
    assert_eq!(m.warnings.count("force_sign_flipped"), 1);
    let k = truth.gratings[0].sensitivity_pm_per_n;
    assert!((m.gratings[0].sensitivity_pm_per_n - k).abs() / k < 0.01);
    assert_eq!(m.gratings[0].pulses.len(), truth.gratings[0].lags_s.len());
}

#[test]
fn chunked_parallel_parsing_keeps_rows_and_line_numbers() {
    // Over 4 MB, so the body is split into chunks parsed in parallel.
    let d = design();
    let cfg = SynthConfig {
        sample_rate_hz: 1000.0,
        duration_s: 90.0,
        ..Default::default()
    };
    let (log, _, _) = synth::generate(&d, &cfg).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let lp = dir.path().join("big.txt");
    write_peaks(&lp, &log, &cfg);
    let text = std::fs::read_to_string(&lp).unwrap();
    assert!(text.len() > 5 << 20, "{} bytes", text.len());
    let mut lines: Vec<&str> = text.lines().collect();
    let header = lines
        .iter()
        .position(|l| l.starts_with("Timestamp\t"))
        .unwrap();
    // Garbage at three places; remember their 1-based line numbers.
    let targets = [header + 10, lines.len() / 2, lines.len() - 3];
    for &i in &targets {
        lines[i] = "garbage";
    }
    std::fs::write(&lp, lines.join("\n") + "\n").unwrap();
    let pl = logs::read_peak_log(&lp, &ReadOptions::default()).unwrap();
    assert_eq!(pl.rows(), log.time_s.len() - 3);
    assert_eq!(pl.warnings.count("unreadable_line"), 3);
    let first = &pl.warnings.counts["unreadable_line"].first;
    assert!(
        first.contains(&format!("big.txt:{}: ", targets[0] + 1)),
        "{first}"
    );
    // Every row keeps its own line number and its peaks.
    for (r, &line) in pl.line_of_row.iter().enumerate().step_by(997) {
        let want = lines[line as usize - 1];
        let first_peak = want.split('\t').nth(4).unwrap().parse::<f64>().unwrap();
        assert_eq!(pl.row(r).0[0], first_peak, "row {r} line {line}");
    }
    // Epoch seconds near 1.7e9 carry about 0.2 µs of rounding.
    assert!((pl.median_period_s() - 1e-3).abs() < 1e-6);
}

#[test]
fn a_shift_that_leaves_its_window_under_load_is_reported() {
    // 150 pm/N at up to 60 N is a 9 nm shift: far outside the default ±2.5 nm window,
    // so the high-force rows lose their peak and the fit would be biased low.
    let cfg = SynthConfig {
        sensitivity_pm_per_n: 150.0,
        ..Default::default()
    };
    let big = analyse_edited(&cfg, |_| {}, &AnalysisOptions::default()).unwrap();
    assert!(big.warnings.count("peaks_outside_window") > 0);
    // The default 12 pm/N stays inside its window: no such warning.
    let small =
        analyse_edited(&SynthConfig::default(), |_| {}, &AnalysisOptions::default()).unwrap();
    assert_eq!(small.warnings.count("peaks_outside_window"), 0);
}

#[test]
fn a_corrupted_force_time_is_refused_naming_its_line_and_a_nan_offset_is_an_error() {
    // One time of -1e308 among the samples: an error naming line 6, not a panic and not
    // a K stretched over an absurd span.
    let d = common::shipped_path("clip-on-34mm.toml");
    let dir = tempfile::tempdir().unwrap();
    let design = common::shipped("clip-on-34mm.toml");
    let cfg = fbgforge::synth::module_log::SynthConfig::default();
    let (log, force, _) = fbgforge::synth::module_log::generate(&design, &cfg).unwrap();
    let lp = dir.path().join("log.txt");
    let fp = dir.path().join("force.csv");
    fbgforge::synth::module_log::write_log(
        &lp,
        fbgforge::logs::LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &fbgforge::synth::module_log::LogStyle::default(),
    )
    .unwrap();
    fbgforge::synth::module_log::write_force_csv(&fp, &force).unwrap();
    let text = std::fs::read_to_string(&fp).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let rest = lines[5].split_once(',').unwrap().1.to_string();
    lines[5] = format!("-1e308,{rest}");
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, lines.join("\n")).unwrap();
    let mut req = fbgforge::verify::VerifyRequest::new(d.clone(), lp.clone(), bad.clone());
    let e = format!("{:#}", fbgforge::verify::run(&req).unwrap_err());
    assert!(
        e.contains("bad.csv:6") && e.contains("runs backwards"),
        "{e}"
    );
    req.force = fp.clone();
    req.analysis.clock_offset_s = Some(f64::NAN);
    let e = format!("{:#}", fbgforge::verify::run(&req).unwrap_err());
    assert!(
        e.contains("AnalysisOptions.clock_offset_s") && e.contains("finite"),
        "{e}"
    );
    req.analysis.clock_offset_s = None;
    req.analysis.max_clock_offset_s = f64::INFINITY;
    let e = format!("{:#}", fbgforge::verify::run(&req).unwrap_err());
    assert!(e.contains("AnalysisOptions.max_clock_offset_s"), "{e}");
}

#[test]
fn a_wavelength_log_that_ends_before_the_first_pulse_is_an_error_naming_both_ranges() {
    use fbgforge::synth::module_log::{self as synth, LogStyle, SynthConfig};
    let d = common::shipped_path("clip-on-34mm.toml");
    let design = common::shipped("clip-on-34mm.toml");
    let dir = tempfile::tempdir().unwrap();
    // The force log's first pulse starts at 5 s; the wavelength log stops at 3 s.
    let cfg = SynthConfig::default();
    let (mut log, force, _) = synth::generate(&design, &cfg).unwrap();
    let keep = log.time_s.iter().take_while(|&&t| t < 3.0).count();
    log.time_s.truncate(keep);
    log.wavelength_nm.truncate(keep);
    let lp = dir.path().join("log.txt");
    let fp = dir.path().join("force.csv");
    synth::write_log(
        &lp,
        fbgforge::logs::LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &LogStyle::default(),
    )
    .unwrap();
    synth::write_force_csv(&fp, &force).unwrap();
    let mut req = fbgforge::verify::VerifyRequest::new(d, lp, fp);
    req.analysis.clock_offset_s = Some(synth::reported_offset_s(
        &cfg,
        fbgforge::logs::LogFormat::EnlightPeaks,
    ));
    let e = format!("{:#}", fbgforge::verify::run(&req).unwrap_err());
    assert!(
        e.contains("covers none of the") && e.contains("log.txt") && e.contains("force.csv"),
        "{e}"
    );
}
