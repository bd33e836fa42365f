//! Verdicts at the edges (issue 23): each scenario's logs are generated here with a
//! known truth, run through the whole verification, and its verdict checked.

use crate::common;
use fbgforge::logs::LogFormat;
use fbgforge::model::LoadCase;
use fbgforge::synth::module_log::{self as synth, LogStyle, SynthConfig};
use fbgforge::verify::verdict::{GratingVerdict, Status};
use fbgforge::verify::{VerifyOutcome, VerifyRequest};
use std::path::Path;
use std::sync::OnceLock;

/// The core the scenarios load (Case II): λ21 and λ22 respond.
const CORE: &str = "psc2";

/// The model's K for `CORE`'s gratings in Case II, pm/N (read off a verification, so
/// the scenarios follow the model wherever it goes).
fn model_k() -> &'static Vec<(String, f64)> {
    static K: OnceLock<Vec<(String, f64)>> = OnceLock::new();
    K.get_or_init(|| {
        let out = verify_cfg(&paper_cfg(), true, |_| {}).unwrap();
        out.report
            .verdict
            .gratings
            .iter()
            .map(|g| (g.grating.clone(), g.predicted_sensitivity_pm_per_n.unwrap()))
            .collect()
    })
}

/// A run of impulse presses of 1–5 N on `CORE` (shifts inside the windows), K set
/// per grating by `k` (the model's K when empty).
fn paper_cfg() -> SynthConfig {
    SynthConfig {
        core: Some(CORE.into()),
        sensitivity_pm_per_n: -170.0,
        pulses: synth::pulse_train(&[2.0, 3.0, 4.0, 5.0, 3.5, 4.5, 2.5, 4.0], 4.0, 6.0, 5.0),
        duration_s: 90.0,
        ..SynthConfig::default()
    }
}

/// `cfg` with every grating's K at `scale` × the model's.
fn at_model(mut cfg: SynthConfig, scale: f64) -> SynthConfig {
    cfg.grating_sensitivity_pm_per_n = model_k()
        .iter()
        .map(|(g, k)| (g.clone(), scale * k))
        .collect();
    cfg
}

/// Generate the logs of `cfg` (ENLIGHT Peaks and a force CSV) in `dir`.
fn write_logs(
    dir: &Path,
    cfg: &SynthConfig,
) -> anyhow::Result<(std::path::PathBuf, std::path::PathBuf)> {
    let d = common::shipped("clip-on-34mm.toml");
    let (log, force, _) = synth::generate(&d, cfg)?;
    let lp = dir.join("log.txt");
    let fp = dir.join("force.csv");
    synth::write_log(
        &lp,
        LogFormat::EnlightPeaks,
        &log,
        cfg,
        &LogStyle::default(),
    )?;
    synth::write_force_csv(&fp, &force)?;
    Ok((lp, fp))
}

/// Verify the logs of `cfg` against the shipped clip-on design, Case II, core
/// `CORE`, with the clock offset given (as `--force-start` gives it) or estimated.
fn verify_cfg(
    cfg: &SynthConfig,
    offset_given: bool,
    tweak: impl FnOnce(&mut VerifyRequest),
) -> anyhow::Result<VerifyOutcome> {
    let dir = tempfile::tempdir().unwrap();
    let (lp, fp) = write_logs(dir.path(), cfg)?;
    let mut req = VerifyRequest::new(common::shipped_path("clip-on-34mm.toml"), lp, fp);
    req.case = Some(LoadCase::II);
    req.analysis.core = Some(CORE.into());
    if offset_given {
        req.analysis.clock_offset_s = Some(synth::reported_offset_s(cfg, LogFormat::EnlightPeaks));
    }
    tweak(&mut req);
    fbgforge::verify::run(&req)
}

fn grating<'a>(out: &'a VerifyOutcome, name: &str) -> &'a GratingVerdict {
    out.report
        .verdict
        .gratings
        .iter()
        .find(|g| g.grating == name)
        .unwrap()
}

#[test]
fn a_dead_grating_fails_the_module_naming_it() {
    // λ21 never responds (K 0.07 pm/N where the model says about −170), λ22 matches.
    let mut cfg = at_model(paper_cfg(), 1.0);
    cfg.grating_sensitivity_pm_per_n[0].1 = 0.07;
    let dead = cfg.grating_sensitivity_pm_per_n[0].0.clone();
    let out = verify_cfg(&cfg, true, |_| {}).unwrap();
    let v = &out.report.verdict;
    assert_eq!(v.overall, Status::Fail, "{v:#?}");
    let g = grating(&out, &dead);
    assert_eq!(g.status, Status::Fail);
    assert!(!g.responded);
    assert!(
        g.reason.as_deref().unwrap().contains("dead grating"),
        "{g:?}"
    );
    let live = &v.gratings.iter().find(|g| g.grating != dead).unwrap();
    assert_eq!(live.status, Status::Pass, "{live:?}");
    // The same run with both gratings alive passes.
    let out = verify_cfg(&at_model(paper_cfg(), 1.0), true, |_| {}).unwrap();
    assert_eq!(
        out.report.verdict.overall,
        Status::Pass,
        "{:#?}",
        out.report.verdict
    );
}

