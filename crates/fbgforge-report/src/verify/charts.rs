//! The charts of a verification report, as values: the report folder writes them as
//! SVG files and the HTML report inlines the same charts.
//!
//! The shift–force chart shows what the verdict compares: per grating, the measured
//! points, the fitted K, the model's K (dashed, through the fit's intercept, so the
//! two slopes are compared on the same baseline) with the tolerance that passes
//! shaded around it, and the band between the bounding contact readings when the
//! model policy gives one.

use crate::plot::{Chart, Mark, Series as PlotSeries, Stroke};
use fbgforge_verify::analysis::{Measurement, Series};
use fbgforge_verify::VerifyReport;

/// Plots keep at most 2 500 markers per series and 8 000 line points, so the SVGs stay
/// small enough to open; the CSVs hold the denser data.
const MAX_MARKERS: usize = 2_500;
const MAX_LINE_POINTS: usize = 8_000;

fn stride(n: usize, max: usize) -> usize {
    n.div_ceil(max.max(1)).max(1)
}

/// `role` of the model's K line in the SVG (`data-role`); its band of passing
/// tolerance is drawn with it.
pub(crate) const ROLE_MODEL_K: &str = "model-k";
/// `role` of the band between the bounding contact readings.
pub(crate) const ROLE_MODEL_BAND: &str = "model-band";
/// `role` of the fitted K line.
pub(crate) const ROLE_FIT: &str = "fit";

/// Each grating's shift against force, its fitted line, and the model's K and band.
pub fn shift_vs_force(r: &VerifyReport, series: &Series) -> Chart {
    let n = series.time_s.len();
    let scatter: Vec<usize> = (0..n).step_by(stride(n, MAX_MARKERS)).collect();
    let mut c = Chart::new(
        format!("Shift against force: measured and model K, {}", r.design),
        "force F (N)",
        "shift Δλ (pm)",
    );
    for (gi, ((name, v), (_, slope, intercept))) in
        series.shift_pm.iter().zip(&series.fit).enumerate()
    {
        let pts: Vec<(f64, f64)> = scatter
            .iter()
            .map(|&i| (series.force_n[i], v[i]))
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .collect();
        let (lo, hi) = pts
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
        c = c.with(
            PlotSeries::new(format!("{name}, measured"), pts, Mark::Points)
                .with_color(gi)
                .with_role("measured"),
        );
        if lo >= hi {
            continue;
        }
        let line = |k: f64| vec![(lo, intercept + k * lo), (hi, intercept + k * hi)];
        c = c.with(
            PlotSeries::new(
                format!("{name}: fitted K = {slope:.3} pm/N"),
                line(*slope),
                Mark::Line,
            )
            .with_color(gi)
            .with_role(ROLE_FIT),
        );
        let Some(v) = r.verdict.gratings.iter().find(|v| &v.grating == name) else {
            continue;
        };
        let Some(k) = v.predicted_sensitivity_pm_per_n.filter(|k| k.is_finite()) else {
            continue;
        };
        // The cone of slopes within the tolerance of the model's K passes: its edges
        // are the lines of the smallest and the largest passing slope.
        let (a, b) = (k * (1.0 - v.tolerance), k * (1.0 + v.tolerance));
        let (k_lo, k_hi) = (a.min(b), a.max(b));
        let cone = |f: f64| (f, intercept + k_lo * f, intercept + k_hi * f);
        c = c.with(
            PlotSeries::new(
                format!(
                    "{name}: model K = {k:.3} pm/N (shaded: within {:.1} %, passes)",
                    100.0 * v.tolerance
                ),
                line(k),
                Mark::Line,
            )
            .with_band(vec![cone(lo), cone(hi)])
            .with_color(gi)
            .with_stroke(Stroke::Dashed)
            .with_role(ROLE_MODEL_K),
        );
        if let Some([b_lo, b_hi]) = v.band_pm_per_n {
            let (b_lo, b_hi) = (b_lo.min(b_hi), b_lo.max(b_hi));
            let edge = |f: f64| (f, intercept + b_lo * f, intercept + b_hi * f);
            c = c.with(
                PlotSeries::new(
                    format!("{name}: model band {b_lo:.3} … {b_hi:.3} pm/N (contact readings)"),
                    Vec::new(),
                    Mark::Line,
                )
                .with_band(vec![edge(lo), edge(hi)])
                .with_color(gi)
                .with_stroke(Stroke::Dotted)
                .with_role(ROLE_MODEL_BAND),
            );
        }
    }
    c
}

/// The force on the wavelength clock.
pub fn force_vs_time(series: &Series) -> Chart {
    let n = series.time_s.len();
    let pts: Vec<(f64, f64)> = (0..n)
        .step_by(stride(n, MAX_LINE_POINTS))
        .map(|i| (series.time_s[i], series.force_n[i]))
        .collect();
    Chart::new(
        "Force against time (wavelength clock)",
        "time (s)",
        "force F (N)",
    )
    .with(PlotSeries::new("force", pts, Mark::Line))
}

/// Each grating's shift on the wavelength clock.
pub fn shift_vs_time(series: &Series) -> Chart {
    let n = series.time_s.len();
    let idx: Vec<usize> = (0..n).step_by(stride(n, MAX_LINE_POINTS)).collect();
    let mut c = Chart::new(
        "Shift against time (temperature and drift removed)",
        "time (s)",
        "shift Δλ (pm)",
    );
    for (gi, (name, v)) in series.shift_pm.iter().enumerate() {
        c = c.with(
            PlotSeries::new(
                name.clone(),
                idx.iter().map(|&i| (series.time_s[i], v[i])).collect(),
                Mark::Line,
            )
            .with_color(gi),
        );
    }
    c
}

/// The lag of the shift behind the force per segment, when any segment has one, each
/// grating's lags with their ±1 standard uncertainty as a band (`pulses.csv` has the
/// same ±): 1 ms of scatter inside a ±1.2 ms band is not a trend.
pub(crate) fn lag_per_segment(m: &Measurement) -> Option<Chart> {
    let mut c = Chart::new(
        "Lag of the shift behind the force, per segment (band: ±1 standard uncertainty)",
        "segment",
        "lag (s)",
    );
    let mut any = false;
    for (gi, g) in m.gratings.iter().enumerate() {
        let pts: Vec<(f64, f64)> = g.pulses.iter().map(|p| (p.index as f64, p.lag_s)).collect();
        any |= pts.iter().any(|(a, b)| a.is_finite() && b.is_finite());
        let band: Vec<(f64, f64, f64)> = g
            .pulses
            .iter()
            .filter(|p| p.lag_s.is_finite() && p.lag_uncertainty_s.is_finite())
            .map(|p| {
                (
                    p.index as f64,
                    p.lag_s - p.lag_uncertainty_s,
                    p.lag_s + p.lag_uncertainty_s,
                )
            })
            .collect();
        let mut series = PlotSeries::new(g.grating.clone(), pts, Mark::LinePoints).with_color(gi);
        if !band.is_empty() {
            series = series.with_band(band).with_role(ROLE_LAG_UNCERTAINTY);
        }
        c = c.with(series);
    }
    any.then_some(c)
}

/// The role of a lag series drawn with its uncertainty band.
pub(crate) const ROLE_LAG_UNCERTAINTY: &str = "lag-with-uncertainty";
