//! The model's stated error (issue 38): on random valid designs, wider than the shipped
//! family (diameter 8–40 mm, cap and core walls from the printer's minimum to a quarter
//! of the radius, dome 0.4–1 × the radius, log-uniform cap, core and insert moduli, a
//! PolyJet or an FDM-like printer), every prediction row's nominal K lies inside its
//! bounding readings widened by its stated model error — or, where those readings do
//! not fix K's sign, the row says the model is wrong there — and inside its design
//! interval;
//! a stated error above 0.15 is flagged on the row; and the strain at the largest force
//! comes from the far end of the design interval, never less than the nominal plus its
//! error. The policy's own mesh choice refines a configuration whose level-1 rows state
//! more than 0.15 one level at a time up to level 3; a row still over 0.15 there (issue
//! 38's design: the FE step stops shrinking) says so, and `optimize` does not write it.

use crate::common::shipped;
use fbgforge::fem::FemOptions;
use fbgforge::model::LoadCase;
use fbgforge::prediction::{predict, ModelledPrediction, PredictionRequest, MAX_MODEL_ERROR};
use fbgforge::spec::{Design, PrintProcess};
use proptest::prelude::*;

/// One random valid design from unit draws `u` (see the module doc), or `None` when
/// the spec refuses it.
fn random_design(base: &Design, u: [f64; 8], fdm: bool) -> Option<Design> {
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let log = |a: f64, b: f64, t: f64| (a.ln() + (b.ln() - a.ln()) * t).exp();
    let diameter = lerp(8.0, 40.0, u[0]);
    let mut d = fbgforge::family::scaled_design(base, diameter, 1.0).ok()?;
    if fdm {
        d.printer.process = PrintProcess::Fdm;
        d.printer.resolution_mm = 0.1;
        d.printer.min_wall_mm = 0.4;
    }
    let w = d.printer.min_wall_mm;
    let r = diameter / 2.0;
    let m = d.module.as_mut()?;
    m.cap_wall_mm = lerp(w, (0.25 * r).min(3.0), u[1]);
    m.core_wall_mm = lerp(w, (0.25 * r).min(3.0), u[2]);
    m.dome_height_mm = lerp(0.4 * r, r, u[3]);
    let cap = m.cap_material.clone();
    let cores: Vec<String> = m.cores.iter().map(|c| c.material.clone()).collect();
    let inserts: Vec<String> = m.inserts.iter().map(|i| i.material.clone()).collect();
    d.materials.get_mut(&cap)?.youngs_modulus_mpa = log(20.0, 200.0, u[4]);
    for (k, c) in cores.iter().enumerate() {
        d.materials.get_mut(c)?.youngs_modulus_mpa = log(0.8, 8.0, u[5 + k.min(1)]);
    }
    for (k, i) in inserts.iter().enumerate() {
        let t = (u[7] + 0.37 * k as f64).fract();
        d.materials.get_mut(i)?.youngs_modulus_mpa = log(20.0, 3000.0, t);
    }
    d.validate().ok()?;
    Some(d)
}

