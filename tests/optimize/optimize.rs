//! Module optimisation against synthetic models whose optimum is known in closed form,
//! constraint handling, and bad input.

use crate::common;
use fbgforge::model::{GratingPrediction, LoadCase};
use fbgforge::optimize::materials::MaterialLibrary;
use fbgforge::optimize::module::{
    optimise_module, parse_bounds, ModuleSettings, Objective, Predictor, Variable,
};
use fbgforge::progress::Quiet;
use fbgforge::solvers::SolverKind;
use fbgforge::spec::{Design, GratingRole};
use std::sync::Arc;

use common::shipped as design;

/// A synthetic model: every strain grating gets K = k(module) pm/N in every case, and
/// the strain that K implies through the fiber's strain sensitivity.
fn synthetic(k: impl Fn(&fbgforge::spec::Module) -> f64 + Send + Sync + 'static) -> Predictor {
    Predictor::Function(Arc::new(move |d: &Design, f: f64| {
        let m = d.module.as_ref().unwrap();
        let kk = k(m);
        let mut out = Vec::new();
        for g in m.gratings.iter().filter(|g| g.role == GratingRole::Strain) {
            let strain = d.fiber.strain_from_shift(g.bragg_wavelength_nm, kk * f);
            let mut push = |case, insert: Option<String>| {
                out.push(GratingPrediction {
                    grating: g.name.clone(),
                    core: g.core.clone().unwrap(),
                    case,
                    insert,
                    sensitivity_pm_per_n: kk,
                    shift_pm: kk * f,
                    strain,
                    warnings: vec![],
                })
            };
            push(LoadCase::II, None);
            for i in &m.inserts {
                push(LoadCase::I, Some(i.name.clone()));
            }
        }
        Ok(out)
    }))
}

/// A library of one purely elastic core and one insert, so that Q = |K| / sample period
/// exactly (no lag, R² = 1).
fn elastic_library() -> MaterialLibrary {
    let entry = |name: &str, role: &str, e: f64| {
        format!(
            "[materials.{name}]\nprocess = 'polyjet'\nroles = ['{role}']\nyoungs_modulus_mpa = {e}\npoisson_ratio = 0.45\nrelaxation_time_s = 1.0\nunrelaxed_to_relaxed_ratio = 1.0\nnonlinearity = 0.0\nsource = 'test'\n"
        )
    };
    let text = [
        entry("core_rubber_case_i", "core", 3.2),
        entry("cap_digital_abs", "cap", 44.0),
        entry("insert_blue", "insert", 2000.0),
    ]
    .concat();
    MaterialLibrary::parse(&text, "test-library").unwrap()
}

fn only_start_choice(s: &mut ModuleSettings) {
    s.cores = Some(vec!["core_rubber_case_i".into()]);
    s.inserts = Some(vec!["insert_blue".into()]);
}

#[test]
fn finds_an_interior_analytic_optimum_with_both_solvers() {
    // K = 10 exp(−((D − 16)/6)² − (t_core − 1)²): maximum 10 pm/N at D = 16 mm,
    // t_core = 1 mm; Q = K / 0.5 s = 20 pm/(N·s).
    let pred = synthetic(|m| {
        10.0 * (-((m.outer_diameter_mm - 16.0) / 6.0).powi(2) - (m.core_wall_mm - 1.0).powi(2))
            .exp()
    });
    let base = design("clip-on-16mm.toml");
    let lib = elastic_library();
    for solver in SolverKind::ALL {
        let mut s = ModuleSettings {
            vary: vec![Variable::OuterDiameterMm, Variable::CoreWallMm],
            solvers: vec![solver],
            ..ModuleSettings::default()
        };
        s.run.max_iters = 300;
        s.run.swarm_iters = 150;
        only_start_choice(&mut s);
        let out = optimise_module(&base, &lib, &s, None, pred.clone(), &Quiet).unwrap();
        let best = out.choices[out.best_choice].best.as_ref().unwrap();
        assert!(
            (best.x[0] - 16.0).abs() < 0.15,
            "{solver:?}: D = {}",
            best.x[0]
        );
        assert!(
            (best.x[1] - 1.0).abs() < 0.03,
            "{solver:?}: t = {}",
            best.x[1]
        );
        assert!(
            (best.objective - 20.0).abs() < 0.01,
            "{solver:?}: Q = {}",
            best.objective
        );
        // The design written out carries the optimum.
        let m = out.design.module.as_ref().unwrap();
        assert!((m.outer_diameter_mm - best.x[0]).abs() < 1e-12);
        assert!(out.choices[0]
            .runs
            .iter()
            .all(|r| r.iterations > 0 && !r.history.is_empty()));
    }
}

