//! The one model policy (`fbgforge::prediction`): `predict`, `verify` and `optimize`
//! give the same K for every shipped design and configuration; the default Case I
//! reading meets the paper's experimental statements on the 34 mm module; the band
//! holds the bounding FE readings; `[module.contact]` is checked field by field; and a
//! measured log calibrates the contact so that `predict` reproduces it and `optimize`
//! follows.

use crate::common;
use fbgforge::model::{configurations, LoadCase};
use fbgforge::optimize::materials::MaterialLibrary;
use fbgforge::optimize::module::{model_predictor, Choice, ModuleProblem, ModuleSettings};
use fbgforge::optimize::quality::Calibration;
use fbgforge::prediction::{self, Fidelity, ModelledPrediction, PredictionRequest};
use fbgforge::progress::Quiet;
use fbgforge::spec::Design;

use common::shipped as design;

const SHIPPED: [&str; 4] = [
    "clip-on-10mm.toml",
    "clip-on-16mm.toml",
    "clip-on-22mm.toml",
    "clip-on-34mm.toml",
];

fn policy(d: &Design, band: bool) -> Vec<ModelledPrediction> {
    prediction::predict(
        d,
        &PredictionRequest {
            band,
            ..Default::default()
        },
    )
    .unwrap()
}

fn k_of(rows: &[ModelledPrediction], grating: &str, case: LoadCase, insert: Option<&str>) -> f64 {
    rows.iter()
        .map(|r| &r.detail.prediction)
        .find(|p| p.grating == grating && p.case == case && p.insert.as_deref() == insert)
        .unwrap_or_else(|| panic!("no row for {grating} {case} {insert:?}"))
        .sensitivity_pm_per_n
}

/// The design with `core` listed first (the optimiser works on the first core and its
/// gratings).
fn core_first(d: &Design, core: &str) -> Design {
    let mut d = d.clone();
    let m = d.module.as_mut().unwrap();
    let i = m.cores.iter().position(|c| c.name == core).unwrap();
    let c = m.cores.remove(i);
    m.cores.insert(0, c);
    d
}

/// The optimiser's K for every grating of `config` at its start point (what its
/// objective and constraints see for the start design).
fn optimiser_k(d: &Design, core: &str, insert: Option<&str>) -> Vec<(String, f64)> {
    let d = core_first(d, core);
    let m = d.module.as_ref().unwrap();
    let choice = Choice {
        core_material: m.cores[0].material.clone(),
        insert_material: insert.map(|name| {
            m.inserts
                .iter()
                .find(|i| i.name == name)
                .unwrap()
                .material
                .clone()
        }),
    };
    let s = ModuleSettings::default();
    let p = ModuleProblem::new(
        &d,
        choice,
        &MaterialLibrary::shipped(),
        &s,
        Calibration::identity(&s.quality),
        model_predictor(),
    )
    .unwrap();
    let e = p.evaluate(&p.start_point());
    assert!(!e.gratings.is_empty(), "{:?}", e.constraints);
    e.gratings
        .iter()
        .map(|g| (g.grating.clone(), g.sensitivity_pm_per_n))
        .collect()
}

#[test]
fn predict_verify_and_optimize_agree_on_k_for_every_shipped_design_and_configuration() {
    for file in SHIPPED {
        let d = design(file);
        let rows = policy(&d, false);
        for config in configurations(&d).unwrap() {
            let insert = config.insert.as_deref();
            // What verify judges against: the policy's rows for the configuration.
            let verify_rows = fbgforge::verify::run::model_predictions(
                &d,
                config.case,
                insert,
                Some(&config.core),
            )
            .unwrap();
            assert!(!verify_rows.is_empty(), "{file} {}", config.label());
            for v in &verify_rows {
                let p = &v.detail.prediction;
                let k = k_of(&rows, &p.grating, p.case, p.insert.as_deref());
                // The same policy; the band's readings share the nominal's
                // factorisation in verify's batch, so the two agree to round-off.
                assert!(
                    (p.sensitivity_pm_per_n - k).abs() <= 1e-9 * k.abs(),
                    "{file} {}: verify {} vs predict {k}",
                    config.label(),
                    p.sensitivity_pm_per_n
                );
                assert!(v.band_contains(k), "{file}: nominal outside its band");
            }
            // What optimize scores at its start.
            for (g, k_opt) in optimiser_k(&d, &config.core, insert) {
                let k = k_of(&rows, &g, config.case, insert);
                assert!(
                    (k_opt - k).abs() <= 1e-9 * k.abs(),
                    "{file} {} {g}: optimize {k_opt} vs predict {k}",
                    config.label()
                );
            }
        }
        // Every row names its model: Case I by the FE model with the design's contact.
        for r in &rows {
            assert!(!r.model_description.is_empty());
            if r.detail.prediction.case == LoadCase::I {
                assert_eq!(r.model, Fidelity::Fem, "{file}");
                assert!(r.model_description.contains("domes in contact within"));
            }
        }
    }
}

