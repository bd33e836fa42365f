//! The one solver layer, argmin style, for everything fbgforge minimises: a problem is
//! a [`BoxProblem`] (a penalised cost over a box), the method is a [`SolverKind`]
//! (Nelder–Mead, particle swarm, differential evolution): an argmin `Solver`, a
//! small type that only says how to start and how to step. One run loop,
//! [`execute`], hands it to argmin's `Executor`, which owns iteration, stopping and
//! the observer that records the convergence history, and reads the best point from
//! the final state ([`RunState`]). [`multi_start`] runs several starts of several
//! solvers in parallel (rayon) and keeps every run for the report.
//!
//! Users: module optimisation and grating placement ([`crate::optimize`]) through
//! [`run_one`]/[`multi_start`]; the lag fit of the verifier through
//! [`nelder_mead::minimise`]; the `de` reconstruction method through [`execute`] with
//! [`differential_evolution::DifferentialEvolution`].
//!
//! A new solver: a file here with its argmin `Solver` (as
//! [`differential_evolution`]), a [`SolverKind`] variant and the line in
//! [`run_one`] that builds it; a new argmin state shape also implements
//! [`RunState`].

pub mod differential_evolution;
pub mod nelder_mead;

use argmin::core::observers::{Observe, ObserverMode};
use argmin::core::{
    ArgminError, CostFunction, Error, Executor, IterState, PopulationState, Solver, State,
    TerminationReason, KV,
};
use argmin::solver::neldermead::NelderMead;
use argmin::solver::particleswarm::{Particle, ParticleSwarm};
use fbgforge_core::progress::{Progress, Quiet};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A minimisation problem over a box: the cost is finite everywhere in the box
/// (constraints are folded in as penalties by the problem itself).
pub trait BoxProblem: Sync {
    /// Lower and upper bounds of each variable.
    fn bounds(&self) -> (Vec<f64>, Vec<f64>);
    /// Cost at `x` (inside the box). Lower is better.
    fn cost(&self, x: &[f64]) -> f64;
}

/// The argmin methods fbgforge compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Hash)]
#[serde(rename_all = "kebab-case")]
pub enum SolverKind {
    /// Nelder–Mead simplex (argmin), started from a point.
    NelderMead,
    /// Particle swarm (argmin), seeded, over the whole box.
    ParticleSwarm,
    /// Differential evolution (DE/rand/1/bin, [`differential_evolution`]), seeded, over
    /// the whole box.
    DifferentialEvolution,
}

impl SolverKind {
    /// Every solver.
    pub const ALL: [SolverKind; 3] = [
        SolverKind::NelderMead,
        SolverKind::ParticleSwarm,
        SolverKind::DifferentialEvolution,
    ];
    /// The pair the optimisers compare by default (`--solver both`).
    pub const BOTH: [SolverKind; 2] = [SolverKind::NelderMead, SolverKind::ParticleSwarm];

    /// Name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::NelderMead => "nelder-mead",
            SolverKind::ParticleSwarm => "particle-swarm",
            SolverKind::DifferentialEvolution => "differential-evolution",
        }
    }

    /// Parse a name, listing the known ones on failure.
    pub fn parse(s: &str) -> anyhow::Result<Vec<SolverKind>> {
        match s {
            "nelder-mead" => Ok(vec![SolverKind::NelderMead]),
            "particle-swarm" => Ok(vec![SolverKind::ParticleSwarm]),
            "differential-evolution" => Ok(vec![SolverKind::DifferentialEvolution]),
            "both" => Ok(SolverKind::BOTH.to_vec()),
            "all" => Ok(SolverKind::ALL.to_vec()),
            _ => {
                anyhow::bail!("unknown solver `{s}`; expected nelder-mead, particle-swarm, differential-evolution, both (the first two) or all")
            }
        }
    }
}

