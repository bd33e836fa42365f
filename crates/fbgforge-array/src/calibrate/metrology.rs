//! The paper's metrological table (its Table 2) for every grating on every cell loaded
//! as a staircase, with the paper's definitions (§2.4 and Table 2 of the array paper):
//!
//! * a **cycle** is a run of states on one cell alone from unloaded, up in steps to a
//!   top and back down in steps to unloaded (at least two different masses);
//! * the **points** are each state's shift from the run's first unloaded reading,
//!   against the mass on the cell; the **calibration line** is the least-squares line
//!   through every point of every cycle, its slope the **sensitivity**, ± the standard
//!   error of the mean of the cycles' own slopes; **R** is the points' correlation;
//! * **resolution** = the interrogator's resolution / the sensitivity, g;
//! * the **span** is the line's output over the measuring interval, |slope| × (top − 0);
//! * the **calibration curve** is the mean over cycles of the points of each branch
//!   at each mass (up, down, and the top, which both branches share);
//! * **linearity** = the largest |deviation| of the curve from the line, % of span;
//! * **hysteresis** = the largest sum, over the branches at one mass, of the curve's
//!   |deviations| from the line, % of span (up and down at the same mass; the top
//!   counts once).

use super::levels::StateLevels;
use super::schedule::LoadState;
use crate::profile::cell_label;
use serde::Serialize;

/// Which branch of a cycle a point lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Branch {
    /// Loading (including the unloaded start).
    Up,
    /// The top step, shared by both branches.
    Top,
    /// Unloading (including the unloaded end).
    Down,
}

/// One point of the calibration curve (mean over cycles).
#[derive(Debug, Clone, Serialize)]
pub struct CurvePoint {
    /// Mass on the cell, g.
    pub load_g: f64,
    /// Branch.
    pub branch: Branch,
    /// Mean shift over the cycles, pm.
    pub shift_pm: f64,
    /// Deviation from the calibration line, pm.
    pub deviation_pm: f64,
}

/// Table 2 for one grating on one staircase-loaded cell.
#[derive(Debug, Clone, Serialize)]
pub struct Metrology {
    /// Cell label.
    pub cell: String,
    /// Grating name.
    pub grating: String,
    /// Slope of the calibration line, pm/g.
    pub sensitivity_pm_per_g: f64,
    /// Standard error of the mean of the cycles' slopes, pm/g (None with one cycle).
    pub sensitivity_sem_pm_per_g: Option<f64>,
    /// Intercept of the calibration line, pm.
    pub intercept_pm: f64,
    /// Correlation coefficient of the points.
    pub r: f64,
    /// Interrogator resolution / sensitivity, g.
    pub resolution_g: f64,
    /// Largest |deviation| of the calibration curve from the line, % of span.
    pub linearity_percent_span: f64,
    /// Largest summed |deviation| of the branches at one mass, % of span.
    pub hysteresis_percent_span: f64,
    /// Up-and-down cycles.
    pub cycles: usize,
    /// Measuring interval, g.
    pub measuring_interval_g: [f64; 2],
    /// |sensitivity| × the interval, pm.
    pub span_pm: f64,
    /// Points in the fit.
    pub points: usize,
    /// The calibration curve.
    pub curve: Vec<CurvePoint>,
}

/// A staircase cycle: the states of one cell, by branch.
#[derive(Debug, Clone)]
struct Cycle {
    cell: usize,
    /// (state index, load g, branch).
    points: Vec<(usize, f64, Branch)>,
}

/// The cycle starting at unloaded state `k`, if one does.
fn cycle_at(states: &[LoadState], k: usize) -> Option<Cycle> {
    let (cell, _) = states.get(k + 1)?.single()?;
    let mut loads = Vec::new();
    let mut j = k + 1;
    while let Some((c, l)) = states.get(j).and_then(LoadState::single) {
        if c != cell {
            return None;
        }
        loads.push((j, l));
        j += 1;
    }
    if !states.get(j)?.is_unloaded() {
        return None;
    }
    let top = loads
        .iter()
        .enumerate()
        .max_by(|a, b| a.1 .1.total_cmp(&b.1 .1))?
        .0;
    let up_ok = loads[..=top].windows(2).all(|w| w[1].1 > w[0].1);
    let down_ok = loads[top..].windows(2).all(|w| w[1].1 < w[0].1);
    let mut distinct: Vec<f64> = loads.iter().map(|x| x.1).collect();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    if !(up_ok && down_ok && distinct.len() >= 2) {
        return None;
    }
    let mut points = vec![(k, 0.0, Branch::Up)];
    for (i, &(s, l)) in loads.iter().enumerate() {
        let b = match i.cmp(&top) {
            std::cmp::Ordering::Less => Branch::Up,
            std::cmp::Ordering::Equal => Branch::Top,
            std::cmp::Ordering::Greater => Branch::Down,
        };
        points.push((s, l, b));
    }
    points.push((j, 0.0, Branch::Down));
    Some(Cycle { cell, points })
}

