//! Issue 35: the frame test's size is what it states. A true answer (the synthetic
//! frame's own loads, read with exactly the stated noise) is flagged by the test
//! with probability at most the significance, on arrays of every size; an answer a
//! far better explanation beats is flagged.

use fbgforge::array::kernel::{
    fiber_grid_layout, matrix_from_positions, paper_layout, DistanceKernel,
};
use fbgforge::array::methods::Reconstruction;
use fbgforge::array::problem::{SensingProblem, Uncertainty, PAPER_MIN_LOAD_G};
use fbgforge::array::trust::{FrameTest, DEFAULT_SIGNIFICANCE, TESTS};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// The paper's 6 × 8 array and the fiber grids of 12 × 32 and 16 × 64 cells.
fn arrays() -> Vec<(&'static str, DMatrix<f64>)> {
    let (c, g) = paper_layout();
    let mut v = vec![(
        "6x8",
        matrix_from_positions(&c, &g, &DistanceKernel::paper()),
    )];
    for (name, cx, cy, nf, gpf) in [("12x32", 8, 4, 2, 6), ("16x64", 8, 8, 4, 4)] {
        let (c, g) = fiber_grid_layout(cx, cy, nf, gpf);
        v.push((
            name,
            matrix_from_positions(&c, &g, &DistanceKernel::table1_power_law(3.0)),
        ));
    }
    v
}

/// 1–4 loads of 30–240 g on distinct cells.
fn loads(n: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let mut x = vec![0.0; n];
    let k = rng.random_range(1..=4usize);
    let mut cells: Vec<usize> = (0..n).collect();
    for i in 0..k {
        let j = rng.random_range(i..n);
        cells.swap(i, j);
        x[cells[i]] = rng.random_range(30.0..240.0);
    }
    x
}

/// A frame read with exactly the stated noise: the matrix's per-entry error, the
/// additivity error (Gaussian, the stated sd) on frames of two or more loads, and
/// the resolution.
fn read(a: &DMatrix<f64>, x: &[f64], u: &Uncertainty, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let z = Normal::new(0.0, 1.0).unwrap();
    let several = x.iter().filter(|&&v| v > 0.0).count() >= 2;
    let seen = a.zip_map(&u.matrix_sd_pm_per_g, |v, s| v + s * z.sample(rng));
    (seen * DVector::from_column_slice(x))
        .iter()
        .map(|&y| {
            let add = if several {
                u.additivity_sd_frac * z.sample(rng)
            } else {
                0.0
            };
            y * (1.0 + add) + u.resolution_pm * z.sample(rng)
        })
        .collect()
}

/// The truth with its largest load moved to the cell whose column differs most from
/// its own (a wrong answer a far better explanation beats).
fn moved(a: &DMatrix<f64>, x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let j = (0..n).max_by(|&p, &q| x[p].total_cmp(&x[q])).unwrap();
    let far = (0..n)
        .filter(|&l| x[l] == 0.0)
        .max_by(|&p, &q| {
            let d = |l: usize| (a.column(l) - a.column(j)).norm();
            d(p).total_cmp(&d(q))
        })
        .unwrap();
    let mut w = x.to_vec();
    w[far] = w[j];
    w[j] = 0.0;
    w
}

#[test]
fn a_true_answer_is_flagged_at_most_at_the_stated_significance_on_every_array_size() {
    let frames = 400;
    for (name, a) in arrays() {
        let (m, n) = a.shape();
        for sigma in [0.25, 1.0] {
            let u = Uncertainty::paper(m, n, sigma);
            let p = SensingProblem::new(a.clone(), 250.0, true)
                .unwrap()
                .with_min_load_g(PAPER_MIN_LOAD_G)
                .unwrap()
                .with_uncertainty(u.clone())
                .unwrap();
            let test = FrameTest::new(&p, 4);
            let mut rng = ChaCha8Rng::seed_from_u64(3500 + n as u64);
            let (mut flagged, mut ambiguous, mut wrong_flagged) = (0usize, 0usize, 0usize);
            let mut words = std::collections::BTreeMap::<&str, usize>::new();
            for _ in 0..frames {
                let x = loads(n, &mut rng);
                let y = read(&a, &x, &u, &mut rng);
                let mut wrong = Reconstruction::answer(moved(&a, &x));
                test.assess(&y, &mut wrong);
                wrong_flagged += usize::from(!wrong.flags.trusted());
                let mut r = Reconstruction::answer(x);
                test.assess(&y, &mut r);
                flagged += usize::from(!r.flags.trusted());
                ambiguous += usize::from(r.flags.ambiguous);
                for w in r.flags.words() {
                    *words.entry(w).or_default() += 1;
                }
            }
            // At α = 0.05 a true answer is flagged with probability ≤ 0.05 (20 of 400
            // on average; the bound is 3 binomial sd above), `ambiguous` ≤ α/3.
            let sd = |q: f64| 3.0 * (q * (1.0 - q) * frames as f64).sqrt();
            let alpha = DEFAULT_SIGNIFICANCE;
            assert!(
                (flagged as f64) <= alpha * frames as f64 + sd(alpha),
                "{name} σ {sigma}: {flagged} of {frames} flagged: {words:?}"
            );
            assert!(
                (ambiguous as f64) <= alpha / TESTS * frames as f64 + sd(alpha / TESTS),
                "{name} σ {sigma}: {ambiguous} of {frames} ambiguous"
            );
            // A wrong answer (its largest load moved to the most different cell) is
            // flagged, `inconsistent` or `ambiguous`.
            assert!(
                wrong_flagged as f64 >= 0.95 * frames as f64,
                "{name} σ {sigma}: {wrong_flagged} of {frames} wrong answers flagged"
            );
        }
    }
}