/// Budget and tolerances of one run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RunSettings {
    /// Iteration limit per Nelder–Mead run.
    pub max_iters: u64,
    /// Iteration limit per particle-swarm run.
    pub swarm_iters: u64,
    /// Nelder–Mead: stop when the simplex costs' standard deviation falls below this.
    pub sd_tolerance: f64,
    /// Particle swarm: number of particles; differential evolution: individuals.
    pub particles: usize,
    /// Nelder–Mead: initial simplex edge as a share of each variable's range.
    pub simplex_share: f64,
}

impl Default for RunSettings {
    fn default() -> Self {
        RunSettings {
            max_iters: 200,
            swarm_iters: 80,
            sd_tolerance: 1e-7,
            particles: 16,
            simplex_share: 0.15,
        }
    }
}

/// One run of one solver from one start.
#[derive(Debug, Clone, Serialize)]
pub struct Run {
    /// Solver.
    pub solver: SolverKind,
    /// Start index (0 = the given start point).
    pub start: usize,
    /// Best point found (inside the box).
    pub best_x: Vec<f64>,
    /// Its cost.
    pub best_cost: f64,
    /// Iterations done.
    pub iterations: u64,
    /// Cost evaluations.
    pub evaluations: u64,
    /// Wall time, s.
    pub time_s: f64,
    /// Why it stopped, as argmin reports it.
    pub termination: String,
    /// Best cost after each iteration.
    pub history: Vec<f64>,
}

/// argmin adapter: projects onto the box (a feasible parameterisation of the bounds)
/// and adds the squared distance outside it so the simplex is pulled back in.
struct Boxed<'a, P: BoxProblem> {
    problem: &'a P,
    lo: Vec<f64>,
    hi: Vec<f64>,
    evaluations: Arc<AtomicU64>,
    ticker: &'a Ticker<'a>,
}

/// A run's iterations as progress steps: the observer counts them (`observed`), the
/// cost function (called on the solver's thread, where the borrowed sink can go)
/// passes the new ones on, and the run's end passes on the rest of its budget, so a
/// run is always worth exactly its iteration limit.
struct Ticker<'a> {
    progress: &'a dyn Progress,
    observed: Arc<AtomicU64>,
    reported: AtomicU64,
    budget: u64,
}

impl Ticker<'_> {
    /// Report the iterations observed since the last report (at most the budget).
    fn catch_up(&self, done: u64) {
        let done = done.min(self.budget);
        let before = self.reported.fetch_max(done, Ordering::Relaxed);
        if done > before {
            self.progress.advance(done - before);
        }
    }
}

/// `x` clamped into [lo, hi] (a non-finite value goes to the lower bound), and the
/// squared distance outside, each coordinate in units of its range.
fn project(lo: &[f64], hi: &[f64], x: &[f64]) -> (Vec<f64>, f64) {
    let mut outside = 0.0;
    let y = x
        .iter()
        .zip(lo.iter().zip(hi))
        .map(|(&v, (&l, &h))| {
            let c = if v.is_finite() { v.clamp(l, h) } else { l };
            let span = (h - l).max(1e-12);
            outside += ((v - c) / span).powi(2);
            c
        })
        .collect();
    (y, outside)
}

impl<P: BoxProblem> CostFunction for Boxed<'_, P> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        self.ticker
            .catch_up(self.ticker.observed.load(Ordering::Relaxed));
        let (y, outside) = project(&self.lo, &self.hi, x);
        let c = self.problem.cost(&y);
        let c = if c.is_finite() { c } else { 1e12 };
        Ok(c + 1e3 * outside)
    }
}

/// The observer type for runs nobody watches (`None` in [`execute`]).
pub struct Unobserved;

impl<I> Observe<I> for Unobserved {}

/// Records the best cost after every iteration, and counts the iterations.
struct History(Arc<Mutex<Vec<f64>>>, Arc<AtomicU64>);

impl<I: State<Float = f64>> Observe<I> for History {
    fn observe_iter(&mut self, state: &I, _kv: &KV) -> Result<(), Error> {
        self.1.fetch_add(1, Ordering::Relaxed);
        if let Ok(mut h) = self.0.lock() {
            h.push(state.get_best_cost());
        }
        Ok(())
    }
}