/// The paper's own set-up: an SM125 at 2 Hz reporting 1 pm steps, 1 s impulse loads,
/// a lag of `tau_s`.
fn sm125_cfg(pulse_s: f64, tau_s: f64) -> SynthConfig {
    let peaks: Vec<f64> = (0..16).map(|i| 2.0 + 0.2 * ((i * 7) % 16) as f64).collect();
    let rest = 5.0;
    SynthConfig {
        sample_rate_hz: 2.0,
        quantization_pm: 1.0,
        tau_s,
        pulses: synth::pulse_train(&peaks, pulse_s, rest, 5.0),
        duration_s: 5.0 + 16.0 * (pulse_s + rest) + 5.0,
        ..paper_cfg()
    }
}

/// Every grating's verdict and the relative error of its K, for a failure message.
fn summary(out: &VerifyOutcome) -> String {
    let v = &out.report.verdict;
    let mut s = format!("overall {:?} ({:?})", v.overall, v.reason);
    for g in &v.gratings {
        s += &format!(
            "\n  {} K {:.2} model {:?} {:?} {:?}",
            g.grating,
            g.measured_sensitivity_pm_per_n,
            g.predicted_sensitivity_pm_per_n,
            g.status,
            g.reason
        );
    }
    s += &format!(
        "\n  skew {:?} ± {:?} ppm, warnings {:?}",
        out.report.measurement.clock_skew_ppm,
        out.report.measurement.clock_skew_uncertainty_ppm,
        out.report.measurement.warnings
    );
    s
}

#[test]
fn the_papers_own_2_hz_set_up_is_judged_and_a_15_percent_low_part_fails() {
    let scenarios: Vec<(&str, SynthConfig)> = vec![
        ("1 s impulses, 0.3 s lag", sm125_cfg(1.0, 0.3)),
        ("1 s impulses, 1 s lag", sm125_cfg(1.0, 1.0)),
        ("4 s presses, 1 s lag", sm125_cfg(4.0, 1.0)),
        (
            "1 s impulses, 0.3 s lag, -1000 ppm skew",
            SynthConfig {
                force_clock_skew_ppm: -1000.0,
                ..sm125_cfg(1.0, 0.3)
            },
        ),
    ];
    for (what, cfg) in scenarios {
        let out = verify_cfg(&at_model(cfg.clone(), 1.0), true, |_| {}).unwrap();
        assert_eq!(
            out.report.verdict.overall,
            Status::Pass,
            "{what}: {}",
            summary(&out)
        );
        // A part whose K is truly 15 % low is judged, and fails.
        let low = at_model(cfg, 0.85);
        let out = verify_cfg(&low, true, |_| {}).unwrap();
        assert_eq!(
            out.report.verdict.overall,
            Status::Fail,
            "{what}, K 15 % low: {}",
            summary(&out)
        );
        for g in &out.report.verdict.gratings {
            assert!(g.responded, "{what}: {g:?}");
            let e = g.relative_error.unwrap();
            assert!((e - 0.15).abs() < 0.04, "{what}: {g:?}");
        }
    }
}

#[test]
fn whole_second_timestamps_at_2_hz_are_judged() {
    let cfg = at_model(sm125_cfg(1.0, 0.3), 1.0);
    let dir = tempfile::tempdir().unwrap();
    let (lp, fp) = write_logs(dir.path(), &cfg).unwrap();
    // Cut every timestamp to its whole second (`15:44:56.650000` → `15:44:56`).
    let text = std::fs::read_to_string(&lp).unwrap();
    let cut: String = text
        .lines()
        .map(|l| match (l.find(':'), l.find('.'), l.find('\t')) {
            (Some(c), Some(d), Some(t)) if c < d && d < t && l.as_bytes()[2] == b'/' => {
                format!("{}{}\n", &l[..d], &l[t..])
            }
            _ => format!("{l}\n"),
        })
        .collect();
    assert_ne!(cut, text);
    std::fs::write(&lp, cut).unwrap();
    let mut req = VerifyRequest::new(common::shipped_path("clip-on-34mm.toml"), lp, fp);
    req.case = Some(LoadCase::II);
    req.analysis.core = Some(CORE.into());
    let out = fbgforge::verify::run(&req).unwrap();
    assert_eq!(
        out.report.verdict.overall,
        Status::Pass,
        "{}",
        summary(&out)
    );
}

