//! Grating placement for the flat array: choose each grating's offset from the centre
//! line (and optionally the fibers' x positions) so that sparse load reconstruction
//! works best.
//!
//! Two objectives, both through the forward model the design names (`array.model`: the
//! physical sheet model by default, docs/array.md §12, or the paper kernel):
//! * `protocol`: the seeded simulation of the paper's 84-test protocol
//!   ([`crate::array::protocol`]), scored as RR (%) + mean SNR (dB), averaged over a
//!   few training seeds (common random numbers, so layouts are compared on the same
//!   noise draws). A 1 dB gain in mean SNR counts as much as one more recovered test
//!   in 84 (1.2 %).
//! * `coherence`: the mutual coherence of the sensing matrix, a cheap proxy; how well
//!   it agrees with the protocol is measured on random layouts ([`proxy_agreement`]).
//!
//! The optimised layout is compared with the start (the paper's layout) on held-out
//! protocol seeds, with the penalty tuned per layout as the paper does, and again on
//! frames drawn from a perturbed model (every matrix entry scattered by a stated
//! fraction): a real sheet is not its model, and a layout tuned to the model's fine
//! structure gains less there ([`PerturbedGain`]). The mold follows the fibers
//! automatically: its slits derive from `array.fiber_x_mm`.

use crate::array::kernel::{matrix_from_positions, mutual_coherence, DistanceKernel};
use crate::array::methods::Method;
use crate::array::protocol::{run_protocol, ProtocolConfig};
use crate::array::sheet::layouts::LayoutMatrices;
use crate::array::sheet::GratingOnFiber;
use crate::profile::ArrayLayout;
use crate::progress::Progress;
use crate::solvers::{
    iteration_budget, multi_start_with_progress, start_points, BoxProblem, Run, RunSettings,
    SolverKind,
};
use crate::spec::ArrayModelKind;
use crate::spec::{Design, TactileArray};
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_distr::Distribution;
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// What placement maximises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PlaceObjective {
    /// RR + mean SNR on the seeded protocol.
    Protocol,
    /// Low mutual coherence of the sensing matrix.
    Coherence,
}

impl PlaceObjective {
    /// Parse `protocol` or `coherence`.
    pub fn parse(s: &str) -> anyhow::Result<Self> {
        match s {
            "protocol" => Ok(PlaceObjective::Protocol),
            "coherence" => Ok(PlaceObjective::Coherence),
            _ => anyhow::bail!("unknown placement objective `{s}`; expected protocol or coherence"),
        }
    }
}

/// Settings of a placement run.
#[derive(Debug, Clone, Serialize)]
pub struct PlaceSettings {
    /// Objective.
    pub objective: PlaceObjective,
    /// Reconstruction method the protocol runs.
    pub method: Method,
    /// Protocol seeds the search scores layouts on.
    pub train_seeds: Vec<u64>,
    /// Held-out protocol seeds for the final comparison.
    pub test_seeds: Vec<u64>,
    /// Also move the fibers along x.
    pub vary_fibers: bool,
    /// Distance kept between a grating's end and the sheet edge, mm.
    pub edge_margin_mm: f64,
    /// Solvers compared.
    pub solvers: Vec<SolverKind>,
    /// Random starts besides the start layout.
    pub extra_starts: usize,
    /// Budget of each run.
    pub run: RunSettings,
    /// Seed of starts and swarms.
    pub seed: u64,
    /// Random layouts used to measure the proxy's agreement with the protocol.
    pub agreement_samples: usize,
    /// Forward model; `None`: the one the design names (`array.model`, the sheet
    /// model by default).
    pub model: Option<ArrayModelKind>,
    /// Relative scatter of every matrix entry in the perturbed model the final layouts
    /// are also scored on (0.10: 10 % per entry, independent normal draws).
    pub perturbed_scatter: f64,
    /// Perturbed models drawn (each scored on one held-out seed, in turn).
    pub perturbed_draws: usize,
}