/// What a run of the executor found, read from argmin's final state.
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    /// Best point.
    pub best_x: Vec<f64>,
    /// Its cost.
    pub best_cost: f64,
    /// Iterations done.
    pub iterations: u64,
    /// Why it stopped, as argmin reports it.
    pub termination: String,
    /// Whether the solver's own convergence test stopped it (not the iteration
    /// limit).
    pub solver_converged: bool,
}

/// The state of a solver of this layer, as the run loop needs it: an iteration
/// limit to set and a best point to read. argmin's states keep the best point in
/// different shapes (a vector, a particle).
pub trait RunState: State<Float = f64> {
    /// The same state with an iteration limit.
    fn with_max_iters(self, max_iters: u64) -> Self;
    /// The best point so far.
    fn best_point(&self) -> Option<Vec<f64>>;
}

impl RunState for IterState<Vec<f64>, (), (), (), (), f64> {
    fn with_max_iters(self, max_iters: u64) -> Self {
        self.max_iters(max_iters)
    }
    fn best_point(&self) -> Option<Vec<f64>> {
        self.get_best_param().cloned()
    }
}

impl RunState for PopulationState<Particle<Vec<f64>, f64>, f64> {
    fn with_max_iters(self, max_iters: u64) -> Self {
        self.max_iters(max_iters)
    }
    fn best_point(&self) -> Option<Vec<f64>> {
        self.get_best_param().map(|p| p.position.clone())
    }
}

/// The one run loop of the layer: argmin's executor runs `solver` on `cost` for at
/// most `max_iters` iterations and owns the iteration, the stopping tests and the
/// observer; the best point is read from its final state. Every solver (an argmin
/// [`Solver`] whose state is a [`RunState`]) runs through here: the optimisers'
/// through [`run_one`], the verifier's lag fit through [`nelder_mead::minimise`],
/// the `de` reconstruction method frame by frame.
pub fn execute<C, S, I, O>(
    cost: C,
    solver: S,
    max_iters: u64,
    observer: Option<O>,
) -> Result<Minimum, Error>
where
    S: Solver<C, I>,
    I: RunState,
    O: Observe<I> + 'static,
{
    let mut exec = Executor::new(cost, solver).configure(|s| s.with_max_iters(max_iters));
    if let Some(o) = observer {
        exec = exec.add_observer(o, ObserverMode::Always);
    }
    let res = exec.run()?;
    let st = res.state();
    let best_x = st.best_point().ok_or_else(|| ArgminError::NotInitialized {
        text: "the solver reported no best point".into(),
    })?;
    Ok(Minimum {
        best_x,
        best_cost: st.get_best_cost(),
        iterations: st.get_iter(),
        termination: st.get_termination_status().to_string(),
        solver_converged: matches!(
            st.get_termination_reason(),
            Some(TerminationReason::SolverConverged)
        ),
    })
}

