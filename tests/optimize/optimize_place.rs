//! Grating placement in the flat array: a degenerate start is strictly improved, also on
//! held-out protocol seeds; the reported objective is the written layout's; valid
//! designs whose mold follows the fibers; clear errors.

use crate::common;
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

/// The paper's array with every grating on the centre line, y = 0: each grating is then
/// as far from the cell above it as from the cell below, so the sensing matrix has
/// pairs of equal columns (mutual coherence exactly 1) and a load on one of the pair
/// cannot be told from a load on the other.
fn degenerate_layout() -> fbgforge::spec::Design {
    let mut d = design("tactile-array-60x80.toml");
    for g in &mut d.array.as_mut().unwrap().gratings {
        g.y_mm = 0.0;
    }
    d.validate().unwrap();
    d
}

#[test]
fn placement_strictly_improves_a_degenerate_layout_on_held_out_seeds() {
    let base = degenerate_layout();
    let s = quick(PlaceObjective::Coherence, false);
    let p = PlacementProblem::new(&base, &s).unwrap();
    let mu0 = p.coherence(&p.start_point());
    assert!((mu0 - 1.0).abs() < 1e-12, "coherence of the start {mu0}");
    let out = place(&base, &s, &Quiet).unwrap();
    // The search leaves the start: the placed layout is not the degenerate one and its
    // coherence is clearly below 1 (0.76 measured).
    assert!(out.best_x.iter().any(|y| y.abs() > 1.0), "{:?}", out.best_x);
    assert!(
        out.best_objective > out.start_objective + 0.1,
        "coherence {} -> {}",
        -out.start_objective,
        -out.best_objective
    );
    // On protocol seeds the search never saw (penalty tuned for each layout) the
    // placed layout recovers clearly more tests than the start, which confuses the
    // two cells of every column (19 % -> 68 % measured).
    assert_ne!(s.test_seeds, s.train_seeds);
    let (before, after) = (&out.start_test, &out.best_test);
    assert!(
        after.rr_pct > before.rr_pct + 25.0,
        "held-out RR {:.1} % -> {:.1} %",
        before.rr_pct,
        after.rr_pct
    );
    assert!(
        after.mean_snr_db > before.mean_snr_db,
        "{before:?} -> {after:?}"
    );
}

