//! The default method: the most accurate reconstruction method that keeps within a
//! per-frame time budget on this array, on this machine.
//!
//! Methods are tried in order of accuracy ([`PREFERENCE`], from the `reconstruct`
//! study's protocol and scaling tables, docs/array.md). For each, a cheap estimate
//! first rules out the hopeless (an enumeration of too many supports is not even
//! built); the others are built and timed on probe frames — twelve frames spread
//! over the caller's stream, or frames synthesised from the matrix — and the first
//! whose median time
//! per frame is within the budget is taken. If none is, the fastest one measured is
//! taken and the choice says so: an array is never refused because the budget is
//! tight. Every candidate's fate is reported ([`MethodChoice::candidates`]) so the
//! CLI and JSON can say which method was picked and why.
//!
//! Timing makes the choice depend on the machine and its load near the budget; pass
//! a method explicitly for a reproducible run.

use super::methods::{build, Method, MethodSettings, Reconstructor};
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

/// Optimistic cost of one support per frame, ns (enumeration methods), used only to
/// skip building an enumeration that cannot meet the budget: `support` measured
/// 10–15 ns, `wsupport` 100–200 ns per support (docs/array.md).
fn ns_per_support(m: Method) -> Option<f64> {
    if m == Method::Support {
        Some(5.0)
    } else if m == Method::WeightedSupport {
        Some(50.0)
    } else {
        None
    }
}

/// What happened to one candidate method.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    /// Method name.
    pub method: Method,
    /// `picked`, `over budget`, `not applicable`, `estimated over budget` or `not tried`.
    pub status: &'static str,
    /// Median time per probe frame, µs (one thread), when it was timed.
    pub probe_us_per_frame: Option<f64>,
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

/// What timing a candidate on the probe frames gave.
struct Probe {
    median_us: f64,
    /// Frames where the method reported no convergence (`bnb`: node budget reached).
    stopped: usize,
    frames: usize,
    /// Iterations (for `bnb`: nodes) per µs over the probe.
    nodes_per_us: f64,
}