impl PlaceSettings {
    /// Check the numbers a front end gives before anything is loaded.
    pub fn check(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.run.max_iters > 0 && self.run.swarm_iters > 0,
            "RunSettings.max_iters must be at least 1"
        );
        Ok(())
    }
}

impl Default for PlaceSettings {
    fn default() -> Self {
        PlaceSettings {
            objective: PlaceObjective::Protocol,
            method: Method::WeightedSupport,
            train_seeds: vec![1, 2, 3],
            test_seeds: vec![101, 102, 103, 104, 105],
            vary_fibers: false,
            edge_margin_mm: 2.0,
            solvers: SolverKind::BOTH.to_vec(),
            extra_starts: 1,
            // ~2000 protocol evaluations for the swarm: about half the 60 s budget on
            // two cores in a release build (the `optimize` study).
            run: RunSettings {
                max_iters: 100,
                swarm_iters: 90,
                particles: 20,
                ..RunSettings::default()
            },
            seed: 7,
            agreement_samples: 40,
            model: None,
            perturbed_scatter: 0.10,
            perturbed_draws: 5,
        }
    }
}

/// Protocol result of one layout.
#[derive(Debug, Clone, Serialize)]
pub struct LayoutScore {
    /// Reconstruction ratio over every test, % (mean over seeds).
    pub rr_pct: f64,
    /// Mean SNR over every test, dB (mean over seeds).
    pub mean_snr_db: f64,
    /// Mutual coherence of the sensing matrix.
    pub mutual_coherence: f64,
    /// Per number of loads: (loads, RR %, mean SNR dB), means over seeds, as in the
    /// paper's Table 3.
    pub by_load_count: Vec<(usize, f64, f64)>,
}

impl LayoutScore {
    /// The scalar the protocol objective maximises.
    pub fn score(&self) -> f64 {
        self.rr_pct + self.mean_snr_db
    }
}

/// The forward model placement scores layouts with.
enum PlaceModel {
    /// The empirical distance kernel.
    Kernel(DistanceKernel),
    /// The physical sheet model (boxed: it holds its solved fiber system).
    Sheet(Box<LayoutMatrices>),
}

/// The placement problem: a [`BoxProblem`] over grating offsets (and fiber x).
pub struct PlacementProblem {
    array: TactileArray,
    min_fiber_gap_mm: f64,
    cells: Vec<(f64, f64)>,
    model: PlaceModel,
    settings: PlaceSettings,
    lo: Vec<f64>,
    hi: Vec<f64>,
}

