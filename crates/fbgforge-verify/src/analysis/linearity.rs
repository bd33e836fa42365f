//! Hysteresis and non-linearity of a grating's shift against the force, as % of the
//! full-scale output.

use crate::fit;

/// Hysteresis and non-linearity, % of the full-scale output |slope|·(F_max − F_min):
/// samples are binned by force (20 bins); hysteresis is the largest difference between
/// the mean shift while loading (force rising) and unloading in one bin, non-linearity
/// the largest distance of a bin's mean from the fitted line (both from residuals
/// about the line).
pub fn hysteresis_and_linearity(force: &[f64], shift: &[f64], line: &fit::LineFit) -> (f64, f64) {
    let n = force.len();
    if n < 5 {
        return (f64::NAN, f64::NAN);
    }
    let (fmin, fmax) = force
        .iter()
        .filter(|f| f.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &f| {
            (lo.min(f), hi.max(f))
        });
    let span = line.slope.abs() * (fmax - fmin);
    if span.is_nan() || span <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    const BINS: usize = 20;
    let mut acc = [[0.0f64; 6]; BINS]; // sum_load, n_load, sum_unload, n_unload, sum_all, n_all
    for i in 1..n - 1 {
        let b = (((force[i] - fmin) / (fmax - fmin)) * BINS as f64)
            .floor()
            .clamp(0.0, (BINS - 1) as f64) as usize;
        // Residuals from the line, so that samples spread across a bin compare fairly.
        let res = shift[i] - (line.intercept + line.slope * force[i]);
        let df = force[i + 1] - force[i - 1];
        if !res.is_finite() || !df.is_finite() {
            continue;
        }
        if df > 0.0 {
            acc[b][0] += res;
            acc[b][1] += 1.0;
        } else if df < 0.0 {
            acc[b][2] += res;
            acc[b][3] += 1.0;
        }
        acc[b][4] += res;
        acc[b][5] += 1.0;
    }
    let (mut hyst, mut lin) = (0.0f64, 0.0f64);
    for a in acc.iter() {
        if a[1] >= 3.0 && a[3] >= 3.0 {
            hyst = hyst.max((a[0] / a[1] - a[2] / a[3]).abs());
        }
        if a[5] >= 3.0 {
            lin = lin.max((a[4] / a[5]).abs());
        }
    }
    (100.0 * hyst / span, 100.0 * lin / span)
}

/// Where the lag-corrected force goes, row by row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Branch {
    /// Not used (no shift, no force, left out).
    None,
    /// At rest (x below 3 % of its largest value).
    Rest,
    /// x rising.
    Loading,
    /// x falling.
    Unloading,
    /// x held (neither rising nor falling beyond its noise).
    Hold,
}

/// Hysteresis and non-linearity of the lag-corrected signal, % of span, as the
/// tactile-array paper defines them: the calibration line is the loading branch's,
/// Δλ = K·x through the origin (the slow curve is removed from `d`), and the span its
/// full-scale output |K|·x_max. Rows are binned by x (up to 20 bins, fewer when the
/// branches have few rows, at least 3 of each per bin); hysteresis is the largest
/// difference between the unloading and loading branch means in one bin,
/// non-linearity the largest distance of a loading bin's mean from the line. Held rows
/// belong to neither branch. NaN when no bin has rows of both branches.
pub(crate) fn lag_corrected_loop(
    x: &[f64],
    d: &[f64],
    branch: &[Branch],
    k: f64,
    x_max: f64,
) -> (f64, f64) {
    let span = k.abs() * x_max;
    if span.is_nan() || span <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let count = |b: Branch| branch.iter().filter(|&&v| v == b).count();
    let bins = (count(Branch::Loading).min(count(Branch::Unloading)) / 6).clamp(3, 20);
    // sum and count of the residual from the line, loading then unloading.
    let mut acc = vec![[0.0f64; 4]; bins];
    for i in 0..x.len() {
        let slot = match branch[i] {
            Branch::Loading => 0,
            Branch::Unloading => 2,
            _ => continue,
        };
        let res = d[i] - k * x[i];
        if !res.is_finite() {
            continue;
        }
        let b = ((x[i] / x_max) * bins as f64)
            .floor()
            .clamp(0.0, (bins - 1) as f64) as usize;
        acc[b][slot] += res;
        acc[b][slot + 1] += 1.0;
    }
    let (mut hyst, mut lin, mut any) = (0.0f64, 0.0f64, false);
    for a in &acc {
        if a[1] >= 3.0 {
            lin = lin.max((a[0] / a[1]).abs());
            if a[3] >= 3.0 {
                hyst = hyst.max((a[2] / a[3] - a[0] / a[1]).abs());
                any = true;
            }
        }
    }
    if !any {
        return (f64::NAN, 100.0 * lin / span);
    }
    (100.0 * hyst / span, 100.0 * lin / span)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_straight_reversible_response_has_no_hysteresis() {
        let f: Vec<f64> = (0..400)
            .map(|i| 10.0 * (1.0 - (i as f64 * 0.05).cos()))
            .collect();
        let s: Vec<f64> = f.iter().map(|x| 3.0 * x).collect();
        let line = fit::fit_line(&f, &s).unwrap();
        let (h, l) = hysteresis_and_linearity(&f, &s, &line);
        assert!(h < 1e-9 && l < 1e-9, "{h} {l}");
        // A response that lags shows up as hysteresis.
        let s2: Vec<f64> = (0..400)
            .map(|i| 30.0 * (1.0 - (i as f64 * 0.05 - 0.3).cos()))
            .collect();
        let line2 = fit::fit_line(&f, &s2).unwrap();
        assert!(hysteresis_and_linearity(&f, &s2, &line2).0 > 5.0);
    }
}
