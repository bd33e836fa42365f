//! The default method: the most accurate reconstruction method that keeps within a
//! per-frame time budget **on the mean**, decided from the problem alone.
//!
//! Methods are tried in order of accuracy ([`PREFERENCE`], from the `reconstruct`
//! study's protocol and scaling tables, docs/array.md). Each is judged by an
//! *estimated* mean time per frame, not a timed one: the work it does on probe
//! frames synthesised from the matrix ([`synthetic_probe_frames`]: 1 to K loads in
//! the rated range, the stated noise; seeded, so the same matrix always gives the
//! same frames) — supports enumerated, `bnb` work units, OMP atoms, coordinate
//! sweeps, Lawson–Hanson steps, and the frame test's own work — converted with
//! per-operation costs measured once on the reference machine by a calibration
//! benchmark ([`estimated_frame_ns`]; `studies/examples/reconstruct_cost.rs`,
//! docs/array.md §10.3). The first method whose mean estimate is within the budget
//! is taken. `bnb` over the budget gets the work budget at which its *mean* fits
//! (most frames finish far below it; the few that would need more stop there,
//! best support found, not certified). Where `support` is within the budget, `bnb`
//! is taken instead when it completed on every probe frame with a smaller estimate
//! (the same objective, so the same loads, faster). If no method is within the
//! budget, the one with the smallest estimate is taken and the choice says so: an
//! array is never refused because the budget is tight.
//!
//! The choice is deterministic and independent of the frames: the same matrix and
//! settings give the same method on any machine, under any load, whatever frames a
//! stream starts with (a choice probed on twelve frames of the data flipped with the
//! frames it happened to draw). Data the probe frames did not foresee (overloads
//! that make every support need a bounded solve) are caught while the stream runs:
//! the run's guard ([`crate::reconstruct::StreamRun`]) moves to
//! [`cheaper_settings`] when the mean estimate over the frames exceeds the budget.

use super::methods::{
    build, BnbSettings, Method, MethodSettings, ReadingSettings, Reconstruction, Reconstructor,
};
use super::problem::SensingProblem;
use super::trust::FrameTest;
use super::ArrayError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::time::Instant;

/// Per-frame budget used when none is given, µs (10 000 frames/s on one thread).
pub const DEFAULT_BUDGET_US: f64 = 100.0;

/// Methods in order of accuracy, most accurate first. `support` and `bnb` minimise
/// the same objective (identical answers when `bnb` completes); the enumeration comes
/// first because it never stops at a budget. `de` is never chosen automatically (the
/// slowest method, and less accurate than `bnb` from 8 × 16 on).
pub const PREFERENCE: [Method; 6] = [
    Method::WeightedSupport,
    Method::Support,
    Method::BranchAndBound,
    Method::Lasso,
    Method::Omp,
    Method::Nnls,
];

/// Probe frames synthesised per choice.
const PROBE_FRAMES: usize = 48;

/// Cost of one support per frame, ns, by method and array (enumeration methods):
/// the support's fit is O(m·k), so the cost grows with the gratings. Fitted on the
/// calibration benchmark (docs/array.md §10.3).
fn ns_per_support(method: Method, m: usize) -> Option<f64> {
    let mf = m as f64;
    if method == Method::Support {
        Some(2.0 + 0.6 * mf)
    } else if method == Method::WeightedSupport {
        Some(20.0 + 40.0 * mf)
    } else {
        None
    }
}

/// ns per `bnb` work unit (one leaf valued, or ~8 multiply-adds of a push or of a
/// relaxation step) with n cells: 2.5 + 240/n, fitted to 17, 10.5, 5.5, 4.2 and
/// 4.0 ns measured at 8 × 16, 12 × 32, 16 × 64, 24 × 128 and 32 × 256 (longer
/// vectors cost less per multiply-add; docs/array.md §10.3).
pub(crate) fn ns_per_bnb_unit(n: usize) -> f64 {
    2.5 + 240.0 / n.max(1) as f64
}