impl PlacementProblem {
    /// Set up from a design with an `[array]` section.
    pub fn new(design: &Design, settings: &PlaceSettings) -> anyhow::Result<Self> {
        let a = design
            .array
            .as_ref()
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "design `{}` has no [array] section to place gratings in",
                    design.name
                )
            })?
            .clone();
        anyhow::ensure!(
            !settings.train_seeds.is_empty(),
            "no training seed for the protocol objective"
        );
        anyhow::ensure!(
            settings.edge_margin_mm.is_finite() && settings.edge_margin_mm >= 0.0,
            "the edge margin must be a non-negative number of mm, got {}",
            settings.edge_margin_mm
        );
        let longest = a.gratings.iter().map(|g| g.length_mm).fold(0.0, f64::max);
        let ymax = a.size_y_mm / 2.0 - longest / 2.0 - settings.edge_margin_mm;
        let xmax = a.size_x_mm / 2.0 - settings.edge_margin_mm;
        anyhow::ensure!(
            ymax > 0.0,
            "infeasible: constraint `edge_margin` cannot be met: a {longest} mm grating with a {} mm margin does not fit in the {} mm sheet",
            settings.edge_margin_mm,
            a.size_y_mm
        );
        let min_gap = a.mold.slit_width_mm + design.printer.min_wall_mm;
        if settings.vary_fibers {
            let need = min_gap * (a.fiber_x_mm.len().saturating_sub(1)) as f64;
            anyhow::ensure!(
                need <= 2.0 * xmax,
                "infeasible: constraint `fiber_spacing` cannot be met: {} fibers {min_gap:.3} mm apart need {need:.3} mm, the sheet offers {:.3} mm",
                a.fiber_x_mm.len(),
                2.0 * xmax
            );
        }
        let mut lo = vec![-ymax; a.gratings.len()];
        let mut hi = vec![ymax; a.gratings.len()];
        if settings.vary_fibers {
            lo.extend(std::iter::repeat_n(-xmax, a.fiber_x_mm.len()));
            hi.extend(std::iter::repeat_n(xmax, a.fiber_x_mm.len()));
        }
        anyhow::ensure!(
            settings.perturbed_scatter.is_finite() && settings.perturbed_scatter >= 0.0,
            "the perturbed model's scatter must be a non-negative fraction, got {}",
            settings.perturbed_scatter
        );
        let cells = ArrayLayout::from_array(&a).cell_centers_mm;
        let model = match settings.model.unwrap_or_else(|| a.model_kind()) {
            ArrayModelKind::Kernel => PlaceModel::Kernel(DistanceKernel::paper()),
            // Moving fibers rebuilds the fiber system at every evaluation: the coarse
            // resolution keeps that affordable (docs/array.md §12.4).
            ArrayModelKind::Sheet => PlaceModel::Sheet(Box::new(LayoutMatrices::from_design(
                design,
                settings.vary_fibers,
            )?)),
        };
        Ok(PlacementProblem {
            array: a,
            min_fiber_gap_mm: min_gap,
            cells,
            model,
            settings: settings.clone(),
            lo,
            hi,
        })
    }

    /// The start layout's variables (clamped into the box).
    pub fn start_point(&self) -> Vec<f64> {
        let mut x: Vec<f64> = self.array.gratings.iter().map(|g| g.y_mm).collect();
        if self.settings.vary_fibers {
            x.extend(self.array.fiber_x_mm.iter().copied());
        }
        x.iter()
            .zip(self.lo.iter().zip(&self.hi))
            .map(|(v, (l, h))| v.clamp(*l, *h))
            .collect()
    }

    /// Array section with the layout `x` applied.
    pub(crate) fn array_at(&self, x: &[f64]) -> TactileArray {
        let mut a = self.array.clone();
        for (g, &y) in a.gratings.iter_mut().zip(x) {
            g.y_mm = y;
        }
        if self.settings.vary_fibers {
            let n = a.gratings.len();
            a.fiber_x_mm = x[n..n + a.fiber_x_mm.len()].to_vec();
        }
        a
    }

    /// Grating positions (x, y), mm, of layout `x`.
    pub fn positions(&self, x: &[f64]) -> Vec<(f64, f64)> {
        let a = self.array_at(x);
        a.gratings
            .iter()
            .map(|g| (a.fiber_x_mm[g.fiber as usize], g.y_mm))
            .collect()
    }

    /// Normalised violation of the spacing constraints (fibers far enough apart for
    /// their slits; gratings on one fiber not overlapping); 0 when met.
    pub fn violation(&self, x: &[f64]) -> f64 {
        let a = self.array_at(x);
        let mut v = 0.0;
        let mut xs = a.fiber_x_mm.clone();
        xs.sort_by(|p, q| p.total_cmp(q));
        for w in xs.windows(2) {
            v += ((self.min_fiber_gap_mm - (w[1] - w[0])) / self.min_fiber_gap_mm).max(0.0);
        }
        for (i, g) in a.gratings.iter().enumerate() {
            for h in &a.gratings[i + 1..] {
                if g.fiber == h.fiber {
                    let need = 0.5 * (g.length_mm + h.length_mm) + 1.0;
                    v += ((need - (g.y_mm - h.y_mm).abs()) / need).max(0.0);
                }
            }
        }
        v
    }

    /// Which forward model scores layouts.
    pub fn model_kind(&self) -> ArrayModelKind {
        match self.model {
            PlaceModel::Kernel(_) => ArrayModelKind::Kernel,
            PlaceModel::Sheet(_) => ArrayModelKind::Sheet,
        }
    }

    /// The model sensing matrix (pm/g, gratings × cells) of layout `x`.
    pub fn matrix(&self, x: &[f64]) -> anyhow::Result<DMatrix<f64>> {
        match &self.model {
            PlaceModel::Kernel(k) => Ok(matrix_from_positions(&self.cells, &self.positions(x), k)),
            PlaceModel::Sheet(m) => {
                let a = self.array_at(x);
                let g: Vec<GratingOnFiber> = a
                    .gratings
                    .iter()
                    .map(|g| GratingOnFiber {
                        fiber: g.fiber as usize,
                        y_mm: g.y_mm,
                        length_mm: g.length_mm,
                    })
                    .collect();
                m.matrix(&a.fiber_x_mm, &g)
            }
        }
    }

    /// Mutual coherence of the layout's sensing matrix (1, the worst, if the model
    /// cannot be solved there).
    pub fn coherence(&self, x: &[f64]) -> f64 {
        self.matrix(x).map(|a| mutual_coherence(&a)).unwrap_or(1.0)
    }

    /// Protocol score of layout `x` over `seeds`, penalty tuned or not.
    pub fn protocol(&self, x: &[f64], seeds: &[u64], tune: bool) -> anyhow::Result<LayoutScore> {
        let a = self.matrix(x)?;
        self.protocol_on(&a, seeds, tune)
    }

    /// Protocol score of the true matrix `a` over `seeds`.
    fn protocol_on(
        &self,
        a: &DMatrix<f64>,
        seeds: &[u64],
        tune: bool,
    ) -> anyhow::Result<LayoutScore> {
        let mut rr = 0.0;
        let mut snr = 0.0;
        let mut by: Vec<(usize, f64, f64)> = Vec::new();
        for &s in seeds {
            let mut cfg = ProtocolConfig::paper(s);
            cfg.ulimit_g = self.array.ulimit_g;
            cfg.tune_penalty = tune;
            let r = run_protocol(a, self.settings.method, &cfg)?;
            rr += r.overall.rr_pct;
            snr += r.overall.mean_snr_db;
            for g in &r.by_load_count {
                match by.iter_mut().find(|b| b.0 == g.n_loads) {
                    Some(b) => {
                        b.1 += g.rr_pct;
                        b.2 += g.mean_snr_db;
                    }
                    None => by.push((g.n_loads, g.rr_pct, g.mean_snr_db)),
                }
            }
        }
        let n = seeds.len().max(1) as f64;
        for b in by.iter_mut() {
            b.1 /= n;
            b.2 /= n;
        }
        Ok(LayoutScore {
            rr_pct: rr / n,
            mean_snr_db: snr / n,
            mutual_coherence: mutual_coherence(a),
            by_load_count: by,
        })
    }

    /// The start and the optimised layouts scored on frames drawn from perturbed
    /// models: for draw k, every entry of each layout's matrix is multiplied by
    /// 1 + σ·z with z standard normal (the same z for both layouts: common random
    /// numbers), and the protocol (penalty tuned) runs on held-out seed k.
    pub fn perturbed_gain(&self, start: &[f64], best: &[f64]) -> anyhow::Result<PerturbedGain> {
        let sigma = self.settings.perturbed_scatter;
        let draws = self.settings.perturbed_draws;
        let seeds = &self.settings.test_seeds;
        anyhow::ensure!(
            !seeds.is_empty(),
            "no held-out seed to score perturbed models on"
        );
        let (a0, a1) = (self.matrix(start)?, self.matrix(best)?);
        let normal = rand_distr::Normal::new(0.0, 1.0).expect("unit normal");
        let scored: Vec<(LayoutScore, LayoutScore)> = (0..draws)
            .into_par_iter()
            .map(|k| {
                let seed = seeds[k % seeds.len()];
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x5CA7_7E40 ^ k as u64);
                let z: Vec<f64> = (0..a0.len()).map(|_| normal.sample(&mut rng)).collect();
                let perturb = |a: &DMatrix<f64>| {
                    let mut p = a.clone();
                    for (v, zi) in p.iter_mut().zip(&z) {
                        *v *= 1.0 + sigma * zi;
                    }
                    p
                };
                Ok((
                    self.protocol_on(&perturb(&a0), &[seed], true)?,
                    self.protocol_on(&perturb(&a1), &[seed], true)?,
                ))
            })
            .collect::<anyhow::Result<_>>()?;
        let (s, b): (Vec<_>, Vec<_>) = scored.into_iter().unzip();
        let (start, best) = (mean_score(&s), mean_score(&b));
        Ok(PerturbedGain {
            scatter_per_entry: sigma,
            draws,
            gain_rr_pct: best.rr_pct - start.rr_pct,
            gain_score: best.score() - start.score(),
            start,
            best,
        })
    }

    /// The objective to maximise at `x` (ignoring constraints).
    pub fn objective(&self, x: &[f64]) -> f64 {
        match self.settings.objective {
            PlaceObjective::Protocol => self
                .protocol(x, &self.settings.train_seeds, false)
                .map(|s| s.score())
                .unwrap_or(f64::NEG_INFINITY),
            PlaceObjective::Coherence => -self.coherence(x),
        }
    }

    /// Of the start and the runs' best points (argmin's state), the feasible layout
    /// of highest objective and that objective.
    pub fn best_of(&self, start: &[f64], runs: &[Run]) -> Option<(f64, Vec<f64>)> {
        std::iter::once(start)
            .chain(runs.iter().map(|r| r.best_x.as_slice()))
            .filter(|x| self.violation(x) <= 0.0)
            .map(|x| (self.objective(x), x.to_vec()))
            .filter(|(f, _)| f.is_finite())
            .max_by(|a, b| a.0.total_cmp(&b.0))
    }
}