/// Every containment the policy states, on one design's rows (a message naming the
/// first row that breaks one).
pub(crate) fn check_containment(label: &str, rows: &[ModelledPrediction]) -> Result<(), String> {
    for r in rows {
        let p = &r.detail.prediction;
        let id = format!("{label} {} {} {:?}", p.grating, p.case, p.insert);
        let k = p.sensitivity_pm_per_n;
        let Some(f) = r.model_error_fraction else {
            // Only the closed form in Case I states no error.
            if r.model != fbgforge::prediction::Fidelity::ClosedForm {
                return Err(format!("{id}: an FE row without a stated error"));
            }
            continue;
        };
        if r.nominal_contained() != Some(true) {
            // Outside only where the bounding readings do not fix K's sign, and then
            // said on the row (very thin caps on large modules: the model-error study,
            // seed 7, 12 rows of 2 of 100 designs, the same at mesh level 3).
            let said = |text: &str| p.warnings.iter().any(|w| w.contains(text));
            if !(said("the model is wrong here") && said("sign of K is not fixed")) {
                return Err(format!(
                    "{id}: nominal {k} outside its widened readings {:?} (error {f}) and not flagged: {:?}",
                    r.widened_readings(),
                    p.warnings
                ));
            }
        }
        let [lo, hi] = r
            .design_interval_pm_per_n
            .ok_or(format!("{id}: no interval"))?;
        if !(lo <= k && k <= hi) {
            return Err(format!(
                "{id}: nominal {k} outside its design interval [{lo}, {hi}]"
            ));
        }
        // The interval holds the nominal widened by its own error.
        let d = f * k.abs();
        if !(lo <= k - d + 1e-9 * k.abs() && k + d - 1e-9 * k.abs() <= hi) {
            return Err(format!(
                "{id}: interval [{lo}, {hi}] narrower than {k} ± {d}"
            ));
        }
        let flagged = p.warnings.iter().any(|w| w.contains("stated model error"));
        if f > MAX_MODEL_ERROR && !flagged {
            return Err(format!(
                "{id}: error {f} over {MAX_MODEL_ERROR} and not flagged"
            ));
        }
        let c = r.limit_check.ok_or(format!("{id}: no limit check"))?;
        let nominal_plus = c.nominal_strain_microstrain.abs() * (1.0 + f);
        if c.far_end_strain_microstrain.abs() < nominal_plus * (1.0 - 1e-12) {
            return Err(format!(
                "{id}: far-end strain {} µε under the nominal plus its error {nominal_plus} µε",
                c.far_end_strain_microstrain
            ));
        }
    }
    Ok(())
}

fn rows_of(d: &Design) -> Vec<ModelledPrediction> {
    predict(
        d,
        &PredictionRequest {
            band: true,
            design_interval: true,
            cache: crate::fe_cache().clone(),
            ..PredictionRequest::default()
        },
    )
    .unwrap()
}

#[test]
fn every_shipped_design_states_its_error_and_holds_its_nominal_inside() {
    for file in [
        "clip-on-10mm.toml",
        "clip-on-16mm.toml",
        "clip-on-22mm.toml",
        "clip-on-34mm.toml",
    ] {
        let rows = rows_of(&shipped(file));
        check_containment(file, &rows).unwrap();
        // The shipped designs need no flag: every nominal inside.
        assert!(
            rows.iter().all(|r| r.nominal_contained() != Some(false)),
            "{file}"
        );
        for r in &rows {
            let p = &r.detail.prediction;
            if r.model == fbgforge::prediction::Fidelity::Fem {
                // Case I FE: 9 % modelling plus the mesh; Case II FE: 14 % plus it.
                let e = r.model_error.unwrap();
                assert!(e.discretisation_fraction >= fbgforge::prediction::DISCRETISATION_FLOOR);
                assert!(e.modelling_fraction == 0.09 || e.modelling_fraction == 0.14);
                // The shipped designs are meshed finely enough to state ≤ 15 %.
                assert!(
                    r.model_error_fraction.unwrap() <= MAX_MODEL_ERROR,
                    "{file} {p:?}"
                );
            }
        }
    }
}

/// The unit draws of issue 38's design: a 34.2 mm PolyJet module with a 0.37 mm cap and
/// a 0.68 mm core wall, whose light-green Case I rows state 17.2 % at mesh level 3 (a
/// free draw of the proptest below found it).
const ISSUE_38_DESIGN: [f64; 8] = [0.8189, 0.0249, 0.1416, 0.0, 0.0, 0.0, 0.0, 0.0];

