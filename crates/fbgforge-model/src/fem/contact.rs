//! Unilateral (no-tension) contact on the linear axisymmetric model, solved exactly
//! on the contact unknowns.
//!
//! A contact pair joins a node `a` to a node `b` facing it across a printed gap (or to
//! a rigid obstacle). With `n` the unit normal from `a` towards `b`, the gap under load
//! is g = g₀ + n·(u_b − u_a) (for an obstacle, g = g₀ − n·u_a − d, d its approach).
//! The pair may push (contact force λ ≥ 0, on `b` along +n, on `a` along −n) but never
//! pull, and pushes only where it touches: λ ≥ 0, g ≥ 0, λ g = 0.
//!
//! Why this method: the bodies stay linear, only the contact set is unknown. So the
//! stiffness is factorised once, each pair's unit force is solved once, and the
//! problem shrinks to a dense one on the pairs, the flexibility W (gap change at pair i
//! per newton at pair j, symmetric positive definite) and the free gaps q(t) at load
//! factor t:
//!
//! g = q(t) + W λ,  q(t) = g₀ + t B u₁ − d,
//!
//! a linear complementarity problem equal to the quadratic programme
//! min ½ λᵀWλ + qᵀλ over λ ≥ 0, solved exactly by an active-set method
//! (Lawson–Hanson). Every load factor of a force–response curve then costs a solve
//! of a system the size of the contact set, not a refactorisation; every quantity read
//! from the model (a grating's strain) is linear in u, hence
//! r(t) = t r₁ + Σ λ_k r_k with r₁, r_k read once from the unit solutions.
//! The first closure (the knee of the curve) is found exactly: with λ = 0,
//! gap k closes at t = −g₀ₖ / (B u₁)ₖ.
//!
//! Small displacements: the normal and the facing node stay those of the undeformed
//! mesh (node-to-node contact; the module's meshes put facing nodes on one ray).
//!
//! Friction is not modelled: the pairs are frictionless. Along the module's cylinders
//! the printed clearance opens under load (the cap, compressed, grows in radius; the
//! core, stretched, shrinks), so no normal force arises there for friction to act on
//! (`fem::module`, docs/fem.md).

use super::solve::{Component, FactoredProblem, Solution, R, Z};
use anyhow::{bail, Result};
use nalgebra::{DMatrix, DVector};

/// One node-to-node (or node-to-obstacle) contact pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPair {
    /// Node on one side.
    pub a: usize,
    /// Node facing it, or `None` for a rigid obstacle held in place (or moved by the
    /// approach `d` of [`ReducedContact::solve`]).
    pub b: Option<usize>,
    /// Unit normal from `a` towards `b` (r, z).
    pub normal: [f64; 2],
    /// Gap at zero load, mm (≥ 0).
    pub gap_mm: f64,
}

/// The contact problem condensed on the pairs.
#[derive(Debug, Clone)]
pub struct ReducedContact {
    /// The pairs.
    pub pairs: Vec<ContactPair>,
    /// Gaps at zero load, mm.
    pub gap0_mm: DVector<f64>,
    /// Gap change of each pair per unit load factor, mm (B u₁).
    pub free_per_load: DVector<f64>,
    /// Flexibility W: gap change at pair i per newton pressing pair j, mm/N.
    pub flexibility: DMatrix<f64>,
    /// Observables (e.g. grating strains) of the unit load.
    pub observe_per_load: Vec<f64>,
    /// Observables of a unit force pressing each pair.
    pub observe_per_force: Vec<Vec<f64>>,
}

/// The state at one load factor.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactState {
    /// Load factor t (the applied loads times t), e.g. the force in N for a 1 N load.
    pub load_factor: f64,
    /// Normal contact force of each pair, N (≥ 0).
    pub normal_force_n: Vec<f64>,
    /// Gap of each pair, mm (≥ 0 up to round-off).
    pub gap_mm: Vec<f64>,
    /// Observables at this state.
    pub observed: Vec<f64>,
}