impl BoxProblem for PlacementProblem {
    fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
        (self.lo.clone(), self.hi.clone())
    }

    fn cost(&self, x: &[f64]) -> f64 {
        let v = self.violation(x);
        if v > 0.0 {
            // Infeasible layouts cost more than any feasible one (scores are ≥ −1 for
            // coherence and ≤ 100 + SNR for the protocol).
            return 1e3 * (1.0 + v);
        }
        -self.objective(x)
    }
}

/// The mean of several scores (per load count too).
fn mean_score(v: &[LayoutScore]) -> LayoutScore {
    let n = v.len().max(1) as f64;
    let mut by: Vec<(usize, f64, f64)> = Vec::new();
    for s in v {
        for g in &s.by_load_count {
            match by.iter_mut().find(|b| b.0 == g.0) {
                Some(b) => {
                    b.1 += g.1 / n;
                    b.2 += g.2 / n;
                }
                None => by.push((g.0, g.1 / n, g.2 / n)),
            }
        }
    }
    LayoutScore {
        rr_pct: v.iter().map(|s| s.rr_pct).sum::<f64>() / n,
        mean_snr_db: v.iter().map(|s| s.mean_snr_db).sum::<f64>() / n,
        mutual_coherence: v.iter().map(|s| s.mutual_coherence).sum::<f64>() / n,
        by_load_count: by,
    }
}