#[test]
fn calibrate_into_works_on_the_2_hz_set_up() {
    // The contact calibration is of Case I: the 2 Hz, 1 pm, lagged log of a part whose
    // K is 15 % off the nominal model (inside what a contact radius reaches) is judged
    // and calibrated, and the calibrated design reproduces its K.
    let probe = verify_case_i(&sm125_cfg(1.0, 0.3));
    let cfg = SynthConfig {
        grating_sensitivity_pm_per_n: probe
            .report
            .verdict
            .gratings
            .iter()
            .map(|g| {
                (
                    g.grating.clone(),
                    1.15 * g.predicted_sensitivity_pm_per_n.unwrap(),
                )
            })
            .collect(),
        ..sm125_cfg(1.0, 0.3)
    };
    let dir = tempfile::tempdir().unwrap();
    let into = dir.path().join("calibrated.toml");
    let out = verify_cfg(&cfg, true, |r| {
        r.case = Some(LoadCase::I);
        r.insert = Some("blue".into());
        r.calibrate_into = Some(into.clone());
    })
    .unwrap();
    assert!(
        out.report.verdict.gratings.iter().all(|g| g.responded),
        "{}",
        summary(&out)
    );
    assert!(out.calibration.is_some(), "{}", summary(&out));
    // Against the calibrated design (its contact marked calibrated) the same log is
    // judged on the nominal K, whatever the band's width, and passes.
    let again = verify_cfg(&cfg, true, |r| {
        r.design = into.clone();
        r.case = Some(LoadCase::I);
        r.insert = Some("blue".into());
    })
    .unwrap();
    assert_eq!(
        again.report.verdict.overall,
        Status::Pass,
        "{}",
        summary(&again)
    );
}

#[test]
fn a_clipped_force_channel_never_gives_a_confident_fail() {
    // Every press (3.5–4.5 N) reaches the 3 N ceiling of the force channel: nothing
    // trustworthy is left.
    let peaks = [3.5, 4.0, 4.5, 3.8, 4.2, 3.6, 4.4, 4.0];
    let cfg = SynthConfig {
        pulses: synth::pulse_train(&peaks, 4.0, 6.0, 5.0),
        force_saturation_n: Some(3.0),
        ..at_model(paper_cfg(), 1.0)
    };
    let out = verify_cfg(&cfg, true, |_| {}).unwrap();
    let m = &out.report.measurement;
    assert_eq!(
        out.report.verdict.overall,
        Status::NotJudged,
        "{}",
        summary(&out)
    );
    assert_eq!(
        m.force_trust.clipped_pulses.len(),
        peaks.len(),
        "{:?}",
        m.force_trust
    );
    assert!((m.force_trust.saturation_n.unwrap() - 3.0).abs() < 0.05);
    // Half the presses stay below the ceiling: the clipped ones are left out with a
    // warning and K is judged on the rest (it passes, as the truth does).
    let peaks = [2.0, 3.5, 2.5, 4.0, 1.5, 4.5, 2.8, 3.8, 2.2, 2.6];
    let cfg = SynthConfig {
        pulses: synth::pulse_train(&peaks, 4.0, 6.0, 5.0),
        duration_s: 5.0 + 10.0 * 10.0 + 5.0,
        force_saturation_n: Some(3.0),
        ..at_model(paper_cfg(), 1.0)
    };
    let out = verify_cfg(&cfg, true, |_| {}).unwrap();
    let m = &out.report.measurement;
    assert_eq!(
        m.force_trust.clipped_pulses,
        vec![2, 4, 6, 8],
        "{:?}",
        m.force_trust
    );
    assert!(m.warnings.count("force_clipped") >= 1, "{:?}", m.warnings);
    assert_eq!(
        out.report.verdict.overall,
        Status::Pass,
        "{}",
        summary(&out)
    );
}