#[test]
fn strain_limit_sets_the_optimum_diameter() {
    // K = 2·D pm/N grows with D; at 50 N the strain limit 1500 µε, less the 5 % margin
    // every design keeps, caps K at K* = 0.95 · 1500e-6 · λ(1 − p_e)·1e3 / 50 for the
    // shorter-wavelength grating (the same shift is a larger strain there), so D* =
    // K*/2. The synthetic model states no error: its design interval is its nominal.
    let base = design("clip-on-16mm.toml");
    let lambda_min = 1524.570;
    let lim = 1.5e-3;
    let held = (1.0 - ModuleSettings::default().strain_margin_fraction) * lim;
    assert!((held - 1.425e-3).abs() < 1e-15);
    let k_star = held * lambda_min * 1e3 * (1.0 - base.fiber.photoelastic_pe) / 50.0;
    let d_star = k_star / 2.0;
    assert!(d_star > 10.0 && d_star < 22.0, "test set-up: D* = {d_star}");
    let pred = synthetic(|m| 2.0 * m.outer_diameter_mm);
    let mut s = ModuleSettings {
        objective: Objective::Sensitivity,
        vary: vec![Variable::OuterDiameterMm],
        max_force_n: 50.0,
        max_grating_strain: lim,
        ..ModuleSettings::default()
    };
    only_start_choice(&mut s);
    let out = optimise_module(&base, &elastic_library(), &s, None, pred, &Quiet).unwrap();
    let best = out.choices[out.best_choice].best.as_ref().unwrap();
    assert!(
        best.x[0] <= d_star + 1e-9,
        "constraint broken: D = {} > {d_star}",
        best.x[0]
    );
    assert!(
        d_star - best.x[0] < 0.05,
        "optimum not reached: D = {}, D* = {d_star}",
        best.x[0]
    );
    let strain = best
        .constraints
        .iter()
        .find(|c| c.name == "grating_strain")
        .unwrap();
    assert_eq!(strain.violation, 0.0);
}

#[test]
fn every_returned_design_meets_every_constraint_loads_and_beats_the_start() {
    // A model with a real trade-off: K grows with D and falls with both walls.
    let pred = synthetic(|m| {
        0.8 * m.outer_diameter_mm / (m.cap_wall_mm + m.core_wall_mm) * m.dome_height_mm
            / m.outer_diameter_mm
    });
    for file in [
        "clip-on-34mm.toml",
        "clip-on-16mm.toml",
        "clip-on-10mm.toml",
    ] {
        let base = design(file);
        let s = ModuleSettings {
            extra_starts: 1,
            ..ModuleSettings::default()
        };
        let out = optimise_module(
            &base,
            &MaterialLibrary::shipped(),
            &s,
            None,
            pred.clone(),
            &Quiet,
        )
        .unwrap();
        for c in &out.choices {
            if let Some(b) = &c.best {
                for con in &b.constraints {
                    assert_eq!(
                        con.violation, 0.0,
                        "{file} {}: {} violated: {}",
                        c.choice, con.name, con.detail
                    );
                }
            }
        }
        let best = out.choices[out.best_choice].best.as_ref().unwrap();
        assert!(
            out.start.feasible(),
            "{file}: start infeasible: {:?}",
            out.start.constraints
        );
        assert!(
            best.objective >= out.start.objective,
            "{file}: {} < start {}",
            best.objective,
            out.start.objective
        );
        // The written TOML loads and validates, and describes the same design.
        let text = out.design.to_toml();
        let back = fbgforge::design::parse(&text).unwrap_or_else(|e| panic!("{file}: {e}\n{text}"));
        assert_eq!(back, out.design);
        let m = back.module.as_ref().unwrap();
        assert_eq!(m.cores.len(), 1);
        assert!(
            m.outer_diameter_mm >= out.lower_bounds[0] - 1e-9
                && m.outer_diameter_mm <= out.upper_bounds[0] + 1e-9
        );
        assert!(
            m.cap_wall_mm >= base.printer.min_wall_mm && m.core_wall_mm >= base.printer.min_wall_mm
        );
    }
}

