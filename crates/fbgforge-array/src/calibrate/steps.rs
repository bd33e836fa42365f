//! Load changes found in the shifts themselves, every grating together.
//!
//! A dead weight put on or taken off moves every grating at once, by a step. At each
//! sample the mean of the `w` samples after it is compared with the mean of the `w`
//! before it, grating by grating, in units of that grating's noise; the sum of squares
//! D follows a χ² law with one degree of freedom per grating where nothing changes. A
//! change is a local maximum of D above the χ² quantile of 10⁻⁶ (Wilson–Hilferty), so a
//! log of 10⁵ rows sees about one chance peak. Pulses shorter than w/2 samples are
//! removed first (a running median, which leaves a step's edge in place), and a change
//! followed within 1.5 w samples by one that undoes it (a bump on the table) is dropped as
//! a transient.

use serde::Serialize;

/// A load change found in the data.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Change {
    /// The first sample after the change.
    pub index: usize,
    /// Its time, s from the log's first row.
    pub time_s: f64,
    /// D at the change: the squared jump summed over gratings in noise units.
    pub score: f64,
    /// The jump of each grating across the change, pm.
    pub jump_pm: Vec<f64>,
}

/// What the detector found and the numbers it used.
#[derive(Debug, Clone, Serialize)]
pub struct Detection {
    /// The changes, in time order.
    pub changes: Vec<Change>,
    /// Each grating's noise, pm (robust: from the median absolute sample-to-sample
    /// difference), never below the floor given.
    pub noise_pm: Vec<f64>,
    /// Samples on each side of the test.
    pub window: usize,
    /// D above which a local maximum is a change.
    pub threshold: f64,
    /// Bumps dropped (a change undone within 1.5 windows), by time, s.
    pub transients_s: Vec<f64>,
}

/// A series (NaN = no peak) through a running median of `width` samples (odd): it
/// keeps a step's edge where it is and removes any pulse shorter than half the width.
fn running_median(x: &[f64], width: usize) -> Vec<f64> {
    let h = width / 2;
    let n = x.len();
    if h == 0 {
        return x.to_vec();
    }
    let mut buf = Vec::with_capacity(width);
    (0..n)
        .map(|i| {
            buf.clear();
            buf.extend_from_slice(&x[i.saturating_sub(h)..(i + h + 1).min(n)]);
            let m = median(&mut buf);
            if m.is_finite() {
                m
            } else {
                x[i]
            }
        })
        .collect()
}