fn probe_frames(r: &dyn Reconstructor, frames: &[Vec<f64>], budget_us: f64) -> Probe {
    let mut times = Vec::with_capacity(frames.len());
    let (mut stopped, mut nodes, mut total_us) = (0usize, 0u64, 0.0f64);
    for y in frames {
        let t = Instant::now();
        let rec = r.reconstruct(y);
        let us = 1e6 * t.elapsed().as_secs_f64();
        times.push(us);
        total_us += us;
        nodes += rec.iterations;
        if !rec.converged {
            stopped += 1;
        }
        // A method already far over the budget need not finish the probe.
        if times.len() >= 3 && median(times.clone()) > 20.0 * budget_us {
            break;
        }
    }
    Probe {
        frames: times.len(),
        median_us: median(times),
        stopped,
        nodes_per_us: if total_us > 0.0 {
            nodes as f64 / total_us
        } else {
            0.0
        },
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

/// The array's default method, as every caller without a named method gets it
/// (`reconstruct`, the live mode, the Python binding): [`choose_method`] with each
/// method's default settings under a cap of `max_loads` simultaneous loads.
pub fn default_choice(
    problem: &SensingProblem,
    max_loads: usize,
    budget_us: f64,
    probe: Option<&[Vec<f64>]>,
) -> Result<MethodChoice, ArrayError> {
    let settings_for = |m: Method| MethodSettings {
        max_loads,
        ..MethodSettings::for_method(m)
    };
    choose_method(problem, &settings_for, budget_us, probe)
}

/// Choose the default method for `problem`: the first of [`PREFERENCE`] whose median
/// time per probe frame is within `budget_us`, else the fastest one measured.
/// `settings_for` gives each method's settings (penalty, max loads); `probe` are the
/// caller's frames (twelve spread over them are timed), or None to synthesise them.
pub fn choose_method(
    problem: &SensingProblem,
    settings_for: &dyn Fn(Method) -> MethodSettings,
    budget_us: f64,
    probe: Option<&[Vec<f64>]>,
) -> Result<MethodChoice, ArrayError> {
    if !(budget_us.is_finite() && budget_us > 0.0) {
        return Err(ArrayError::Input(format!(
            "the per-frame budget must be a positive time in µs, got {budget_us}"
        )));
    }
    // Probe frames spread evenly over the caller's stream (a stream's first frames
    // are often alike: one load, or none), unusable frames left out.
    let given: Vec<&Vec<f64>> = probe
        .unwrap_or(&[])
        .iter()
        .filter(|y| problem.check_shifts(y).is_ok())
        .collect();
    let usable: Vec<Vec<f64>> = (0..given.len().min(PROBE_FRAMES))
        .map(|i| given[i * given.len() / given.len().min(PROBE_FRAMES)].clone())
        .collect();
    let probed_on_data = !usable.is_empty();
    let (m, n) = (problem.n_gratings(), problem.n_cells());
    let mut candidates: Vec<Candidate> = Vec::new();
    // The fastest built so far, in case none meets the budget.
    let mut fastest: Option<(usize, f64, Box<dyn Reconstructor>, MethodSettings)> = None;
    for method in PREFERENCE {
        let settings = settings_for(method);
        let frames = if probed_on_data {
            usable.clone()
        } else {
            synthetic_probe_frames(problem, settings.max_loads)
        };
        if let Some(ns) = ns_per_support(method) {
            let count = support_count(n, settings.max_loads.min(m));
            let estimate_us = count * ns * 1e-3;
            if estimate_us > budget_us {
                candidates.push(Candidate {
                    method,
                    status: "estimated over budget",
                    probe_us_per_frame: None,
                    setup_ms: None,
                    note: format!(
                        "{count:.0} supports of up to {} loads: at least ~{estimate_us:.0} µs per frame",
                        settings.max_loads.min(m).min(n)
                    ),
                });
                continue;
            }
        }
        let t0 = Instant::now();
        let r = match build(method, problem, settings) {
            Ok(r) => r,
            Err(e) => {
                candidates.push(Candidate {
                    method,
                    status: "not applicable",
                    probe_us_per_frame: None,
                    setup_ms: None,
                    note: e.to_string(),
                });
                continue;
            }
        };
        let mut setup_ms = 1e3 * t0.elapsed().as_secs_f64();
        let mut r = r;
        let mut settings = settings;
        let mut p = probe_frames(r.as_ref(), &frames, budget_us);
        // `bnb` over the budget: give it the node budget that fits (its answer is then
        // the best support found, certified only where the search completed).
        let mut fitted = String::new();
        if method == Method::BranchAndBound && p.median_us > budget_us && p.nodes_per_us > 0.0 {
            let nodes = (0.7 * budget_us * p.nodes_per_us).floor().max(50.0) as u64;
            if nodes < settings.node_budget {
                settings.node_budget = nodes;
                let t1 = Instant::now();
                if let Ok(rb) = build(method, problem, settings) {
                    setup_ms += 1e3 * t1.elapsed().as_secs_f64();
                    r = rb;
                    p = probe_frames(r.as_ref(), &frames, budget_us);
                    fitted = format!("node budget {nodes} to fit the time budget; ");
                }
            }
        }
        let us = p.median_us;
        let stopped = p.stopped;
        let within = us <= budget_us;
        let note = format!(
            "{fitted}median {us:.1} µs per probe frame ({} frames{}){}",
            frames.len(),
            if probed_on_data {
                " of the data"
            } else {
                ", synthetic"
            },
            if stopped > 0 && method == Method::BranchAndBound {
                format!(
                    "; stopped at its node budget on {stopped} of {} (best support found, not certified)",
                    p.frames
                )
            } else if stopped > 0 {
                format!("; not converged on {stopped} of {}", p.frames)
            } else {
                String::new()
            }
        );
        candidates.push(Candidate {
            method,
            status: if within { "picked" } else { "over budget" },
            probe_us_per_frame: Some(us),
            setup_ms: Some(setup_ms),
            note,
        });
        if within {
            let reason = format!(
                "{} is the most accurate method within {budget_us} µs per frame for {m} gratings × {n} cells ({us:.1} µs per probe frame){}",
                method.name(),
                skipped_summary(&candidates, "more accurate but over budget")
            );
            return Ok(MethodChoice {
                method,
                reconstructor: r,
                settings,
                budget_us,
                reason,
                candidates,
                probed_on_data,
            });
        }
        if fastest.as_ref().is_none_or(|(_, t, _, _)| us < *t) {
            fastest = Some((candidates.len() - 1, us, r, settings));
        }
    }
    let Some((idx, us, r, settings)) = fastest else {
        return Err(ArrayError::Input(
            "no reconstruction method could be built for this matrix".into(),
        ));
    };
    candidates[idx].status = "picked";
    let method = candidates[idx].method;
    let reason = format!(
        "no method met {budget_us} µs per frame for {m} gratings × {n} cells; {} is the fastest measured ({us:.1} µs per probe frame){}",
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

/// "; <label>: wsupport 900 µs, support (estimated over budget)" for the reason.
fn skipped_summary(candidates: &[Candidate], label: &str) -> String {
    let skipped: Vec<String> = candidates
        .iter()
        .filter(|c| c.status != "picked")
        .map(|c| match c.probe_us_per_frame {
            Some(us) => format!("{} {us:.0} µs", c.method.name()),
            None => format!("{} ({})", c.method.name(), c.status),
        })
        .collect();
    if skipped.is_empty() {
        String::new()
    } else {
        format!("; {label}: {}", skipped.join(", "))
    }
}
