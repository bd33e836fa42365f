//! Levenberg–Marquardt least squares for the small peak models (a handful of
//! parameters, tens of samples): normal equations accumulated without forming the
//! Jacobian, Marquardt's diagonal scaling, covariance σ̂²·(JᵀJ)⁻¹ at the solution with
//! σ̂² = RSS/(n − p).

use nalgebra::{DMatrix, DVector};

/// A model y = f(x; p) with its gradient in p.
pub(crate) trait Model {
    /// Number of parameters.
    fn n_params(&self) -> usize;
    /// f(x; p); writes ∂f/∂p into `grad`.
    fn eval(&self, x: f64, p: &[f64], grad: &mut [f64]) -> f64;
    /// False for parameters outside the model's domain (a width ≤ 0, …).
    fn valid(&self, _p: &[f64]) -> bool {
        true
    }
}

/// A least-squares solution.
#[derive(Debug, Clone)]
pub(crate) struct Fit {
    pub params: Vec<f64>,
    /// (JᵀJ)⁻¹ at the solution (the Fisher information is JᵀJ/σ²).
    pub jtj_inverse: DMatrix<f64>,
    /// σ̂²·(JᵀJ)⁻¹.
    pub covariance: DMatrix<f64>,
    /// Residual sum of squares.
    pub rss: f64,
    /// n − p.
    pub dof: usize,
}

impl Fit {
    pub fn std_error(&self, k: usize) -> f64 {
        self.covariance[(k, k)].max(0.0).sqrt()
    }
}

fn normal_equations(
    model: &impl Model,
    x: &[f64],
    y: &[f64],
    p: &[f64],
    grad: &mut [f64],
) -> (DMatrix<f64>, DVector<f64>, f64) {
    let m = p.len();
    let mut jtj = DMatrix::<f64>::zeros(m, m);
    let mut jtr = DVector::<f64>::zeros(m);
    let mut rss = 0.0;
    for (&xi, &yi) in x.iter().zip(y) {
        let r = yi - model.eval(xi, p, grad);
        rss += r * r;
        for a in 0..m {
            jtr[a] += grad[a] * r;
            for b in 0..=a {
                jtj[(a, b)] += grad[a] * grad[b];
            }
        }
    }
    for a in 0..m {
        for b in 0..a {
            jtj[(b, a)] = jtj[(a, b)];
        }
    }
    (jtj, jtr, rss)
}

fn residual_sum(model: &impl Model, x: &[f64], y: &[f64], p: &[f64], grad: &mut [f64]) -> f64 {
    x.iter()
        .zip(y)
        .map(|(&xi, &yi)| (yi - model.eval(xi, p, grad)).powi(2))
        .sum()
}

/// Minimises Σ (yᵢ − f(xᵢ; p))² from `p0`; `None` if there are not more samples than
/// parameters, the start is invalid or JᵀJ is singular at the solution.
pub(crate) fn fit(model: &impl Model, x: &[f64], y: &[f64], p0: Vec<f64>) -> Option<Fit> {
    let m = model.n_params();
    let n = x.len();
    if n <= m || p0.len() != m || !model.valid(&p0) {
        return None;
    }
    let mut grad = vec![0.0; m];
    let mut p = p0;
    let (mut jtj, mut jtr, mut rss) = normal_equations(model, x, y, &p, &mut grad);
    let mut lambda = 1e-3;
    for _ in 0..300 {
        let max_diag = (0..m).map(|k| jtj[(k, k)]).fold(0.0, f64::max);
        let mut a = jtj.clone();
        for k in 0..m {
            a[(k, k)] += lambda * jtj[(k, k)].max(1e-12 * max_diag).max(f64::MIN_POSITIVE);
        }
        let Some(chol) = a.cholesky() else {
            lambda *= 10.0;
            if lambda > 1e14 {
                break;
            }
            continue;
        };
        let step = chol.solve(&jtr);
        let trial: Vec<f64> = p.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
        let trial_rss = if model.valid(&trial) {
            residual_sum(model, x, y, &trial, &mut grad)
        } else {
            f64::INFINITY
        };
        if trial_rss.is_finite() && trial_rss <= rss {
            let small_step = step
                .iter()
                .zip(&p)
                .all(|(d, q)| d.abs() <= 1e-10 * (q.abs() + 1e-12));
            let small_gain = rss - trial_rss <= 1e-13 * rss;
            p = trial;
            (jtj, jtr, rss) = normal_equations(model, x, y, &p, &mut grad);
            lambda = (lambda * 0.2).max(1e-12);
            if small_step || small_gain {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e14 {
                break;
            }
        }
    }
    let dof = n - m;
    let inverse = jtj.clone().cholesky()?.inverse();
    let sigma2 = rss / dof as f64;
    Some(Fit {
        params: p,
        covariance: &inverse * sigma2,
        jtj_inverse: inverse,
        rss,
        dof,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Line;
    impl Model for Line {
        fn n_params(&self) -> usize {
            2
        }
        fn eval(&self, x: f64, p: &[f64], g: &mut [f64]) -> f64 {
            g[0] = 1.0;
            g[1] = x;
            p[0] + p[1] * x
        }
    }

    #[test]
    fn straight_line_matches_the_closed_form() {
        // Ordinary least squares of a line: slope = Sxy/Sxx, its variance σ̂²/Sxx.
        let x: Vec<f64> = (0..10).map(f64::from).collect();
        let y: Vec<f64> = x
            .iter()
            .map(|&v| 2.0 + 0.5 * v + if (v as i32) % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        let f = fit(&Line, &x, &y, vec![0.0, 0.0]).unwrap();
        let (mx, my) = (x.iter().sum::<f64>() / 10.0, y.iter().sum::<f64>() / 10.0);
        let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
        let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
        let slope = sxy / sxx;
        assert!((f.params[1] - slope).abs() < 1e-9);
        let rss: f64 = x
            .iter()
            .zip(&y)
            .map(|(a, b)| (b - (my - slope * mx) - slope * a).powi(2))
            .sum();
        assert!((f.std_error(1) - (rss / 8.0 / sxx).sqrt()).abs() < 1e-9);
    }
}
