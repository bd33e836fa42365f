//! `omp`: non-negative orthogonal matching pursuit; a cell is added only while it
//! lowers ‖Âz − y‖² by more than λ.

use super::*;

/// The registry entry of `omp`.
pub(super) const ENTRY: MethodEntry = MethodEntry {
    name: "omp",
    default_penalty: 0.25,
    has_penalty: true,
    penalty_grid: doubling_grid,
    build: |common, s| {
        Ok(Box::new(Omp {
            common,
            lambda: s.penalty,
        }))
    },
};

pub(super) struct Omp {
    pub(super) common: Common,
    pub(super) lambda: f64,
}

impl Reconstructor for Omp {
    fn method(&self) -> Method {
        Method::Omp
    }

    fn reconstruct(&self, y: &[f64]) -> Reconstruction {
        let Some(aty) = self.common.aty(y) else {
            return self.common.unusable();
        };
        let n = self.common.n();
        let kmax = self.common.problem.n_gratings().min(n);
        let yty: f64 = y.iter().map(|v| v * v).sum();
        let g = &self.common.gram;
        let mut support: Vec<usize> = Vec::with_capacity(kmax);
        let mut z = DVector::<f64>::zeros(n);
        let mut rr = yty;
        let mut converged = true;
        while support.len() < kmax {
            // Correlation of each column with the residual: Âᵀ(y − Âz) = b − Gz.
            let corr = &aty - g * &z;
            let Some(j) = (0..n)
                .filter(|q| !support.contains(q))
                .max_by(|&a, &b| corr[a].total_cmp(&corr[b]))
            else {
                break;
            };
            if corr[j] <= 0.0 {
                break; // no cell can explain the residual with a positive load
            }
            let mut trial = support.clone();
            trial.push(j);
            let (zt, ok) = bounded_ls_on(&self.common, &aty, &trial);
            let rr_t = misfit(g, &aty, yty, &zt);
            if rr - rr_t < self.lambda {
                break;
            }
            converged &= ok;
            support = trial;
            z = zt;
            rr = rr_t;
        }
        self.common
            .finish(z.as_slice(), y, converged, support.len() as u64)
    }
}