/// The start and optimised layouts on frames drawn from perturbed models: what the
/// placement gains when the real sheet is not exactly its model.
#[derive(Debug, Clone, Serialize)]
pub struct PerturbedGain {
    /// Relative scatter of every matrix entry (normal, independent per entry).
    pub scatter_per_entry: f64,
    /// Perturbed models drawn.
    pub draws: usize,
    /// The start layout, mean over draws.
    pub start: LayoutScore,
    /// The optimised layout, mean over draws.
    pub best: LayoutScore,
    /// RR gain, percentage points.
    pub gain_rr_pct: f64,
    /// Gain of RR + mean SNR (the protocol objective's scale).
    pub gain_score: f64,
}

/// Agreement between the coherence proxy and the protocol on random layouts.
#[derive(Debug, Clone, Serialize)]
pub struct ProxyAgreement {
    /// Layouts sampled.
    pub samples: usize,
    /// Spearman rank correlation between −coherence and the protocol score.
    pub spearman_coherence_vs_score: f64,
    /// (coherence, protocol score) per sample.
    pub points: Vec<(f64, f64)>,
}

fn ranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
            j += 1;
        }
        let avg = (i + j) as f64 / 2.0;
        for k in i..=j {
            r[idx[k]] = avg;
        }
        i = j + 1;
    }
    r
}

