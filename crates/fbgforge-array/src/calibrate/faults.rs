//! Faults the measured matrix shows against the design's predicted one.
//!
//! The model's level is uncertain (the sheet's modulus is assumed), its pattern much
//! less so, so each test compares patterns after one common scale s (the median of
//! measured / predicted over the entries that matter) and allows the model its band:
//! an entry may be off by the tolerance t (relative) of its prediction plus t of 5 % of
//! the largest predicted entry (near-zero entries are off in absolute terms).
//!
//! * **swapped gratings**: rows i and j, in log ratio to the scaled prediction (floor
//!   5 % of the largest entry), misfit the band on average, and exchanged they misfit
//!   four times less, each row better (judged with three loaded columns or more);
//! * **collinear cells**: two measured columns are closer in angle than three times
//!   their noise allows, or than a quarter of the angle the model predicts between
//!   them (evidence: both angles and both condition numbers);
//! * **a loading that reads like another cell**: a measured column is at least 10°
//!   nearer another cell's predicted column than its own (and 15° from its own): the
//!   schedule names the wrong cell (`schedule_misaligned`) and the named cell was never
//!   loaded (`unloaded_cell`);
//! * **unloaded cell**: no grating moved beyond three standard deviations when the
//!   scaled model expects one to move by ten;
//! * **negative entry**: below zero and below the band's lower edge by three standard
//!   deviations.

use super::{Fault, FaultKind, Severity};
use crate::kernel::condition_number;
use nalgebra::DMatrix;
use std::collections::BTreeMap;

/// The measured and predicted matrices and what the checks need around them.
pub struct Inputs<'a> {
    /// Measured entries, pm/g (NaN: cell not loaded).
    pub measured: &'a DMatrix<f64>,
    /// Their standard deviations, pm/g.
    pub sd: &'a DMatrix<f64>,
    /// Predicted entries, pm/g.
    pub predicted: &'a DMatrix<f64>,
    /// Relative band of the model.
    pub tolerance: f64,
    /// Grating names.
    pub gratings: &'a [String],
    /// Cell labels.
    pub cells: &'a [String],
}

/// The faults found and the row order that undoes any swap.
pub struct Found {
    /// Faults.
    pub faults: Vec<Fault>,
    /// Measured row of each predicted grating after undoing swaps.
    pub row_of: Vec<usize>,
    /// Common scale measured / predicted.
    pub scale: f64,
}

fn loaded_cells(m: &DMatrix<f64>) -> Vec<usize> {
    (0..m.ncols())
        .filter(|&c| m.column(c).iter().all(|v| v.is_finite()))
        .collect()
}

/// The median of measured / predicted over entries predicted above a quarter of their
/// row's largest and measured above three standard deviations.
pub fn common_scale(m: &DMatrix<f64>, sd: &DMatrix<f64>, p: &DMatrix<f64>) -> f64 {
    let cols = loaded_cells(m);
    let mut r = Vec::new();
    for g in 0..m.nrows() {
        let top = cols.iter().map(|&c| p[(g, c)].abs()).fold(0.0, f64::max);
        for &c in &cols {
            if p[(g, c)] > 0.25 * top && m[(g, c)] > 3.0 * sd[(g, c)] {
                r.push(m[(g, c)] / p[(g, c)]);
            }
        }
    }
    let s = super::steps::median(&mut r);
    if s.is_finite() && s > 0.0 {
        s
    } else {
        1.0
    }
}

fn angle_deg(a: &[f64], b: &[f64]) -> f64 {
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += x * y;
        aa += x * x;
        bb += y * y;
    }
    if aa <= 0.0 || bb <= 0.0 {
        return 90.0;
    }
    (ab / (aa * bb).sqrt()).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Run every check.
pub fn check(i: &Inputs) -> Found {
    let scale = common_scale(i.measured, i.sd, i.predicted);
    let (mut faults, row_of) = swapped(i, scale);
    let m = DMatrix::from_fn(i.measured.nrows(), i.measured.ncols(), |g, c| {
        i.measured[(row_of[g], c)]
    });
    let sd = DMatrix::from_fn(i.sd.nrows(), i.sd.ncols(), |g, c| i.sd[(row_of[g], c)]);
    let fixed = Inputs {
        measured: &m,
        sd: &sd,
        ..*i
    };
    faults.extend(collinear(&fixed));
    faults.extend(identity(&fixed));
    faults.extend(unloaded(&fixed, scale));
    faults.extend(negative(i, scale));
    Found {
        faults,
        row_of,
        scale,
    }
}

/// Squared log misfit of measured row `a` against predicted row `b`, in band units.
fn row_misfit(i: &Inputs, scale: f64, a: usize, b: usize, cols: &[usize]) -> f64 {
    let top = i.predicted.iter().fold(0.0f64, |x, v| x.max(v.abs())) * scale;
    let band = (1.0 + i.tolerance).ln();
    let s: f64 = cols
        .iter()
        .map(|&c| {
            let f = (0.05 * top).max(3.0 * i.sd[(a, c)]);
            let r = (i.measured[(a, c)].max(0.0) + f) / (scale * i.predicted[(b, c)].max(0.0) + f);
            (r.ln() / band).powi(2)
        })
        .sum();
    s / cols.len().max(1) as f64
}

