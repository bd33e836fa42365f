//! Fitting tools: small least squares, the standard-linear-solid lag model, and the
//! joint fit of clock offset and lag model by variable projection.
//!
//! The lag model (a standard linear solid driven by force) is
//!
//!   y + τ·dy/dt = F + r·τ·dF/dt,
//!
//! i.e. a fraction r of the response follows the force at once and the rest,
//! 1 − r, follows it through a first-order lag of time constant τ. The shift is
//! Δλ = K·y: for a step of force the shift jumps to r·K·F and creeps to K·F. K is the
//! equilibrium (static) sensitivity, the one an elastic model predicts.
//!
//! The clock offset between the two logs and the viscoelastic lag are told apart by
//! the shape of the response: a clock offset shifts every feature of the force by the
//! same time, the lag model smooths and delays it. With the model linear in K and in
//! a baseline and drift, only (offset, τ, r) are searched (variable projection), by
//! Nelder–Mead through argmin: the cost is [`LagModelCost`], the solver interchangeable.
//!
//! A pure transport delay d (the response follows the force late, shape unchanged)
//! is the same parameter as an offset: once the clocks are aligned, each grating's
//! fit frees the offset within bounds and reads it as its delay (d = −offset), so that
//! a delay is not forced into τ and r (which bent K by +30 % for 1 s presses at 2 Hz).

use crate::solvers::nelder_mead;
use argmin::core::CostFunction;

/// Ordinary least squares with an arbitrary number of regressors (normal equations;
/// the problems here have at most three columns). Returns (coefficients, SSR,
/// inverse of XᵀX) or None when singular.
pub(crate) struct Ols {
    /// Coefficients in column order.
    pub coef: Vec<f64>,
    /// Residual sum of squares.
    pub ssr: f64,
    /// (XᵀX)⁻¹, row-major.
    pub xtx_inv: Vec<f64>,
    /// Number of observations.
    pub n: usize,
}

/// Accumulates XᵀX and Xᵀy for up to 3 regressors.
#[derive(Clone, Default)]
pub(crate) struct NormalEq {
    k: usize,
    xtx: [[f64; 3]; 3],
    xty: [f64; 3],
    yty: f64,
    n: usize,
}

impl NormalEq {
    /// For `k` regressors (1 to 3).
    pub fn new(k: usize) -> Self {
        NormalEq {
            k,
            ..Default::default()
        }
    }

    /// Add one observation.
    #[inline]
    pub fn add(&mut self, x: &[f64], y: f64) {
        for i in 0..self.k {
            for j in 0..self.k {
                self.xtx[i][j] += x[i] * x[j];
            }
            self.xty[i] += x[i] * y;
        }
        self.yty += y * y;
        self.n += 1;
    }

    /// Solve; None if singular.
    pub fn solve(&self) -> Option<Ols> {
        let k = self.k;
        let inv = invert(&self.xtx, k)?;
        let mut coef = vec![0.0; k];
        for i in 0..k {
            for j in 0..k {
                coef[i] += inv[i * 3 + j] * self.xty[j];
            }
        }
        // SSR = yᵀy − βᵀXᵀy (exact for the least-squares β).
        let fit: f64 = (0..k).map(|i| coef[i] * self.xty[i]).sum();
        let ssr = (self.yty - fit).max(0.0);
        let xtx_inv = (0..k)
            .flat_map(|i| (0..k).map(move |j| (i, j)))
            .map(|(i, j)| inv[i * 3 + j])
            .collect();
        Some(Ols {
            coef,
            ssr,
            xtx_inv,
            n: self.n,
        })
    }
}

