//! Issue 24, points 2–4: a flag on every frame, the common-mode term, dead gratings
//! and the matrix's own uncertainty, through the one core every front end calls
//! (`array::reconstruct`), on synthetic frames with known truth.

use fbgforge::array::kernel::{matrix_from_positions, paper_layout, DistanceKernel};
use fbgforge::array::methods::{Method, ReadingSettings};
use fbgforge::array::problem::{SensingProblem, Uncertainty};
use fbgforge::array::protocol::snr_db;
use fbgforge::array::reconstruct::{reconstruct, Frames, MethodRequest, Reconstructed};
use fbgforge::progress::Quiet;
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

fn paper_matrix() -> DMatrix<f64> {
    let (c, g) = paper_layout();
    matrix_from_positions(&c, &g, &DistanceKernel::paper())
}

fn names(m: usize) -> Vec<String> {
    (1..=m).map(|i| format!("fbg{i}")).collect()
}

/// `count` frames of 1–2 loads of 50–200 g on distinct cells: (truth, clean shifts).
fn cases(a: &DMatrix<f64>, count: usize, seed: u64) -> Vec<(Vec<f64>, Vec<f64>)> {
    let n = a.ncols();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|f| {
            let mut x = vec![0.0; n];
            for _ in 0..1 + f % 2 {
                x[rng.random_range(0..n)] = [50.0, 100.0, 200.0][rng.random_range(0..3)];
            }
            let y = (a * DVector::from_column_slice(&x))
                .iter()
                .copied()
                .collect();
            (x, y)
        })
        .collect()
}

fn add_noise(y: &[f64], sigma: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let d = Normal::new(0.0, sigma).unwrap();
    y.iter().map(|v| v + d.sample(rng)).collect()
}

fn run(p: &SensingProblem, ys: &[Vec<f64>], method: Method) -> Reconstructed {
    run_k(p, ys, method, 4)
}

fn run_k(p: &SensingProblem, ys: &[Vec<f64>], method: Method, max_loads: usize) -> Reconstructed {
    let g = names(p.n_gratings());
    let prior = ReadingSettings {
        max_loads,
        resolution_pm: p.uncertainty.resolution_pm,
    };
    reconstruct(
        p,
        Frames {
            gratings: &g,
            shifts_pm: ys,
        },
        &prior,
        &MethodRequest::named(method),
        &Quiet,
    )
    .unwrap()
}

fn share(
    done: &Reconstructed,
    f: impl Fn(&fbgforge::array::methods::Reconstruction) -> bool,
) -> f64 {
    done.frames.iter().filter(|r| f(r)).count() as f64 / done.frames.len() as f64
}