proptest! {
    // A fixed seed, so that CI draws the same six designs every run; free seeds are
    // run locally (PROPTEST_RNG_SEED is ignored here: edit the seed; the model-error
    // study draws the same space at any --seed). A row may state more than 0.15 only
    // at the finest level the policy refines to, and then says so
    // (check_containment); issue 38's design is the explicit case below.
    #![proptest_config(ProptestConfig {
        cases: 6,
        failure_persistence: None,
        rng_seed: proptest::test_runner::RngSeed::Fixed(38),
        ..ProptestConfig::default()
    })]

    #[test]
    fn on_random_valid_designs_the_nominal_lies_inside_its_widened_readings_and_interval(
        u in prop::array::uniform8(0.0f64..1.0),
        fdm in prop::bool::weighted(0.3),
    ) {
        let base = shipped("clip-on-34mm.toml");
        let d = random_design(&base, u, fdm);
        prop_assume!(d.is_some());
        let d = d.unwrap();
        let rows = rows_of(&d);
        prop_assert!(!rows.is_empty());
        let label = format!("D {:.2} mm", d.module.as_ref().unwrap().outer_diameter_mm);
        if let Err(e) = check_containment(&label, &rows) {
            prop_assert!(false, "{}", e);
        }
        // Over 0.15 only where the policy refined as far as it goes.
        for r in &rows {
            let f = r.model_error_fraction.unwrap_or(0.0);
            prop_assert!(
                f <= MAX_MODEL_ERROR || r.mesh_level == Some(FemOptions::AUTO_FINEST_MESH_LEVEL),
                "{} {}: stated {} at mesh level {:?}", label, r.detail.prediction.grating, f, r.mesh_level
            );
        }
    }
}

/// Issue 38's design: the light-green Case I rows cannot state ≤ 0.15 at the finest
/// level the policy refines to, and the cause is real, not the estimate: the raw FE
/// reading's step between levels stops shrinking (levels 2→3→4 on the light-green
/// insert: +1.14, +1.27 pm/N on K ≈ 14 pm/N), so level 4 would state the same. The
/// rows say so, naming the row's error and why; the blue insert's rows (K ≈ 63 pm/N,
/// the same absolute step) state within 0.15.
#[test]
fn issue_38_design_states_over_15_percent_on_its_light_green_rows_and_says_why() {
    let d = random_design(&shipped("clip-on-34mm.toml"), ISSUE_38_DESIGN, false).unwrap();
    let rows = case_i(&d, 1, PredictionRequest::default().refine_to_level);
    check_containment("issue 38 design", &rows).unwrap();
    let insert = |r: &ModelledPrediction| r.detail.prediction.insert.clone().unwrap();
    let over: Vec<&ModelledPrediction> = rows
        .iter()
        .filter(|r| r.model_error_fraction.unwrap() > MAX_MODEL_ERROR)
        .collect();
    assert!(!over.is_empty());
    for r in &over {
        assert_eq!(insert(r), "light_green");
        assert_eq!(r.mesh_level, Some(FemOptions::AUTO_FINEST_MESH_LEVEL));
        let e = r.model_error.unwrap();
        // The discretisation term is what breaks 15 % (the modelling term is 9 %).
        assert!(e.discretisation_fraction > MAX_MODEL_ERROR - e.modelling_fraction);
        let w = r
            .detail
            .prediction
            .warnings
            .iter()
            .find(|w| w.contains("stated model error"))
            .expect("flagged");
        let pct = format!("{:.1} %", 100.0 * e.total_fraction);
        assert!(w.contains(&pct) && w.contains("at mesh level 3"), "{w}");
        assert!(
            w.contains("a finer mesh need not help") && w.contains("do not rely"),
            "{w}"
        );
    }
    for r in rows.iter().filter(|r| insert(r) == "blue") {
        assert!(r.model_error_fraction.unwrap() <= MAX_MODEL_ERROR);
    }
    // Why: the raw light-green reading's step does not shrink from level 2→3 to 3→4.
    let raw = |level: u32| {
        let rows = predict(
            &d,
            &PredictionRequest {
                case: Some(LoadCase::I),
                insert: Some("light_green".into()),
                fem_options: FemOptions {
                    reference_diameter_mm: Some(FemOptions::REFERENCE_DIAMETER_MM),
                    ..FemOptions::level(level)
                },
                refine_to_level: None,
                cache: crate::fe_cache().clone(),
                ..PredictionRequest::default()
            },
        )
        .unwrap();
        rows[0].detail.prediction.sensitivity_pm_per_n
    };
    let (k2, k3, k4) = (raw(2), raw(3), raw(4));
    assert!(
        (k4 - k3).abs() > 0.8 * (k3 - k2).abs(),
        "steps {} then {}",
        k3 - k2,
        k4 - k3
    );
}