/// Least-squares line (intercept, slope) and correlation of (x, y).
fn line_fit(pts: &[(f64, f64)]) -> (f64, f64, f64) {
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let syy: f64 = pts.iter().map(|p| (p.1 - my).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    let r = if sxx > 0.0 && syy > 0.0 {
        sxy / (sxx * syy).sqrt()
    } else {
        f64::NAN
    };
    (my - b * mx, b, r)
}

/// Table 2 of every grating for every staircase-loaded cell of the run.
pub fn metrology(
    states: &[LoadState],
    levels: &[StateLevels],
    gratings: &[String],
    resolution_pm: f64,
) -> Vec<Metrology> {
    let cycles: Vec<Cycle> = (0..states.len())
        .filter(|&k| states[k].is_unloaded())
        .filter_map(|k| cycle_at(states, k))
        .collect();
    let mut cells: Vec<usize> = cycles.iter().map(|c| c.cell).collect();
    cells.sort_unstable();
    cells.dedup();
    let reference = (0..states.len()).find(|&k| states[k].is_unloaded() && levels[k].used > 0);
    let mut out = Vec::new();
    for &cell in &cells {
        let of: Vec<&Cycle> = cycles.iter().filter(|c| c.cell == cell).collect();
        for (g, name) in gratings.iter().enumerate() {
            let zero = reference.map_or(0.0, |k| levels[k].gratings[g].shift_pm);
            let shift = |s: usize| levels[s].gratings[g].shift_pm - zero;
            if let Some(m) = one_grating(&of, &shift, resolution_pm) {
                out.push(Metrology {
                    cell: cell_label(cell),
                    grating: name.clone(),
                    ..m
                });
            }
        }
    }
    out
}

fn one_grating(
    cycles: &[&Cycle],
    shift: &dyn Fn(usize) -> f64,
    resolution_pm: f64,
) -> Option<Metrology> {
    let per_cycle: Vec<Vec<(f64, f64, Branch)>> = cycles
        .iter()
        .map(|c| {
            c.points
                .iter()
                .map(|&(s, l, b)| (l, shift(s), b))
                .filter(|p| p.1.is_finite())
                .collect()
        })
        .collect();
    let all: Vec<(f64, f64)> = per_cycle.iter().flatten().map(|p| (p.0, p.1)).collect();
    if all.len() < 3 {
        return None;
    }
    let (a, b, r) = line_fit(&all);
    let slopes: Vec<f64> = per_cycle
        .iter()
        .filter(|c| c.len() >= 3)
        .map(|c| line_fit(&c.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>()).1)
        .collect();
    let (_, sem) = crate::protocol::mean_sem(&slopes);
    let top = all.iter().map(|p| p.0).fold(0.0, f64::max);
    let span = b.abs() * top;
    // The calibration curve: the mean of each (branch, mass) over the cycles.
    let mut groups: Vec<(Branch, f64, f64, usize)> = Vec::new();
    for &(l, y, br) in per_cycle.iter().flatten() {
        match groups
            .iter_mut()
            .find(|g| g.0 == br && (g.1 - l).abs() <= 1e-6 * top.max(1.0))
        {
            Some(g) => {
                g.2 += y;
                g.3 += 1;
            }
            None => groups.push((br, l, y, 1)),
        }
    }
    let mut curve: Vec<CurvePoint> = groups
        .iter()
        .map(|&(branch, load_g, sum, n)| {
            let shift_pm = sum / n as f64;
            CurvePoint {
                load_g,
                branch,
                shift_pm,
                deviation_pm: shift_pm - (a + b * load_g),
            }
        })
        .collect();
    curve.sort_by(|x, y| x.branch.cmp(&y.branch).then(x.load_g.total_cmp(&y.load_g)));
    let linearity = curve
        .iter()
        .map(|p| p.deviation_pm.abs())
        .fold(0.0, f64::max);
    let hysteresis = curve
        .iter()
        .map(|p| {
            curve
                .iter()
                .filter(|q| (q.load_g - p.load_g).abs() <= 1e-6 * top.max(1.0))
                .map(|q| q.deviation_pm.abs())
                .sum::<f64>()
        })
        .fold(0.0, f64::max);
    let pct = |v: f64| {
        if span > 0.0 {
            100.0 * v / span
        } else {
            f64::NAN
        }
    };
    Some(Metrology {
        cell: String::new(),
        grating: String::new(),
        sensitivity_pm_per_g: b,
        sensitivity_sem_pm_per_g: (slopes.len() >= 2).then_some(sem),
        intercept_pm: a,
        r,
        resolution_g: resolution_pm / b.abs(),
        linearity_percent_span: pct(linearity),
        hysteresis_percent_span: pct(hysteresis),
        cycles: cycles.len(),
        measuring_interval_g: [0.0, top],
        span_pm: span,
        points: all.len(),
        curve,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_staircase_cycle_is_up_then_down_on_one_cell() {
        let st = |cell: Option<(usize, f64)>| {
            let mut loads_g = vec![0.0; 2];
            if let Some((c, l)) = cell {
                loads_g[c] = l;
            }
            LoadState {
                start_s: 0.0,
                end_s: 1.0,
                loads_g,
            }
        };
        let states = vec![
            st(None),
            st(Some((0, 25.0))),
            st(Some((0, 50.0))),
            st(Some((0, 25.0))),
            st(None),
            st(Some((1, 200.0))),
            st(None),
        ];
        let c = cycle_at(&states, 0).unwrap();
        let branches: Vec<Branch> = c.points.iter().map(|p| p.2).collect();
        use Branch::*;
        assert_eq!(branches, vec![Up, Up, Top, Down, Down]);
        // One mass on and off is not a staircase.
        assert!(cycle_at(&states, 4).is_none());
    }

    #[test]
    fn line_fit_is_exact_on_a_line() {
        let (a, b, r) = line_fit(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)]);
        assert!((a - 1.0).abs() < 1e-12 && (b - 2.0).abs() < 1e-12 && (r - 1.0).abs() < 1e-12);
    }
}