impl ContactState {
    /// Pairs in contact (positive normal force).
    pub fn active(&self) -> usize {
        self.normal_force_n.iter().filter(|&&l| l > 0.0).count()
    }
}

/// The unknowns' coefficients of one contact row: (node, component, coefficient).
fn row_terms(p: &ContactPair) -> Vec<(usize, Component, f64)> {
    let dir = p.normal;
    let mut t = vec![(p.a, R, -dir[0]), (p.a, Z, -dir[1])];
    if let Some(b) = p.b {
        t.push((b, R, dir[0]));
        t.push((b, Z, dir[1]));
    }
    t
}

fn row_value(sol: &Solution, terms: &[(usize, Component, f64)]) -> f64 {
    terms
        .iter()
        .map(|&(n, c, k)| k * sol.displacement_mm[n][c])
        .sum()
}

/// Condense the contact problem of a factorised model loaded by `loads` (at load
/// factor 1) on `pairs`. `observe` reads the quantities of interest from a solution;
/// it must be linear in the displacements.
pub fn reduce(
    factored: &FactoredProblem,
    loads: &[(usize, Component, f64)],
    pairs: &[ContactPair],
    observe: impl Fn(&Solution) -> Result<Vec<f64>>,
) -> Result<ReducedContact> {
    for (i, p) in pairs.iter().enumerate() {
        let len = p.normal[0].hypot(p.normal[1]);
        if !((len - 1.0).abs() < 1e-9 && p.gap_mm.is_finite() && p.gap_mm >= 0.0) {
            bail!(
                "contact pair {i}: the normal must be a unit vector and the gap ≥ 0 mm (got |n| = {len}, gap {} mm)",
                p.gap_mm
            );
        }
    }
    let rows: Vec<Vec<(usize, Component, f64)>> = pairs.iter().map(row_terms).collect();
    let unit = factored.solve_loads(loads)?;
    let free_per_load =
        DVector::from_iterator(rows.len(), rows.iter().map(|r| row_value(&unit, r)));
    let observe_per_load = observe(&unit)?;
    let m = rows.len();
    let mut flexibility = DMatrix::zeros(m, m);
    let mut observe_per_force = Vec::with_capacity(m);
    // A unit force pressing pair j is the transpose of its row: +n on b, −n on a. All
    // pairs' unit forces are solved as one block of right-hand sides on the one factor.
    for (j, sol) in factored.solve_load_cases(&rows)?.iter().enumerate() {
        for (i, ri) in rows.iter().enumerate() {
            flexibility[(i, j)] = row_value(sol, ri);
        }
        observe_per_force.push(observe(sol)?);
    }
    // Symmetrise the round-off.
    let w = 0.5 * (&flexibility + flexibility.transpose());
    Ok(ReducedContact {
        gap0_mm: DVector::from_iterator(pairs.len(), pairs.iter().map(|p| p.gap_mm)),
        pairs: pairs.to_vec(),
        free_per_load,
        flexibility: w,
        observe_per_load,
        observe_per_force,
    })
}