/// The 34 mm module with a thin, soft cap over a stiff Case I core (the shape of the
/// model-error study's design 19): K_I of psc1 is small, and mesh level 1 states
/// 20–26 % on it, psc2's rows 13 %.
fn thin_cap() -> Design {
    let mut d = shipped("clip-on-34mm.toml");
    let m = d.module.as_mut().unwrap();
    m.cap_wall_mm = 0.64;
    m.core_wall_mm = 1.27;
    m.dome_height_mm = 12.0;
    let cap = m.cap_material.clone();
    d.materials.get_mut(&cap).unwrap().youngs_modulus_mpa = 30.0;
    d.materials
        .get_mut("core_rubber_case_i")
        .unwrap()
        .youngs_modulus_mpa = 5.5;
    d.validate().unwrap();
    d
}

fn case_i(d: &Design, level: u32, refine: Option<u32>) -> Vec<ModelledPrediction> {
    predict(
        d,
        &PredictionRequest {
            case: Some(LoadCase::I),
            band: true,
            design_interval: true,
            fem_options: FemOptions::mesh_level(level),
            refine_to_level: refine,
            cache: crate::fe_cache().clone(),
            ..PredictionRequest::default()
        },
    )
    .unwrap()
}

#[test]
fn where_level_1_states_over_15_percent_the_policy_refines_that_configuration_only() {
    let d = thin_cap();
    let fixed = case_i(&d, 1, None);
    let default = PredictionRequest::default();
    assert_eq!(
        default.refine_to_level,
        Some(FemOptions::AUTO_FINEST_MESH_LEVEL)
    );
    let auto = case_i(&d, 1, default.refine_to_level);
    check_containment("thin cap", &auto).unwrap();
    let config = |r: &ModelledPrediction| {
        let p = &r.detail.prediction;
        (p.core.clone(), p.insert.clone())
    };
    let over: Vec<_> = fixed
        .iter()
        .filter(|r| r.model_error_fraction.unwrap() > MAX_MODEL_ERROR)
        .map(config)
        .collect();
    assert!(
        !over.is_empty(),
        "the thin cap should state > 15 % at level 1"
    );
    let mut refined = 0;
    for (a, f) in auto.iter().zip(&fixed) {
        let (p, id) = (&a.detail.prediction, config(a));
        // Level 1, asked for exactly: the row says which term breaks 15 % and where.
        if f.model_error_fraction.unwrap() > MAX_MODEL_ERROR {
            assert!(
                f.detail
                    .prediction
                    .warnings
                    .iter()
                    .any(|w| w.contains("stated model error")
                        && w.contains("mesh is too coarse")
                        && w.contains("at mesh level 1")),
                "{:?}",
                f.detail.prediction.warnings
            );
        }
        assert!(a.model_error_fraction.unwrap() <= MAX_MODEL_ERROR, "{p:?}");
        assert!(!p.warnings.iter().any(|w| w.contains("stated model error")));
        if over.contains(&id) {
            // Refined: the row is the fixed prediction at the level it names.
            let k = a.mesh_level.unwrap();
            assert!(k > 1 && k <= FemOptions::AUTO_FINEST_MESH_LEVEL, "{k}");
            let at = case_i(&d, k, None);
            let same = at
                .iter()
                .find(|r| config(r) == id && r.detail.prediction.grating == p.grating)
                .unwrap();
            assert_eq!(
                same.detail.prediction.sensitivity_pm_per_n,
                p.sensitivity_pm_per_n
            );
            assert_eq!(same.design_interval_pm_per_n, a.design_interval_pm_per_n);
            assert_eq!(same.band_readings, a.band_readings);
            refined += 1;
        } else {
            // A configuration within 15 % keeps level 1 and its numbers.
            assert_eq!(a.mesh_level, Some(1));
            assert_eq!(
                p.sensitivity_pm_per_n,
                f.detail.prediction.sensitivity_pm_per_n
            );
        }
    }
    assert!(
        refined > 0 && refined < auto.len(),
        "{refined} of {}",
        auto.len()
    );
}