/// Estimated time of the frame test ([`crate::trust`]) for an answer of `loads`
/// loads on m gratings × n cells, ns: the weighted matrix and the Gram rows of the
/// answer's cells (m·n·(k + 2) multiply-adds), the one-cell neighbourhood's
/// Cholesky updates (n·k³) and a part per load (the exact fits that pass the screen,
/// each rival fitted twice: on the frame and on the answer's prediction). Fitted by
/// the calibration benchmark (`studies/examples/reconstruct_cost.rs`, `bnb` on the
/// scaling study's 8 × 16, 12 × 32, 16 × 64 and 32 × 256 frames, answers of 1–4
/// loads): within 25 % of the measured test there (the coefficients before the
/// rival test fitted each rival twice, 1.2 / 1.5 / 1 500 / 400, were 1.15–2.3×
/// under it).
pub fn estimated_test_ns(m: usize, n: usize, loads: usize) -> f64 {
    let (mf, nf, k) = (m as f64, n as f64, loads as f64);
    2.7 * mf * nf * (k + 2.0) + 0.8 * nf * (k + 1.0).powi(3) + 900.0 + 1000.0 * k
}

/// Estimated time of one frame's method on the reference machine (the project's
/// 2-core machine, one thread), ns, from the work `iterations` it reported:
/// `bnb` work units × [`ns_per_bnb_unit`]; OMP (atoms + 1) × n·m × 6 ns + 5 µs;
/// `lasso` sweeps × n × 4.5 ns + n·m × 2 ns; `nnls` steps × n·m × 2.5 ns + 1 µs; `de`
/// generations × population × n·m × 1 ns; the enumerations their supports (bounded
/// solves counted in) × the cost of one support. Fitted on the scaling study's
/// arrays (6 × 8 to 32 × 256) by the calibration benchmark; each within about
/// 1.5× of the measured time per frame there. Without the frame test: see
/// [`estimated_frame_ns`].
pub fn estimated_ns_per_frame(
    method: Method,
    settings: &MethodSettings,
    m: usize,
    n: usize,
    iterations: u64,
) -> f64 {
    let (mf, nf, it) = (m as f64, n as f64, iterations as f64);
    if let Some(ns) = ns_per_support(method, m) {
        it.max(support_count(n, settings.max_loads().unwrap_or(m).min(m))) * ns
    } else if method == Method::BranchAndBound {
        it * ns_per_bnb_unit(n)
    } else if method == Method::Omp {
        (it + 1.0) * nf * mf * 6.0 + 5e3
    } else if method == Method::Lasso {
        it * nf * 4.5 + nf * mf * 2.0
    } else if method == Method::Nnls {
        it.max(1.0) * nf * mf * 2.5 + 1e3
    } else if let MethodSettings::De(de) = settings {
        it * de.population as f64 * nf * mf
    } else {
        // A method without a calibrated cost: one n·m pass per iteration.
        it.max(1.0) * nf * mf
    }
}

/// Estimated time of one frame on the reference machine, ns: its method's
/// ([`estimated_ns_per_frame`], from the work it reported) and the frame test's
/// ([`estimated_test_ns`], from its loads). What the choice and the stream's
/// budget guard add up.
pub fn estimated_frame_ns(
    settings: &MethodSettings,
    m: usize,
    n: usize,
    r: &Reconstruction,
) -> f64 {
    let loads = r.loads_g.iter().filter(|&&v| v > 0.0).count();
    estimated_ns_per_frame(settings.method(), settings, m, n, r.iterations)
        + estimated_test_ns(m, n, loads)
}

/// What happened to one candidate method.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    /// Method name.
    pub method: Method,
    /// `picked`, `over budget`, `not applicable`, `estimated over budget`, or for
    /// `support` against `bnb`: `same answers, slower` (support left for `bnb`),
    /// `slower or incomplete` (`bnb` not preferred).
    pub status: &'static str,
    /// Estimated mean time per frame on the reference machine, µs (method and
    /// frame test, over the probe frames): what the choice is made on.
    pub probe_us_per_frame: Option<f64>,
    /// Median measured time per probe frame here, µs (one thread), when it was run:
    /// for information only, the choice does not depend on it.
    pub measured_us_per_frame: Option<f64>,
    /// Time to build it (precomputation for the matrix), ms, when it was built.
    pub setup_ms: Option<f64>,
    /// Why, in words.
    pub note: String,
}

/// The chosen method, its reconstructor (already built) and the reasons.
pub struct MethodChoice {
    /// The method picked.
    pub method: Method,
    /// Its reconstructor, built for the problem (reuse it: building is the set-up).
    pub reconstructor: Box<dyn Reconstructor>,
    /// The settings it was built with.
    pub settings: MethodSettings,
    /// The budget, µs per frame.
    pub budget_us: f64,
    /// One sentence: which method and why.
    pub reason: String,
    /// Every method considered, in order.
    pub candidates: Vec<Candidate>,
}

