//! Differential evolution (DE/rand/1/bin) as an `argmin` solver.
//!
//! argmin 0.11 ships no DE, so this file writes one against argmin's [`Solver`] trait:
//! the executor owns the loop, the iteration limit and the stopping test, the cost
//! function is any `CostFunction<Param = Vec<f64>, Output = f64>`. Speed matters (the
//! array paper runs 150 individuals for up to 1500 generations, i.e. up to 225 000 cost
//! evaluations per frame): the population and the trial vectors live in buffers
//! allocated once in `init`, and each generation is evaluated with one `bulk_problem`
//! call.
//!
//! Mutation: v = x_r1 + F (x_r2 − x_r3) with r1, r2, r3 distinct and different from
//! the target; binomial crossover with rate CR and one forced coordinate; components
//! that leave the box are clamped onto it. Clamping (rather than re-sampling) lets
//! components land exactly on 0, which is what a sparsity penalty rewards. The paper
//! does not give F and CR; we use the classic F = 0.5, CR = 0.9.

use argmin::core::{
    CostFunction, Error, IterState, Problem, Solver, TerminationReason, TerminationStatus, KV,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// DE/rand/1/bin over the box lower ≤ z ≤ upper.
#[derive(Debug, Clone)]
pub struct DifferentialEvolution {
    lower: Vec<f64>,
    upper: Vec<f64>,
    /// Individuals in the population (the paper: 150).
    pub population_size: usize,
    /// Differential weight F.
    pub weight: f64,
    /// Crossover rate CR.
    pub crossover: f64,
    /// Stop when (worst − best) cost in the population ≤ tol · (1 + |best|).
    pub tolerance: f64,
    rng: ChaCha8Rng,
    population: Vec<Vec<f64>>,
    costs: Vec<f64>,
    trials: Vec<Vec<f64>>,
    trial_costs: Vec<f64>,
    /// Individuals placed in the initial population (after the origin), clamped into
    /// the box.
    seeds: Vec<Vec<f64>>,
}

impl DifferentialEvolution {
    /// A solver over the box [lower, upper] with the paper's 150 individuals, F = 0.5,
    /// CR = 0.9 and a seeded ChaCha8 generator.
    pub fn new(lower: Vec<f64>, upper: Vec<f64>, seed: u64) -> Result<Self, Error> {
        if lower.len() != upper.len() || lower.is_empty() {
            return Err(argmin::core::ArgminError::InvalidParameter {
                text: "DE bounds must be non-empty and of equal length".into(),
            }
            .into());
        }
        if lower
            .iter()
            .zip(&upper)
            .any(|(l, u)| l.is_nan() || u.is_nan() || l > u)
        {
            return Err(argmin::core::ArgminError::InvalidParameter {
                text: "DE lower bound above upper bound (or NaN)".into(),
            }
            .into());
        }
        Ok(DifferentialEvolution {
            lower,
            upper,
            population_size: 150,
            weight: 0.5,
            crossover: 0.9,
            tolerance: 1e-10,
            rng: ChaCha8Rng::seed_from_u64(seed),
            population: Vec::new(),
            costs: Vec::new(),
            trials: Vec::new(),
            trial_costs: Vec::new(),
            seeds: Vec::new(),
        })
    }

    /// Set the population size (at least 4: DE/rand/1 needs three others).
    pub fn with_population(mut self, size: usize) -> Self {
        self.population_size = size.max(4);
        self
    }

    /// Start with these individuals in the population (after the origin; as many as
    /// fit): good guesses a caller already has. Selection is elitist, so the answer is
    /// never worse than the best seed.
    pub fn with_seeds(mut self, seeds: Vec<Vec<f64>>) -> Self {
        self.seeds = seeds;
        self
    }

    fn best_index(&self) -> usize {
        let mut b = 0;
        for (i, &c) in self.costs.iter().enumerate() {
            if c < self.costs[b] {
                b = i;
            }
        }
        b
    }
}

type DeState = IterState<Vec<f64>, (), (), (), (), f64>;

impl<O> Solver<O, DeState> for DifferentialEvolution
where
    O: CostFunction<Param = Vec<f64>, Output = f64>,
{
    fn name(&self) -> &str {
        "DE/rand/1/bin"
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: DeState,
    ) -> Result<(DeState, Option<KV>), Error> {
        let (np, n) = (self.population_size, self.lower.len());
        self.population = (0..np)
            .map(|_| {
                (0..n)
                    .map(|j| {
                        self.lower[j] + self.rng.random::<f64>() * (self.upper[j] - self.lower[j])
                    })
                    .collect()
            })
            .collect();
        // Seed one individual at the origin: the all-zero frame is a legal answer that
        // random sampling of the box would almost never reach.
        self.population[0]
            .iter_mut()
            .zip(&self.lower)
            .for_each(|(z, l)| *z = *l);
        for (ind, seed) in self.population[1..].iter_mut().zip(&self.seeds) {
            if seed.len() == n {
                for (j, (z, &v)) in ind.iter_mut().zip(seed).enumerate() {
                    *z = v.clamp(self.lower[j], self.upper[j]);
                }
            }
        }
        self.trials = self.population.clone();
        self.trial_costs = vec![0.0; np];
        let pop = &self.population;
        let costs = &mut self.costs;
        problem.bulk_problem("cost_count", np, |p| {
            *costs = pop
                .iter()
                .map(|z| p.cost(z))
                .collect::<Result<Vec<f64>, Error>>()?;
            Ok(())
        })?;
        let b = self.best_index();
        Ok((
            state.param(self.population[b].clone()).cost(self.costs[b]),
            None,
        ))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        state: DeState,
    ) -> Result<(DeState, Option<KV>), Error> {
        let (np, n) = (self.population_size, self.lower.len());
        for i in 0..np {
            let (mut r1, mut r2, mut r3);
            loop {
                r1 = self.rng.random_range(0..np);
                if r1 != i {
                    break;
                }
            }
            loop {
                r2 = self.rng.random_range(0..np);
                if r2 != i && r2 != r1 {
                    break;
                }
            }
            loop {
                r3 = self.rng.random_range(0..np);
                if r3 != i && r3 != r1 && r3 != r2 {
                    break;
                }
            }
            let forced = self.rng.random_range(0..n);
            let trial = &mut self.trials[i];
            for (j, t) in trial.iter_mut().enumerate() {
                *t = if j == forced || self.rng.random::<f64>() < self.crossover {
                    let v = self.population[r1][j]
                        + self.weight * (self.population[r2][j] - self.population[r3][j]);
                    v.clamp(self.lower[j], self.upper[j])
                } else {
                    self.population[i][j]
                };
            }
        }
        let trials = &self.trials;
        let tc = &mut self.trial_costs;
        problem.bulk_problem("cost_count", np, |p| {
            for (c, z) in tc.iter_mut().zip(trials) {
                *c = p.cost(z)?;
            }
            Ok(())
        })?;
        for i in 0..np {
            // Greedy selection; ≤ lets the population drift across plateaus.
            if self.trial_costs[i] <= self.costs[i] {
                std::mem::swap(&mut self.population[i], &mut self.trials[i]);
                self.costs[i] = self.trial_costs[i];
            }
        }
        let b = self.best_index();
        Ok((
            state.param(self.population[b].clone()).cost(self.costs[b]),
            None,
        ))
    }

    fn terminate(&mut self, state: &DeState) -> TerminationStatus {
        let best = state.get_best_cost();
        let worst = self.costs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if worst - best <= self.tolerance * (1.0 + best.abs()) {
            TerminationStatus::Terminated(TerminationReason::SolverConverged)
        } else {
            TerminationStatus::NotTerminated
        }
    }
}