/// Loaded columns the swap test needs.
pub const MIN_COLUMNS_FOR_SWAP: usize = 3;

fn swapped(i: &Inputs, scale: f64) -> (Vec<Fault>, Vec<usize>) {
    let n = i.measured.nrows();
    let cols = loaded_cells(i.measured);
    let mut row_of: Vec<usize> = (0..n).collect();
    let mut faults = Vec::new();
    // One or two columns give one or two entries a row: the model's own error on them
    // looks like an exchange as often as a real one does (a staircase on one cell was
    // called swapped in 2 of 200 study runs).
    if cols.len() < MIN_COLUMNS_FOR_SWAP {
        return (faults, row_of);
    }
    let chi = |a: usize, b: usize| row_misfit(i, scale, a, b, &cols);
    let mut done = vec![false; n];
    loop {
        let mut best: Option<(usize, usize, f64, f64)> = None;
        for a in (0..n).filter(|&a| !done[a]) {
            for b in (a + 1..n).filter(|&b| !done[b]) {
                let (aa, bb, ab, ba) = (chi(a, a), chi(b, b), chi(a, b), chi(b, a));
                let (own, exchanged) = (aa + bb, ab + ba);
                if own > 2.0
                    && exchanged < 0.25 * own
                    && ab < aa
                    && ba < bb
                    && best.is_none_or(|x| own - exchanged > x.2 - x.3)
                {
                    best = Some((a, b, own, exchanged));
                }
            }
        }
        let Some((a, b, own, exchanged)) = best else {
            break;
        };
        done[a] = true;
        done[b] = true;
        row_of.swap(a, b);
        faults.push(Fault {
            kind: FaultKind::SwappedGratings,
            severity: Severity::Unusable,
            gratings: vec![i.gratings[a].clone(), i.gratings[b].clone()],
            cells: Vec::new(),
            reason: format!(
                "the rows of {} and {} each match the other's predicted row: mean squared misfit {:.1} band² as labelled, {:.2} exchanged (band ±{:.0} %): the two gratings lie in each other's places (slits or splices swapped); relabel them in the design or re-lay the fibers, then recalibrate",
                i.gratings[a],
                i.gratings[b],
                own / 2.0,
                exchanged / 2.0,
                100.0 * i.tolerance
            ),
            evidence: BTreeMap::from([
                ("misfit_as_labelled".to_string(), own / 2.0),
                ("misfit_exchanged".to_string(), exchanged / 2.0),
            ]),
        });
    }
    (faults, row_of)
}

/// Condition number of the columns `cols` of `m`, each scaled to unit length.
fn normalised_condition(m: &DMatrix<f64>, cols: &[usize]) -> f64 {
    let a = DMatrix::from_fn(m.nrows(), cols.len(), |g, k| {
        let n = m.column(cols[k]).norm();
        if n > 0.0 {
            m[(g, cols[k])] / n
        } else {
            0.0
        }
    });
    condition_number(&a)
}

fn collinear(i: &Inputs) -> Vec<Fault> {
    let cols = loaded_cells(i.measured);
    let col = |m: &DMatrix<f64>, c: usize| -> Vec<f64> { m.column(c).iter().copied().collect() };
    let noise = |c: usize| {
        let s2: f64 = i.sd.column(c).iter().map(|v| v * v).sum();
        s2.sqrt() / i.measured.column(c).norm().max(1e-300)
    };
    let mut out = Vec::new();
    for (k, &a) in cols.iter().enumerate() {
        for &b in &cols[k + 1..] {
            let measured = angle_deg(&col(i.measured, a), &col(i.measured, b));
            let predicted = angle_deg(&col(i.predicted, a), &col(i.predicted, b));
            let noise_deg = (noise(a).powi(2) + noise(b).powi(2)).sqrt().to_degrees();
            if measured >= 3.0 * noise_deg && measured >= 0.25 * predicted {
                continue;
            }
            let pair = [a, b];
            let cond = normalised_condition(i.measured, &cols);
            let cond_p = normalised_condition(i.predicted, &cols);
            out.push(Fault {
                kind: FaultKind::CollinearCells,
                severity: Severity::Unusable,
                gratings: Vec::new(),
                cells: pair.iter().map(|&c| i.cells[c].clone()).collect(),
                reason: format!(
                    "the columns of cells {} and {} point the same way ({measured:.1}° apart; noise allows {noise_deg:.1}°, the model predicts {predicted:.1}°; condition number {cond:.1}, predicted {cond_p:.1}): {}",
                    i.cells[a],
                    i.cells[b],
                    if predicted < 3.0 * noise_deg {
                        "the layout cannot tell these cells apart"
                    } else {
                        "one cell was loaded twice or the weight sat between them; a reconstruction cannot tell them apart"
                    }
                ),
                evidence: BTreeMap::from([
                    ("angle_deg".to_string(), measured),
                    ("predicted_angle_deg".to_string(), predicted),
                    ("noise_angle_deg".to_string(), noise_deg),
                    ("condition_number".to_string(), cond),
                    ("predicted_condition_number".to_string(), cond_p),
                ]),
            });
        }
    }
    out
}

