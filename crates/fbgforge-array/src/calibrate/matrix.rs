//! The sensing matrix from the single-cell states, with each entry's scatter.
//!
//! Each state in which exactly one cell carries a load L gives every grating a shift
//! d = level − baseline (pm). The entry is the least-squares slope through the origin
//! over that cell's states, Σ d·L / Σ L² (a staircase's steps and a repeated 200 g
//! alike). Its standard deviation is the largest of
//! * the scatter of the readings about that slope, √(Σ (d − A·L)² / (n − 1) / Σ L²),
//!   when the cell was read at least twice (repeats, cycles, steps);
//! * the noise of the levels and baselines carried through, √(Σ L² var(d)) / Σ L²;
//! * one interrogator resolution over the loads, r / √(Σ L²): a single 200 g reading
//!   cannot claim better (the default `reconstruct --matrix-sd` assumes the same).

use super::levels::{Baseline, StateLevels};
use super::schedule::LoadState;
use nalgebra::DMatrix;

/// The measured entries: NaN where a cell was never loaded alone.
#[derive(Debug, Clone)]
pub struct Entries {
    /// pm/g, gratings × cells.
    pub value: DMatrix<f64>,
    /// Standard deviation of each entry, pm/g.
    pub sd: DMatrix<f64>,
    /// Single-cell readings of each cell.
    pub readings: Vec<usize>,
}

/// A state's baseline-corrected shift of grating `g` and its variance.
pub fn corrected(level: &StateLevels, baseline: &Baseline, g: usize) -> (f64, f64) {
    let l = level.gratings[g];
    let (b, bs) = baseline.at(level.time_s);
    (l.shift_pm - b, l.sem_pm.powi(2) + bs.powi(2))
}

/// Measure the entries of every (grating, cell) loaded alone.
pub fn measure(
    states: &[LoadState],
    levels: &[StateLevels],
    baselines: &[Baseline],
    n_cells: usize,
    resolution_pm: f64,
) -> Entries {
    let n_g = baselines.len();
    let mut value = DMatrix::from_element(n_g, n_cells, f64::NAN);
    let mut sd = DMatrix::from_element(n_g, n_cells, f64::NAN);
    let mut readings = vec![0; n_cells];
    for c in 0..n_cells {
        let of_cell: Vec<(usize, f64)> = states
            .iter()
            .enumerate()
            .filter_map(|(k, s)| s.single().filter(|x| x.0 == c).map(|x| (k, x.1)))
            .filter(|&(k, _)| levels[k].used > 0)
            .collect();
        readings[c] = of_cell.len();
        if of_cell.is_empty() {
            continue;
        }
        for (g, base) in baselines.iter().enumerate() {
            let pts: Vec<(f64, f64, f64)> = of_cell
                .iter()
                .map(|&(k, l)| {
                    let (d, v) = corrected(&levels[k], base, g);
                    (l, d, v)
                })
                .filter(|p| p.1.is_finite())
                .collect();
            if pts.is_empty() {
                continue;
            }
            let ll: f64 = pts.iter().map(|p| p.0 * p.0).sum::<f64>().max(1e-300);
            let a = pts.iter().map(|p| p.0 * p.1).sum::<f64>() / ll;
            let noise = pts.iter().map(|p| p.0 * p.0 * p.2).sum::<f64>().sqrt() / ll;
            let scatter = if pts.len() >= 2 {
                let ss: f64 = pts.iter().map(|p| (p.1 - a * p.0).powi(2)).sum();
                (ss / (pts.len() - 1) as f64 / ll).sqrt()
            } else {
                0.0
            };
            value[(g, c)] = a;
            sd[(g, c)] = noise.max(scatter).max(resolution_pm / ll.sqrt());
        }
    }
    Entries {
        value,
        sd,
        readings,
    }
}