/// Frames synthesised from the matrix, the same for the same problem: for 1 to K
/// loads in turn, cells drawn at random with loads uniform over the rated range
/// (min_load, or a tenth of ulimit, to ulimit), read with the stated noise (the
/// interrogator resolution, Gaussian) and the paper's ± 4 % additivity on
/// multi-load frames (seeded).
pub fn synthetic_probe_frames(problem: &SensingProblem, max_loads: usize) -> Vec<Vec<f64>> {
    let (m, n) = (problem.n_gratings(), problem.n_cells());
    let a = &problem.sensitivity_pm_per_g;
    let sigma = problem.uncertainty.resolution_pm;
    let lo = if problem.min_load_g > 0.0 {
        problem.min_load_g
    } else {
        0.1 * problem.ulimit_g
    };
    let mut rng = ChaCha8Rng::seed_from_u64(0x00C4_0105);
    let kmax = max_loads.clamp(1, n.min(m));
    (0..PROBE_FRAMES)
        .map(|f| {
            let k = 1 + f % kmax;
            let mut x = vec![0.0; n];
            let mut placed = 0;
            while placed < k {
                let j = rng.random_range(0..n);
                if x[j] == 0.0 {
                    x[j] = rng.random_range(lo..=problem.ulimit_g);
                    placed += 1;
                }
            }
            (0..m)
                .map(|i| {
                    let clean: f64 = (0..n).map(|j| a[(i, j)] * x[j]).sum();
                    let add = if k >= 2 {
                        0.04 * rng.random_range(-1.0..1.0)
                    } else {
                        0.0
                    };
                    let (u1, u2): (f64, f64) = (1.0 - rng.random::<f64>(), rng.random::<f64>());
                    let gauss = (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
                    clean * (1.0 + add) + sigma * gauss
                })
                .collect()
        })
        .collect()
}

/// Number of supports of 1 to K cells: Σ C(n, k).
fn support_count(n: usize, kmax: usize) -> f64 {
    let mut count = 0.0;
    let mut binom = 1.0;
    for k in 1..=kmax.min(n) {
        binom = binom * (n + 1 - k) as f64 / k as f64;
        count += binom;
    }
    count
}

/// What running a candidate on the probe frames gave.
struct Probe {
    /// Mean estimated time per frame on the reference machine (method and test), µs.
    estimate_us: f64,
    /// Per frame: the method's work and the test's estimated ns.
    works: Vec<(f64, f64)>,
    /// Mean work per frame (the method's `iterations`).
    mean_work: f64,
    /// Median measured time per frame here, µs (information only).
    measured_us: f64,
    /// Frames where the method reported no convergence (`bnb`: work budget reached).
    stopped: usize,
    frames: usize,
}

fn probe_frames(
    r: &dyn Reconstructor,
    settings: &MethodSettings,
    test: &FrameTest,
    (m, n): (usize, usize),
    frames: &[Vec<f64>],
) -> Probe {
    let (mut estimates, mut works, mut times) = (Vec::new(), Vec::new(), Vec::new());
    let mut stopped = 0usize;
    for y in frames {
        let t = Instant::now();
        let mut rec = r.reconstruct(y);
        test.assess(y, &mut rec);
        times.push(1e6 * t.elapsed().as_secs_f64());
        let loads = rec.loads_g.iter().filter(|&&v| v > 0.0).count();
        estimates.push(1e-3 * estimated_frame_ns(settings, m, n, &rec));
        works.push((rec.iterations as f64, estimated_test_ns(m, n, loads)));
        if !rec.converged {
            stopped += 1;
        }
    }
    Probe {
        frames: frames.len(),
        estimate_us: estimates.iter().sum::<f64>() / estimates.len().max(1) as f64,
        mean_work: works.iter().map(|w| w.0).sum::<f64>() / works.len().max(1) as f64,
        works,
        measured_us: median(times),
        stopped,
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return f64::INFINITY;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The array's default method for readings of this kind (`prior`: load cap and
/// interrogator resolution): [`choose_method`] with each method's settings for the
/// prior ([`MethodSettings::for_prior`]). Callers outside this module reach it
/// through [`crate::reconstruct()`], the one place a method is picked.
pub fn default_choice(
    problem: &SensingProblem,
    prior: &ReadingSettings,
    budget_us: f64,
) -> Result<MethodChoice, ArrayError> {
    prior.check()?;
    let settings_for = |m: Method| MethodSettings::for_prior(m, prior);
    choose_method(problem, prior, &settings_for, budget_us)
}

/// A per-frame time budget must be a positive, finite time in µs.
pub fn check_budget(budget_us: f64) -> Result<(), ArrayError> {
    if budget_us.is_finite() && budget_us > 0.0 {
        Ok(())
    } else {
        Err(ArrayError::Input(format!(
            "the per-frame budget must be a positive time in µs, got {budget_us}"
        )))
    }
}

/// Choose the default method for `problem`: the first of [`PREFERENCE`] whose mean
/// estimated time per probe frame is within `budget_us` (`support` giving way to
/// `bnb` where that is faster and complete on the probe frames), else the one with the
/// smallest estimate; `settings_for` gives each method's settings (penalty, max
/// loads). Deterministic: it reads no clock and no frame of the caller's.
pub fn choose_method(
    problem: &SensingProblem,
    prior: &ReadingSettings,
    settings_for: &dyn Fn(Method) -> MethodSettings,
    budget_us: f64,
) -> Result<MethodChoice, ArrayError> {
    check_budget(budget_us)?;
    let mut chooser = Chooser::new(problem, budget_us, prior.max_loads);
    for method in PREFERENCE {
        if let Some(choice) = chooser.try_method(method, settings_for(method)) {
            if method == Method::Support {
                return Ok(chooser.prefer_bnb(choice, settings_for(Method::BranchAndBound)));
            }
            return Ok(choice);
        }
    }
    chooser.cheapest_choice()
}

/// The cheaper settings a stream moves to when the mean estimate of `settings`
/// came out at `mean_us`, over `budget_us` (the run's guard): `bnb` with a work
/// budget fitted to the budget (scaled down from its own when it was `bnb`
/// already), and why; None when nothing cheaper is left.
pub fn cheaper_settings(
    problem: &SensingProblem,
    settings: &MethodSettings,
    budget_us: f64,
    mean_us: f64,
) -> Option<(MethodSettings, String)> {
    let n = problem.n_cells();
    let m = problem.n_gratings();
    let test_us = 1e-3 * estimated_test_ns(m, n, settings.max_loads().unwrap_or(4).min(m));
    let room_us = (0.9 * budget_us - test_us).max(0.1 * budget_us);
    let fitted = (room_us * 1e3 / ns_per_bnb_unit(n)).floor().max(50.0) as u64;
    match settings {
        MethodSettings::BranchAndBound(b) => {
            let scaled = ((b.node_budget as f64) * 0.9 * budget_us / mean_us).floor() as u64;
            let units = scaled.min(fitted).max(50);
            (units < b.node_budget).then(|| {
                (
                    MethodSettings::BranchAndBound(BnbSettings {
                        node_budget: units,
                        ..*b
                    }),
                    format!("bnb's work budget lowered to {units} units"),
                )
            })
        }
        MethodSettings::Support(s) => Some((
            MethodSettings::BranchAndBound(BnbSettings {
                penalty: s.penalty,
                max_loads: s.max_loads,
                node_budget: fitted,
            }),
            format!("moved to bnb (support's objective) with a work budget of {fitted} units"),
        )),
        MethodSettings::WeightedSupport(w) => Some((
            MethodSettings::BranchAndBound(BnbSettings {
                max_loads: w.max_loads,
                node_budget: fitted,
                ..BnbSettings::for_prior(&ReadingSettings {
                    max_loads: w.max_loads,
                    resolution_pm: problem.uncertainty.resolution_pm,
                })
            }),
            format!("moved to bnb with a work budget of {fitted} units"),
        )),
        _ => None,
    }
}

/// The cheapest estimate so far, in case none meets the budget: candidate index,
/// estimate (µs), reconstructor and settings. (An enumeration over budget is not
/// built unless it is that one.)
type Cheapest = (usize, f64, Option<Box<dyn Reconstructor>>, MethodSettings);

/// A candidate built and run on the probe frames.
struct Built {
    /// Its reconstructor.
    r: Box<dyn Reconstructor>,
    /// The settings it was built with (`bnb`: perhaps a fitted work budget).
    settings: MethodSettings,
    /// Time spent building, ms.
    setup_ms: f64,
    /// What the probe frames gave.
    p: Probe,
    /// "work budget … to fit the time budget; " when `bnb` was refitted, else empty.
    fitted: String,
}

/// The state of the choice while the methods are tried in order.
struct Chooser<'a> {
    problem: &'a SensingProblem,
    test: FrameTest,
    budget_us: f64,
    /// The probe frames, synthesised from the matrix.
    frames: Vec<Vec<f64>>,
    m: usize,
    n: usize,
    candidates: Vec<Candidate>,
    cheapest: Option<Cheapest>,
}

impl<'a> Chooser<'a> {
    /// Synthesise the probe frames (up to `max_loads` loads) and start with no
    /// candidates.
    fn new(problem: &'a SensingProblem, budget_us: f64, max_loads: usize) -> Self {
        Chooser {
            problem,
            test: FrameTest::new(problem, max_loads),
            budget_us,
            frames: synthetic_probe_frames(problem, max_loads),
            m: problem.n_gratings(),
            n: problem.n_cells(),
            candidates: Vec::new(),
            cheapest: None,
        }
    }

    /// The test's mean estimate over frames of `loads` loads (for an enumeration,
    /// which is not run), µs.
    fn test_us(&self, kmax: usize) -> f64 {
        let k = kmax.div_ceil(2).max(1);
        1e-3 * estimated_test_ns(self.m, self.n, k)
    }

    /// Judge one method; the choice if it is within the budget.
    fn try_method(&mut self, method: Method, settings: MethodSettings) -> Option<MethodChoice> {
        let kmax = settings
            .max_loads()
            .unwrap_or(self.m)
            .min(self.m)
            .min(self.n);
        // An enumeration does the same work on every frame: no need to run it.
        let enumeration =
            ns_per_support(method, self.m).map(|ns| (support_count(self.n, kmax), ns));
        if let Some((count, ns)) = enumeration {
            let estimate_us = 1e-3 * count * ns + self.test_us(kmax);
            if estimate_us > self.budget_us {
                self.enumeration_over_budget(method, settings, (count, ns), kmax, estimate_us);
                return None;
            }
        }
        match self.build_and_probe(settings) {
            Ok(built) => self.judge_probed(method, built, enumeration),
            Err(e) => {
                self.candidates.push(Candidate {
                    method,
                    status: "not applicable",
                    probe_us_per_frame: None,
                    measured_us_per_frame: None,
                    setup_ms: None,
                    note: e.to_string(),
                });
                None
            }
        }
    }

    /// `support` was picked: take `bnb` instead when it minimises the same objective
    /// faster. It must have completed on every probe frame (so its answers there are
    /// `support`'s) with a smaller mean estimate; else `support` stays.
    fn prefer_bnb(&mut self, support: MethodChoice, settings: MethodSettings) -> MethodChoice {
        let mut support = support;
        let Some(support_us) = support.candidates.last().and_then(|c| c.probe_us_per_frame) else {
            return support;
        };
        let Ok(built) = self.build_and_probe(settings) else {
            return support;
        };
        let Built {
            r,
            settings,
            setup_ms,
            p,
            ..
        } = built;
        let us = p.estimate_us;
        let faster = p.stopped == 0 && us < support_us;
        let work = work_summary(Method::BranchAndBound, None, &p, self.n);
        support.candidates.push(Candidate {
            method: Method::BranchAndBound,
            status: if faster {
                "picked"
            } else {
                "slower or incomplete"
            },
            probe_us_per_frame: Some(us),
            measured_us_per_frame: Some(p.measured_us),
            setup_ms: Some(setup_ms),
            note: format!(
                "the same objective as support; estimated {us:.1} µs per frame ({work}, {} synthetic probe frames; measured here {:.1} µs){}",
                p.frames,
                p.measured_us,
                stopped_note(Method::BranchAndBound, &p)
            ),
        });
        if !faster {
            return support;
        }
        let n_c = support.candidates.len();
        support.candidates[n_c - 2].status = "same answers, slower";
        let (budget_us, m, n) = (self.budget_us, self.m, self.n);
        MethodChoice {
            method: Method::BranchAndBound,
            reconstructor: r,
            settings,
            budget_us,
            reason: format!(
                "bnb minimises support's objective (the same answers when it completes, as it did on all {} synthetic probe frames) in less time: estimated {us:.1} µs per frame against support's {support_us:.1} µs on the reference machine for {m} gratings × {n} cells ({work}), within {budget_us} µs{}",
                p.frames,
                skipped_summary(
                    &support.candidates[..n_c - 2],
                    "more accurate but over budget"
                )
            ),
            candidates: support.candidates,
        }
    }

    /// Record an enumeration whose estimate is over the budget, without building it.
    fn enumeration_over_budget(
        &mut self,
        method: Method,
        settings: MethodSettings,
        (count, ns): (f64, f64),
        kmax: usize,
        estimate_us: f64,
    ) {
        self.candidates.push(Candidate {
            method,
            status: "estimated over budget",
            probe_us_per_frame: Some(estimate_us),
            measured_us_per_frame: None,
            setup_ms: None,
            note: format!(
                "{count:.0} supports of up to {kmax} loads × {ns} ns: ~{estimate_us:.0} µs per frame"
            ),
        });
        if self
            .cheapest
            .as_ref()
            .is_none_or(|(_, t, _, _)| estimate_us < *t)
        {
            self.cheapest = Some((self.candidates.len() - 1, estimate_us, None, settings));
        }
    }

    /// Build a method and run it on the probe frames (`bnb` over the budget: its
    /// work budget fitted).
    fn build_and_probe(&self, settings: MethodSettings) -> Result<Built, ArrayError> {
        let t0 = Instant::now();
        let r = build(self.problem, &settings)?;
        let setup_ms = 1e3 * t0.elapsed().as_secs_f64();
        let p = self.probe(r.as_ref(), &settings);
        let mut built = Built {
            r,
            settings,
            setup_ms,
            p,
            fitted: String::new(),
        };
        if built.p.estimate_us > self.budget_us {
            self.fit_bnb_budget(&mut built);
        }
        Ok(built)
    }

    fn probe(&self, r: &dyn Reconstructor, settings: &MethodSettings) -> Probe {
        probe_frames(r, settings, &self.test, (self.m, self.n), &self.frames)
    }

    /// `bnb` over the budget: the work budget at which its **mean** over the probe
    /// frames fits (most frames finish below it and leave room for those that stop
    /// at it, best support found, not certified). Found on the probe frames' work,
    /// then checked by probing again (scaled down, at most three times, until the
    /// mean fits). Any other method is left as it is.
    fn fit_bnb_budget(&self, built: &mut Built) {
        let MethodSettings::BranchAndBound(bnb) = built.settings else {
            return;
        };
        let unit = ns_per_bnb_unit(self.n);
        let target_ns = 0.95 * self.budget_us * 1e3;
        let mean_at = |cap: f64| -> f64 {
            let w = &built.p.works;
            w.iter()
                .map(|(work, test)| work.min(cap) * unit + test)
                .sum::<f64>()
                / w.len().max(1) as f64
        };
        // The mean is non-decreasing in the cap: bisect for the largest that fits.
        let (mut lo, mut hi) = (50.0f64, bnb.node_budget as f64);
        if mean_at(lo) > target_ns {
            hi = lo;
        }
        for _ in 0..60 {
            if hi - lo <= 1.0 {
                break;
            }
            let mid = 0.5 * (lo + hi);
            if mean_at(mid) <= target_ns {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut units = lo.floor().max(50.0) as u64;
        for _ in 0..3 {
            if units >= bnb.node_budget {
                return;
            }
            let settings = MethodSettings::BranchAndBound(BnbSettings {
                node_budget: units,
                ..bnb
            });
            let t1 = Instant::now();
            let Ok(rb) = build(self.problem, &settings) else {
                return;
            };
            built.setup_ms += 1e3 * t1.elapsed().as_secs_f64();
            built.p = self.probe(rb.as_ref(), &settings);
            built.settings = settings;
            built.r = rb;
            built.fitted =
                format!("work budget {units} units to fit the time budget on the mean; ");
            if built.p.estimate_us <= self.budget_us || units <= 50 {
                return;
            }
            units = ((units as f64) * 0.95 * self.budget_us / built.p.estimate_us)
                .floor()
                .max(50.0) as u64;
        }
    }

    /// Record a probed candidate; the choice if its estimate is within the budget.
    fn judge_probed(
        &mut self,
        method: Method,
        built: Built,
        enumeration: Option<(f64, f64)>,
    ) -> Option<MethodChoice> {
        let Built {
            r,
            settings,
            setup_ms,
            p,
            fitted,
        } = built;
        let us = p.estimate_us;
        let within = us <= self.budget_us;
        let work = work_summary(method, enumeration, &p, self.n);
        let note = format!(
            "{fitted}estimated {us:.1} µs per frame ({work}, {} synthetic probe frames; measured here {:.1} µs){}",
            p.frames,
            p.measured_us,
            stopped_note(method, &p)
        );
        self.candidates.push(Candidate {
            method,
            status: if within { "picked" } else { "over budget" },
            probe_us_per_frame: Some(us),
            measured_us_per_frame: Some(p.measured_us),
            setup_ms: Some(setup_ms),
            note,
        });
        if within {
            let (budget_us, m, n) = (self.budget_us, self.m, self.n);
            let reason = format!(
                "{} is the most accurate method within {budget_us} µs per frame on the mean for {m} gratings × {n} cells ({fitted}estimated {us:.1} µs per frame on the reference machine from its operation count and the frame test's: {work}, {} synthetic probe frames){}",
                method.name(),
                p.frames,
                skipped_summary(&self.candidates, "more accurate but over budget")
            );
            return Some(MethodChoice {
                method,
                reconstructor: r,
                settings,
                budget_us,
                reason,
                candidates: std::mem::take(&mut self.candidates),
            });
        }
        if self.cheapest.as_ref().is_none_or(|(_, t, _, _)| us < *t) {
            self.cheapest = Some((self.candidates.len() - 1, us, Some(r), settings));
        }
        None
    }

    /// No method met the budget: the one with the smallest estimate, built if need be.
    fn cheapest_choice(self) -> Result<MethodChoice, ArrayError> {
        let Chooser {
            problem,
            budget_us,
            m,
            n,
            mut candidates,
            cheapest,
            ..
        } = self;
        let Some((idx, us, r, settings)) = cheapest else {
            return Err(ArrayError::Input(
                "no reconstruction method could be built for this matrix".into(),
            ));
        };
        let method = candidates[idx].method;
        let r = match r {
            Some(r) => r,
            None => {
                let t0 = Instant::now();
                let r = build(problem, &settings)?;
                candidates[idx].setup_ms = Some(1e3 * t0.elapsed().as_secs_f64());
                r
            }
        };
        candidates[idx].status = "picked";
        let reason = format!(
            "no method met {budget_us} µs per frame for {m} gratings × {n} cells; {} has the smallest estimate ({us:.1} µs per frame on the reference machine, from its operation count on the probe frames){}",
            method.name(),
            skipped_summary(&candidates, "the others")
        );
        Ok(MethodChoice {
            method,
            reconstructor: r,
            settings,
            budget_us,
            reason,
            candidates,
        })
    }
}

/// The work behind an estimate, in words ("… supports × … ns", "mean … iterations").
fn work_summary(method: Method, enumeration: Option<(f64, f64)>, p: &Probe, n: usize) -> String {
    match enumeration {
        Some((count, ns)) => format!("{count:.0} supports × {ns} ns"),
        None if method == Method::BranchAndBound => format!(
            "mean {:.0} work units × {:.2} ns",
            p.mean_work,
            ns_per_bnb_unit(n)
        ),
        None => format!("mean {:.0} iterations", p.mean_work),
    }
}

/// "; stopped at its work budget on …" or "; not converged on …" when frames stopped.
fn stopped_note(method: Method, p: &Probe) -> String {
    if p.stopped > 0 && method == Method::BranchAndBound {
        format!(
            "; stopped at its work budget on {} of {} (best support found, not certified)",
            p.stopped, p.frames
        )
    } else if p.stopped > 0 {
        format!("; not converged on {} of {}", p.stopped, p.frames)
    } else {
        String::new()
    }
}

/// "; <label>: wsupport 900 µs, support (estimated over budget)" for the reason.
fn skipped_summary(candidates: &[Candidate], label: &str) -> String {
    let skipped: Vec<String> = candidates
        .iter()
        .filter(|c| c.status != "picked")
        .map(|c| match c.probe_us_per_frame {
            Some(us) => format!("{} ~{us:.0} µs", c.method.name()),
            None => format!("{} ({})", c.method.name(), c.status),
        })
        .collect();
    if skipped.is_empty() {
        String::new()
    } else {
        format!("; {label}: {}", skipped.join(", "))
    }
}
