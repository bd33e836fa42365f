//! Verdicts at the edges (issue 23): each scenario's logs are generated here with a
//! known truth, run through the whole verification, and its verdict checked.

use crate::common;
use fbgforge::logs::LogFormat;
use fbgforge::model::LoadCase;
use fbgforge::verify::synth::{self, LogStyle, SynthConfig};
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
