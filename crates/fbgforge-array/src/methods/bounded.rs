//! Bounded least squares on one support, solved exactly: min zᵀGz − 2bᵀz over
//! l ≤ z ≤ u (G = ÂₛᵀÂₛ positive definite) by a primal active-set method with lower
//! and upper bounds.
//!
//! Why exactly: at the load ceiling a support whose unconstrained fit has a negative
//! load (e.g. −32 / 430 g) can hold the bounded optimum (127 / 250 g), so "a negative
//! load rejects the support" is valid only when no load of the unconstrained fit is
//! above its upper bound ([`needs_bounded_solve`]); every other support that leaves the
//! box gets this solve.

use nalgebra::{DMatrix, DVector};

/// Where a variable of the active set sits.
#[derive(Clone, Copy, PartialEq)]
enum At {
    Free,
    Lower,
    Upper,
}

/// Exact minimiser of zᵀGz − 2bᵀz over l ≤ z ≤ u, or None when G is not positive
/// definite on the free variables met (dependent columns).
///
/// Primal active set: start at z = l, every variable held at its lower bound; solve
/// for the free ones with the held ones fixed; if that point is inside the box, free
/// the held variable whose gradient pushes hardest into the box (none: the KKT
/// conditions hold, done); else step towards it until the first free variable reaches
/// a bound, which is then held. Each full step lowers the objective strictly, so no
/// working set repeats and the method ends (a guard of 50 (k + 1) steps stays).
pub(crate) fn box_qp(
    g: &DMatrix<f64>,
    b: &DVector<f64>,
    l: &DVector<f64>,
    u: &DVector<f64>,
) -> Option<DVector<f64>> {
    let k = b.len();
    let mut z = l.clone();
    if k == 0 {
        return Some(z);
    }
    let mut at = vec![At::Lower; k];
    let scale = b.amax().max(g.amax() * u.amax().max(l.amax())).max(1e-300);
    let tol = 1e-12 * scale;
    for _ in 0..50 * (k + 1) {
        let free: Vec<usize> = (0..k).filter(|&a| at[a] == At::Free).collect();
        // The free variables' optimum with the held ones fixed.
        let s = if free.is_empty() {
            DVector::zeros(0)
        } else {
            let gf = DMatrix::from_fn(free.len(), free.len(), |p, q| g[(free[p], free[q])]);
            let rhs = DVector::from_fn(free.len(), |p, _| {
                let f = free[p];
                b[f] - (0..k)
                    .filter(|&a| at[a] != At::Free)
                    .map(|a| g[(f, a)] * z[a])
                    .sum::<f64>()
            });
            gf.cholesky()?.solve(&rhs)
        };
        // Largest step towards s that stays in the box, and the variable that blocks.
        let mut alpha = 1.0f64;
        let mut block: Option<(usize, At)> = None;
        for (p, &f) in free.iter().enumerate() {
            let d = s[p] - z[f];
            if s[p] < l[f] && d < 0.0 {
                let t = (l[f] - z[f]) / d;
                if t < alpha {
                    alpha = t.max(0.0);
                    block = Some((f, At::Lower));
                }
            } else if s[p] > u[f] && d > 0.0 {
                let t = (u[f] - z[f]) / d;
                if t < alpha {
                    alpha = t.max(0.0);
                    block = Some((f, At::Upper));
                }
            }
        }
        for (p, &f) in free.iter().enumerate() {
            z[f] += alpha * (s[p] - z[f]);
        }
        if let Some((f, side)) = block {
            z[f] = if side == At::Lower { l[f] } else { u[f] };
            at[f] = side;
            continue;
        }
        // Inside the box: check the held variables' multipliers. The gradient of the
        // objective is 2(Gz − b); a variable at its lower bound may stay if the
        // gradient is ≥ 0 there, one at its upper bound if it is ≤ 0.
        let grad = g * &z - b;
        let mut worst: Option<(usize, f64)> = None;
        for a in 0..k {
            let push = match at[a] {
                At::Free => continue,
                At::Lower if l[a] < u[a] => -grad[a],
                At::Upper if l[a] < u[a] => grad[a],
                _ => continue, // l = u: fixed
            };
            if push > tol && worst.is_none_or(|(_, w)| push > w) {
                worst = Some((a, push));
            }
        }
        match worst {
            Some((a, _)) => at[a] = At::Free,
            None => return Some(z),
        }
    }
    Some(z)
}

