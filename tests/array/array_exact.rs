//! Issue 24, point 1: the ℓ0 objective solved exactly at the load ceiling. `support`
//! and `bnb` against a brute force written apart from them (every support of ≤ K
//! cells, each one's bounded least squares by enumerating every assignment of its
//! loads to lower bound, upper bound or free and keeping the feasible KKT points), on
//! frames whose loads go well above ulimit.

use fbgforge::array::methods::{build, Method, MethodSettings};
use fbgforge::array::problem::SensingProblem;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// min ‖A_S x − y‖² over 0 ≤ x ≤ u by enumerating 3^k active sets (KKT-free: every
/// feasible stationary point of every face is a candidate, the least wins).
fn bounded_misfit(a: &DMatrix<f64>, y: &DVector<f64>, s: &[usize], u: f64) -> f64 {
    let k = s.len();
    let mut best = f64::INFINITY;
    for code in 0..3usize.pow(k as u32) {
        let mut c = code;
        let mut x = vec![0.0; k];
        let mut free = Vec::new();
        for (a_, xa) in x.iter_mut().enumerate() {
            match c % 3 {
                0 => *xa = 0.0,
                1 => *xa = u,
                _ => free.push(a_),
            }
            c /= 3;
        }
        let fixed = DVector::from_fn(a.nrows(), |i, _| {
            (0..k)
                .filter(|q| !free.contains(q))
                .map(|q| a[(i, s[q])] * x[q])
                .sum::<f64>()
        });
        if !free.is_empty() {
            let af = DMatrix::from_fn(a.nrows(), free.len(), |i, p| a[(i, s[free[p]])]);
            let Some(ch) = (af.transpose() * &af).cholesky() else {
                continue;
            };
            let sol = ch.solve(&(af.transpose() * (y - &fixed)));
            if sol.iter().any(|&v| !(-1e-9..=u + 1e-9).contains(&v)) {
                continue;
            }
            for (p, &q) in free.iter().enumerate() {
                x[q] = sol[p];
            }
        }
        let fit = DVector::from_fn(a.nrows(), |i, _| {
            (0..k).map(|q| a[(i, s[q])] * x[q]).sum::<f64>()
        });
        best = best.min((y - fit).norm_squared());
    }
    best
}

/// The ℓ0 optimum by brute force: min over supports S (|S| ≤ K, the empty one
/// included) of bounded_misfit(S) + λ|S|.
fn brute_force(a: &DMatrix<f64>, y: &[f64], kmax: usize, lambda: f64, u: f64) -> f64 {
    let n = a.ncols();
    let yv = DVector::from_column_slice(y);
    let mut best = yv.norm_squared();
    for mask in 1u32..(1 << n) {
        let s: Vec<usize> = (0..n).filter(|j| mask & (1 << j) != 0).collect();
        if s.len() > kmax {
            continue;
        }
        best = best.min(bounded_misfit(a, &yv, &s, u) + lambda * s.len() as f64);
    }
    best
}

fn l0_cost(a: &DMatrix<f64>, y: &[f64], x: &[f64], lambda: f64) -> f64 {
    let r = a * DVector::from_column_slice(x) - DVector::from_column_slice(y);
    r.norm_squared() + lambda * x.iter().filter(|&&v| v > 0.0).count() as f64
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// `support` and `bnb` reach the brute-force bounded optimum, certified, with
    /// loads up to 4 × ulimit (the 400 g on a 250 g array and beyond).
    #[test]
    fn support_and_bnb_match_brute_force_bounded_enumeration_above_the_ceiling(
        m in 3usize..6,
        extra in 0usize..4,
        kmax in 1usize..4,
        lambda in prop::sample::select(vec![0.25, 2.0, 8.0]),
        overload in prop::sample::select(vec![1.0, 1.6, 4.0]),
        seed in any::<u64>(),
    ) {
        let n = m + extra;
        let ulimit = 250.0;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let a = DMatrix::from_fn(m, n, |_, _| rng.random_range(0.02..0.5));
        let mut x = vec![0.0; n];
        for _ in 0..rng.random_range(1..=kmax.min(n)) {
            x[rng.random_range(0..n)] = rng.random_range(25.0..ulimit * overload);
        }
        let y: Vec<f64> = (a.clone() * DVector::from_column_slice(&x))
            .iter()
            .map(|v| v + rng.random_range(-2.0..2.0))
            .collect();
        let want = brute_force(&a, &y, kmax, lambda, ulimit);
        for normalised in [false, true] {
            let p = SensingProblem::new(a.clone(), ulimit, normalised).unwrap();
            for method in [Method::Support, Method::BranchAndBound] {
                let mut settings = MethodSettings::for_method(method)
                    .with_max_loads(kmax);
                // λ is per load in pm² on both scalings (the objective is a residual).
                settings = settings.with_penalty(lambda);
                let r = build(&p, &settings).unwrap().reconstruct(&y);
                prop_assert!(r.converged && r.certified, "{method:?}");
                prop_assert!(r.loads_g.iter().all(|&v| (0.0..=ulimit).contains(&v)));
                let got = l0_cost(&a, &y, &r.loads_g, lambda);
                prop_assert!(
                    (got - want).abs() <= 1e-7 * (1.0 + want),
                    "{method:?} (normalised {normalised}): {got} against brute force {want}"
                );
            }
        }
    }
}
