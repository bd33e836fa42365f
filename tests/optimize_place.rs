//! Grating placement in the flat array: never worse than the start on the training
//! protocol, valid designs whose mold follows the fibers, and clear errors.

mod common;

use fbgforge::array::methods::Method;
use fbgforge::optimize::place::{place, PlaceObjective, PlaceSettings, PlacementProblem};
use fbgforge::profile::ArrayLayout;
use fbgforge::progress::Quiet;
use fbgforge::solvers::{RunSettings, SolverKind};

use common::shipped as design;

fn quick(objective: PlaceObjective, vary_fibers: bool) -> PlaceSettings {
    PlaceSettings {
        objective,
        method: Method::Nnls,
        train_seeds: vec![1],
        test_seeds: vec![11],
        vary_fibers,
        extra_starts: 1,
        run: RunSettings {
            max_iters: 25,
            swarm_iters: 15,
            particles: 10,
            ..RunSettings::default()
        },
        agreement_samples: 0,
        ..PlaceSettings::default()
    }
}

#[test]
fn placement_never_scores_below_the_papers_layout() {
    let base = design("tactile-array-60x80.toml");
    for objective in [PlaceObjective::Protocol, PlaceObjective::Coherence] {
        let s = quick(objective, false);
        let out = place(&base, &s, &Quiet).unwrap();
        assert!(
            out.best_objective >= out.start_objective,
            "{objective:?}: {} < {}",
            out.best_objective,
            out.start_objective
        );
        // The reported objective is the objective of the written layout.
        let p = PlacementProblem::new(&base, &s).unwrap();
        let again = p.objective(&out.best_x);
        assert!(
            (again - out.best_objective).abs() < 1e-9,
            "{again} vs {}",
            out.best_objective
        );
        // Each solver's best is no better than the overall best.
        for r in &out.runs {
            assert!(r.best_objective <= out.best_objective + 1e-9);
            assert!(r.evaluations > 0 && !r.history.is_empty());
        }
        let back = fbgforge::design::parse(&out.design.to_toml()).unwrap();
        assert_eq!(back.array, out.design.array);
    }
}

#[test]
fn moved_fibers_move_the_mold_slits_and_keep_printable_walls() {
    let base = design("tactile-array-60x80.toml");
    let s = quick(PlaceObjective::Coherence, true);
    let out = place(&base, &s, &Quiet).unwrap();
    let a = out.design.array.as_ref().unwrap();
    let layout = ArrayLayout::from_array(a);
    // The slits are the fibers' x positions: the mold follows the optimised fibers.
    assert_eq!(layout.slit_x_mm, a.fiber_x_mm);
    let mut xs = a.fiber_x_mm.clone();
    xs.sort_by(|p, q| p.total_cmp(q));
    let gap = a.mold.slit_width_mm + base.printer.min_wall_mm;
    assert!(xs.windows(2).all(|w| w[1] - w[0] >= gap - 1e-12), "{xs:?}");
    for g in &a.gratings {
        assert!(g.y_mm.abs() + g.length_mm / 2.0 <= a.size_y_mm / 2.0 - s.edge_margin_mm + 1e-9);
    }
    assert!(out.best_objective >= out.start_objective);
    out.design.validate().unwrap();
}

#[test]
fn spacing_violation_is_measured() {
    let base = design("tactile-array-60x80.toml");
    let p = PlacementProblem::new(&base, &quick(PlaceObjective::Coherence, true)).unwrap();
    let mut x = p.start_point();
    assert_eq!(p.violation(&x), 0.0);
    // Put fiber 1 on top of fiber 0: the gap is 0, a full violation of one pair.
    let n = base.array.as_ref().unwrap().gratings.len();
    x[n + 1] = x[n];
    assert!((p.violation(&x) - 1.0).abs() < 1e-12, "{}", p.violation(&x));
}

#[test]
fn bad_placement_input_gets_a_clear_error() {
    let module = design("clip-on-34mm.toml");
    let e = place(&module, &quick(PlaceObjective::Coherence, false), &Quiet)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no [array] section"), "{e}");
    let base = design("tactile-array-60x80.toml");
    let s = PlaceSettings {
        edge_margin_mm: 40.0,
        ..quick(PlaceObjective::Coherence, false)
    };
    let e = place(&base, &s, &Quiet).unwrap_err().to_string();
    assert!(
        e.contains("infeasible") && e.contains("`edge_margin`"),
        "{e}"
    );
    let s = PlaceSettings {
        solvers: vec![],
        ..quick(PlaceObjective::Coherence, false)
    };
    assert!(place(&base, &s, &Quiet)
        .unwrap_err()
        .to_string()
        .contains("no solver"));
    assert!(PlaceObjective::parse("rr")
        .unwrap_err()
        .to_string()
        .contains("protocol or coherence"));
    assert!(SolverKind::parse("de").is_err());
}