#[test]
fn the_default_case_i_reading_meets_the_papers_statements_on_the_34mm_module() {
    let d = design("clip-on-34mm.toml");
    let rows = policy(&d, true);
    // PSC 1 carries Case I, PSC 2 Case II (reference §1); gratings pair up by pillar.
    for (g1, g2) in [("lambda_11", "lambda_21"), ("lambda_12", "lambda_22")] {
        let k_ii = k_of(&rows, g2, LoadCase::II, None);
        assert!(k_ii < 0.0, "Case II is a blue shift");
        let mut last = 0.0;
        for insert in ["blue", "green", "light_green"] {
            let k_i = k_of(&rows, g1, LoadCase::I, Some(insert));
            assert!(k_i > 0.0, "{g1} {insert}: Case I is a red shift, K = {k_i}");
            let ratio = k_ii.abs() / k_i;
            assert!(
                ratio > 1.0 && ratio <= 2.0,
                "{g1} {insert}: |K_II|/K_I = {ratio:.3}, the paper has Case II up to twice Case I"
            );
            assert!(
                k_i > last,
                "{g1}: K_I must rise as the insert softens ({insert}: {k_i} after {last})"
            );
            last = k_i;
        }
        // The paper's model was within 8 % of its blue-insert measurement; the closed
        // form reconstructs that model.
        let blue = k_of(&rows, g1, LoadCase::I, Some("blue"));
        let paper_model =
            fbgforge::model::sensitivity_pm_per_n(&d, LoadCase::I, Some("blue"), g1).unwrap();
        assert!(
            (blue / paper_model - 1.0).abs() <= 0.08,
            "{g1}: FE {blue} vs the paper's model {paper_model}"
        );
    }
    // The band holds both bounding FE readings and the nominal, and those readings are
    // near the independent FE's (reference §5: bonded +10.7 … +24.5, sliding with the
    // apex patch +253 pm/N for the blue insert, λ11; its smearing of the ribs is not
    // known, ours puts the cap's ribs on the cap's side of the sliding face).
    for r in rows
        .iter()
        .filter(|r| r.detail.prediction.case == LoadCase::I)
    {
        let [lo, hi] = r.band_pm_per_n.unwrap();
        let b = r.band_readings.unwrap();
        for k in [
            b.bonded_pillars_pm_per_n,
            b.sliding_apex_patch_pm_per_n,
            r.detail.prediction.sensitivity_pm_per_n,
        ] {
            assert!(lo <= k && k <= hi, "{k} outside [{lo}, {hi}]");
        }
    }
    let blue = rows
        .iter()
        .find(|r| {
            r.detail.prediction.grating == "lambda_11"
                && r.detail.prediction.insert.as_deref() == Some("blue")
        })
        .unwrap()
        .band_readings
        .unwrap();
    assert!(
        (10.0..=24.5).contains(&blue.bonded_pillars_pm_per_n),
        "bonded {}",
        blue.bonded_pillars_pm_per_n
    );
    assert!(
        (blue.sliding_apex_patch_pm_per_n / 253.0 - 1.0).abs() < 0.15,
        "sliding {}",
        blue.sliding_apex_patch_pm_per_n
    );
}

