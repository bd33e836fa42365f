//! The default method: the most accurate reconstruction method that keeps within a
//! per-frame time budget on this array, on this machine.
//!
//! Methods are tried in order of accuracy ([`PREFERENCE`], from the `reconstruct`
//! study's protocol and scaling tables, docs/array.md). Each is judged by an
//! *estimated* time per frame, not a timed one: the work it does on probe frames —
//! twelve frames spread over the caller's stream, or frames synthesised from the
//! matrix — counted in operations (supports enumerated, `bnb` work units, OMP atoms,
//! coordinate sweeps, Lawson–Hanson steps) and converted with a per-method cost
//! calibrated once on the reference machine ([`estimated_ns_per_frame`]). The first
//! method whose *mean* estimate over the probe frames is within the budget is taken
//! (the budget is kept on average, not only on a typical frame: a search whose work
//! varies from frame to frame, `bnb`, has a mean well above its median on large
//! arrays). `bnb` over the budget is given a work budget that fits it: it then
//! returns its best support at that budget, marked not certified (`unconverged`).
//! Where `support` is picked, `bnb` (the same objective, so the same answers when it
//! completes) is taken instead if it completed on every probe frame with a smaller
//! mean estimate. If no method is within the budget, the one
//! with the smallest estimate is taken and the choice says so: an array is never
//! refused because the budget is tight. Every candidate's fate is reported
//! ([`MethodChoice::candidates`]) so the CLI and JSON can say which method was
//! picked and why.
//!
//! The choice is therefore deterministic: the same matrix and frames give the same
//! method and settings on any machine and under any load (a timed choice flipped
//! `bnb` → `omp` at 24 × 128 between two runs on a busy machine). The budget is
//! read as time on the reference machine; the measured time per probe frame is
//! still reported, for information only.

use super::methods::{build, BnbSettings, Method, MethodSettings, ReadingSettings, Reconstructor};
use super::problem::SensingProblem;
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

/// Probe frames timed per candidate (at most).
const PROBE_FRAMES: usize = 12;