/// Whether a support's unconstrained fit `z` (working units) must be given the exact
/// bounded solve: some load is above its upper bound. When none is, a negative load
/// means the bounded optimum has a load at 0 — a smaller support's solution, valued
/// on its own — because the bounded optimum with every load positive would also be the
/// optimum over {z ≤ u}, which the unconstrained fit (inside {z ≤ u}) is.
pub(crate) fn needs_bounded_solve(z: &[f64], upper: impl Fn(usize) -> f64) -> bool {
    z.iter().enumerate().any(|(a, &v)| v > upper(a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute force: every assignment of each variable to lower, upper or free, kept
    /// when it is feasible and meets the KKT conditions; the best objective wins.
    fn brute(g: &DMatrix<f64>, b: &DVector<f64>, l: &DVector<f64>, u: &DVector<f64>) -> f64 {
        let k = b.len();
        let q = |z: &DVector<f64>| z.dot(&(g * z)) - 2.0 * b.dot(z);
        let mut best = f64::INFINITY;
        for code in 0..3usize.pow(k as u32) {
            let mut state = vec![0usize; k];
            let mut c = code;
            for s in state.iter_mut() {
                *s = c % 3;
                c /= 3;
            }
            let free: Vec<usize> = (0..k).filter(|&a| state[a] == 2).collect();
            let mut z = DVector::from_fn(k, |a, _| if state[a] == 1 { u[a] } else { l[a] });
            if !free.is_empty() {
                let gf = DMatrix::from_fn(free.len(), free.len(), |p, r| g[(free[p], free[r])]);
                let rhs = DVector::from_fn(free.len(), |p, _| {
                    b[free[p]]
                        - (0..k)
                            .filter(|&a| state[a] != 2)
                            .map(|a| g[(free[p], a)] * z[a])
                            .sum::<f64>()
                });
                let s = gf.cholesky().unwrap().solve(&rhs);
                for (p, &f) in free.iter().enumerate() {
                    z[f] = s[p];
                }
            }
            if (0..k).all(|a| z[a] >= l[a] - 1e-9 && z[a] <= u[a] + 1e-9) {
                best = best.min(q(&z));
            }
        }
        best
    }

    #[test]
    fn the_ceiling_case_of_the_issue_is_solved_exactly() {
        // Two correlated columns; the unconstrained fit is (−32, 430)-like: one load
        // negative, one far above the bound; the bounded optimum has both positive.
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 0.9, 0.2, 1.0, 0.0, 0.3]);
        let x_true = DVector::from_vec(vec![127.0, 430.0]);
        let y = &a * &x_true - DVector::from_vec(vec![150.0, 0.0, 0.0]);
        let g = a.transpose() * &a;
        let b = a.transpose() * &y;
        let free = g.clone().cholesky().unwrap().solve(&b);
        assert!(free[0] < 0.0 && free[1] > 250.0, "{free}");
        let l = DVector::zeros(2);
        let u = DVector::from_element(2, 250.0);
        let z = box_qp(&g, &b, &l, &u).unwrap();
        assert!(z[0] > 0.0 && (z[1] - 250.0).abs() < 1e-9, "{z}");
        assert!(needs_bounded_solve(free.as_slice(), |_| 250.0));
        let q = z.dot(&(&g * &z)) - 2.0 * b.dot(&z);
        assert!((q - brute(&g, &b, &l, &u)).abs() < 1e-6 * (1.0 + q.abs()));
    }

    proptest! {
        #[test]
        fn box_qp_matches_brute_force_enumeration_of_active_sets(
            k in 1usize..=5,
            entries in proptest::collection::vec(-1.0f64..1.0, 40),
            rhs in proptest::collection::vec(-3.0f64..3.0, 8),
            lo in proptest::collection::vec(0.0f64..0.5, 5),
            width in proptest::collection::vec(0.01f64..2.0, 5),
        ) {
            let m = k + 3;
            let a = DMatrix::from_fn(m, k, |i, j| entries[i * 5 + j] + if i == j { 1.5 } else { 0.0 });
            let g = a.transpose() * &a;
            let y = DVector::from_fn(m, |i, _| rhs[i]);
            let b = a.transpose() * &y;
            let l = DVector::from_fn(k, |i, _| lo[i]);
            let u = DVector::from_fn(k, |i, _| lo[i] + width[i]);
            let z = box_qp(&g, &b, &l, &u).unwrap();
            prop_assert!((0..k).all(|i| z[i] >= l[i] - 1e-12 && z[i] <= u[i] + 1e-12));
            let q = z.dot(&(&g * &z)) - 2.0 * b.dot(&z);
            let want = brute(&g, &b, &l, &u);
            prop_assert!((q - want).abs() <= 1e-8 * (1.0 + want.abs()), "{} vs {}", q, want);
        }
    }
}