fn invert(a: &[[f64; 3]; 3], k: usize) -> Option<[f64; 9]> {
    // Gauss–Jordan with partial pivoting on a k×k block.
    let mut m = [[0.0f64; 6]; 3];
    for i in 0..k {
        for j in 0..k {
            m[i][j] = a[i][j];
        }
        m[i][3 + i] = 1.0;
    }
    let scale = (0..k)
        .map(|i| a[i][i].abs())
        .fold(0.0, f64::max)
        .max(1e-300);
    for c in 0..k {
        let p = (c..k).max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))?;
        if m[p][c].abs() <= 1e-13 * scale {
            return None;
        }
        m.swap(c, p);
        let d = m[c][c];
        for v in m[c].iter_mut() {
            *v /= d;
        }
        for r in 0..k {
            if r != c {
                let f = m[r][c];
                let pivot = m[c];
                for (v, p) in m[r].iter_mut().zip(pivot) {
                    *v -= f * p;
                }
            }
        }
    }
    let mut out = [0.0; 9];
    for i in 0..k {
        for j in 0..k {
            out[i * 3 + j] = m[i][3 + j];
        }
    }
    Some(out)
}

/// A straight-line fit y = a + b x with R² and the standard error of b.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineFit {
    /// Intercept.
    pub intercept: f64,
    /// Slope.
    pub slope: f64,
    /// Standard error of the slope.
    pub slope_std_error: f64,
    /// Coefficient of determination.
    pub r_squared: f64,
    /// Observations used.
    pub n: usize,
}

/// Least-squares line through the finite (x, y) pairs.
pub fn fit_line(x: &[f64], y: &[f64]) -> Option<LineFit> {
    let mut ne = NormalEq::new(2);
    let (mut sy, mut syy) = (0.0, 0.0);
    for (&a, &b) in x.iter().zip(y) {
        if a.is_finite() && b.is_finite() {
            ne.add(&[1.0, a], b);
            sy += b;
            syy += b * b;
        }
    }
    let o = ne.solve()?;
    let n = o.n as f64;
    let sst = syy - sy * sy / n;
    let dof = (n - 2.0).max(1.0);
    Some(LineFit {
        intercept: o.coef[0],
        slope: o.coef[1],
        slope_std_error: (o.ssr / dof * o.xtx_inv[3]).max(0.0).sqrt(),
        r_squared: if sst > 0.0 { 1.0 - o.ssr / sst } else { 0.0 },
        n: o.n,
    })
}

/// Response y of the lag model to a force sampled at (t, F), linear between samples,
/// starting at equilibrium with the first sample. Exact for piecewise-linear force.
pub fn sls_response(
    t: &[f64],
    force: &[f64],
    tau_s: f64,
    instant_fraction: f64,
    out: &mut Vec<f64>,
) {
    out.clear();
    out.reserve(t.len());
    if t.is_empty() {
        return;
    }
    let r = instant_fraction;
    let mut z = force[0];
    out.push(force[0]);
    let mut last_h = f64::NAN;
    let (mut a, mut c) = (0.0, 0.0);
    for k in 1..t.len() {
        let h = t[k] - t[k - 1];
        let (f0, f1) = (force[k - 1], force[k]);
        if h > 0.0 {
            if h != last_h {
                a = (-h / tau_s).exp();
                c = tau_s / h;
                last_h = h;
            }
            let s = (f1 - f0) * c; // slope·τ
            z = f1 - s + (z - f0 + s) * a;
        }
        out.push(r * f1 + (1.0 - r) * z);
    }
}

/// Linear interpolation of (t, v) at `x`, clamped to the ends. `hint` carries the
/// index found last time so that increasing queries cost O(1).
#[inline]
pub fn interp(t: &[f64], v: &[f64], x: f64, hint: &mut usize) -> f64 {
    let n = t.len();
    if x <= t[0] {
        return v[0];
    }
    if x >= t[n - 1] {
        return v[n - 1];
    }
    let mut i = (*hint).min(n - 2);
    if t[i] > x {
        i = t.partition_point(|&a| a <= x).saturating_sub(1);
    } else {
        while t[i + 1] < x {
            i += 1;
            if i + 1 >= n {
                break;
            }
        }
    }
    *hint = i;
    let (t0, t1) = (t[i], t[i + 1]);
    if t1 <= t0 {
        return v[i];
    }
    v[i] + (v[i + 1] - v[i]) * (x - t0) / (t1 - t0)
}

