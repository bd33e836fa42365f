//! Small robust statistics used by the readers and the peak finder.

/// Median of the values (reorders the slice); NaN for an empty slice.
pub fn median(values: &mut [f64]) -> f64 {
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    let mid = n / 2;
    values.select_nth_unstable_by(mid, f64::total_cmp);
    let upper = values[mid];
    if n % 2 == 1 {
        upper
    } else {
        let lower = values[..mid]
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lower + upper)
    }
}

/// Robust standard deviation of white noise from the median absolute deviation of the
/// first differences: σ ≈ 1.4826·MAD(d)/√2 with d_i = y_{i+1} − y_i. Slow baselines and
/// sparse peaks hardly move it. NaN for fewer than 3 samples.
pub fn noise_sigma_mad_diff(values: &[f64]) -> f64 {
    if values.len() < 3 {
        return f64::NAN;
    }
    let mut d: Vec<f64> = values.windows(2).map(|w| w[1] - w[0]).collect();
    let m = median(&mut d.clone());
    for x in d.iter_mut() {
        *x = (*x - m).abs();
    }
    1.482_602_218_505_602 * median(&mut d) / std::f64::consts::SQRT_2
}

/// Root mean square of the values; NaN when empty.
pub fn rms(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

/// Mean and sample standard deviation; (NaN, NaN) when empty.
pub fn mean_std(values: &[f64]) -> (f64, f64) {
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    if n == 1 {
        return (mean, f64::NAN);
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (mean, var.sqrt())
}
