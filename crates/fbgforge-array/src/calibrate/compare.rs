//! The measured matrix against the design's predicted one, entry by entry, with the
//! model's band, and a verdict per grating like the module's `verify`.
//!
//! The band of an entry is its prediction ± the tolerance t (default
//! [`DEFAULT_MODEL_TOLERANCE`]: the models' largest error against the paper's Table 1,
//! 35 % for the sheet model and 38 % for the kernel, docs/array.md §12.3). An entry is
//! in band when |measured − predicted| ≤ t·|predicted| + 2 sd. A grating is judged on
//! the entries that matter: loaded cells where it is predicted to read at least a
//! quarter of its largest predicted entry, a shift of at least five interrogator
//! resolutions under the run's load, and where the measurement is precise to t/2.
//! PASS: every such entry in band; FAIL: one is out; NOT JUDGED: no such entry, or a
//! fault (swap, drift, a wrong loading) names the grating or leaves it nothing to judge.

use super::{Fault, Severity};
use nalgebra::DMatrix;
use serde::Serialize;

/// Default relative band of a predicted entry.
pub const DEFAULT_MODEL_TOLERANCE: f64 = 0.40;

/// A grating's outcome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Judgement {
    /// Every judged entry within the model's band.
    #[serde(rename = "PASS")]
    Pass,
    /// A judged entry outside it.
    #[serde(rename = "FAIL")]
    Fail,
    /// Nothing to judge, or a fault in the way.
    #[serde(rename = "NOT JUDGED")]
    NotJudged,
}

impl Judgement {
    /// As printed.
    pub fn label(self) -> &'static str {
        match self {
            Judgement::Pass => "PASS",
            Judgement::Fail => "FAIL",
            Judgement::NotJudged => "NOT JUDGED",
        }
    }
}

/// One entry, measured and predicted.
#[derive(Debug, Clone, Serialize)]
pub struct EntryComparison {
    /// Grating.
    pub grating: String,
    /// Cell.
    pub cell: String,
    /// Measured, pm/g (None: cell not loaded).
    pub measured_pm_per_g: Option<f64>,
    /// Its standard deviation, pm/g.
    pub measured_sd_pm_per_g: Option<f64>,
    /// Predicted, pm/g.
    pub predicted_pm_per_g: f64,
    /// The model's band, pm/g.
    pub band_pm_per_g: [f64; 2],
    /// (measured − predicted)/|predicted|.
    pub relative_error: Option<f64>,
    /// Counts for the verdict.
    pub judged: bool,
    /// Within the band (allowing two standard deviations).
    pub in_band: Option<bool>,
}

/// A grating's verdict.
#[derive(Debug, Clone, Serialize)]
pub struct GratingVerdict {
    /// Grating.
    pub grating: String,
    /// Outcome.
    pub status: Judgement,
    /// Entries judged.
    pub judged_entries: usize,
    /// The judged entry farthest from its prediction (relative).
    pub worst_cell: Option<String>,
    /// Its relative error.
    pub worst_relative_error: Option<f64>,
    /// Why, when not PASS.
    pub reason: Option<String>,
}

/// The whole comparison.
#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    /// The model that predicted, in words.
    pub model: String,
    /// Relative band.
    pub tolerance: f64,
    /// Median measured / predicted over the entries that matter (the level the model
    /// misses by, whatever the pattern).
    pub level_ratio: f64,
    /// Per grating.
    pub gratings: Vec<GratingVerdict>,
    /// Every entry.
    pub entries: Vec<EntryComparison>,
}

/// What the comparison reads.
pub struct CompareInputs<'a> {
    /// Measured, pm/g (NaN: not loaded).
    pub measured: &'a DMatrix<f64>,
    /// Standard deviations, pm/g.
    pub sd: &'a DMatrix<f64>,
    /// Predicted, pm/g.
    pub predicted: &'a DMatrix<f64>,
    /// Largest load of each cell in the run, g.
    pub max_load_g: &'a [f64],
    /// Grating names and cell labels.
    pub gratings: &'a [String],
    /// Cell labels.
    pub cells: &'a [String],
    /// Relative band.
    pub tolerance: f64,
    /// Interrogator resolution, pm.
    pub resolution_pm: f64,
}