#[test]
fn module_contact_is_checked_field_by_field() {
    let base = std::fs::read_to_string(common::shipped_path("clip-on-34mm.toml")).unwrap();
    let radius = "dome_contact_radius_to_patch = 1.376";
    assert!(base.contains(radius));
    let with = |line: &str| base.replace(radius, line);
    // An unknown field is refused, naming the table and the field.
    let e = fbgforge::design::parse(&with(&format!("{radius}\nfriction = 0.3")))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("module.contact") && e.contains("friction"),
        "{e}"
    );
    let e =
        fbgforge::design::parse(&base.replace("cylinders = \"sliding\"", "cylinders = \"glued\""))
            .unwrap_err()
            .to_string();
    assert!(e.contains("module.contact") && e.contains("glued"), "{e}");
    for (line, field) in [
        (
            "dome_contact_radius_to_patch = -1.0",
            "module.contact.dome_contact_radius_to_patch",
        ),
        (
            "dome_contact_radius_to_patch = nan",
            "module.contact.dome_contact_radius_to_patch",
        ),
        // 40 patches: a radius beyond half the module's radius.
        (
            "dome_contact_radius_to_patch = 40.0",
            "module.contact.dome_contact_radius_to_patch",
        ),
        (
            "dome_contact_radius_mm = -1.0",
            "module.contact.dome_contact_radius_mm",
        ),
        (
            "dome_contact_radius_mm = 40.0",
            "module.contact.dome_contact_radius_mm",
        ),
        // A length given both ways.
        (
            "dome_contact_radius_to_patch = 1.376\ndome_contact_radius_mm = 1.72",
            "module.contact.dome_contact_radius_mm",
        ),
    ] {
        let e = fbgforge::design::parse(&with(line))
            .unwrap_err()
            .to_string();
        assert!(e.contains(field), "{line}: {e}");
    }
    let e = fbgforge::design::parse(&base.replace(
        "clip_height_to_cap_wall = 1.0",
        "clip_height_to_cap_wall = 0",
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("module.contact.clip_height_to_cap_wall"), "{e}");
    // A radius in mm is accepted at this size and means the same as its ratio.
    let d = fbgforge::design::parse(&with("dome_contact_radius_mm = 1.72")).unwrap();
    assert!((d.module.as_ref().unwrap().dome_contact_radius_mm() - 1.72).abs() < 1e-12);
    // Absent, the table takes its defaults: the same prediction as the shipped values.
    let bare = base.split("[module.contact]").next().unwrap().to_string();
    let d = fbgforge::design::parse(&bare).unwrap();
    let m = d.module.as_ref().unwrap();
    assert!((m.dome_contact_radius_mm() - 1.72).abs() < 1e-12);
    assert!((m.clip_height_mm() - 1.5).abs() < 1e-12);
    assert!((m.dome_clearance_mm() - 0.1).abs() < 1e-12);
}

/// The 34 mm design with one strain grating on PSC 1 (the synthetic log gives each
/// further grating of a core 15 % less K than the first, which no model predicts).
fn one_grating_design() -> Design {
    let mut d = design("clip-on-34mm.toml");
    d.module
        .as_mut()
        .unwrap()
        .gratings
        .retain(|g| g.name != "lambda_12");
    d
}

/// Optimise `d` for sensitivity (PSC 1 material, blue insert, 5 N): the start's K,
/// the answer's K as the optimiser reports it and as `predict` gives it for the
/// written design, and the answer's variables.
fn sensitivity_optimum(d: &Design) -> (f64, f64, f64, Vec<f64>) {
    use fbgforge::optimize::module::{optimise_module, Objective};
    let s = ModuleSettings {
        objective: Objective::Sensitivity,
        extra_starts: 0,
        max_force_n: 5.0,
        cores: Some(vec!["core_rubber_case_i".into()]),
        inserts: Some(vec!["insert_blue".into()]),
        // The table's best, not the front's knee: this follows the scalar optimum.
        prefer: fbgforge::optimize::module::Preference::Objective,
        // One grating in one case: the paper's Case II/Case I statement cannot hold,
        // and this follows the optimum, so the design is written naming it.
        paper_statements: fbgforge::optimize::module::PaperStatementsPolicy::Report,
        ..ModuleSettings::default()
    };
    let out = optimise_module(
        d,
        &MaterialLibrary::shipped(),
        &s,
        None,
        model_predictor(),
        &Quiet,
    )
    .unwrap();
    let start_k = out.start.gratings[0].sensitivity_pm_per_n;
    let best = out.choices[out.best_choice].best.as_ref().unwrap();
    let written = fbgforge::design::parse(&out.design.to_toml()).unwrap();
    let insert = written.module.as_ref().unwrap().inserts[0].name.clone();
    let k_written = k_of(
        &policy(&written, false),
        "lambda_11",
        LoadCase::I,
        Some(&insert),
    );
    (
        start_k,
        best.gratings[0].sensitivity_pm_per_n,
        k_written,
        best.x.clone(),
    )
}

