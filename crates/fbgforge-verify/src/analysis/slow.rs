//! The slow rival of a response: a variation slower than the loading (temperature the
//! reference does not remove, drift, creep of the interrogator) as a piecewise-linear
//! curve with knots `spacing` apart (hat functions: they hold a constant and a linear
//! drift, and follow any curve whose bends are that far apart), and the least squares
//! of a shift on it, with or without the lag-corrected force as one more column.
//!
//! Each row touches two hats only, so the normal equations are accumulated in O(1) per
//! row and solved once (a few dozen columns for an hour-long log).

use nalgebra::{DMatrix, DVector};

/// Hat functions on knots `spacing` apart from `t0` (`m` of them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SlowBasis {
    t0: f64,
    spacing: f64,
    m: usize,
}

impl SlowBasis {
    /// Hats over `[a, b]` with knots at most `spacing` apart (at least two: a constant
    /// and a drift).
    pub(crate) fn new((a, b): (f64, f64), spacing: f64) -> Self {
        let span = (b - a).max(1e-9);
        let intervals = (span / spacing.max(1e-9)).ceil().max(1.0) as usize;
        SlowBasis {
            t0: a,
            spacing: span / intervals as f64,
            m: intervals + 1,
        }
    }

    /// Number of hat functions.
    pub(crate) fn len(&self) -> usize {
        self.m
    }

    /// Knot spacing, s.
    pub(crate) fn spacing_s(&self) -> f64 {
        self.spacing
    }

    /// The two hats at `t`: the left one's index and the right one's weight.
    #[inline]
    fn at(&self, t: f64) -> (usize, f64) {
        let u = ((t - self.t0) / self.spacing).clamp(0.0, (self.m - 1) as f64);
        let j = (u.floor() as usize).min(self.m.saturating_sub(2));
        (j, u - j as f64)
    }

    /// The curve with hat coefficients `c` at `t`.
    pub(crate) fn value(&self, c: &[f64], t: f64) -> f64 {
        if self.m == 1 {
            return c[0];
        }
        let (j, w) = self.at(t);
        c[j] * (1.0 - w) + c[j + 1] * w
    }
}

/// A least-squares fit of y on [x (optional), hats].
#[derive(Debug, Clone)]
pub(crate) struct SlowFit {
    /// Coefficient of x (NaN without x).
    pub k: f64,
    /// Standard error of `k` for white residuals.
    pub k_std_error: f64,
    /// Hat coefficients.
    pub hats: Vec<f64>,
    /// Residual sum of squares.
    pub rss: f64,
}

/// Normal equations of y on [x?, hats], accumulated row by row.
pub(crate) struct SlowNormal {
    basis: SlowBasis,
    with_x: bool,
    xtx: DMatrix<f64>,
    xty: DVector<f64>,
    yty: f64,
    n: usize,
}

impl SlowNormal {
    /// Empty equations for `basis`, with the x column or without.
    pub(crate) fn new(basis: SlowBasis, with_x: bool) -> Self {
        let p = basis.len() + usize::from(with_x);
        SlowNormal {
            basis,
            with_x,
            xtx: DMatrix::zeros(p, p),
            xty: DVector::zeros(p),
            yty: 0.0,
            n: 0,
        }
    }

    /// Add the row (t, x, y) (x ignored without the x column).
    #[inline]
    pub(crate) fn add(&mut self, t: f64, x: f64, y: f64) {
        let off = usize::from(self.with_x);
        let (j, w) = self.basis.at(t);
        let cols: [(usize, f64); 2] = if self.basis.len() == 1 {
            [(off, 1.0), (off, 0.0)]
        } else {
            [(off + j, 1.0 - w), (off + j + 1, w)]
        };
        for &(a, va) in &cols {
            for &(b, vb) in &cols {
                self.xtx[(a, b)] += va * vb;
            }
            self.xty[a] += va * y;
        }
        if self.with_x {
            self.xtx[(0, 0)] += x * x;
            self.xty[0] += x * y;
            for &(a, va) in &cols {
                self.xtx[(0, a)] += x * va;
                self.xtx[(a, 0)] += x * va;
            }
        }
        self.yty += y * y;
        self.n += 1;
    }

    /// Solve (hats no row reaches are held at zero); None when the x column is
    /// degenerate or too few rows were added.
    pub(crate) fn solve(&self) -> Option<SlowFit> {
        let p = self.xtx.nrows();
        if self.n <= p {
            return None;
        }
        // A small ridge keeps hats without rows (a gap) at zero; it is far below the
        // diagonal of any hat that has rows.
        let scale = (0..p)
            .map(|i| self.xtx[(i, i)])
            .fold(0.0, f64::max)
            .max(1e-300);
        let mut a = self.xtx.clone();
        for i in 0..p {
            a[(i, i)] += 1e-12 * scale;
        }
        if self.with_x && self.xtx[(0, 0)] <= 1e-12 * scale {
            return None;
        }
        let chol = a.cholesky()?;
        let coef = chol.solve(&self.xty);
        let fit_ss: f64 = coef.dot(&self.xty);
        let rss = (self.yty - fit_ss).max(0.0);
        let (k, k_std_error) = if self.with_x {
            let mut e0 = DVector::zeros(p);
            e0[0] = 1.0;
            let inv00 = chol.solve(&e0)[0];
            let dof = (self.n - p).max(1) as f64;
            (coef[0], (rss / dof * inv00).max(0.0).sqrt())
        } else {
            (f64::NAN, f64::NAN)
        };
        let off = usize::from(self.with_x);
        Some(SlowFit {
            k,
            k_std_error,
            hats: coef.iter().skip(off).copied().collect(),
            rss,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hats_hold_a_line_and_the_x_column_is_recovered_beside_a_slow_curve() {
        // y = 3 x + a slow parabola: the hats follow the parabola within its bending
        // between knots, and the x column's coefficient comes back.
        let basis = SlowBasis::new((0.0, 600.0), 60.0);
        assert_eq!(basis.len(), 11);
        let mut with = SlowNormal::new(basis, true);
        let mut without = SlowNormal::new(basis, false);
        for i in 0..6000 {
            let t = i as f64 * 0.1;
            let x = if (t % 20.0) < 4.0 { 5.0 } else { 0.0 };
            let slow = 2.0 + 0.01 * t + 1e-5 * (t - 300.0).powi(2);
            with.add(t, x, 3.0 * x + slow);
            without.add(t, x, 2.0 + 0.01 * t);
        }
        let f = with.solve().unwrap();
        assert!((f.k - 3.0).abs() < 2e-3, "{}", f.k);
        // A straight line lies in the hats' span exactly: the residual is rounding only
        // (Σy² is about 6e4 here; rss comes as Σy² − fit², so 1e-12 of it is rounding).
        let g = without.solve().unwrap();
        assert!(g.rss < 1e-6, "{}", g.rss);
        assert!((basis.value(&g.hats, 123.0) - 3.23).abs() < 1e-6);
    }
}
