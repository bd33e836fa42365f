//! `lasso`: ½‖Âz − y‖² + λ‖z‖₁ over the box, by FISTA with adaptive restart.

use super::*;

/// The registry entry of `lasso`.
pub(super) const ENTRY: MethodEntry = MethodEntry {
    name: "lasso",
    default_penalty: 0.16,
    has_penalty: true,
    penalty_grid: || (0..13).map(|k| 0.01 * 2f64.powi(k)).collect(),
    build: |common, s| {
        Ok(Box::new(Lasso {
            common,
            lambda: s.penalty,
            iterations: s.fista_iterations,
        }))
    },
};

pub(super) struct Lasso {
    pub(super) common: Common,
    pub(super) lambda: f64,
    pub(super) iterations: u64,
}

impl Reconstructor for Lasso {
    fn method(&self) -> Method {
        Method::Lasso
    }

    fn reconstruct(&self, y: &[f64]) -> Reconstruction {
        let Some(aty) = self.common.aty(y) else {
            return self.common.unusable();
        };
        let (z, it, ok) = fista_box(
            &self.common.gram,
            &aty,
            &self.common.problem.upper,
            self.lambda,
            self.common.lipschitz,
            DVector::zeros(self.common.n()),
            self.iterations,
        );
        self.common.finish(z.as_slice(), y, ok, it)
    }
}
