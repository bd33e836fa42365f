//! `de`: the paper's replica, ‖Âz − y‖² + σ Σ z_jᵖ with p = 0.01, by differential
//! evolution (DE/rand/1/bin, 150 individuals, ≤ 1500 generations).

use super::*;
use crate::solvers::differential_evolution::DifferentialEvolution;
use argmin::core::{CostFunction, Error, Executor, State, TerminationReason};
use std::sync::Arc;

/// The registry entry of `de`.
pub(super) const ENTRY: MethodEntry = MethodEntry {
    name: "de",
    default_penalty: 4.0,
    has_penalty: true,
    penalty_grid: doubling_grid,
    build: |common, s| {
        Ok(Box::new(De {
            gram: row_major(&common.gram),
            common,
            settings: *s,
        }))
    },
};

pub(super) struct De {
    pub(super) common: Common,
    pub(super) settings: MethodSettings,
    /// The common Gram matrix, row-major, computed once for the stream.
    gram: Arc<[f64]>,
}

/// A matrix's entries in row-major order.
fn row_major(g: &DMatrix<f64>) -> Arc<[f64]> {
    let n = g.ncols();
    (0..g.nrows() * n).map(|k| g[(k / n, k % n)]).collect()
}

/// FNV-1a over the bits of a frame, mixed into the seed so that equal frames give
/// equal answers whatever order or thread they are reconstructed in.
fn frame_seed(seed: u64, y: &[f64]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64 ^ seed;
    for v in y {
        for byte in v.to_bits().to_le_bytes() {
            h ^= byte as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

impl Reconstructor for De {
    fn method(&self) -> Method {
        Method::De
    }

    fn reconstruct(&self, y: &[f64]) -> Reconstruction {
        if self.common.problem.check_shifts(y).is_err() {
            return self.common.unusable();
        }
        let p = &self.common.problem;
        let cost = PenalisedCost::with_gram(
            self.gram.clone(),
            &p.working,
            &DVector::from_column_slice(y),
            self.settings.penalty,
            0.01,
        );
        let lower = vec![0.0; p.n_cells()];
        let upper: Vec<f64> = p.upper.iter().copied().collect();
        let solver =
            match DifferentialEvolution::new(lower, upper, frame_seed(self.settings.seed, y)) {
                Ok(s) => s.with_population(self.settings.de_population),
                Err(_) => return self.common.unusable(),
            };
        let generations = self.settings.de_generations;
        match Executor::new(cost, solver)
            .configure(|s| s.max_iters(generations))
            .run()
        {
            Ok(res) => {
                let st = res.state();
                let converged = matches!(
                    st.get_termination_reason(),
                    Some(TerminationReason::SolverConverged)
                );
                let iterations = st.get_iter();
                match st.get_best_param() {
                    Some(z) => self.common.finish(z, y, converged, iterations),
                    None => self.common.unusable(),
                }
            }
            Err(_) => self.common.unusable(),
        }
    }
}

/// The paper's objective in the working unknowns z (see [`crate::array::problem`]):
/// ‖Âz − y‖² + σ Σ_j z_jᵖ, evaluated as zᵀGz − 2bᵀz + yᵀy with G = ÂᵀÂ, b = Âᵀy.
#[derive(Debug, Clone)]
pub struct PenalisedCost {
    /// Gram matrix ÂᵀÂ, row-major n × n, shared by every frame of a stream.
    gram: Arc<[f64]>,
    /// Âᵀy.
    aty: Vec<f64>,
    /// yᵀy, pm².
    yty: f64,
    /// Number of unknowns.
    n: usize,
    /// Penalty weight σ, pm² per unit of Σ zᵖ.
    pub sigma: f64,
    /// Exponent p of the penalty (0.01 in the paper: a smooth stand-in for ℓ0).
    pub p: f64,
}

impl PenalisedCost {
    /// Cost for matrix `a`, frame `y`, weight `sigma` and exponent `p`.
    pub fn new(a: &DMatrix<f64>, y: &DVector<f64>, sigma: f64, p: f64) -> Self {
        Self::with_gram(row_major(&(a.transpose() * a)), a, y, sigma, p)
    }

    /// The same cost with the Gram matrix ÂᵀÂ already computed (row-major), as the
    /// reconstructor holds it for a whole stream.
    pub fn with_gram(
        gram: Arc<[f64]>,
        a: &DMatrix<f64>,
        y: &DVector<f64>,
        sigma: f64,
        p: f64,
    ) -> Self {
        PenalisedCost {
            gram,
            aty: (a.transpose() * y).iter().copied().collect(),
            yty: y.norm_squared(),
            n: a.ncols(),
            sigma,
            p,
        }
    }

    /// The data term ‖Âz − y‖² alone.
    pub fn misfit(&self, z: &[f64]) -> f64 {
        let mut q = 0.0;
        for (j, &zj) in z.iter().enumerate() {
            if zj == 0.0 {
                continue;
            }
            let row = &self.gram[j * self.n..(j + 1) * self.n];
            let gz: f64 = row.iter().zip(z).map(|(g, zk)| g * zk).sum();
            q += zj * (gz - 2.0 * self.aty[j]);
        }
        (q + self.yty).max(0.0)
    }

    /// Full cost of a candidate given as a slice.
    pub fn eval(&self, z: &[f64]) -> f64 {
        let mut penalty = 0.0;
        for &zj in z {
            if zj > 0.0 {
                penalty += (self.p * zj.ln()).exp();
            }
        }
        self.misfit(z) + self.sigma * penalty
    }
}

impl CostFunction for PenalisedCost {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, z: &Self::Param) -> Result<f64, Error> {
        Ok(self.eval(z))
    }
}
