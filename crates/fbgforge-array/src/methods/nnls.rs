//! `nnls`: Lawson–Hanson non-negative least squares, then the upper bound enforced by
//! a bounded projected-gradient polish.

use super::*;

/// The registry entry of `nnls`.
pub(super) const ENTRY: MethodEntry = MethodEntry {
    name: "nnls",
    penalty_grid: || vec![0.0],
    defaults: |_| MethodSettings::Nnls(NnlsSettings::default()),
};

/// Settings of `nnls` (no penalty: no sparsity prior beyond x ≥ 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NnlsSettings {
    /// Iteration limit of the bounded projected-gradient polish that enforces the
    /// upper bound.
    pub polish_iterations: u64,
}

impl Default for NnlsSettings {
    fn default() -> Self {
        NnlsSettings {
            polish_iterations: 20_000,
        }
    }
}

impl Knobs for NnlsSettings {
    fn method(&self) -> Method {
        Method::Nnls
    }
    fn build(&self, common: Common) -> Result<Box<dyn Reconstructor>, ArrayError> {
        Ok(Box::new(Nnls {
            common,
            iterations: self.polish_iterations,
        }))
    }
}

pub(super) struct Nnls {
    pub(super) common: Common,
    pub(super) iterations: u64,
}

impl Reconstructor for Nnls {
    fn method(&self) -> Method {
        Method::Nnls
    }

    /// ‖Âz − y‖² over the box.
    fn objective(&self, y: &[f64], loads_g: &[f64]) -> Option<f64> {
        self.common.misfit_of(y, loads_g).map(|(m, _)| m)
    }

    fn reconstruct(&self, y: &[f64]) -> Reconstruction {
        let Some(aty) = self.common.aty(y) else {
            return self.common.unusable();
        };
        let n = self.common.n();
        let g = &self.common.gram;
        let tol = 1e-12 * aty.amax().max(1e-300);
        let mut z = DVector::<f64>::zeros(n);
        let mut passive = vec![false; n];
        let mut outer = 0u64;
        let mut converged = false;
        // Lawson–Hanson active-set method.
        while outer < 3 * n as u64 + 10 {
            outer += 1;
            let w = &aty - g * &z;
            let cand = (0..n)
                .filter(|&j| !passive[j] && w[j] > tol)
                .max_by(|&a, &b| w[a].total_cmp(&w[b]));
            let Some(j) = cand else {
                converged = true;
                break;
            };
            passive[j] = true;
            let mut inner = 0;
            loop {
                inner += 1;
                let cols: Vec<usize> = (0..n).filter(|&q| passive[q]).collect();
                let gs = DMatrix::from_fn(cols.len(), cols.len(), |a, b| g[(cols[a], cols[b])]);
                let bs = DVector::from_fn(cols.len(), |a, _| aty[cols[a]]);
                let Some(s) = gs.cholesky().map(|c| c.solve(&bs)) else {
                    // Dependent columns: drop the newest one and stop growing.
                    passive[j] = false;
                    break;
                };
                if s.iter().all(|&v| v > 0.0) || inner > n + 5 {
                    z.fill(0.0);
                    for (a, &q) in cols.iter().enumerate() {
                        z[q] = s[a].max(0.0);
                    }
                    break;
                }
                let mut alpha = 1.0f64;
                for (a, &q) in cols.iter().enumerate() {
                    if s[a] <= 0.0 {
                        let d = z[q] - s[a];
                        if d > 0.0 {
                            alpha = alpha.min(z[q] / d);
                        }
                    }
                }
                for (a, &q) in cols.iter().enumerate() {
                    z[q] += alpha * (s[a] - z[q]);
                    if z[q] <= tol {
                        z[q] = 0.0;
                        passive[q] = false;
                    }
                }
            }
        }
        let upper = &self.common.problem.upper;
        let mut iterations = outer;
        if z.iter().zip(upper.iter()).any(|(v, u)| v > u) {
            // The upper bound is active: polish by projected gradient from the clamp.
            let (zb, it, ok) = fista_box(
                g,
                &aty,
                upper,
                0.0,
                self.common.lipschitz,
                z.clone(),
                self.iterations,
            );
            z = zb;
            iterations += it;
            converged &= ok;
        }
        let mut r = self.common.finish(z.as_slice(), y, converged, iterations);
        // A convex problem: meeting its optimality test proves the optimum.
        r.certified = converged;
        r
    }
}