/// Spearman rank correlation of two equally long samples (ties get average ranks).
pub(crate) fn spearman(a: &[f64], b: &[f64]) -> f64 {
    let (ra, rb) = (ranks(a), ranks(b));
    let n = ra.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let (ma, mb) = (ra.iter().sum::<f64>() / n, rb.iter().sum::<f64>() / n);
    let cov: f64 = ra.iter().zip(&rb).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = ra.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = rb.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

/// Measure how well the coherence proxy ranks layouts like the protocol does.
pub fn proxy_agreement(
    p: &PlacementProblem,
    samples: usize,
    seed: u64,
) -> anyhow::Result<ProxyAgreement> {
    let (lo, hi) = p.bounds();
    let pts: Vec<Vec<f64>> =
        start_points(&p.start_point(), &lo, &hi, samples.saturating_sub(1), seed)
            .into_iter()
            .filter(|x| p.violation(x) == 0.0)
            .collect();
    let scored: Vec<(f64, f64)> = pts
        .par_iter()
        .map(|x| {
            Ok((
                p.coherence(x),
                p.protocol(x, &p.settings.train_seeds, false)?.score(),
            ))
        })
        .collect::<anyhow::Result<_>>()?;
    let neg_mu: Vec<f64> = scored.iter().map(|s| -s.0).collect();
    let score: Vec<f64> = scored.iter().map(|s| s.1).collect();
    Ok(ProxyAgreement {
        samples: scored.len(),
        spearman_coherence_vs_score: spearman(&neg_mu, &score),
        points: scored,
    })
}

/// One solver's placement result.
#[derive(Debug, Clone, Serialize)]
pub struct PlaceRun {
    /// Solver.
    pub solver: SolverKind,
    /// Best objective over its starts.
    pub best_objective: f64,
    /// Iterations summed over starts.
    pub iterations: u64,
    /// Objective evaluations summed over starts.
    pub evaluations: u64,
    /// Wall time of the slowest start, s.
    pub time_s: f64,
    /// History (best cost per iteration) of its best start.
    pub history: Vec<f64>,
}

/// Outcome of a placement.
#[derive(Debug, Clone, Serialize)]
pub struct PlaceOutcome {
    /// Objective.
    pub objective: PlaceObjective,
    /// Method.
    pub method: &'static str,
    /// Start layout: grating y (and fiber x).
    pub start_x: Vec<f64>,
    /// Optimised layout.
    pub best_x: Vec<f64>,
    /// Training objective at the start.
    pub start_objective: f64,
    /// Training objective at the optimum.
    pub best_objective: f64,
    /// Start on held-out seeds, penalty tuned.
    pub start_test: LayoutScore,
    /// Optimum on held-out seeds, penalty tuned.
    pub best_test: LayoutScore,
    /// The forward model the layouts were scored with.
    pub model: ArrayModelKind,
    /// Start and optimum on frames drawn from perturbed models (absent when no draw
    /// was asked for).
    pub perturbed: Option<PerturbedGain>,
    /// Per solver.
    pub runs: Vec<PlaceRun>,
    /// Proxy agreement, if measured.
    pub agreement: Option<ProxyAgreement>,
    /// Wall time, s.
    pub time_s: f64,
    /// The optimised design.
    #[serde(skip)]
    pub design: Design,
}

/// Place the gratings of `design`'s array.
pub fn place(
    design: &Design,
    settings: &PlaceSettings,
    progress: &dyn Progress,
) -> anyhow::Result<PlaceOutcome> {
    let t0 = Instant::now();
    anyhow::ensure!(!settings.solvers.is_empty(), "no solver selected");
    let p = PlacementProblem::new(design, settings)?;
    let x0 = p.start_point();
    anyhow::ensure!(
        p.violation(&x0) == 0.0,
        "the start layout breaks the spacing constraints (fibers closer than slit width + min wall, or gratings overlapping on a fiber)"
    );
    let start_objective = p.objective(&x0);
    let (lo, hi) = p.bounds();
    let starts = start_points(&x0, &lo, &hi, settings.extra_starts, settings.seed);
    // One stage per phase, each begun afresh, so a drawn ETA extrapolates from the
    // steps of its own phase only; the search's steps are the runs' iterations.
    progress.begin(
        "searching",
        iteration_budget(&settings.solvers, starts.len(), &settings.run),
    );
    let runs = multi_start_with_progress(
        &p,
        &settings.solvers,
        &starts,
        settings.seed,
        &settings.run,
        progress,
    )?;
    let mut per_solver = Vec::new();
    for &k in &settings.solvers {
        let mine: Vec<_> = runs.iter().filter(|r| r.solver == k).collect();
        let best = mine
            .iter()
            .min_by(|a, b| a.best_cost.total_cmp(&b.best_cost))
            .expect("one run per start");
        per_solver.push(PlaceRun {
            solver: k,
            best_objective: -best.best_cost,
            iterations: mine.iter().map(|r| r.iterations).sum(),
            evaluations: mine.iter().map(|r| r.evaluations).sum(),
            time_s: mine.iter().map(|r| r.time_s).fold(0.0, f64::max),
            history: best.history.clone(),
        });
    }
    // The start is a candidate, so the answer can never score below it.
    let (best_objective, best_x) = p
        .best_of(&x0, &runs)
        .unwrap_or((start_objective, x0.clone()));
    progress.begin("held-out", 2);
    let scored = |x: &[f64]| {
        let r = p.protocol(x, &settings.test_seeds, true);
        progress.advance(1);
        r
    };
    let (start_test, best_test) = rayon::join(|| scored(&x0), || scored(&best_x));
    let perturbed = if settings.perturbed_draws > 0 {
        progress.begin("perturbed", 1);
        let gain = p.perturbed_gain(&x0, &best_x)?;
        progress.advance(1);
        Some(gain)
    } else {
        None
    };
    let agreement = if settings.agreement_samples >= 3 {
        progress.begin("agreement", 1);
        let a = proxy_agreement(&p, settings.agreement_samples, settings.seed ^ 0xA5A5)?;
        progress.advance(1);
        Some(a)
    } else {
        None
    };
    progress.end();
    let mut out = design.clone();
    out.array = Some(p.array_at(&best_x));
    out.name = format!("{}-placed", design.name.trim_end_matches("-placed"));
    out.description = Some(format!(
        "Grating placement optimised by fbgforge place from `{}` ({:?} objective, method {})",
        design.name,
        settings.objective,
        settings.method.name()
    ));
    out.validate()
        .map_err(|e| anyhow::anyhow!("internal: the placed design does not validate: {e}"))?;
    Ok(PlaceOutcome {
        objective: settings.objective,
        method: settings.method.name(),
        start_x: x0,
        best_x,
        start_objective,
        best_objective,
        start_test: start_test?,
        best_test: best_test?,
        model: p.model_kind(),
        perturbed,
        runs: per_solver,
        agreement,
        time_s: t0.elapsed().as_secs_f64(),
        design: out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spearman_of_monotone_and_reversed_samples() {
        let a = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert!((spearman(&a, &[2.0, 4.0, 8.0, 16.0, 32.0]) - 1.0).abs() < 1e-12);
        assert!((spearman(&a, &[5.0, 4.0, 3.0, 2.0, 1.0]) + 1.0).abs() < 1e-12);
        // Ties get average ranks: [1, 1, 2] ranks as [0.5, 0.5, 2].
        assert_eq!(ranks(&[1.0, 1.0, 2.0]), vec![0.5, 0.5, 2.0]);
    }
}