#[test]
fn clock_skew_over_20_min_is_recovered_and_corrected() {
    for ppm in [1000.0, -1000.0] {
        let peaks: Vec<f64> = (0..100).map(|i| 2.0 + 0.3 * (i % 10) as f64).collect();
        let cfg = SynthConfig {
            pulses: synth::pulse_train(&peaks, 4.0, 8.0, 5.0),
            duration_s: 5.0 + 100.0 * 12.0 + 5.0,
            force_clock_skew_ppm: ppm,
            ..at_model(paper_cfg(), 1.0)
        };
        let d = common::shipped("clip-on-34mm.toml");
        let (_, _, truth) = synth::generate(&d, &cfg).unwrap();
        let out = verify_cfg(&cfg, true, |_| {}).unwrap();
        let m = &out.report.measurement;
        let (s, u) = (
            m.clock_skew_ppm.unwrap(),
            m.clock_skew_uncertainty_ppm.unwrap(),
        );
        assert!((s - ppm).abs() <= 3.0 * u && u < 100.0, "{ppm}: {s} ± {u}");
        assert!(m.clock_skew_corrected);
        assert_eq!(m.warnings.count("clock_skew"), 1, "{:?}", m.warnings);
        assert_eq!(
            out.report.verdict.overall,
            Status::Pass,
            "{}",
            summary(&out)
        );
        // With the offset estimated on the skewed clocks, no bound on Q is claimed
        // (the relative lags no longer sit below the true ones); K stays.
        let est = verify_cfg(&cfg, false, |_| {}).unwrap();
        let me = &est.report.measurement;
        assert!(me.clock_skew_corrected && me.lag_is_relative);
        for g in &me.gratings {
            assert!(
                g.quality_q_pm_per_n_s.is_none() && g.quality_q_bound.is_none(),
                "{g:?}"
            );
            assert!(g.quality_q_note.as_deref().unwrap().contains("skew"));
        }
        assert_eq!(
            est.report.verdict.overall,
            Status::Pass,
            "{}",
            summary(&est)
        );
        // Q, with the offset given, close to the truth once the skew is removed.
        for (g, t) in m
            .gratings
            .iter()
            .zip(truth.gratings.iter().filter(|g| !g.reference))
        {
            let q = g.quality_q_pm_per_n_s.unwrap();
            assert!(
                (q / t.quality_q_expected - 1.0).abs() < 0.15,
                "{ppm}: Q {q} vs {}",
                t.quality_q_expected
            );
        }
    }
}

#[test]
fn q_with_an_estimated_offset_is_only_bounded_and_k_stays() {
    for cfg in [
        at_model(paper_cfg(), 1.0),
        at_model(sm125_cfg(1.0, 0.3), 1.0),
    ] {
        let cfg = SynthConfig {
            transport_delay_s: 0.3,
            ..cfg
        };
        let d = common::shipped("clip-on-34mm.toml");
        let (_, _, truth) = synth::generate(&d, &cfg).unwrap();
        let out = verify_cfg(&cfg, false, |_| {}).unwrap();
        let m = &out.report.measurement;
        assert!(m.lag_is_relative);
        for (g, t) in m
            .gratings
            .iter()
            .zip(truth.gratings.iter().filter(|g| !g.reference))
        {
            assert!(
                g.quality_q_pm_per_n_s.is_none() && g.quality_q_uncertainty_pm_per_n_s.is_none()
            );
            assert!(
                g.quality_q_note.as_deref().unwrap().contains("estimated"),
                "{g:?}"
            );
            if let Some(b) = g.quality_q_bound {
                assert_eq!(b.kind, fbgforge::verify::analysis::BoundKind::Upper);
                assert!(
                    b.value_pm_per_n_s >= 0.9 * t.quality_q_expected,
                    "{b:?} vs {}",
                    t.quality_q_expected
                );
            }
            let k_err = (g.sensitivity_pm_per_n / t.sensitivity_pm_per_n - 1.0).abs();
            assert!(
                k_err < 0.02,
                "{}: K {} vs {}",
                g.grating,
                g.sensitivity_pm_per_n,
                t.sensitivity_pm_per_n
            );
        }
        assert_eq!(
            out.report.verdict.overall,
            Status::Pass,
            "{}",
            summary(&out)
        );
    }
}

#[test]
fn a_force_gap_inside_a_press_is_flagged_and_left_out() {
    // A 3 s stall of the force logger in the middle of the fourth press (it starts at
    // 35 s on the pulses' clock, 1.7 s later on the wavelength log's).
    let mut cfg = at_model(paper_cfg(), 1.0);
    cfg.force_gaps_s = vec![(36.0, 39.0)];
    let out = verify_cfg(&cfg, true, |_| {}).unwrap();
    let m = &out.report.measurement;
    assert_eq!(m.force_trust.gapped_pulses, vec![4], "{:?}", m.force_trust);
    assert!(m.force_trust.excluded_pulses.contains(&4));
    assert!(
        m.warnings.count("force_gap_in_press") >= 1,
        "{:?}",
        m.warnings
    );
    assert_eq!(
        out.report.verdict.overall,
        Status::Pass,
        "{}",
        summary(&out)
    );
}