/// The median of finite values (NaN when none).
pub(crate) fn median(v: &mut Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// A grating's white noise, pm: 1.4826 × the median |x(i+1) − x(i)| / √2 (steps are a
/// few differences among many, so they do not move it).
pub(crate) fn noise_of(x: &[f64]) -> f64 {
    let mut d: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    1.4826 * median(&mut d) / std::f64::consts::SQRT_2
}

/// Prefix sums of finite values and their counts, for window means in O(1).
struct Prefix {
    sum: Vec<f64>,
    count: Vec<usize>,
}

impl Prefix {
    fn new(x: &[f64]) -> Self {
        let mut sum = vec![0.0; x.len() + 1];
        let mut count = vec![0; x.len() + 1];
        for (i, &v) in x.iter().enumerate() {
            let ok = v.is_finite();
            sum[i + 1] = sum[i] + if ok { v } else { 0.0 };
            count[i + 1] = count[i] + usize::from(ok);
        }
        Prefix { sum, count }
    }
    fn mean(&self, a: usize, b: usize) -> Option<f64> {
        let n = self.count[b] - self.count[a];
        (n > 0).then(|| (self.sum[b] - self.sum[a]) / n as f64)
    }
}

/// The χ² quantile of `dof` degrees of freedom at standard normal quantile `z`
/// (Wilson–Hilferty).
pub(crate) fn chi2_quantile(dof: f64, z: f64) -> f64 {
    let a = 2.0 / (9.0 * dof);
    dof * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Standard normal quantile of a one-sided 10⁻⁶ tail.
const Z_1E6: f64 = 4.753;

/// Find the load changes in `shifts_pm` (one series per grating, NaN = no peak)
/// sampled at `time_s`, testing `window` samples on each side; no grating's noise is
/// taken below `noise_floor_pm`.
pub fn detect(
    time_s: &[f64],
    shifts_pm: &[Vec<f64>],
    window: usize,
    noise_floor_pm: f64,
) -> Detection {
    let n = time_s.len();
    let w = window.max(1);
    let clean: Vec<Vec<f64>> = shifts_pm
        .iter()
        .map(|x| running_median(x, 2 * (w / 2) + 1))
        .collect();
    // The noise of the raw series: the running median's output moves in runs of equal
    // values, so its sample-to-sample differences would understate it several-fold.
    let noise_pm: Vec<f64> = shifts_pm
        .iter()
        .map(|x| noise_of(x).max(noise_floor_pm).max(1e-9))
        .collect();
    let prefix: Vec<Prefix> = clean.iter().map(|x| Prefix::new(x)).collect();
    let threshold = chi2_quantile(shifts_pm.len().max(1) as f64, Z_1E6);
    let jump = |i: usize| -> Vec<f64> {
        prefix
            .iter()
            .map(
                |p| match (p.mean(i.saturating_sub(w), i), p.mean(i, (i + w).min(n))) {
                    (Some(a), Some(b)) => b - a,
                    _ => 0.0,
                },
            )
            .collect()
    };
    let score_of = |j: &[f64]| -> f64 {
        j.iter()
            .zip(&noise_pm)
            .map(|(d, s)| (d / s).powi(2) * w as f64 / 2.0)
            .sum()
    };
    let d: Vec<f64> = (0..=n)
        .map(|i| {
            if i < w || i + w > n {
                0.0
            } else {
                score_of(&jump(i))
            }
        })
        .collect();
    let mut changes = Vec::new();
    for i in w..=n.saturating_sub(w) {
        if d[i] <= threshold {
            continue;
        }
        let lo = i.saturating_sub(w);
        let hi = (i + w).min(n);
        // The first of equal maxima, so a flat top gives one change.
        let is_max = (lo..=hi).all(|k| d[k] < d[i] || (d[k] == d[i] && k >= i));
        if is_max && i < n {
            changes.push(Change {
                index: i,
                time_s: time_s[i],
                score: d[i],
                jump_pm: jump(i),
            });
        }
    }
    let (changes, transients_s) = drop_transients(changes, w, &noise_pm);
    Detection {
        changes,
        noise_pm,
        window: w,
        threshold,
        transients_s,
    }
}

/// Noise-weighted norm of a jump.
fn norm(j: &[f64], noise: &[f64]) -> f64 {
    j.iter()
        .zip(noise)
        .map(|(d, s)| (d / s).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Drop pairs of changes within 1.5 w samples whose jumps cancel (their sum under a
/// quarter of the smaller one): a bump, not a load. (Changes are at least w apart;
/// not more than 1.5 w: the top step of a staircase put on by hand is undone after as
/// little as two thirds of a step, 1.7 w.)
fn drop_transients(changes: Vec<Change>, w: usize, noise: &[f64]) -> (Vec<Change>, Vec<f64>) {
    let mut keep = vec![true; changes.len()];
    let mut transients = Vec::new();
    let mut k = 0;
    while k + 1 < changes.len() {
        let (a, b) = (&changes[k], &changes[k + 1]);
        let sum: Vec<f64> = a
            .jump_pm
            .iter()
            .zip(&b.jump_pm)
            .map(|(x, y)| x + y)
            .collect();
        let small = norm(&a.jump_pm, noise).min(norm(&b.jump_pm, noise));
        if 2 * (b.index - a.index) <= 3 * w && norm(&sum, noise) < 0.25 * small {
            keep[k] = false;
            keep[k + 1] = false;
            transients.push(a.time_s);
            k += 2;
        } else {
            k += 1;
        }
    }
    let kept = changes
        .into_iter()
        .zip(keep)
        .filter_map(|(c, k)| k.then_some(c))
        .collect();
    (kept, transients)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_are_found_where_they_are_and_a_bump_is_not_a_step() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        // Two gratings with 0.1 pm white noise, a two-step staircase with a 3-sample
        // bump at 150 (removed by the running median) and a 12-sample one at 250 (two
        // changes that cancel within 1.5 windows of 10 samples).
        let n = 300;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.1).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, 0.1).unwrap();
        let mut a = vec![0.0; n];
        let mut b = vec![0.0; n];
        for i in 0..n {
            let level = if i >= 200 {
                2.0
            } else if i >= 100 {
                1.0
            } else {
                0.0
            };
            a[i] = 10.0 * level + noise.sample(&mut rng);
            b[i] = 2.0 * level + noise.sample(&mut rng);
        }
        for v in &mut a[150..153] {
            *v += 8.0;
        }
        for v in &mut a[250..262] {
            *v += 8.0;
        }
        let d = detect(&t, &[a, b], 10, 0.01);
        let at: Vec<usize> = d.changes.iter().map(|c| c.index).collect();
        assert_eq!(at, vec![100, 200], "{:?}", d.changes);
        assert!((d.changes[0].jump_pm[0] - 10.0).abs() < 0.3);
        assert!((d.noise_pm[0] - 0.1).abs() < 0.02, "{:?}", d.noise_pm);
        assert_eq!(d.transients_s.len(), 1);
        assert!(
            (d.transients_s[0] - 25.0).abs() < 0.2,
            "{:?}",
            d.transients_s
        );
    }

    #[test]
    fn the_chi2_quantile_is_wilson_hilferty() {
        // The 95 % points of χ²₂ (5.99) and χ²₆ (12.59) within 1 %; at one degree of
        // freedom the approximation overstates (4.93 for 3.84): a single grating's
        // threshold errs on the side of fewer chance changes.
        assert!((chi2_quantile(2.0, 1.645) / 5.991 - 1.0).abs() < 0.01);
        assert!((chi2_quantile(6.0, 1.645) / 12.592 - 1.0).abs() < 0.01);
        assert!(chi2_quantile(1.0, 1.96) > 3.84);
    }
}