/// Whether entry (g, c) counts for the verdict.
fn judged(i: &CompareInputs, g: usize, c: usize) -> bool {
    let (m, sd, p) = (i.measured[(g, c)], i.sd[(g, c)], i.predicted[(g, c)]);
    let top = (0..i.measured.ncols())
        .filter(|&k| i.measured[(g, k)].is_finite())
        .map(|k| i.predicted[(g, k)].abs())
        .fold(0.0, f64::max);
    m.is_finite()
        && p.abs() >= 0.25 * top
        && p.abs() * i.max_load_g[c] >= 5.0 * i.resolution_pm
        && sd <= 0.5 * i.tolerance * p.abs()
}

/// Compare every entry and judge every grating; `faults` take gratings and cells out.
pub fn compare(i: &CompareInputs, faults: &[Fault], model: &str) -> Comparison {
    let blocked_cells: Vec<&String> = faults
        .iter()
        .filter(|f| f.severity == Severity::Unusable)
        .flat_map(|f| f.cells.iter())
        .collect();
    let mut entries = Vec::new();
    let mut ratios = Vec::new();
    let mut gratings = Vec::new();
    for (g, name) in i.gratings.iter().enumerate() {
        let mut worst: Option<(usize, f64)> = None;
        let (mut n_judged, mut out_of_band) = (0, false);
        for (c, cell) in i.cells.iter().enumerate() {
            let (m, sd, p) = (i.measured[(g, c)], i.sd[(g, c)], i.predicted[(g, c)]);
            let half = i.tolerance * p.abs();
            let counts = judged(i, g, c) && !blocked_cells.contains(&cell);
            let rel = (m.is_finite() && p != 0.0).then(|| (m - p) / p.abs());
            let in_band = m.is_finite().then(|| (m - p).abs() <= half + 2.0 * sd);
            if counts {
                n_judged += 1;
                ratios.push(m / p);
                out_of_band |= in_band == Some(false);
                if let Some(r) = rel {
                    if worst.is_none_or(|w| r.abs() > w.1.abs()) {
                        worst = Some((c, r));
                    }
                }
            }
            entries.push(EntryComparison {
                grating: name.clone(),
                cell: cell.clone(),
                measured_pm_per_g: m.is_finite().then_some(m),
                measured_sd_pm_per_g: sd.is_finite().then_some(sd),
                predicted_pm_per_g: p,
                band_pm_per_g: [p - half, p + half],
                relative_error: rel,
                judged: counts,
                in_band,
            });
        }
        gratings.push(verdict(i, faults, g, n_judged, out_of_band, worst));
    }
    Comparison {
        model: model.to_string(),
        tolerance: i.tolerance,
        level_ratio: super::steps::median(&mut ratios),
        gratings,
        entries,
    }
}

fn verdict(
    i: &CompareInputs,
    faults: &[Fault],
    g: usize,
    n_judged: usize,
    out_of_band: bool,
    worst: Option<(usize, f64)>,
) -> GratingVerdict {
    let name = &i.gratings[g];
    let fault = faults
        .iter()
        .find(|f| f.severity == Severity::Unusable && f.gratings.contains(name));
    let (status, reason) = if let Some(f) = fault {
        (
            Judgement::NotJudged,
            Some(format!("fault {}: see the faults", f.kind.name())),
        )
    } else if n_judged == 0 {
        (
            Judgement::NotJudged,
            Some(format!(
                "no loaded cell where the model predicts this grating reads ≥ 5 × the {} pm resolution, measured to ±{:.0} %",
                i.resolution_pm,
                50.0 * i.tolerance
            )),
        )
    } else if out_of_band {
        let (c, r) = worst.expect("judged entries");
        (
            Judgement::Fail,
            Some(format!(
                "cell {}: measured {:.4} pm/g, predicted {:.4} ({:+.0} %, band ±{:.0} %)",
                i.cells[c],
                i.measured[(g, c)],
                i.predicted[(g, c)],
                100.0 * r,
                100.0 * i.tolerance
            )),
        )
    } else {
        (Judgement::Pass, None)
    };
    GratingVerdict {
        grating: name.clone(),
        status,
        judged_entries: n_judged,
        worst_cell: worst.map(|w| i.cells[w.0].clone()),
        worst_relative_error: worst.map(|w| w.1),
        reason,
    }
}
