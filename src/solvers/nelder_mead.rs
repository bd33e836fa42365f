//! Nelder–Mead through argmin: the initial simplex and one call that runs the
//! executor and reads the best point from argmin's state. Module optimisation,
//! placement ([`super::run_one`]) and the verifier's lag fit all minimise with it.

use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{CostFunction, Executor, IterState, State};
use argmin::solver::neldermead::NelderMead;

/// What a Nelder–Mead run found.
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    /// Best vertex.
    pub best_x: Vec<f64>,
    /// Its cost.
    pub best_cost: f64,
    /// Iterations done.
    pub iterations: u64,
    /// Why it stopped, as argmin reports it.
    pub termination: String,
}

/// The observer type for runs nobody watches (`None` in [`minimise`]).
pub struct Unobserved;

impl<I> Observe<I> for Unobserved {}

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
/// `sd_tolerance` or `max_iters` iterations; `observer` sees every iteration.
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
    let start = simplex.first().cloned().unwrap_or_default();
    let solver = NelderMead::new(simplex).with_sd_tolerance(sd_tolerance)?;
    let mut exec = Executor::new(cost, solver).configure(|s| s.max_iters(max_iters));
    if let Some(o) = observer {
        exec = exec.add_observer(o, ObserverMode::Always);
    }
    let res = exec.run()?;
    let st = res.state();
    Ok(Minimum {
        best_x: st.get_best_param().cloned().unwrap_or(start),
        best_cost: st.get_best_cost(),
        iterations: st.get_iter(),
        termination: st.get_termination_status().to_string(),
    })
}
