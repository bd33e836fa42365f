//! `optimize` warns of a written design whose grating stops being one clean peak
//! inside its force range (docs/spectra.md §8.5): a warning, not a constraint.

use crate::common;
use fbgforge::optimize::module::{ModuleSettings, Objective, Variable};
use fbgforge::optimize::run::{run_module, ModuleRequest};
use fbgforge::progress::Quiet;

#[test]
fn the_written_design_carries_the_spectrum_warning_with_the_force() {
    // The 34 mm module with a 30 mm weak grating under the dome (17 µε/N from end to
    // end), rated for 10 N: it stops being one clean peak near 1.24 N.
    let d = common::long_grating_design();
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("long-grating.toml");
    std::fs::write(&spec, d.to_toml()).unwrap();
    let mut settings = ModuleSettings {
        objective: Objective::Sensitivity,
        vary: vec![Variable::CapWallMm],
        inserts: Some(vec!["none".into()]),
        extra_starts: 0,
        solvers: vec![fbgforge::solvers::SolverKind::NelderMead],
        ..ModuleSettings::default()
    };
    settings.run.max_iters = 4;
    let request = ModuleRequest {
        design: spec,
        materials: None,
        settings,
        measured: None,
        landscape: None,
        out: Some(dir.path().join("optimised.toml")),
        report_dir: None,
        words: fbgforge::fields::own_words,
    };
    let run = run_module(&request, &Quiet, &mut ()).unwrap();
    let o = &run.outcome;
    let w = o
        .warnings
        .iter()
        .find(|w| w.contains("lambda_11") && w.contains("one clean peak at"))
        .unwrap_or_else(|| panic!("{:#?}", o.warnings));
    // The force it names is the written design's own, from the same check run on it.
    let again = fbgforge::prediction::spectrum::design_warnings(
        &o.design,
        &fbgforge::fem::GeometryCache::default(),
    )
    .unwrap();
    assert!(again.contains(w), "{w} not in {again:#?}");
    let f: f64 = w
        .split("one clean peak at ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap();
    assert!(f > 0.5 && f < 3.0, "{f} N");
    // And the table (the terminal sink) states it.
    let table = fbgforge::report::optimize::module_table(o, fbgforge::fields::own_words);
    assert!(
        table.contains("warning:") && table.contains("lambda_11"),
        "{table}"
    );
}
