//! Additivity (the array paper's Figs. 6–8): loads put on cells one at a time, then
//! together. A linear sheet reads the sum of the single responses; the error per
//! grating is (together − sum of singles) / |sum of singles|. A state with two or more
//! loaded cells is a test when every one of its cells was also loaded alone with the
//! same mass (within 0.5 %); repeats of a configuration, and of each single, are
//! averaged. Each error comes with whether it stands above the readings' noise.

use super::levels::{Baseline, StateLevels};
use super::matrix::corrected;
use super::schedule::LoadState;
use crate::profile::cell_label;
use serde::Serialize;

/// One grating in one additivity test.
#[derive(Debug, Clone, Serialize)]
pub struct AdditiveGrating {
    /// Grating name.
    pub grating: String,
    /// Its shift under each load alone, pm (in the test's cell order).
    pub individual_pm: Vec<f64>,
    /// Their sum, pm.
    pub sum_pm: f64,
    /// Its shift under the loads together, pm.
    pub simultaneous_pm: f64,
    /// 100 × (together − sum) / |sum|.
    pub error_percent: f64,
    /// Standard error of (together − sum), pm.
    pub difference_sem_pm: f64,
    /// |together − sum| exceeds three standard errors and the interrogator's
    /// resolution.
    pub significant: bool,
}

/// One configuration of simultaneous loads.
#[derive(Debug, Clone, Serialize)]
pub struct AdditivityTest {
    /// The loaded cells.
    pub cells: Vec<String>,
    /// Their masses, g.
    pub loads_g: Vec<f64>,
    /// How often the configuration was read together.
    pub repeats: usize,
    /// Per grating.
    pub gratings: Vec<AdditiveGrating>,
}

/// Mean corrected shift (and its variance) of grating `g` over the states `ks`.
fn mean_of(ks: &[usize], levels: &[StateLevels], base: &Baseline, g: usize) -> (f64, f64) {
    let v: Vec<(f64, f64)> = ks
        .iter()
        .map(|&k| corrected(&levels[k], base, g))
        .filter(|x| x.0.is_finite())
        .collect();
    let n = v.len().max(1) as f64;
    (
        v.iter().map(|x| x.0).sum::<f64>() / n,
        v.iter().map(|x| x.1).sum::<f64>() / (n * n),
    )
}

/// Every additivity test of the run.
pub fn additivity(
    states: &[LoadState],
    levels: &[StateLevels],
    baselines: &[Baseline],
    gratings: &[String],
    resolution_pm: f64,
) -> Vec<AdditivityTest> {
    let same = |a: f64, b: f64| (a - b).abs() <= 0.005 * a.abs().max(b.abs());
    let read = |k: &usize| levels[*k].used > 0;
    let mut configs: Vec<Vec<f64>> = Vec::new();
    for s in states.iter().filter(|s| s.loaded_cells().len() >= 2) {
        if !configs
            .iter()
            .any(|c| c.iter().zip(&s.loads_g).all(|(a, b)| same(*a, *b)))
        {
            configs.push(s.loads_g.clone());
        }
    }
    let mut out = Vec::new();
    for loads in configs {
        let cells: Vec<usize> = (0..loads.len()).filter(|&c| loads[c] > 0.0).collect();
        let together: Vec<usize> = (0..states.len())
            .filter(|&k| {
                states[k]
                    .loads_g
                    .iter()
                    .zip(&loads)
                    .all(|(a, b)| same(*a, *b))
            })
            .filter(read)
            .collect();
        let alone: Vec<Vec<usize>> = cells
            .iter()
            .map(|&c| {
                (0..states.len())
                    .filter(|&k| {
                        states[k]
                            .single()
                            .is_some_and(|(x, l)| x == c && same(l, loads[c]))
                    })
                    .filter(read)
                    .collect()
            })
            .collect();
        if together.is_empty() || alone.iter().any(Vec::is_empty) {
            continue;
        }
        let per_grating = gratings
            .iter()
            .enumerate()
            .map(|(g, name)| {
                let singles: Vec<(f64, f64)> = alone
                    .iter()
                    .map(|ks| mean_of(ks, levels, &baselines[g], g))
                    .collect();
                let (sim, sim_var) = mean_of(&together, levels, &baselines[g], g);
                let sum: f64 = singles.iter().map(|x| x.0).sum();
                let sem = (sim_var + singles.iter().map(|x| x.1).sum::<f64>()).sqrt();
                let diff = sim - sum;
                AdditiveGrating {
                    grating: name.clone(),
                    individual_pm: singles.iter().map(|x| x.0).collect(),
                    sum_pm: sum,
                    simultaneous_pm: sim,
                    error_percent: 100.0 * diff / sum.abs(),
                    difference_sem_pm: sem,
                    significant: diff.abs() > 3.0 * sem && diff.abs() > resolution_pm,
                }
            })
            .collect();
        out.push(AdditivityTest {
            cells: cells.iter().map(|&c| cell_label(c)).collect(),
            loads_g: cells.iter().map(|&c| loads[c]).collect(),
            repeats: together.len(),
            gratings: per_grating,
        });
    }
    out
}
