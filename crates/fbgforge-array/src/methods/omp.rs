//! `omp`: non-negative orthogonal matching pursuit; a cell is added only while it
//! lowers ‖Âz − y‖² by more than λ.

use super::*;

/// The registry entry of `omp`.
pub(super) const ENTRY: MethodEntry = MethodEntry {
    name: "omp",
    penalty_grid: doubling_grid,
    defaults: |_| MethodSettings::Omp(OmpSettings::default()),
};

/// Settings of `omp`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OmpSettings {
    /// λ, pm²: a cell is added only while it lowers ‖Âz − y‖² by more than this.
    pub penalty: f64,
}

impl Default for OmpSettings {
    /// The tuned default, 0.25.
    fn default() -> Self {
        OmpSettings { penalty: 0.25 }
    }
}

impl Knobs for OmpSettings {
    fn method(&self) -> Method {
        Method::Omp
    }
    fn build(&self, common: Common) -> Result<Box<dyn Reconstructor>, ArrayError> {
        Ok(Box::new(Omp {
            common,
            lambda: self.penalty,
        }))
    }
    fn penalty_mut(&mut self) -> Option<&mut f64> {
        Some(&mut self.penalty)
    }
}

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