/// `predict --json` names the level the policy started from and the levels its rows
/// were answered at: on the thin cap some configurations are refined, so the two differ
/// (a single top-level `mesh_level` would have named the starting level as if every row
/// had it).
#[test]
fn predict_json_names_the_starting_mesh_level_and_every_level_the_rows_used() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("thin-cap.toml");
    std::fs::write(&path, thin_cap().to_toml()).unwrap();
    let o = crate::common::bin()
        .args([
            "predict",
            path.to_str().unwrap(),
            "--case",
            "i",
            "--json",
            "--no-spectrum",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v.get("mesh_level").is_none(), "{v}");
    assert_eq!(v["starting_mesh_level"], 1);
    let mut rows: Vec<u64> = v["predictions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["mesh_level"].as_u64().unwrap())
        .collect();
    rows.sort_unstable();
    rows.dedup();
    let used: Vec<u64> = v["mesh_levels_used"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l.as_u64().unwrap())
        .collect();
    assert_eq!(used, rows);
    assert!(used.len() > 1 && used[0] == 1, "{used:?}");
}

/// The 34 mm module with a very thin cap (0.35 mm) over a stiff Case I core (the
/// model-error study's seed-7 designs 59 and 87 have this shape).
fn very_thin_cap() -> Design {
    let mut d = shipped("clip-on-34mm.toml");
    let m = d.module.as_mut().unwrap();
    m.cap_wall_mm = 0.35;
    m.core_wall_mm = 1.43;
    m.dome_height_mm = 13.5;
    let cap = m.cap_material.clone();
    for (name, e) in [
        (cap.as_str(), 29.0),
        ("core_rubber_case_ii", 6.5),
        ("insert_blue", 195.0),
    ] {
        d.materials.get_mut(name).unwrap().youngs_modulus_mpa = e;
    }
    d.validate().unwrap();
    d
}

#[test]
fn where_the_bounding_readings_do_not_bound_the_nominal_the_rows_say_the_model_is_wrong() {
    let d = very_thin_cap();
    let rows = case_i(&d, 1, PredictionRequest::default().refine_to_level);
    // Outside only with both flags (check_containment), and the mesh is not the cause:
    // every row states its error within 15 %.
    check_containment("very thin cap", &rows).unwrap();
    let outside: Vec<&ModelledPrediction> = rows
        .iter()
        .filter(|r| r.nominal_contained() == Some(false))
        .collect();
    assert!(outside.len() >= 4, "{} rows outside", outside.len());
    for r in &outside {
        assert!(r.model_error_fraction.unwrap() <= MAX_MODEL_ERROR);
        // The family rule's contact radius turns Case I blue here: the readings
        // bracket neither its size nor its sign.
        assert!(r.detail.prediction.sensitivity_pm_per_n < 0.0);
    }
    let failed = fbgforge::prediction::check_paper_statements(&d, &rows)
        .map(|s| {
            s.failures()
                .iter()
                .map(|c| c.statement.to_string())
                .collect::<Vec<_>>()
        })
        .unwrap_or_default();
    assert!(failed.iter().any(|s| s == "case_i_red_shift"), "{failed:?}");
}
