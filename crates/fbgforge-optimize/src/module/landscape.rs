//! The objective over a grid of two variables, for the landscape plot.

use super::problem::ModuleProblem;
use rayon::prelude::*;
use serde::Serialize;

/// One point of a landscape.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LandscapePoint {
    /// Value of the first variable.
    pub a: f64,
    /// Value of the second variable.
    pub b: f64,
    /// Objective (NaN where the geometry or the model fails).
    pub objective: f64,
    /// Whether every constraint is met.
    pub feasible: bool,
}

/// Objective over a grid of two variables around a point (others fixed), for the
/// landscape plot. Infeasible points keep their objective when the model could
/// evaluate them (strain or window broken), so the plot shows what the limits cut off.
pub fn landscape(
    p: &ModuleProblem,
    at: &[f64],
    a: usize,
    b: usize,
    steps: usize,
) -> Vec<LandscapePoint> {
    let (lo, hi) = p.box_bounds();
    let steps = steps.max(2);
    let cells: Vec<(f64, f64)> = (0..steps)
        .flat_map(|i| {
            let va = lo[a] + (hi[a] - lo[a]) * i as f64 / (steps - 1) as f64;
            let (lb, hb) = (lo[b], hi[b]);
            (0..steps).map(move |j| (va, lb + (hb - lb) * j as f64 / (steps - 1) as f64))
        })
        .collect();
    cells
        .par_iter()
        .map(|&(va, vb)| {
            let mut x = at.to_vec();
            x[a] = va;
            x[b] = vb;
            let e = p.evaluate(&x);
            LandscapePoint {
                a: va,
                b: vb,
                objective: if e.gratings.is_empty() {
                    f64::NAN
                } else {
                    e.objective
                },
                feasible: e.feasible(),
            }
        })
        .collect()
}