#[test]
fn clean_frames_pass_the_residual_test_and_a_common_offset_fails_it() {
    let a = paper_matrix();
    let mut rng = ChaCha8Rng::seed_from_u64(24);
    let truth = cases(&a, 200, 7);
    let clean: Vec<Vec<f64>> = truth
        .iter()
        .map(|(_, y)| add_noise(y, 0.5, &mut rng))
        .collect();
    let p = SensingProblem::new(a.clone(), 250.0, true).unwrap();
    for method in [
        Method::Support,
        Method::BranchAndBound,
        Method::WeightedSupport,
    ] {
        let done = run(&p, &clean, method);
        // At the default significance α = 0.05 a clean frame fails the χ² test with
        // probability 0.05: 10 of 200 on average, 20 three standard deviations above.
        let false_flags = share(&done, |r| r.flags.inconsistent);
        assert!(false_flags <= 0.10, "{method:?}: {false_flags}");
        assert!(done.frames.iter().all(|r| r.dof > 0 && r.chi2 >= 0.0));
        assert_eq!(
            done.flag_counts.inconsistent,
            (false_flags * 200.0).round() as usize
        );
    }
    // A temperature change of 3 pm on every grating since the tare: without the
    // common-mode term spurious light loads absorb it (flagged below the rated
    // range) and frames are lost.
    let warm: Vec<Vec<f64>> = clean
        .iter()
        .map(|y| y.iter().map(|v| v + 3.0).collect())
        .collect();
    let rr = |d: &Reconstructed| {
        d.frames
            .iter()
            .zip(&truth)
            .filter(|(r, (x, _))| snr_db(x, &r.loads_g) >= 12.0)
            .count()
    };
    // Without the term (the diagnosis may not fit one: `with_auto_common_mode(None)`).
    let p_blind = p.clone().with_auto_common_mode(None).unwrap();
    let blind = run(&p_blind, &warm, Method::Support);
    let missed: Vec<bool> = blind
        .frames
        .iter()
        .zip(&truth)
        .map(|(r, (x, _))| snr_db(x, &r.loads_g) < 12.0)
        .collect();
    let flagged_misses = blind
        .frames
        .iter()
        .zip(&missed)
        .filter(|(r, &miss)| miss && !r.flags.trusted())
        .count();
    let misses = missed.iter().filter(|&&m| m).count();
    assert!(misses >= 10, "the offset costs frames: {misses}");
    // (29 of 60 measured: each of the frame's three tests runs at α/3 since issue 35,
    // and the misses whose spurious loads explain the offset within the noise are
    // beyond any test of that size.)
    assert!(
        flagged_misses as f64 >= 0.4 * misses as f64,
        "{flagged_misses} of {misses} missed frames flagged"
    );
    // With the common-mode term the offset is fitted: frames pass, loads come back,
    // and the offset is reported.
    let pc = SensingProblem::new(a.clone(), 250.0, true)
        .unwrap()
        .with_common_mode(&[1.0; 6])
        .unwrap();
    let done = run(&pc, &warm, Method::Support);
    let flagged = share(&done, |r| r.flags.inconsistent);
    assert!(flagged <= 0.10, "with the common mode: {flagged}");
    // Left to the stream diagnosis the decision is stated with its numbers. (On this
    // 6-grating array a constant 3 pm offset is partly absorbed by the loads: the
    // median frame's χ² drop, 1.1, is under the rule's 2, and the term is not
    // fitted; on the 10 × 20 grid it is: array_faults.)
    let auto = run(&p, &warm, Method::Support);
    let note = &auto.diagnosis.common_mode;
    assert_eq!(note.decided, "auto");
    assert!(note.reason.contains("χ²"), "{note:?}");
    let recovered = done
        .frames
        .iter()
        .zip(&truth)
        .filter(|(r, (x, _))| snr_db(x, &r.loads_g) >= 12.0)
        .count();
    assert!(recovered >= 180, "recovered {recovered} of 200");
    assert!(recovered > rr(&blind));
    let offsets: Vec<f64> = done
        .frames
        .iter()
        .map(|r| r.common_mode_pm.unwrap())
        .collect();
    let mean = offsets.iter().sum::<f64>() / offsets.len() as f64;
    assert!((mean - 3.0).abs() < 0.3, "mean fitted offset {mean} pm");
}

#[test]
fn a_load_above_the_ceiling_is_flagged_and_one_below_is_not() {
    let a = paper_matrix();
    let p = SensingProblem::new(a.clone(), 250.0, true).unwrap();
    let frame = |load: f64| -> Vec<f64> {
        let mut x = vec![0.0; 8];
        x[1] = load;
        (&a * DVector::from_column_slice(&x))
            .iter()
            .copied()
            .collect()
    };
    for method in [
        Method::Support,
        Method::BranchAndBound,
        Method::WeightedSupport,
        Method::Nnls,
    ] {
        let done = run(&p, &[frame(400.0), frame(200.0), frame(1000.0)], method);
        let f = |k: usize| done.frames[k].flags;
        assert!(
            f(0).ceiling && f(0).overload,
            "{method:?} 400 g: {:?}",
            f(0)
        );
        assert!(f(2).overload, "{method:?} 1000 g: {:?}", f(2));
        assert!(f(1).trusted(), "{method:?} 200 g: {:?}", f(1));
    }
}