/// The lag-model fit problem: shift samples (time on the wavelength clock, pm) and the
/// force log (time on the force clock, N). Parameters: [offset s, ln τ, logit r],
/// with offset = force clock − wavelength clock.
pub(crate) struct LagModelCost<'a> {
    /// Shift sample times, wavelength clock, s.
    pub shift_t: &'a [f64],
    /// Shift samples, pm (finite).
    pub shift_pm: &'a [f64],
    /// Force times, force clock, s.
    pub force_t: &'a [f64],
    /// Force, N.
    pub force_n: &'a [f64],
    /// Fixed offset (for per-grating fits with the clock already aligned).
    pub fixed_offset_s: Option<f64>,
    /// Bounds of a free offset, s (None: unbounded). With the clocks aligned, a free
    /// offset within bounds is the grating's transport delay (delay = −offset).
    pub offset_range_s: Option<(f64, f64)>,
    /// Mid time of the shifts (drift regressor origin).
    pub t_mid: f64,
    /// Stretches of the force clock whose force cannot be trusted (a saturated channel,
    /// a gap in the force log), s, sorted and disjoint: a shift sample whose time on
    /// the force clock (t + offset) falls inside one is left out of the fit.
    pub excluded_s: &'a [(f64, f64)],
}

/// Result of the lag-model fit at one parameter set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LagModelFit {
    /// Force clock − wavelength clock, s.
    pub offset_s: f64,
    /// τ, s.
    pub tau_s: f64,
    /// r, fraction of the response that follows the force at once.
    pub instant_fraction: f64,
    /// K, pm/N.
    pub k_pm_per_n: f64,
    /// Standard error of K (white-noise assumption), pm/N.
    pub k_std_error_pm_per_n: f64,
    /// Baseline, pm.
    pub baseline_pm: f64,
    /// Drift, pm/s.
    pub drift_pm_per_s: f64,
    /// R² of the lag model.
    pub r_squared: f64,
    /// Residual RMS, pm.
    pub rms_pm: f64,
}

/// Bounds of the searched time constant, s.
pub(crate) const TAU_MIN_S: f64 = 1e-4;
/// Upper bound of τ, s.
pub(crate) const TAU_MAX_S: f64 = 1e4;