/// The model's K and band for the first grating of the configuration under test.
fn first_band(out: &VerifyOutcome) -> (f64, [f64; 2]) {
    let g = &out.report.verdict.gratings[0];
    (
        g.predicted_sensitivity_pm_per_n.unwrap(),
        g.band_pm_per_n.unwrap(),
    )
}

#[test]
fn in_band_says_where_k_lies_and_how_wide_the_band_is() {
    // Case II: a band about a factor 1.1 wide; K 11 % from the nominal model, inside it.
    let probe = verify_cfg(&at_model(paper_cfg(), 1.0), true, |_| {}).unwrap();
    let (model, band) = first_band(&probe);
    assert!(fbgforge::verify::verdict::band_factor(band) < 3.0);
    let k_in = band[0].min(band[1]) + 0.1 * (band[1] - band[0]).abs();
    let scale = k_in / model;
    assert!((scale - 1.0).abs() > 0.08, "{model} {band:?}");
    let out = verify_cfg(&at_model(paper_cfg(), scale), true, |_| {}).unwrap();
    let g = &out.report.verdict.gratings[0];
    assert_eq!(g.status, Status::InBand, "{}", summary(&out));
    let why = g.reason.as_deref().unwrap();
    assert!(
        why.contains("% of the way through the band") && why.contains("a factor 1.1"),
        "{why}"
    );
    let pos = g.band_position.unwrap();
    assert!((0.0..=1.0).contains(&pos), "{pos}");
}

/// Verify `cfg`'s logs in Case I with the blue insert.
fn verify_case_i(cfg: &SynthConfig) -> VerifyOutcome {
    verify_cfg(cfg, true, |r| {
        r.case = Some(LoadCase::I);
        r.insert = Some("blue".into());
    })
    .unwrap()
}

#[test]
fn a_band_wider_than_a_factor_3_asks_for_the_contact_to_be_calibrated() {
    let probe = verify_case_i(&paper_cfg());
    let (model, band) = first_band(&probe);
    assert!(
        fbgforge::verify::verdict::band_factor(band) > 3.0,
        "{band:?}"
    );
    let names: Vec<String> = probe
        .report
        .verdict
        .gratings
        .iter()
        .map(|g| g.grating.clone())
        .collect();
    let with_k = |scale: f64| SynthConfig {
        grating_sensitivity_pm_per_n: probe
            .report
            .verdict
            .gratings
            .iter()
            .map(|g| {
                (
                    g.grating.clone(),
                    scale * g.predicted_sensitivity_pm_per_n.unwrap(),
                )
            })
            .collect(),
        ..paper_cfg()
    };
    assert!(!names.is_empty());
    // K low in the band (the K = 20 against a model of 108.7): no IN BAND, no
    // PASS, but the configuration cannot be judged without calibrating the contact.
    let low = (band[0].min(band[1]) + 0.05 * (band[1] - band[0]).abs()) / model;
    let out = verify_case_i(&with_k(low));
    assert_eq!(
        out.report.verdict.overall,
        Status::CalibrateContact,
        "{}",
        summary(&out)
    );
    let why = out.report.verdict.gratings[0].reason.clone().unwrap();
    assert!(
        why.contains("cannot be judged without calibrating the contact"),
        "{why}"
    );
    assert!(why.contains("of the way through the band"), "{why}");
    // K above the band but within what a contact radius reproduces (the issue's
    // K = 300 against 108.7): the verdict says --calibrate-into explains it.
    let reach = out.report.verdict.gratings[0]
        .calibration_reach_pm_per_n
        .unwrap();
    let (hi, reach_hi) = (band[0].max(band[1]), reach[0].max(reach[1]));
    assert!(reach_hi > 1.2 * hi, "{reach:?} {band:?}");
    // Lighter presses (1-2.5 N) keep the peaks of so stiff a part inside their windows:
    // at 5 N they leave them, and the verifier rightly refuses (instrument) instead.
    let light = SynthConfig {
        pulses: synth::pulse_train(&[1.0, 1.5, 2.0, 2.5, 1.75, 2.25, 1.25, 2.0], 4.0, 6.0, 5.0),
        ..with_k(1.2 * hi / model)
    };
    let out = verify_case_i(&light);
    let g = &out.report.verdict.gratings[0];
    assert!(
        !matches!(g.status, Status::Pass | Status::InBand),
        "{}",
        summary(&out)
    );
    let why = g.reason.as_deref().unwrap();
    assert!(
        why.contains("above the band")
            && why.contains("reproduces it")
            && why.contains("VerifyRequest.calibrate_into"),
        "{why}"
    );
    // Its nominal K passes too, yet says the same: the band, not the fit, is the limit.
    let out = verify_case_i(&with_k(1.0));
    assert_eq!(
        out.report.verdict.overall,
        Status::CalibrateContact,
        "{}",
        summary(&out)
    );
}