/// Run one solver on `problem` from `start` (Nelder–Mead) or over the box with `seed`
/// (particle swarm, differential evolution).
pub(crate) fn run_one<P: BoxProblem>(
    problem: &P,
    kind: SolverKind,
    start: &[f64],
    start_index: usize,
    seed: u64,
    settings: &RunSettings,
    progress: &dyn Progress,
) -> anyhow::Result<Run> {
    let (lo, hi) = problem.bounds();
    anyhow::ensure!(
        lo.len() == hi.len() && lo.len() == start.len(),
        "bounds and start differ in length"
    );
    let evaluations = Arc::new(AtomicU64::new(0));
    let ticker = Ticker {
        progress,
        observed: Arc::new(AtomicU64::new(0)),
        reported: AtomicU64::new(0),
        budget: iteration_limit(kind, settings),
    };
    let boxed = Boxed {
        problem,
        lo: lo.clone(),
        hi: hi.clone(),
        evaluations: evaluations.clone(),
        ticker: &ticker,
    };
    let history = Arc::new(Mutex::new(Vec::new()));
    let observer = Some(History(history.clone(), ticker.observed.clone()));
    let t0 = Instant::now();
    let found = match kind {
        SolverKind::NelderMead => {
            let steps: Vec<f64> = lo
                .iter()
                .zip(&hi)
                .map(|(l, h)| settings.simplex_share * (h - l))
                .collect();
            let simplex = nelder_mead::simplex_inside(start, &steps, &hi);
            let solver = NelderMead::new(simplex).with_sd_tolerance(settings.sd_tolerance);
            solver.and_then(|s| execute(boxed, s, settings.max_iters, observer))
        }
        SolverKind::ParticleSwarm => {
            let solver = ParticleSwarm::new((lo.clone(), hi.clone()), settings.particles)
                .with_rng_generator(rand::rngs::StdRng::seed_from_u64(seed));
            execute(boxed, solver, settings.swarm_iters, observer)
        }
        SolverKind::DifferentialEvolution => {
            let solver =
                differential_evolution::DifferentialEvolution::new(lo.clone(), hi.clone(), seed)
                    .map(|s| s.with_population(settings.particles));
            solver.and_then(|s| execute(boxed, s, settings.swarm_iters, observer))
        }
    }
    .map_err(|e| anyhow::anyhow!("{}: {e}", kind.name()))?;
    // A run that converged before its limit is done: the rest of its budget too.
    ticker.catch_up(ticker.budget);
    let (best_x, _) = project(&lo, &hi, &found.best_x);
    let history = history.lock().map(|h| h.clone()).unwrap_or_default();
    Ok(Run {
        solver: kind,
        start: start_index,
        best_x,
        best_cost: found.best_cost,
        iterations: found.iterations,
        evaluations: evaluations.load(Ordering::Relaxed),
        time_s: t0.elapsed().as_secs_f64(),
        termination: found.termination,
        history,
    })
}

/// Start points: `start` itself, then `extra` seeded uniform points in the box.
pub fn start_points(
    start: &[f64],
    lo: &[f64],
    hi: &[f64],
    extra: usize,
    seed: u64,
) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut pts = vec![start.to_vec()];
    for _ in 0..extra {
        pts.push(
            lo.iter()
                .zip(hi)
                .map(|(&l, &h)| if h > l { rng.random_range(l..=h) } else { l })
                .collect(),
        );
    }
    pts
}

/// The iteration limit of one run of `kind`: its whole budget as progress steps.
fn iteration_limit(kind: SolverKind, settings: &RunSettings) -> u64 {
    match kind {
        SolverKind::NelderMead => settings.max_iters,
        SolverKind::ParticleSwarm | SolverKind::DifferentialEvolution => settings.swarm_iters,
    }
}

/// The runs [`multi_start`] makes: Nelder–Mead from every start, the swarm and
/// differential evolution once (they ignore the start point and cover the whole box).
fn jobs(solvers: &[SolverKind], starts: usize) -> Vec<(SolverKind, usize)> {
    solvers
        .iter()
        .flat_map(|&k| {
            let n = match k {
                SolverKind::NelderMead => starts,
                SolverKind::ParticleSwarm | SolverKind::DifferentialEvolution => starts.min(1),
            };
            (0..n).map(move |i| (k, i))
        })
        .collect()
}

/// The progress steps of [`multi_start_with_progress`]: every run's iteration limit,
/// summed (a run that converges early reports the rest of its limit when it ends).
///
/// ```
/// use fbgforge_model::solvers::{iteration_budget, RunSettings, SolverKind};
/// let s = RunSettings { max_iters: 100, swarm_iters: 90, ..RunSettings::default() };
/// // Nelder–Mead from each of 2 starts, the swarm once.
/// assert_eq!(iteration_budget(&SolverKind::BOTH, 2, &s), 2 * 100 + 90);
/// ```
pub fn iteration_budget(solvers: &[SolverKind], starts: usize, settings: &RunSettings) -> u64 {
    jobs(solvers, starts)
        .iter()
        .map(|&(k, _)| iteration_limit(k, settings))
        .sum()
}