impl LagModelCost<'_> {
    fn unpack(&self, p: &[f64]) -> (f64, f64, f64) {
        let (off, rest) = match self.fixed_offset_s {
            Some(o) => (o, p),
            None => {
                let o = match self.offset_range_s {
                    Some((lo, hi)) => p[0].clamp(lo, hi),
                    None => p[0],
                };
                (o, &p[1..])
            }
        };
        let tau = rest[0].clamp(TAU_MIN_S.ln(), TAU_MAX_S.ln()).exp();
        let r = 1.0 / (1.0 + (-rest[1].clamp(-30.0, 30.0)).exp());
        (off, tau, r)
    }

    /// Evaluate the variable-projection fit at (offset, τ, r).
    pub fn evaluate(&self, offset_s: f64, tau_s: f64, r: f64) -> Option<LagModelFit> {
        let mut y = Vec::new();
        sls_response(self.force_t, self.force_n, tau_s, r, &mut y);
        let mut ne = NormalEq::new(3);
        let mut hint = 0;
        let (mut sy, mut syy) = (0.0, 0.0);
        let (f0, f1) = (self.force_t[0], self.force_t[self.force_t.len() - 1]);
        let mut ex = 0usize;
        for (&t, &s) in self.shift_t.iter().zip(self.shift_pm) {
            // Gaps and samples the force log does not cover carry no information.
            // (The fit subsets keep the force span wider than the shifts' so that
            // the sample set does not change with the offset.)
            if !s.is_finite()
                || (self.fixed_offset_s.is_some() && (t + offset_s < f0 || t + offset_s > f1))
                || self.is_excluded(t + offset_s, &mut ex)
            {
                continue;
            }
            let yv = interp(self.force_t, &y, t + offset_s, &mut hint);
            ne.add(&[yv, 1.0, t - self.t_mid], s);
            sy += s;
            syy += s * s;
        }
        let o = ne.solve()?;
        let n = o.n as f64;
        let sst = syy - sy * sy / n;
        Some(LagModelFit {
            offset_s,
            tau_s,
            instant_fraction: r,
            k_pm_per_n: o.coef[0],
            k_std_error_pm_per_n: (o.ssr / (n - 3.0).max(1.0) * o.xtx_inv[0]).max(0.0).sqrt(),
            baseline_pm: o.coef[1],
            drift_pm_per_s: o.coef[2],
            r_squared: if sst > 0.0 { 1.0 - o.ssr / sst } else { 0.0 },
            rms_pm: (o.ssr / n).sqrt(),
        })
    }

    /// The fit at a packed parameter vector.
    pub fn fit_at(&self, p: &[f64]) -> Option<LagModelFit> {
        let (o, t, r) = self.unpack(p);
        self.evaluate(o, t, r)
    }

    /// Whether force-clock time `x` lies in an excluded stretch; `cursor` walks the
    /// stretches along increasing `x` (O(1) per sample).
    #[inline]
    fn is_excluded(&self, x: f64, cursor: &mut usize) -> bool {
        let ex = self.excluded_s;
        while *cursor < ex.len() && ex[*cursor].1 < x {
            *cursor += 1;
        }
        *cursor < ex.len() && ex[*cursor].0 <= x
    }

    /// The lag model's response y (N: the force as the part follows it, delay and lag
    /// included) at every shift sample with the clocks as in `fit`, at the time
    /// constant `tau_s` (the fit's, or a bound on it), at rows with a peak and without;
    /// NaN outside the force log and in excluded stretches. The shift
    /// against y is the lag-corrected signal: a part that follows its lag model draws
    /// a line there.
    pub fn responses(&self, fit: &LagModelFit, tau_s: f64) -> Vec<f64> {
        let mut y = Vec::new();
        sls_response(
            self.force_t,
            self.force_n,
            tau_s,
            fit.instant_fraction,
            &mut y,
        );
        let (f0, f1) = (self.force_t[0], self.force_t[self.force_t.len() - 1]);
        let (mut hint, mut ex) = (0, 0);
        self.shift_t
            .iter()
            .map(|&t| {
                let x = t + fit.offset_s;
                if x < f0 || x > f1 || self.is_excluded(x, &mut ex) {
                    return f64::NAN;
                }
                interp(self.force_t, &y, x, &mut hint)
            })
            .collect()
    }

    /// The residual of `fit` at every shift sample (shift − K·y − baseline − drift),
    /// pm; NaN where the fit did not use the sample (a gap, outside the force log, an
    /// excluded stretch).
    pub fn residuals(&self, fit: &LagModelFit) -> Vec<f64> {
        let mut y = Vec::new();
        sls_response(
            self.force_t,
            self.force_n,
            fit.tau_s,
            fit.instant_fraction,
            &mut y,
        );
        let (f0, f1) = (self.force_t[0], self.force_t[self.force_t.len() - 1]);
        let (mut hint, mut ex) = (0, 0);
        self.shift_t
            .iter()
            .zip(self.shift_pm)
            .map(|(&t, &s)| {
                let x = t + fit.offset_s;
                if !s.is_finite()
                    || (self.fixed_offset_s.is_some() && (x < f0 || x > f1))
                    || self.is_excluded(x, &mut ex)
                {
                    return f64::NAN;
                }
                let yv = interp(self.force_t, &y, x, &mut hint);
                s - fit.k_pm_per_n * yv - fit.baseline_pm - fit.drift_pm_per_s * (t - self.t_mid)
            })
            .collect()
    }
}