/// Cost of one support per frame, ns (enumeration methods): `support` measured
/// 5–15 ns, `wsupport` 90–140 ns per support up to 8 × 16 (docs/array.md). The
/// enumerations do the same work on every frame, so they are judged without probing.
fn ns_per_support(m: Method) -> Option<f64> {
    if m == Method::Support {
        Some(5.0)
    } else if m == Method::WeightedSupport {
        Some(120.0)
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

/// Estimated time of one frame on the reference machine (the project's 2-core
/// machine, one thread), ns, from the work `iterations` a method reported for it:
/// `bnb` work units × [`ns_per_bnb_unit`]; OMP (atoms + 1) × n·m × 6 ns + 5 µs;
/// `lasso` sweeps × n × 4.5 ns + n·m × 2 ns; `nnls` steps × n·m × 2.5 ns + 1 µs; `de`
/// generations × population × n·m × 1 ns; the enumerations their support count ×
/// the cost of one support. The coefficients were fitted on the scaling study's
/// arrays (6 × 8 to 32 × 256, `studies/examples`-style runs of each method on its
/// frames, best of 3 per frame); each is within about 2× of the measured time per
/// frame there, and they only decide which method to use.
pub fn estimated_ns_per_frame(
    method: Method,
    settings: &MethodSettings,
    m: usize,
    n: usize,
    iterations: u64,
) -> f64 {
    let (mf, nf, it) = (m as f64, n as f64, iterations as f64);
    if let Some(ns) = ns_per_support(method) {
        support_count(n, settings.max_loads().unwrap_or(m).min(m)) * ns
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

/// What happened to one candidate method.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    /// Method name.
    pub method: Method,
    /// `picked`, `over budget`, `not applicable`, `estimated over budget`, or for
    /// `support` against `bnb`: `same answers, slower` (support left for `bnb`),
    /// `slower or incomplete` (`bnb` not preferred).
    pub status: &'static str,
    /// Estimated time per frame on the reference machine, µs: the mean over the
    /// probe frames of [`estimated_ns_per_frame`] (what the choice is made on).
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
    /// Whether the probe frames were the caller's (true) or synthesised (false).
    pub probed_on_data: bool,
}

/// Frames synthesised from the matrix when the caller has none: for 1 to K loads,
/// cells spread over the array with loads of 20–80 % of ulimit, 2 % relative and
/// 0.5 pm absolute noise (deterministic seed).
pub fn synthetic_probe_frames(problem: &SensingProblem, max_loads: usize) -> Vec<Vec<f64>> {
    let (m, n) = (problem.n_gratings(), problem.n_cells());
    let a = &problem.sensitivity_pm_per_g;
    let mut rng = ChaCha8Rng::seed_from_u64(0x00C4_0105);
    let kmax = max_loads.clamp(1, n.min(m));
    (0..PROBE_FRAMES)
        .map(|f| {
            let k = 1 + f % kmax;
            let mut x = vec![0.0; n];
            for _ in 0..k {
                let j = rng.random_range(0..n);
                x[j] = problem.ulimit_g * rng.random_range(0.2..0.8);
            }
            (0..m)
                .map(|i| {
                    let clean: f64 = (0..n).map(|j| a[(i, j)] * x[j]).sum();
                    clean * (1.0 + 0.02 * rng.random_range(-1.0..1.0))
                        + 0.5 * rng.random_range(-1.0..1.0)
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
    /// Mean estimated time per frame on the reference machine, µs.
    estimate_us: f64,
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
    (m, n): (usize, usize),
    frames: &[Vec<f64>],
) -> Probe {
    let (mut estimates, mut works, mut times) = (Vec::new(), Vec::new(), Vec::new());
    let mut stopped = 0usize;
    for y in frames {
        let t = Instant::now();
        let rec = r.reconstruct(y);
        times.push(1e6 * t.elapsed().as_secs_f64());
        estimates.push(1e-3 * estimated_ns_per_frame(r.method(), settings, m, n, rec.iterations));
        works.push(rec.iterations as f64);
        if !rec.converged {
            stopped += 1;
        }
    }
    Probe {
        frames: frames.len(),
        estimate_us: estimates.iter().sum::<f64>() / estimates.len().max(1) as f64,
        mean_work: works.iter().sum::<f64>() / works.len().max(1) as f64,
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
    probe: Option<&[Vec<f64>]>,
) -> Result<MethodChoice, ArrayError> {
    prior.check()?;
    let settings_for = |m: Method| MethodSettings::for_prior(m, prior);
    choose_method(problem, prior, &settings_for, budget_us, probe)
}

/// Choose the default method for `problem`: the first of [`PREFERENCE`] whose mean
/// estimated time per probe frame is within `budget_us` (`support` giving way to
/// `bnb` where that is faster and complete on the probe frames), else the one with the
/// smallest estimate. Deterministic: it does not read the clock to decide.
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

/// `settings_for` gives each method's settings (penalty, max loads); `probe` are the
/// caller's frames (twelve spread over them are timed), or None to synthesise them
/// with up to `prior.max_loads` loads (also when none of the caller's is usable).
pub fn choose_method(
    problem: &SensingProblem,
    prior: &ReadingSettings,
    settings_for: &dyn Fn(Method) -> MethodSettings,
    budget_us: f64,
    probe: Option<&[Vec<f64>]>,
) -> Result<MethodChoice, ArrayError> {
    check_budget(budget_us)?;
    let mut chooser = Chooser::new(problem, budget_us, prior.max_loads, probe);
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

/// Probe frames spread evenly over the caller's stream, unusable frames left out.
fn usable_probe_frames(problem: &SensingProblem, probe: Option<&[Vec<f64>]>) -> Vec<Vec<f64>> {
    // A stream's first frames are often alike (one load, or none), hence the spread.
    let given: Vec<&Vec<f64>> = probe
        .unwrap_or(&[])
        .iter()
        .filter(|y| problem.check_shifts(y).is_ok())
        .collect();
    (0..given.len().min(PROBE_FRAMES))
        .map(|i| given[i * given.len() / given.len().min(PROBE_FRAMES)].clone())
        .collect()
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
    budget_us: f64,
    /// The probe frames: the caller's usable ones, else synthesised.
    frames: Vec<Vec<f64>>,
    probed_on_data: bool,
    /// " of the data" or ", synthetic", for the notes.
    source: &'static str,
    m: usize,
    n: usize,
    candidates: Vec<Candidate>,
    cheapest: Option<Cheapest>,
}

impl<'a> Chooser<'a> {
    /// Pick the probe frames (synthesised with up to `max_loads` loads when the
    /// caller has no usable one) and start with no candidates.
    fn new(
        problem: &'a SensingProblem,
        budget_us: f64,
        max_loads: usize,
        probe: Option<&[Vec<f64>]>,
    ) -> Self {
        let usable = usable_probe_frames(problem, probe);
        let probed_on_data = !usable.is_empty();
        let frames = if probed_on_data {
            usable
        } else {
            synthetic_probe_frames(problem, max_loads)
        };
        Chooser {
            problem,
            budget_us,
            frames,
            probed_on_data,
            source: if probed_on_data {
                " of the data"
            } else {
                ", synthetic"
            },
            m: problem.n_gratings(),
            n: problem.n_cells(),
            candidates: Vec::new(),
            cheapest: None,
        }
    }

    /// Judge one method; the choice if it is within the budget.
    fn try_method(&mut self, method: Method, settings: MethodSettings) -> Option<MethodChoice> {
        let kmax = settings
            .max_loads()
            .unwrap_or(self.m)
            .min(self.m)
            .min(self.n);
        // An enumeration does the same work on every frame: no need to run it.
        let enumeration = ns_per_support(method).map(|ns| (support_count(self.n, kmax), ns));
        if let Some((count, ns)) = enumeration {
            let estimate_us = 1e-3 * count * ns;
            if estimate_us > self.budget_us {
                self.enumeration_over_budget(method, settings, (count, ns), kmax, estimate_us);
                return None;
            }
        }
        match self.build_and_probe(settings, &self.frames) {
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
        let Ok(built) = self.build_and_probe(settings, &self.frames) else {
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
                "the same objective as support; estimated {us:.1} µs per frame ({work}, {} probe frames{}; measured here {:.1} µs){}",
                p.frames,
                self.source,
                p.measured_us,
                stopped_note(Method::BranchAndBound, &p)
            ),
        });
        if !faster {
            return support;
        }
        let n_c = support.candidates.len();
        support.candidates[n_c - 2].status = "same answers, slower";
        let (budget_us, m, n, source) = (self.budget_us, self.m, self.n, self.source);
        MethodChoice {
            method: Method::BranchAndBound,
            reconstructor: r,
            settings,
            budget_us,
            reason: format!(
                "bnb minimises support's objective (the same answers when it completes, as it did on all {} probe frames{source}) in less time: estimated {us:.1} µs per frame against support's {support_us:.1} µs on the reference machine for {m} gratings × {n} cells ({work}), within {budget_us} µs{}",
                p.frames,
                skipped_summary(
                    &support.candidates[..n_c - 2],
                    "more accurate but over budget"
                )
            ),
            candidates: support.candidates,
            probed_on_data: support.probed_on_data,
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

    /// Build a method and run it on the probe frames (`bnb` over the budget: refitted).
    fn build_and_probe(
        &self,
        settings: MethodSettings,
        frames: &[Vec<f64>],
    ) -> Result<Built, ArrayError> {
        let t0 = Instant::now();
        let r = build(self.problem, &settings)?;
        let setup_ms = 1e3 * t0.elapsed().as_secs_f64();
        let p = probe_frames(r.as_ref(), &settings, (self.m, self.n), frames);
        let mut built = Built {
            r,
            settings,
            setup_ms,
            p,
            fitted: String::new(),
        };
        if built.p.estimate_us > self.budget_us {
            self.fit_bnb_budget(&mut built, frames);
        }
        Ok(built)
    }

    /// `bnb` over the budget: give it the work budget that fits, with a margin for
    /// the incumbent's search, which runs before the budget is checked (its answer
    /// is then the best support found, certified only where the search completed).
    /// Any other method is left as it is.
    fn fit_bnb_budget(&self, built: &mut Built, frames: &[Vec<f64>]) {
        let MethodSettings::BranchAndBound(bnb) = built.settings else {
            return;
        };
        let units = (0.7 * self.budget_us * 1e3 / ns_per_bnb_unit(self.n))
            .floor()
            .max(50.0) as u64;
        if units < bnb.node_budget {
            let settings = MethodSettings::BranchAndBound(BnbSettings {
                node_budget: units,
                ..bnb
            });
            let t1 = Instant::now();
            if let Ok(rb) = build(self.problem, &settings) {
                built.settings = settings;
                built.setup_ms += 1e3 * t1.elapsed().as_secs_f64();
                built.r = rb;
                built.p = probe_frames(built.r.as_ref(), &built.settings, (self.m, self.n), frames);
                built.fitted = format!("work budget {units} units to fit the time budget; ");
            }
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
            "{fitted}estimated {us:.1} µs per frame ({work}, {} probe frames{}; measured here {:.1} µs){}",
            p.frames,
            self.source,
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
            let (budget_us, m, n, source) = (self.budget_us, self.m, self.n, self.source);
            let reason = format!(
                "{} is the most accurate method within {budget_us} µs per frame for {m} gratings × {n} cells ({fitted}estimated {us:.1} µs per frame on the reference machine from its operation count: {work}, {} probe frames{source}){}",
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
                probed_on_data: self.probed_on_data,
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
            probed_on_data,
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
            probed_on_data,
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
