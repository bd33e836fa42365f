//! `de`: the paper's replica, ‖Âz − y‖² + σ Σ z_jᵖ with p = 0.01, by differential
//! evolution (DE/rand/1/bin, 150 individuals, ≤ 1500 generations).
//!
//! Two things keep it honest on large arrays, where a random population in a box of
//! hundreds of dimensions has enormous misfits and collapses onto the all-zero
//! individual (32 × 256: all-zero loads on every single-load frame, "converged"):
//!
//! * **Seeds.** Besides the origin, the initial population holds the greedy fits of
//!   one to K loads (forward selection, bounded least squares on each support).
//!   Selection is elitist, so DE never ends worse than those.
//! * **Label.** DE's own stop (the population's costs within 10⁻¹⁰ of each other)
//!   says nothing about the global optimum. After the run the answer is polished
//!   (bounded least squares on its support, kept if it lowers the objective) and
//!   compared under DE's own objective with an independent candidate: the certified
//!   ℓ0 optimum of `bnb` with λ = σ, fitted on its support. When that candidate is
//!   better, the frame is reported not converged (the answer stays DE's).

use super::*;
use crate::solvers::differential_evolution::DifferentialEvolution;
use crate::solvers::{execute, Unobserved};
use argmin::core::{CostFunction, Error};
use std::sync::Arc;

/// The registry entry of `de`.
pub(super) const ENTRY: MethodEntry = MethodEntry {
    name: "de",
    penalty_grid: doubling_grid,
    defaults: |prior| MethodSettings::De(DeSettings::for_prior(prior)),
};

/// Settings of `de` (the paper's numbers by default).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DeSettings {
    /// σ, pm² per unit of Σ zᵖ (working units).
    pub penalty: f64,
    /// Population size (paper: 150).
    pub population: usize,
    /// Generation limit (paper: 1500).
    pub generations: u64,
    /// Seed of the generator (mixed with the frame's content, so a frame always gets
    /// the same answer).
    pub seed: u64,
    /// Most loads of the greedy seeds and of the independent `bnb` candidate the
    /// answer is checked against.
    pub max_loads: usize,
    /// Work budget of that candidate per frame (`bnb` units).
    pub reference_node_budget: u64,
}

impl DeSettings {
    /// For readings of this kind: the load cap; σ = 4 and the paper's population and
    /// generations.
    pub fn for_prior(prior: &ReadingSettings) -> Self {
        DeSettings {
            penalty: 4.0,
            population: 150,
            generations: 1500,
            seed: 0x5EED_F8C5,
            max_loads: prior.max_loads,
            reference_node_budget: 1_000_000,
        }
    }
}

impl Default for DeSettings {
    /// The paper's readings.
    fn default() -> Self {
        Self::for_prior(&ReadingSettings::paper())
    }
}

impl Knobs for DeSettings {
    fn method(&self) -> Method {
        Method::De
    }
    fn build(&self, common: Common) -> Result<Box<dyn Reconstructor>, ArrayError> {
        let reference = BnbSettings {
            penalty: self.penalty,
            max_loads: self.max_loads,
            node_budget: self.reference_node_budget,
        }
        .build(Common::new(&common.problem))?;
        Ok(Box::new(De {
            gram: row_major(&common.gram),
            common,
            settings: *self,
            reference,
        }))
    }
    fn penalty_mut(&mut self) -> Option<&mut f64> {
        Some(&mut self.penalty)
    }
    fn max_loads_mut(&mut self) -> Option<&mut usize> {
        Some(&mut self.max_loads)
    }
}

pub(super) struct De {
    pub(super) common: Common,
    pub(super) settings: DeSettings,
    /// The common Gram matrix, row-major, computed once for the stream.
    gram: Arc<[f64]>,
    /// The independent candidate DE's answer is checked against (`bnb`, λ = σ).
    reference: Box<dyn Reconstructor>,
}

impl De {
    /// Greedy forward selection: the bounded least-squares fit of 1, 2, … K loads,
    /// each time adding the cell most correlated with the residual.
    fn greedy_seeds(&self, aty: &DVector<f64>) -> Vec<Vec<f64>> {
        let n = self.common.n();
        let kmax = self
            .settings
            .max_loads
            .min(self.common.problem.n_gratings())
            .min(n);
        let mut support: Vec<usize> = Vec::new();
        let mut z = DVector::<f64>::zeros(n);
        let mut seeds = Vec::new();
        while support.len() < kmax {
            let corr = aty - &self.common.gram * &z;
            let Some(j) = (0..n)
                .filter(|q| !support.contains(q))
                .max_by(|&a, &b| corr[a].total_cmp(&corr[b]))
            else {
                break;
            };
            if corr[j] <= 0.0 {
                break;
            }
            support.push(j);
            z = bounded_ls_on(&self.common, aty, &support).0;
            seeds.push(z.iter().copied().collect());
        }
        seeds
    }

    /// Bounded least squares on the support of `z` (its cells with a load).
    fn polish(&self, aty: &DVector<f64>, z: &[f64]) -> Vec<f64> {
        let cols: Vec<usize> = (0..z.len()).filter(|&j| z[j] > 0.0).collect();
        bounded_ls_on(&self.common, aty, &cols)
            .0
            .iter()
            .copied()
            .collect()
    }
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

    /// ‖Âz − y‖² + σ Σ z_jᵖ.
    fn objective(&self, y: &[f64], loads_g: &[f64]) -> Option<f64> {
        let (_, z) = self.common.misfit_of(y, loads_g)?;
        Some(self.cost(y).eval(&z))
    }

    fn reconstruct(&self, y: &[f64]) -> Reconstruction {
        let Some(aty) = self.common.aty(y) else {
            return self.common.unusable();
        };
        let p = &self.common.problem;
        let cost = self.cost(y);
        let lower = vec![0.0; p.n_cells()];
        let upper: Vec<f64> = p.upper.iter().copied().collect();
        let solver =
            match DifferentialEvolution::new(lower, upper, frame_seed(self.settings.seed, y)) {
                Ok(s) => s
                    .with_population(self.settings.population)
                    .with_seeds(self.greedy_seeds(&aty)),
                Err(_) => return self.common.unusable(),
            };
        let Ok(found) = execute(
            cost.clone(),
            solver,
            self.settings.generations,
            None::<Unobserved>,
        ) else {
            return self.common.unusable();
        };
        // DE's own stop: the population's costs within 10⁻¹⁰ of each other.
        let collapsed = found.solver_converged;
        let iterations = found.iterations;
        let z = &found.best_x;
        let polished = self.polish(&aty, z);
        let (z, value) = {
            let (a, b) = (cost.eval(z), cost.eval(&polished));
            if b < a {
                (polished, b)
            } else {
                (z.clone(), a)
            }
        };
        // The label: no independent candidate may beat the answer.
        let reference = self.reference.reconstruct(y);
        let beaten = self
            .objective(y, &reference.loads_g)
            .is_some_and(|r| r < value - 1e-9 * (1.0 + value.abs()));
        self.common.finish(&z, y, collapsed && !beaten, iterations)
    }
}

impl De {
    /// The paper's objective for one frame.
    fn cost(&self, y: &[f64]) -> PenalisedCost {
        PenalisedCost::with_gram(
            self.gram.clone(),
            &self.common.problem.working,
            &DVector::from_column_slice(y),
            self.settings.penalty,
            0.01,
        )
    }
}

/// The paper's objective in the working unknowns z (see [`crate::problem`]):
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
    pub(crate) fn with_gram(
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