/// Share of the variance left in `shift` after a baseline and a linear drift (the
/// regressors 1 and t − `t_mid`, fitted over the samples where `residual` is finite)
/// that the lag model's response explains: 1 − SSR(lag model) / SSR(baseline and
/// drift alone). Unlike the lag model's own R², it gives no credit for the drift, so an
/// unloaded log with a drifting baseline scores near 0.
pub(crate) fn response_r_squared(t: &[f64], shift: &[f64], residual: &[f64], t_mid: f64) -> f64 {
    let mut ne = NormalEq::new(2);
    let mut ssr_full = 0.0;
    for ((&ti, &s), &e) in t.iter().zip(shift).zip(residual) {
        if e.is_finite() && s.is_finite() {
            ne.add(&[1.0, ti - t_mid], s);
            ssr_full += e * e;
        }
    }
    match ne.solve() {
        Some(o) if o.ssr > 0.0 => 1.0 - ssr_full / o.ssr,
        _ => f64::NAN,
    }
}

impl CostFunction for LagModelCost<'_> {
    type Param = Vec<f64>;
    type Output = f64;

    fn cost(&self, p: &Self::Param) -> Result<f64, argmin::core::Error> {
        Ok(match self.fit_at(p) {
            Some(f) if f.rms_pm.is_finite() => f.rms_pm,
            _ => f64::MAX,
        })
    }
}

/// Minimise a cost with Nelder–Mead from `start` with initial steps `step`; returns
/// the best parameters and cost (the start and `f64::MAX` when the solver fails).
pub fn nelder_mead<C>(cost: C, start: &[f64], step: &[f64], max_iters: u64) -> (Vec<f64>, f64)
where
    C: CostFunction<Param = Vec<f64>, Output = f64>,
{
    let unbounded = vec![f64::INFINITY; start.len()];
    let simplex = nelder_mead::simplex_inside(start, step, &unbounded);
    // The cost is an RMS in pm: a spread below 1e-7 pm across the simplex is converged.
    match nelder_mead::minimise::<_, nelder_mead::Unobserved>(cost, simplex, 1e-7, max_iters, None)
    {
        Ok(m) => (m.best_x, m.best_cost),
        Err(_) => (start.to_vec(), f64::MAX),
    }
}