/// Minimise ½ xᵀWx + qᵀx over x ≥ 0 (W symmetric positive definite) by the
/// Lawson–Hanson active-set method; exact up to round-off.
pub(crate) fn nonnegative_qp(w: &DMatrix<f64>, q: &DVector<f64>) -> Result<DVector<f64>> {
    let n = q.len();
    let mut x = DVector::zeros(n);
    if n == 0 {
        return Ok(x);
    }
    let scale = q.amax().max(1e-300);
    let tol = 1e-11 * scale;
    let mut passive = vec![false; n];
    for _ in 0..(3 * n + 10) {
        // Negative gradient −(Wx + q): positive where a closed constraint wants force.
        let grad = -(w * &x + q);
        let cand = (0..n)
            .filter(|&j| !passive[j] && grad[j] > tol)
            .max_by(|&a, &b| grad[a].total_cmp(&grad[b]));
        let Some(j) = cand else {
            return Ok(x);
        };
        passive[j] = true;
        for _ in 0..(3 * n + 10) {
            let cols: Vec<usize> = (0..n).filter(|&k| passive[k]).collect();
            let ws = DMatrix::from_fn(cols.len(), cols.len(), |a, b| w[(cols[a], cols[b])]);
            let qs = DVector::from_fn(cols.len(), |a, _| -q[cols[a]]);
            let Some(z) = ws.cholesky().map(|c| c.solve(&qs)) else {
                bail!("contact: the flexibility of the touching pairs is singular (two pairs constrain the same motion)");
            };
            if z.iter().all(|&v| v > 0.0) {
                for (a, &k) in cols.iter().enumerate() {
                    x[k] = z[a];
                }
                break;
            }
            // Step from x towards z until the first passive variable reaches zero.
            let mut alpha = 1.0f64;
            for (a, &k) in cols.iter().enumerate() {
                if z[a] <= 0.0 {
                    let denom = x[k] - z[a];
                    if denom > 0.0 {
                        alpha = alpha.min(x[k] / denom);
                    }
                }
            }
            for (a, &k) in cols.iter().enumerate() {
                x[k] += alpha * (z[a] - x[k]);
                if x[k] <= 1e-15 * scale.max(1.0) {
                    x[k] = 0.0;
                    passive[k] = false;
                }
            }
        }
    }
    bail!("contact: the active-set method did not settle")
}

impl ReducedContact {
    /// The load factor at which the first gap closes (the knee of the response), or
    /// `None` when no gap closes under this load. Pairs that touch already (gap 0)
    /// and are pressed give 0.
    pub fn knee_load_factor(&self) -> Option<f64> {
        (0..self.pairs.len())
            .filter(|&k| self.free_per_load[k] < 0.0)
            .map(|k| -self.gap0_mm[k] / self.free_per_load[k])
            .min_by(f64::total_cmp)
    }

    /// The state at load factor `t` with rigid obstacles approached by
    /// `obstacle_approach_mm`.
    pub fn solve(&self, t: f64, obstacle_approach_mm: f64) -> Result<ContactState> {
        if !t.is_finite() || !obstacle_approach_mm.is_finite() {
            bail!("contact: the load factor and the obstacle approach must be finite (got {t}, {obstacle_approach_mm})");
        }
        let n = self.pairs.len();
        let q = DVector::from_fn(n, |k, _| {
            let obstacle = if self.pairs[k].b.is_none() {
                obstacle_approach_mm
            } else {
                0.0
            };
            self.gap0_mm[k] + t * self.free_per_load[k] - obstacle
        });
        let lambda = nonnegative_qp(&self.flexibility, &q)?;
        let gaps = &q + &self.flexibility * &lambda;
        let mut observed: Vec<f64> = self.observe_per_load.iter().map(|v| t * v).collect();
        for (j, obs) in self.observe_per_force.iter().enumerate() {
            if lambda[j] != 0.0 {
                for (o, v) in observed.iter_mut().zip(obs) {
                    *o += lambda[j] * v;
                }
            }
        }
        Ok(ContactState {
            load_factor: t,
            normal_force_n: lambda.iter().copied().collect(),
            gap_mm: gaps.iter().copied().collect(),
            observed,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_active_set_qp_solves_a_small_complementarity_problem_exactly() {
        // W = [[2, 1], [1, 2]], q = [-1, 1]: x = [0.5, 0], gaps [0, 1.5].
        let w = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        let q = DVector::from_vec(vec![-1.0, 1.0]);
        let x = nonnegative_qp(&w, &q).unwrap();
        assert!((x[0] - 0.5).abs() < 1e-14 && x[1] == 0.0);
        // Both pressed: q = [-3, -3] → x = [1, 1].
        let x = nonnegative_qp(&w, &DVector::from_vec(vec![-3.0, -3.0])).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-14 && (x[1] - 1.0).abs() < 1e-14);
        // Nothing pressed.
        let x = nonnegative_qp(&w, &DVector::from_vec(vec![1.0, 0.5])).unwrap();
        assert_eq!(x, DVector::zeros(2));
    }
}