#[test]
fn the_cli_refuses_options_out_of_range_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let (lp, fp) = write_logs(dir.path(), &paper_cfg()).unwrap();
    let design = common::shipped_path("clip-on-34mm.toml");
    for (flag, value, range) in [
        ("--k-tolerance", "inf", "(0, 0.5]"),
        ("--k-tolerance", "5", "(0, 0.5]"),
        ("--k-tolerance", "NaN", "(0, 0.5]"),
        ("--window-nm", "inf", "(0, 10]"),
        ("--resolution-pm", "0", "(0, 100]"),
        ("--max-offset-s=-1", "", "[0, 86400]"),
    ] {
        let out = crate::common::bin()
            .arg("verify")
            .arg(&design)
            .args(["--case", "II", "--core", CORE, "--log"])
            .arg(&lp)
            .arg("--force")
            .arg(&fp)
            .args([flag, value].into_iter().filter(|a| !a.is_empty()))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        let name = flag.split('=').next().unwrap();
        assert_eq!(out.status.code(), Some(1), "{flag} {value}: {err}");
        assert!(
            err.contains(name) && err.contains(range),
            "{flag} {value}: {err}"
        );
    }
}

#[test]
fn synth_log_refuses_lengths_it_cannot_write() {
    let design = common::shipped_path("clip-on-34mm.toml");
    let dir = tempfile::tempdir().unwrap();
    for (flag, value) in [
        ("--pulse-s", "1e308"),
        ("--rest-s", "1e308"),
        ("--pulse-s", "1e9"),
        ("--pulse-s", "inf"),
    ] {
        let out = crate::common::bin()
            .arg("synth-log")
            .arg(&design)
            .args([flag, value, "--out"])
            .arg(dir.path().join("out"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flag} {value}: {err}");
        assert!(!err.contains("panicked"), "{flag} {value}: {err}");
        assert!(
            err.contains("--pulse-s") || err.contains("--rest-s"),
            "{flag} {value}: {err}"
        );
        assert!(!dir.path().join("out").join("log.txt").exists());
    }
}

#[test]
fn synth_log_bounds_the_step_and_the_metadata_naming_the_flag() {
    // Issue #33: `--step-pm 1e308` wrote every peak at 0 nm with exit 0, and
    // `--metadata-lines 100000000` wrote 2.5 GB and left a temporary file.
    let design = common::shipped_path("clip-on-34mm.toml");
    let dir = tempfile::tempdir().unwrap();
    for (flag, value) in [
        ("--step-pm", "1e308"),
        ("--step-pm=-1", ""),
        ("--metadata-lines", "100000000"),
    ] {
        let out_dir = dir.path().join("out");
        let out = crate::common::bin()
            .arg("synth-log")
            .arg(&design)
            .arg(flag)
            .args((!value.is_empty()).then_some(value))
            .arg("--out")
            .arg(&out_dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{flag} {value}: {err}");
        let name = flag.split('=').next().unwrap();
        assert!(err.contains(name), "{flag} {value}: {err}");
        // Nothing written, no temporary file left.
        let left: Vec<_> = std::fs::read_dir(&out_dir)
            .map(|d| d.flatten().map(|e| e.file_name()).collect())
            .unwrap_or_default();
        assert!(left.is_empty(), "{flag} {value}: {left:?}");
    }
}

mod no_panic {
    use super::*;
    use proptest::prelude::*;

    /// Option values from the awkward end: non-finite, huge, zero, negative, tiny.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(f64::NAN),
            Just(1e308),
            Just(1e9),
            Just(0.0),
            Just(-1.0),
            Just(1e-300),
            -10.0..60.0f64,
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn synth_options_refuse_or_write_never_panic(
            pulse_s in value(), rest_s in value(), rate in value(), force_rate in value(),
            tau in value(), peak in value(), skew in value(), sat in value(), step in value(),
        ) {
            let d = common::shipped("clip-on-34mm.toml");
            let shape = synth::PulseShape::Haversine;
            if let Ok((pulses, duration_s)) = synth::train(&synth::TrainSettings { peaks_n: vec![peak, 2.0], pulse_s, rest_s, lead_s: 5.0, shape }) {
                let cfg = SynthConfig {
                    sample_rate_hz: rate,
                    force_rate_hz: force_rate,
                    tau_s: tau,
                    pulses,
                    duration_s,
                    force_clock_skew_ppm: skew,
                    force_saturation_n: Some(sat),
                    quantization_pm: step,
                    ..SynthConfig::default()
                };
                // Small enough runs are generated; larger ones only checked.
                if synth::check_config(&d, &cfg).is_ok() && cfg.rows() < 5e4 && cfg.force_samples() < 2e5 {
                    let _ = synth::generate(&d, &cfg);
                }
            }
        }

        #[test]
        fn verify_options_are_checked_never_panic(
            tol in value(), window in value(), resolution in value(), range in value(),
            offset in value(), scale in value(),
        ) {
            let mut req = VerifyRequest::new("d.toml".into(), "l.txt".into(), "f.csv".into());
            req.k_tolerance = tol;
            req.analysis.window_half_width_nm = Some(window);
            req.analysis.resolution_pm = Some(resolution);
            req.analysis.max_clock_offset_s = range;
            req.analysis.clock_offset_s = Some(offset);
            req.force_read.scale_to_n = Some(scale);
            let ok = req.validate().is_ok();
            let fine = |v: f64, lo: f64, hi: f64| v.is_finite() && v > lo && v <= hi;
            prop_assert_eq!(
                ok,
                fine(tol, 0.0, 0.5)
                    && fine(window, 0.0, 10.0)
                    && fine(resolution, 0.0, 100.0)
                    && range.is_finite() && (0.0..=86_400.0).contains(&range)
                    && offset.is_finite()
                    && scale.is_finite() && scale > 0.0
            );
        }
    }
}

#[test]
fn spectrum_exports_are_read_as_spectra() {
    // Issue 36: spectra are no longer refused; they are read as spectra and their
    // peaks found (the ENLIGHT one is flat and holds none; the OSA one is a sawtooth).
    let dir = tempfile::tempdir().unwrap();
    let mut enlight = String::from("Wvl (nm)\tCH 1\tCH 2\n");
    let mut osa = String::from("Wavelength (nm),Amplitude (AU)\n");
    for i in 0..500 {
        let w = 1510.0 + 0.008 * i as f64;
        enlight += &format!("{w:.3}\t-42.1\t-40.3\n");
        osa += &format!("{w:.3},{}\n", 100 + i % 7);
    }
    for (name, text, format) in [
        ("spectrum.txt", enlight, "enlight-spectrum"),
        ("spectrum.csv", osa, "osa-csv"),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        let log = fbgforge::logs::read_peak_log(&p, &fbgforge::logs::ReadOptions::default())
            .unwrap_or_else(|e| panic!("{name}: {e:#}"));
        assert_eq!(log.format.name(), format, "{name}");
        assert_eq!(log.estimator(), Some("gaussian"), "{name}");
        assert_eq!(log.rows(), 1, "{name}");
        if format == "enlight-spectrum" {
            assert!(
                log.row(0).0.is_empty(),
                "{name}: a flat spectrum has no peak"
            );
        }
    }
}

#[test]
fn a_failed_report_run_leaves_no_stale_report() {
    let dir = tempfile::tempdir().unwrap();
    let (lp, fp) = write_logs(dir.path(), &at_model(paper_cfg(), 1.0)).unwrap();
    let design = common::shipped_path("clip-on-34mm.toml");
    let report = dir.path().join("report");
    let run = |force: &Path| {
        crate::common::bin()
            .arg("verify")
            .arg(&design)
            .args(["--case", "II", "--core", CORE, "--log"])
            .arg(&lp)
            .arg("--force")
            .arg(force)
            .arg("--report")
            .arg(&report)
            .output()
            .unwrap()
    };
    let ok = run(&fp);
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    assert!(report.join("report.md").exists() && report.join("report.json").exists());
    // No temporary folder is left beside it.
    let siblings: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(siblings.is_empty(), "{siblings:?}");
    // A run that fails (a force log that does not exist) removes the previous report.
    let bad = run(&dir.path().join("missing.csv"));
    assert_eq!(bad.status.code(), Some(1));
    assert!(
        !report.join("report.md").exists(),
        "a stale report.md stayed"
    );
}

#[test]
fn a_negative_lag_never_passes_silently() {
    // A given clock offset 1 s off one way puts the shift 0.75 s ahead of the force,
    // which a passive part cannot do: warned per segment, and Q withheld.
    let cfg = at_model(paper_cfg(), 1.0);
    let truth = synth::reported_offset_s(&cfg, LogFormat::EnlightPeaks);
    let out = verify_cfg(&cfg, true, |r| {
        r.analysis.clock_offset_s = Some(truth - 1.0)
    })
    .unwrap();
    let m = &out.report.measurement;
    let segments: usize = m.gratings.iter().map(|g| g.pulses.len()).sum();
    assert!(m
        .gratings
        .iter()
        .flat_map(|g| &g.pulses)
        .all(|p| p.lag_s < 0.0));
    assert_eq!(
        m.warnings.count("negative_lag"),
        segments,
        "{:?}",
        m.warnings
    );
    assert!(m.gratings.iter().all(|g| g.quality_q_pm_per_n_s.is_none()));
    // 1 s off the other way: lags of 1.25 s, positive, no such warning.
    let out = verify_cfg(&cfg, true, |r| {
        r.analysis.clock_offset_s = Some(truth + 1.0)
    })
    .unwrap();
    assert_eq!(out.report.measurement.warnings.count("negative_lag"), 0);
}

#[test]
fn calibrate_contact_has_its_own_exit_status_and_words() {
    // A part at the nominal Case I model's K (blue insert, a band wider than 3×).
    let probe = verify_case_i(&paper_cfg());
    let cfg = SynthConfig {
        grating_sensitivity_pm_per_n: probe
            .report
            .verdict
            .gratings
            .iter()
            .map(|g| (g.grating.clone(), g.predicted_sensitivity_pm_per_n.unwrap()))
            .collect(),
        ..paper_cfg()
    };
    let dir = tempfile::tempdir().unwrap();
    let (lp, fp) = write_logs(dir.path(), &cfg).unwrap();
    let offset = synth::reported_offset_s(&cfg, LogFormat::EnlightPeaks);
    let out = crate::common::bin()
        .arg("verify")
        .arg(common::shipped_path("clip-on-34mm.toml"))
        .args(["--case", "I", "--insert", "blue", "--core", CORE, "--log"])
        .arg(&lp)
        .arg("--force")
        .arg(&fp)
        .arg(format!("--clock-offset-s={offset}"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(5),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("verdict: CALIBRATE CONTACT"), "{text}");
    // The summary wraps at 80 columns: the phrase may span two lines.
    let words = text.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        words.contains("cannot be judged without calibrating the contact"),
        "{text}"
    );
    // --help documents it.
    let help = crate::common::bin()
        .args(["verify", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(help.contains("5  CALIBRATE CONTACT"), "{help}");
}

#[test]
fn a_given_offset_that_misses_the_log_says_so() {
    // Relative clocks on both logs (CSV), a given offset of 1000 s: the error names
    // the given offset, not an alignment of the starts.
    let d = common::shipped("clip-on-34mm.toml");
    let cfg = paper_cfg();
    let (log, force, _) = synth::generate(&d, &cfg).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let lp = dir.path().join("log.csv");
    let fp = dir.path().join("force.csv");
    synth::write_log(&lp, LogFormat::Csv, &log, &cfg, &LogStyle::default()).unwrap();
    synth::write_force_csv(&fp, &force).unwrap();
    let mut req = VerifyRequest::new(common::shipped_path("clip-on-34mm.toml"), lp, fp);
    req.case = Some(LoadCase::II);
    req.analysis.clock_offset_s = Some(1000.0);
    let e = format!("{:#}", fbgforge::verify::run(&req).unwrap_err());
    assert!(e.contains("placed by the given clock offset 1000"), "{e}");
    assert!(!e.contains("starts aligned"), "{e}");
}

#[test]
fn a_perfectly_elastic_part_with_a_pure_delay_shows_no_loop() {
    // Issue #33, bonding: a part that follows the force exactly, 0.3 s late (no lag of
    // its own: every bit of the response instant), read 37 % of span in
    // `hysteresis_percent_span` when the loop was drawn without taking the delay out.
    // Drawn on the lag-corrected signal it is ~0 % (noise only), well under the design's
    // limit, and the part PASSes, with the clock offset given (the delay then measured
    // as a lag) and estimated (the delay absorbed by the offset).
    let cfg = SynthConfig {
        transport_delay_s: 0.3,
        instant_fraction: 1.0,
        noise_pm: 0.5,
        ..at_model(paper_cfg(), 1.0)
    };
    for given in [true, false] {
        let out = verify_cfg(&cfg, given, |_| {}).unwrap();
        for g in &out.report.measurement.gratings {
            assert!(
                g.hysteresis_percent_span.abs() < 1.0,
                "given {given}, {}: hysteresis {:.2} % of span",
                g.grating,
                g.hysteresis_percent_span
            );
            assert!(g.hysteresis_percent_span < g.hysteresis_limit_percent_span);
            if given {
                assert!(
                    (g.max_lag_s - 0.3).abs() < 0.05,
                    "{}: Δt_max {}",
                    g.grating,
                    g.max_lag_s
                );
            }
        }
        assert_eq!(
            out.report.verdict.overall,
            Status::Pass,
            "given {given}: {}",
            summary(&out)
        );
    }
}
