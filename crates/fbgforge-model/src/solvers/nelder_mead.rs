//! Nelder–Mead through argmin: the initial simplex and one call that runs it
//! through the layer's run loop ([`super::execute`]). Module optimisation,
//! placement ([`super::run_one`]) and the verifier's lag fit all minimise with it.

use argmin::core::observers::Observe;
use argmin::core::{CostFunction, IterState};
use argmin::solver::neldermead::NelderMead;

pub use super::{Minimum, Unobserved};

/// The start and one step along each axis; a step that would leave the box above
/// `upper` goes the other way (so the simplex starts inside when the start sits on
/// its upper bound).
pub fn simplex_inside(start: &[f64], steps: &[f64], upper: &[f64]) -> Vec<Vec<f64>> {
    let mut simplex = vec![start.to_vec()];
    for i in 0..start.len() {
        let mut v = start.to_vec();
        v[i] = if v[i] + steps[i] <= upper[i] {
            v[i] + steps[i]
        } else {
            v[i] - steps[i]
        };
        simplex.push(v);
    }
    simplex
}

/// Minimise `cost` from `simplex` until the spread of the vertex costs falls below
/// `sd_tolerance` or `max_iters` iterations; `observer` sees every iteration. Runs
/// through the layer's one loop, [`super::execute`].
pub fn minimise<C, O>(
    cost: C,
    simplex: Vec<Vec<f64>>,
    sd_tolerance: f64,
    max_iters: u64,
    observer: Option<O>,
) -> Result<Minimum, argmin::core::Error>
where
    C: CostFunction<Param = Vec<f64>, Output = f64>,
    O: Observe<IterState<Vec<f64>, (), (), (), (), f64>> + 'static,
{
    let solver = NelderMead::new(simplex).with_sd_tolerance(sd_tolerance)?;
    super::execute(cost, solver, max_iters, observer)
}