#[test]
fn identical_columns_make_the_frame_ambiguous_for_every_method() {
    let mut a = paper_matrix();
    let twin = a.column(2).clone_owned();
    a.set_column(5, &twin);
    let p = SensingProblem::new(a.clone(), 250.0, true).unwrap();
    let mut x = vec![0.0; 8];
    x[2] = 120.0;
    let y: Vec<f64> = (&a * DVector::from_column_slice(&x))
        .iter()
        .copied()
        .collect();
    let mut other = vec![0.0; 8];
    other[0] = 100.0;
    let y_other: Vec<f64> = (&a * DVector::from_column_slice(&other))
        .iter()
        .copied()
        .collect();
    for method in [
        Method::Support,
        Method::BranchAndBound,
        Method::WeightedSupport,
        Method::Nnls,
        Method::Omp,
        Method::Lasso,
    ] {
        let done = run(&p, &[y.clone(), y_other.clone()], method);
        assert!(
            done.frames[0].flags.ambiguous,
            "{method:?}: {:?}",
            done.frames[0]
        );
        assert!(
            !done.frames[1].flags.ambiguous,
            "{method:?}: {:?}",
            done.frames[1]
        );
    }
}

#[test]
fn a_dead_grating_is_named_and_the_frames_are_solved_without_it() {
    let a = paper_matrix();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let truth = cases(&a, 60, 11);
    let dead = 2;
    let ys: Vec<Vec<f64>> = truth
        .iter()
        .map(|(_, y)| {
            let mut v = add_noise(y, 0.5, &mut rng);
            v[dead] = 0.5 * rng.random_range(-1.0..1.0);
            v
        })
        .collect();
    let p = SensingProblem::new(a.clone(), 250.0, true).unwrap();
    let done = run(&p, &ys, Method::Support);
    let names: Vec<&str> = done
        .suspect_gratings
        .iter()
        .map(|s| s.name.as_str())
        .collect();
    assert_eq!(names, vec!["fbg3"]);
    assert_eq!(done.setup.problem().n_gratings(), 5);
    let rr = |d: &Reconstructed| {
        d.frames
            .iter()
            .zip(&truth)
            .filter(|(r, (x, _))| snr_db(x, &r.loads_g) >= 12.0)
            .count()
    };
    let without_check = run(
        &p.clone().with_dead_grating_check(false),
        &ys,
        Method::Support,
    );
    assert!(without_check.suspect_gratings.is_empty());
    assert!(
        rr(&done) > rr(&without_check),
        "{} against {}",
        rr(&done),
        rr(&without_check)
    );
    // A healthy stream names none.
    let healthy: Vec<Vec<f64>> = truth
        .iter()
        .map(|(_, y)| add_noise(y, 0.5, &mut rng))
        .collect();
    assert!(run(&p, &healthy, Method::Support)
        .suspect_gratings
        .is_empty());
}

#[test]
fn a_stated_matrix_uncertainty_explains_calibration_scatter() {
    // The lab's matrix has one entry twice what it should be (cell A's second most
    // sensitive grating: its repeat scatter is that large); frames load cell A with
    // 100–200 g, one load at a time (so no second load can absorb the error; an
    // error on the most sensitive grating would mostly move the load instead).
    let a = paper_matrix();
    let (m, n) = a.shape();
    let mut measured = a.clone();
    let mut rows: Vec<usize> = (0..m).collect();
    rows.sort_by(|&p, &q| a[(q, 0)].total_cmp(&a[(p, 0)]));
    let i = rows[1];
    measured[(i, 0)] *= 2.0;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let ys: Vec<Vec<f64>> = (0..100)
        .map(|f| {
            let mut x = vec![0.0; n];
            x[0] = 100.0 + f as f64;
            let y: Vec<f64> = (&a * DVector::from_column_slice(&x))
                .iter()
                .copied()
                .collect();
            add_noise(&y, 0.5, &mut rng)
        })
        .collect();
    // The per-frame test alone: the stream diagnosis, which would leave the grating
    // out, is off.
    let unaware = SensingProblem::new(measured.clone(), 250.0, true)
        .unwrap()
        .with_diagnosis(false);
    let mut sd = Uncertainty::paper(m, n, 0.5);
    sd.matrix_sd_pm_per_g[(i, 0)] = a[(i, 0)];
    let aware = unaware.clone().with_uncertainty(sd).unwrap();
    let f_unaware = share(&run_k(&unaware, &ys, Method::Support, 1), |r| {
        r.flags.inconsistent
    });
    let f_aware = share(&run_k(&aware, &ys, Method::Support, 1), |r| {
        r.flags.inconsistent
    });
    assert!(f_unaware > 0.5, "unaware of the scatter: {f_unaware}");
    assert!(f_aware < 0.05, "aware of it: {f_aware}");
}