#[test]
fn a_measured_log_calibrates_the_contact_so_predict_reproduces_it_and_optimize_follows() {
    use fbgforge::synth::module_log::{self as synth, LogStyle, SynthConfig};
    use fbgforge::verify::verdict::Status;
    let dir = tempfile::tempdir().unwrap();
    let d = one_grating_design();
    let design_path = dir.path().join("design.toml");
    std::fs::write(&design_path, d.to_toml()).unwrap();
    // The truth: the same module whose domes touch over 2.1 mm instead of 1.72 mm.
    let truth_design = prediction::with_contact_radius(&d, 2.1);
    let k_true = k_of(
        &policy(&truth_design, false),
        "lambda_11",
        LoadCase::I,
        Some("blue"),
    );
    let k_nominal = k_of(&policy(&d, false), "lambda_11", LoadCase::I, Some("blue"));
    assert!(
        k_nominal / k_true > 1.2,
        "{k_nominal} vs {k_true}: the settings must differ"
    );
    let cfg = SynthConfig {
        core: Some("psc1".into()),
        sensitivity_pm_per_n: k_true,
        pulses: synth::pulse_train(&[2.0, 4.0, 6.0, 8.0, 5.0], 4.0, 6.0, 5.0),
        duration_s: 55.0,
        ..SynthConfig::default()
    };
    let (log, force, _) = synth::generate(&d, &cfg).unwrap();
    let log_path = dir.path().join("log.txt");
    let force_path = dir.path().join("force.csv");
    synth::write_log(
        &log_path,
        fbgforge::logs::LogFormat::EnlightPeaks,
        &log,
        &cfg,
        &LogStyle::default(),
    )
    .unwrap();
    synth::write_force_csv(&force_path, &force).unwrap();
    let calibrated_path = dir.path().join("calibrated.toml");
    let mut req = fbgforge::verify::VerifyRequest::new(design_path, log_path, force_path);
    req.case = Some(LoadCase::I);
    req.insert = Some("blue".into());
    req.analysis.core = Some("psc1".into());
    req.calibrate_into = Some(calibrated_path.clone());
    let out = fbgforge::verify::run(&req).unwrap();
    // Far from the nominal K but inside the band: its own status, not a FAIL. The
    // band spans more than a factor 3 (10.7 … 221 pm/N), so the configuration cannot be
    // judged until the contact is calibrated (issue 23).
    let g = &out.report.verdict.gratings[0];
    assert_eq!(g.status, Status::CalibrateContact, "{g:?}");
    assert_eq!(out.report.verdict.overall, Status::CalibrateContact);
    let cal = out.calibration.unwrap();
    assert!((cal.previous_radius_mm - 1.72).abs() < 1e-12);
    assert!(
        (cal.radius_mm / 2.1 - 1.0).abs() < 0.02,
        "calibrated radius {} mm, truth 2.1 mm",
        cal.radius_mm
    );
    // The written design predicts the truth.
    let calibrated = fbgforge::design::load(&calibrated_path).unwrap();
    let k_cal = k_of(
        &policy(&calibrated, false),
        "lambda_11",
        LoadCase::I,
        Some("blue"),
    );
    assert!(
        (k_cal / k_true - 1.0).abs() <= 0.02,
        "calibrated predict {k_cal} vs truth {k_true}"
    );
    assert!(calibrated.module.as_ref().unwrap().contact.note.is_some());
    // And optimize uses it: its start K is the calibrated prediction, and its answer
    // moves with it.
    let (start_before, best_before, written_before, x_before) = sensitivity_optimum(&d);
    let (start_after, best_after, written_after, x_after) = sensitivity_optimum(&calibrated);
    assert!((start_before / k_nominal - 1.0).abs() < 1e-9);
    assert!((start_after / k_cal - 1.0).abs() < 1e-9);
    // What optimize reports for its answer is what predict says of the written design.
    assert!(
        (best_before / written_before - 1.0).abs() < 1e-9,
        "{best_before} vs {written_before}"
    );
    assert!(
        (best_after / written_after - 1.0).abs() < 1e-9,
        "{best_after} vs {written_after}"
    );
    // Both answers reach the strain limit (723 pm/N at 5 N), so the calibrated module,
    // less sensitive at the start, needs another design to get there.
    let moved = x_before
        .iter()
        .zip(&x_after)
        .any(|(a, b)| (a - b).abs() > 0.01 * a.abs());
    assert!(
        moved,
        "the answer did not move: {x_before:?} vs {x_after:?}"
    );
}
