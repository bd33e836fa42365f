//! `--fidelity auto`: the closed form inside its measured validity region, the FE
//! model outside it. Each decision is checked against a fresh FE solve.

use fbgforge::fem::compare::{scaled_design, TOLERANCE};
use fbgforge::fem::{
    self, choose_fidelity, choose_fidelity_for, Configuration, FemOptions, Fidelity,
};
use fbgforge::model::LoadCase;
use fbgforge::spec::{self, Design};
use std::path::Path;

fn design() -> Design {
    spec::load(Path::new("designs/clip-on-34mm.toml")).unwrap()
}

/// Relative error of the closed form against the FE model for one configuration.
fn closed_form_error(d: &Design, c: &Configuration) -> f64 {
    let preds = fbgforge::model::predict(d, 1.0).unwrap();
    let k_cf = fem::compare::closed_form_k(&preds, c).unwrap();
    let r = fem::solve_configuration(d, c, &FemOptions::level(1)).unwrap();
    let (_, lambda, e) = r.strain_per_n[0].clone();
    let k_fe = d.fiber.shift_pm(lambda, e, 0.0);
    (k_cf - k_fe) / k_fe.abs()
}

#[test]
fn hollow_core_designs_inside_the_region_use_the_closed_form_and_it_holds() {
    let mut d = design();
    d.module.as_mut().unwrap().inserts.clear();
    assert_eq!(choose_fidelity(&d), Fidelity::ClosedForm);
    let c = Configuration {
        core: "psc2".into(),
        case: LoadCase::II,
        insert: None,
    };
    let err = closed_form_error(&d, &c);
    assert!(err.abs() <= TOLERANCE, "Case II closed-form error {err:.3}");
}

#[test]
fn designs_with_inserts_use_the_fem_because_case_i_misses_by_more_than_8_percent() {
    let d = design();
    assert_eq!(choose_fidelity(&d), Fidelity::Fem);
    assert_eq!(choose_fidelity_for(&d, LoadCase::II), Fidelity::ClosedForm);
    assert_eq!(choose_fidelity_for(&d, LoadCase::I), Fidelity::Fem);
    let c = Configuration {
        core: "psc1".into(),
        case: LoadCase::I,
        insert: Some("blue".into()),
    };
    let err = closed_form_error(&d, &c);
    assert!(err.abs() > TOLERANCE, "Case I closed-form error {err:.3}");
}

#[test]
fn designs_outside_the_measured_size_range_use_the_fem() {
    let mut d = scaled_design(&design(), 50.0, 1.5).unwrap();
    d.module.as_mut().unwrap().inserts.clear();
    assert_eq!(choose_fidelity(&d), Fidelity::Fem);
    let mut small = scaled_design(&design(), 10.0, 0.8).unwrap();
    small.module.as_mut().unwrap().inserts.clear();
    assert_eq!(choose_fidelity(&small), Fidelity::ClosedForm);
}

#[test]
fn scaled_family_rejects_walls_too_thick_for_the_diameter() {
    let err = scaled_design(&design(), 10.0, 1.5).unwrap_err();
    assert_eq!(err.field, "module.cap_wall_mm");
}