#[test]
fn placement_reports_the_objective_of_the_layout_it_writes() {
    let base = design("tactile-array-60x80.toml");
    for objective in [PlaceObjective::Protocol, PlaceObjective::Coherence] {
        let s = quick(objective, false);
        let out = place(&base, &s, &Quiet).unwrap();
        // The reported objective is the objective of the written layout.
        let p = PlacementProblem::new(&base, &s).unwrap();
        let again = p.objective(&out.best_x);
        assert!(
            (again - out.best_objective).abs() < 1e-9,
            "{objective:?}: {again} vs {}",
            out.best_objective
        );
        let written = ArrayLayout::from_array(out.design.array.as_ref().unwrap());
        let ys: Vec<f64> = written.grating_positions_mm.iter().map(|q| q.1).collect();
        assert_eq!(ys, out.best_x, "{objective:?}");
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

#[test]
fn placement_scores_with_the_designs_model_and_reports_its_gain_on_perturbed_models() {
    use fbgforge::array::kernel::{model_matrix, ArrayModelKind};
    let base = design("tactile-array-60x80.toml");
    let mut s = quick(PlaceObjective::Coherence, false);
    s.test_seeds = vec![11, 12];
    s.perturbed_draws = 2;
    s.perturbed_scatter = 0.0;
    // The design names no model: the sheet model scores layouts, and its matrix at the
    // start is the one every other caller gets.
    for (kind, asked) in [
        (ArrayModelKind::Sheet, None),
        (ArrayModelKind::Kernel, Some(ArrayModelKind::Kernel)),
    ] {
        let mut s = s.clone();
        s.model = asked;
        let p = PlacementProblem::new(&base, &s).unwrap();
        assert_eq!(p.model_kind(), kind);
        let want = model_matrix(&base, Some(kind))
            .unwrap()
            .matrix
            .sensitivity_pm_per_g;
        let got = p.matrix(&p.start_point()).unwrap();
        assert!((&got - &want).norm() <= 1e-9 * want.norm(), "{kind:?}");
    }
    // No scatter: the perturbed models are the model, so their scores are the held-out
    // ones exactly (draw k runs on held-out seed k).
    let out = place(&base, &s, &Quiet).unwrap();
    assert_eq!(out.model, ArrayModelKind::Sheet);
    let g = out.perturbed.clone().unwrap();
    assert_eq!((g.scatter_per_entry, g.draws), (0.0, 2));
    for (a, b) in [(&g.start, &out.start_test), (&g.best, &out.best_test)] {
        assert!((a.rr_pct - b.rr_pct).abs() < 1e-9, "{a:?} {b:?}");
        assert!((a.mean_snr_db - b.mean_snr_db).abs() < 1e-9, "{a:?} {b:?}");
    }
    // 10 % per entry: other frames, other scores, the gain stated on them.
    s.perturbed_scatter = 0.10;
    let p = PlacementProblem::new(&base, &s).unwrap();
    let g = p.perturbed_gain(&out.start_x, &out.best_x).unwrap();
    assert_ne!(g.start.mean_snr_db, out.start_test.mean_snr_db);
    assert!((g.gain_score - (g.best.score() - g.start.score())).abs() < 1e-12);
    // A negative scatter is refused.
    s.perturbed_scatter = -0.1;
    let e = PlacementProblem::new(&base, &s).err().unwrap().to_string();
    assert!(e.contains("scatter"), "{e}");
}

/// The stages a run begins, each with its steps and every advance, in order (parallel
/// runs advance from several threads).
#[derive(Default)]
struct Stages {
    stages: std::sync::Mutex<Vec<(String, u64, Vec<u64>)>>,
    ended: std::sync::atomic::AtomicBool,
}

impl fbgforge::progress::Progress for Stages {
    fn begin(&self, label: &str, steps: u64) {
        self.stages
            .lock()
            .unwrap()
            .push((label.to_string(), steps, Vec::new()));
    }
    fn advance(&self, steps: u64) {
        let mut s = self.stages.lock().unwrap();
        s.last_mut().expect("a step before any stage").2.push(steps);
    }
    fn end(&self) {
        self.ended.store(true, std::sync::atomic::Ordering::SeqCst);
    }
}

#[test]
fn placement_progress_moves_within_the_search_and_each_stage_reaches_its_total() {
    let s = PlaceSettings {
        agreement_samples: 3,
        perturbed_draws: 1,
        ..quick(PlaceObjective::Coherence, false)
    };
    let rec = Stages::default();
    place(&degenerate_layout(), &s, &rec).unwrap();
    assert!(rec.ended.load(std::sync::atomic::Ordering::SeqCst));
    let stages = rec.stages.into_inner().unwrap();
    let labels: Vec<&str> = stages.iter().map(|(l, _, _)| l.as_str()).collect();
    assert_eq!(labels, ["searching", "held-out", "perturbed", "agreement"]);
    for (label, steps, advances) in &stages {
        // Monotone (every advance forward) and ending exactly at the stage's total.
        assert!(advances.iter().all(|&a| a > 0), "{label}: {advances:?}");
        assert_eq!(
            advances.iter().sum::<u64>(),
            *steps,
            "{label}: {advances:?}"
        );
    }
    // The search: Nelder–Mead from the start and one random start (25 iterations
    // each) and the swarm once (15), reported iteration by iteration, not per run.
    let (_, steps, advances) = &stages[0];
    assert_eq!(*steps, 2 * 25 + 15);
    assert!(advances.len() > 10, "{advances:?}");
}