#[test]
fn an_infeasible_problem_names_the_constraint() {
    let base = design("clip-on-16mm.toml");
    let lib = elastic_library();
    // Every design strains its gratings beyond a 1 µε limit.
    let mut s = ModuleSettings {
        max_grating_strain: 1e-6,
        extra_starts: 0,
        ..ModuleSettings::default()
    };
    only_start_choice(&mut s);
    let e = optimise_module(&base, &lib, &s, None, synthetic(|_| 5.0), &Quiet)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("infeasible") && e.contains("`grating_strain`"),
        "{e}"
    );
    // A 20 nm shift leaves the grating's wavelength window.
    let mut s = ModuleSettings {
        max_grating_strain: 0.5,
        extra_starts: 0,
        ..ModuleSettings::default()
    };
    only_start_choice(&mut s);
    let e = optimise_module(&base, &lib, &s, None, synthetic(|_| 400.0), &Quiet)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`wavelength_window`"), "{e}");
    // Walls bounded below the printer's minimum wall.
    let mut s = ModuleSettings {
        bounds: parse_bounds("cap_wall_mm=0.05:0.1").unwrap(),
        ..ModuleSettings::default()
    };
    only_start_choice(&mut s);
    let e = optimise_module(&base, &lib, &s, None, synthetic(|_| 5.0), &Quiet)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`printer_min_wall`"), "{e}");
}

#[test]
fn bad_input_gets_a_clear_error() {
    let base = design("clip-on-16mm.toml");
    let lib = elastic_library();
    let pred = synthetic(|_| 5.0);
    let e = Variable::parse_list("outer_diameter_mm,shell_mm")
        .unwrap_err()
        .to_string();
    assert!(e.contains("`shell_mm`") && e.contains("cap_wall_mm"), "{e}");
    let e = parse_bounds("outer_diameter_mm=22:x")
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a number"), "{e}");
    let s = ModuleSettings {
        bounds: parse_bounds("outer_diameter_mm=22:10").unwrap(),
        ..ModuleSettings::default()
    };
    let e = optimise_module(&base, &lib, &s, None, pred.clone(), &Quiet)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("contradictory bounds") && e.contains("outer_diameter_mm"),
        "{e}"
    );
    let s = ModuleSettings {
        cores: Some(vec!["unobtainium".into()]),
        ..ModuleSettings::default()
    };
    let e = optimise_module(&base, &lib, &s, None, pred.clone(), &Quiet)
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown material `unobtainium`"), "{e}");
    let s = ModuleSettings {
        cores: Some(vec![]),
        ..ModuleSettings::default()
    };
    let e = optimise_module(&base, &lib, &s, None, pred.clone(), &Quiet)
        .unwrap_err()
        .to_string();
    assert!(e.contains("empty"), "{e}");
    let empty = MaterialLibrary {
        materials: Default::default(),
    };
    let e = optimise_module(
        &base,
        &empty,
        &ModuleSettings::default(),
        None,
        pred.clone(),
        &Quiet,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("material library is empty"), "{e}");
    let array = design("tactile-array-60x80.toml");
    let e = optimise_module(&array, &lib, &ModuleSettings::default(), None, pred, &Quiet)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no [module] section"), "{e}");
}