fn identity(i: &Inputs) -> Vec<Fault> {
    let cols = loaded_cells(i.measured);
    let mut out = Vec::new();
    if i.measured.nrows() < 2 {
        return out;
    }
    for &c in &cols {
        let m: Vec<f64> = i.measured.column(c).iter().copied().collect();
        let own = angle_deg(
            &m,
            &i.predicted.column(c).iter().copied().collect::<Vec<_>>(),
        );
        let (other, near) = (0..i.predicted.ncols())
            .filter(|&o| o != c)
            .map(|o| {
                (
                    o,
                    angle_deg(
                        &m,
                        &i.predicted.column(o).iter().copied().collect::<Vec<_>>(),
                    ),
                )
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((c, own));
        if other == c || own < 15.0 || near + 10.0 > own {
            continue;
        }
        let evidence = BTreeMap::from([
            ("angle_to_own_deg".to_string(), own),
            ("angle_to_other_deg".to_string(), near),
        ]);
        out.push(Fault {
            kind: FaultKind::ScheduleMisaligned,
            severity: Severity::Unusable,
            gratings: Vec::new(),
            cells: vec![i.cells[c].clone(), i.cells[other].clone()],
            reason: format!(
                "the loading listed as cell {} reads like cell {} ({near:.1}° from {}'s predicted column, {own:.1}° from its own): the schedule names the wrong cell, or the weight went on {}",
                i.cells[c], i.cells[other], i.cells[other], i.cells[other]
            ),
            evidence: evidence.clone(),
        });
        out.push(Fault {
            kind: FaultKind::UnloadedCell,
            severity: Severity::Unusable,
            gratings: Vec::new(),
            cells: vec![i.cells[c].clone()],
            reason: format!(
                "no loading in the run reads like cell {}: the one listed for it reads like cell {}; load {} and recalibrate",
                i.cells[c], i.cells[other], i.cells[c]
            ),
            evidence,
        });
    }
    out
}

fn unloaded(i: &Inputs, scale: f64) -> Vec<Fault> {
    loaded_cells(i.measured)
        .into_iter()
        .filter_map(|c| {
            let moved = (0..i.measured.nrows())
                .any(|g| i.measured[(g, c)].abs() > 3.0 * i.sd[(g, c)]);
            let expected = (0..i.measured.nrows())
                .map(|g| scale * i.predicted[(g, c)].abs() / i.sd[(g, c)].max(1e-300))
                .fold(0.0, f64::max);
            (!moved && expected >= 10.0).then(|| Fault {
                kind: FaultKind::UnloadedCell,
                severity: Severity::Unusable,
                gratings: Vec::new(),
                cells: vec![i.cells[c].clone()],
                reason: format!(
                    "no grating moved beyond three standard deviations while cell {} was listed as loaded, where the model expects a reading {expected:.0} standard deviations high: the weight did not rest on the sheet, or the schedule's cell is wrong",
                    i.cells[c]
                ),
                evidence: BTreeMap::from([("expected_over_sd".to_string(), expected)]),
            })
        })
        .collect()
}

fn negative(i: &Inputs, scale: f64) -> Vec<Fault> {
    let top = i.predicted.iter().fold(0.0f64, |x, v| x.max(v.abs())) * scale;
    let mut out = Vec::new();
    for c in loaded_cells(i.measured) {
        for g in 0..i.measured.nrows() {
            let (m, s, p) = (
                i.measured[(g, c)],
                i.sd[(g, c)],
                scale * i.predicted[(g, c)],
            );
            let lower = p - i.tolerance * (p.abs() + 0.05 * top);
            if m + 3.0 * s < 0.0 && m + 3.0 * s < lower {
                out.push(Fault {
                    kind: FaultKind::NegativeEntry,
                    severity: Severity::Unusable,
                    gratings: vec![i.gratings[g].clone()],
                    cells: vec![i.cells[c].clone()],
                    reason: format!(
                        "{} reads {m:.4} ± {s:.4} pm/g for a load on cell {}: a load that shortens the grating, where the scaled model allows down to {lower:.4} pm/g; a baseline taken at the wrong time, a wrong schedule, or a fiber pulled by the weight",
                        i.gratings[g], i.cells[c]
                    ),
                    evidence: BTreeMap::from([
                        ("measured_pm_per_g".to_string(), m),
                        ("sd_pm_per_g".to_string(), s),
                        ("band_low_pm_per_g".to_string(), lower),
                    ]),
                });
            }
        }
    }
    out
}