/// Peak of samples (t, v) near index `i_max` (the largest value): vertex of a
/// least-squares parabola through the contiguous samples above `threshold` around it
/// (at least the three nearest). Returns (time, value).
pub(crate) fn peak_vertex(t: &[f64], v: &[f64], i_max: usize, threshold: f64) -> (f64, f64) {
    let n = t.len();
    let (mut a, mut b) = (i_max, i_max);
    while a > 0 && v[a - 1].is_finite() && v[a - 1] >= threshold && i_max - a < 5000 {
        a -= 1;
    }
    while b + 1 < n && v[b + 1].is_finite() && v[b + 1] >= threshold && b - i_max < 5000 {
        b += 1;
    }
    if b - a < 2 {
        a = i_max.saturating_sub(1);
        b = (i_max + 1).min(n - 1);
    }
    if b - a < 2 {
        return (t[i_max], v[i_max]);
    }
    let t0 = t[i_max];
    let mut ne = NormalEq::new(3);
    for i in a..=b {
        if v[i].is_finite() {
            let x = t[i] - t0;
            ne.add(&[1.0, x, x * x], v[i]);
        }
    }
    match ne.solve() {
        Some(o) if o.coef[2] < 0.0 => {
            let x = -o.coef[1] / (2.0 * o.coef[2]);
            if x >= t[a] - t0 && x <= t[b] - t0 {
                (t0 + x, o.coef[0] + o.coef[1] * x + o.coef[2] * x * x)
            } else {
                (t0, v[i_max])
            }
        }
        _ => (t0, v[i_max]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sls_step_response_matches_the_closed_form() {
        // A fast ramp to 1 N, then hold: y(t) = 1 − (1 − r) e^{−t/τ} after the ramp.
        let (tau, r) = (0.5, 0.3);
        let t: Vec<f64> = (0..=4000).map(|i| i as f64 * 1e-3).collect();
        let f: Vec<f64> = t
            .iter()
            .map(|&x| if x < 1e-3 { x / 1e-3 } else { 1.0 })
            .collect();
        let mut y = Vec::new();
        sls_response(&t, &f, tau, r, &mut y);
        for &i in &[100usize, 500, 2000, 4000] {
            let x = t[i] - 1e-3;
            let exact = 1.0 - (1.0 - r) * (-x / tau).exp();
            assert!(
                (y[i] - exact).abs() < 2e-3,
                "t={} y={} exact={exact}",
                t[i],
                y[i]
            );
        }
    }

    #[test]
    fn line_fit_recovers_an_exact_line() {
        let x: Vec<f64> = (0..50).map(|i| i as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| 3.0 - 0.25 * v).collect();
        let f = fit_line(&x, &y).unwrap();
        assert!((f.slope + 0.25).abs() < 1e-12 && (f.intercept - 3.0).abs() < 1e-10);
        assert!((f.r_squared - 1.0).abs() < 1e-12);
    }

    #[test]
    fn parabola_vertex_finds_an_off_grid_peak() {
        let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.1).collect();
        let v: Vec<f64> = t.iter().map(|x| 10.0 - (x - 4.537f64).powi(2)).collect();
        let imax = (0..100).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap();
        let (tp, vp) = peak_vertex(&t, &v, imax, 9.0);
        assert!((tp - 4.537).abs() < 1e-9 && (vp - 10.0).abs() < 1e-9);
    }

    #[test]
    fn lag_model_fit_recovers_offset_tau_and_k() {
        let (k, tau, r, off) = (12.5, 0.4, 0.3, 1.3);
        let ft: Vec<f64> = (0..3000).map(|i| i as f64 * 0.01).collect();
        let ff: Vec<f64> = ft
            .iter()
            .map(|&t| {
                let ph = (t % 6.0) / 3.0;
                if ph < 1.0 {
                    20.0 * (1.0 - (std::f64::consts::TAU * ph).cos()) / 2.0
                } else {
                    0.0
                }
            })
            .collect();
        let mut y = Vec::new();
        sls_response(&ft, &ff, tau, r, &mut y);
        let st: Vec<f64> = (0..560).map(|i| 0.5 + i as f64 * 0.05).collect();
        let mut h = 0;
        let sp: Vec<f64> = st
            .iter()
            .map(|&t| k * interp(&ft, &y, t + off, &mut h) + 3.0)
            .collect();
        let cost = LagModelCost {
            shift_t: &st,
            shift_pm: &sp,
            force_t: &ft,
            force_n: &ff,
            fixed_offset_s: None,
            offset_range_s: None,
            t_mid: 14.0,
            excluded_s: &[],
        };
        let (p, _) = nelder_mead(cost, &[1.1, (0.2f64).ln(), 0.0], &[0.1, 0.5, 1.0], 600);
        let cost = LagModelCost {
            shift_t: &st,
            shift_pm: &sp,
            force_t: &ft,
            force_n: &ff,
            fixed_offset_s: None,
            offset_range_s: None,
            t_mid: 14.0,
            excluded_s: &[],
        };
        let fit = cost.fit_at(&p).unwrap();
        assert!((fit.offset_s - off).abs() < 0.01, "{fit:?}");
        assert!((fit.tau_s - tau).abs() < 0.01, "{fit:?}");
        assert!((fit.k_pm_per_n - k).abs() / k < 1e-3, "{fit:?}");
    }
}