/// Run Nelder–Mead from every start point and the particle swarm once (it searches
/// the whole box), all in parallel.
pub fn multi_start<P: BoxProblem>(
    problem: &P,
    solvers: &[SolverKind],
    starts: &[Vec<f64>],
    seed: u64,
    settings: &RunSettings,
) -> anyhow::Result<Vec<Run>> {
    multi_start_with_progress(problem, solvers, starts, seed, settings, &Quiet)
}

/// [`multi_start`], telling `progress` of every iteration done: the current stage
/// (begun by the caller with [`iteration_budget`] steps) moves with the search and
/// ends exactly at its total.
pub fn multi_start_with_progress<P: BoxProblem>(
    problem: &P,
    solvers: &[SolverKind],
    starts: &[Vec<f64>],
    seed: u64,
    settings: &RunSettings,
    progress: &dyn Progress,
) -> anyhow::Result<Vec<Run>> {
    jobs(solvers, starts.len())
        .par_iter()
        .map(|&(k, i)| {
            run_one(
                problem,
                k,
                &starts[i],
                i,
                seed.wrapping_add(i as u64 * 7919),
                settings,
                progress,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A shifted, scaled quadratic bowl with its minimum inside the box.
    struct Bowl {
        centre: Vec<f64>,
    }
    impl BoxProblem for Bowl {
        fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
            (vec![-5.0; self.centre.len()], vec![5.0; self.centre.len()])
        }
        fn cost(&self, x: &[f64]) -> f64 {
            x.iter()
                .zip(&self.centre)
                .enumerate()
                .map(|(i, (a, c))| (i + 1) as f64 * (a - c).powi(2))
                .sum::<f64>()
                + 3.0
        }
    }

    /// Rosenbrock's valley, whose minimum (1, 1) is known exactly.
    struct Rosenbrock;
    impl BoxProblem for Rosenbrock {
        fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
            (vec![-2.0, -1.0], vec![2.0, 3.0])
        }
        fn cost(&self, x: &[f64]) -> f64 {
            (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2)
        }
    }

    /// Minimum on the boundary: min (x − 7)² over [−5, 5] is at x = 5.
    struct Edge;
    impl BoxProblem for Edge {
        fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
            (vec![-5.0], vec![5.0])
        }
        fn cost(&self, x: &[f64]) -> f64 {
            (x[0] - 7.0).powi(2)
        }
    }

    #[test]
    fn both_solvers_find_the_bowl_minimum() {
        let p = Bowl {
            centre: vec![1.5, -2.0, 0.25],
        };
        let s = RunSettings {
            max_iters: 400,
            swarm_iters: 400,
            particles: 30,
            ..RunSettings::default()
        };
        for kind in SolverKind::ALL {
            let r = run_one(&p, kind, &[0.0, 0.0, 0.0], 0, 3, &s, &Quiet).unwrap();
            for (a, c) in r.best_x.iter().zip(&p.centre) {
                assert!((a - c).abs() < 2e-2, "{kind:?}: {:?}", r.best_x);
            }
            assert!(
                (r.best_cost - 3.0).abs() < 1e-3,
                "{kind:?}: {}",
                r.best_cost
            );
            // The history is the executor's best cost, never rising.
            assert!(r.history.windows(2).all(|w| w[1] <= w[0] + 1e-12));
            assert_eq!(r.history.len() as u64, r.iterations);
        }
    }

    /// Records every step a run reports, from several threads.
    struct Steps(Mutex<Vec<u64>>);

    impl Progress for Steps {
        fn advance(&self, steps: u64) {
            self.0.lock().unwrap().push(steps);
        }
    }

    #[test]
    fn the_search_reports_its_iterations_and_ends_at_its_budget() {
        // Short limits (some runs stop at them) and a loose tolerance (Nelder–Mead
        // converges first): either way each run is worth its limit.
        for (max_iters, tol) in [(15, 1e-14), (2000, 1e-3)] {
            let s = RunSettings {
                max_iters,
                swarm_iters: 12,
                particles: 8,
                sd_tolerance: tol,
                ..RunSettings::default()
            };
            let starts = start_points(&[-1.5, 2.5], &[-2.0, -1.0], &[2.0, 3.0], 3, 11);
            let rec = Steps(Mutex::new(Vec::new()));
            let solvers = SolverKind::BOTH;
            multi_start_with_progress(&Rosenbrock, &solvers, &starts, 1, &s, &rec).unwrap();
            let steps = rec.0.into_inner().unwrap();
            assert!(steps.iter().all(|&k| k > 0), "{steps:?}");
            let total = iteration_budget(&solvers, starts.len(), &s);
            assert_eq!(steps.iter().sum::<u64>(), total);
            assert_eq!(total, 4 * max_iters + 12);
            // The bar moves within the stage, not in one jump per run.
            assert!(steps.len() > 5, "{steps:?}");
        }
    }

    #[test]
    fn multi_start_nelder_mead_solves_rosenbrock() {
        let s = RunSettings {
            max_iters: 2000,
            sd_tolerance: 1e-14,
            ..RunSettings::default()
        };
        let starts = start_points(&[-1.5, 2.5], &[-2.0, -1.0], &[2.0, 3.0], 3, 11);
        let runs = multi_start(&Rosenbrock, &[SolverKind::NelderMead], &starts, 1, &s).unwrap();
        assert_eq!(runs.len(), 4);
        let best = runs
            .iter()
            .min_by(|a, b| a.best_cost.total_cmp(&b.best_cost))
            .unwrap();
        assert!(
            (best.best_x[0] - 1.0).abs() < 1e-3 && (best.best_x[1] - 1.0).abs() < 2e-3,
            "{:?}",
            best.best_x
        );
    }

    #[test]
    fn bounded_minimum_lands_on_the_bound() {
        for kind in SolverKind::ALL {
            let r = run_one(&Edge, kind, &[0.0], 0, 5, &RunSettings::default(), &Quiet).unwrap();
            assert!((r.best_x[0] - 5.0).abs() < 1e-3, "{kind:?}: {:?}", r.best_x);
            assert!((r.best_cost - 4.0).abs() < 1e-2);
        }
    }

    /// ‖x − (1, −2)‖² + 3 as an argmin cost, for the run loop alone.
    struct Quadratic;
    impl CostFunction for Quadratic {
        type Param = Vec<f64>;
        type Output = f64;
        fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
            Ok((x[0] - 1.0).powi(2) + (x[1] + 2.0).powi(2) + 3.0)
        }
    }

    #[test]
    fn the_run_loop_says_whether_the_solver_or_the_limit_stopped_it() {
        let de = || {
            differential_evolution::DifferentialEvolution::new(vec![-5.0; 2], vec![5.0; 2], 9)
                .unwrap()
                .with_population(30)
        };
        // DE's own test (the population's costs together) stops it before the limit.
        let m = execute(Quadratic, de(), 5000, None::<Unobserved>).unwrap();
        assert!(m.solver_converged && m.iterations < 5000, "{m:?}");
        assert!((m.best_x[0] - 1.0).abs() < 1e-4 && (m.best_x[1] + 2.0).abs() < 1e-4);
        // Three generations: the limit stops it, and it says so.
        let m = execute(Quadratic, de(), 3, None::<Unobserved>).unwrap();
        assert!(!m.solver_converged && m.iterations == 3, "{m:?}");
        // The swarm's best point is read from its particle: its cost is the cost there.
        let swarm = ParticleSwarm::new((vec![-5.0; 2], vec![5.0; 2]), 20)
            .with_rng_generator(rand::rngs::StdRng::seed_from_u64(4));
        let m = execute(Quadratic, swarm, 40, None::<Unobserved>).unwrap();
        assert_eq!(m.iterations, 40);
        assert_eq!(m.best_cost, Quadratic.cost(&m.best_x).unwrap());
        assert!(m.best_cost < 3.01, "{m:?}");
    }

    #[test]
    fn unknown_solver_names_are_rejected() {
        assert!(SolverKind::parse("simplex")
            .unwrap_err()
            .to_string()
            .contains("nelder-mead"));
        assert_eq!(SolverKind::parse("both").unwrap().len(), 2);
        assert_eq!(SolverKind::parse("all").unwrap().len(), 3);
    }
}
