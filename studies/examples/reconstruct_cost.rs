//! Calibration of the method choice's cost model (`array::choice::estimated_ns_per_frame`):
//! one method on the scaling study's frames of one size, best of `reps` timings per
//! frame, against the work the method reports (`iterations`).
//!
//!     cargo run --release -p fbgforge-studies --example reconstruct_cost -- <method> <cells> [penalty] [work budget] [frames per load count] [reps]
//!
//! Prints median and mean µs per frame, mean work, ns per unit of work (per n and
//! per n·m too), RR per load count and mean SNR, and frames not converged; then the
//! frame test's time per load count of the answer (best of `reps`, the problem told
//! the frames' noise, rivals of up to 4 loads) beside the cost model's
//! `choice::estimated_test_ns`. docs/array.md §10.3 and §11.5 list what it gave.

use anyhow::Result;
use fbgforge::array::choice::estimated_test_ns;
use fbgforge::array::methods::{build, Method, MethodSettings};
use fbgforge::array::protocol::{snr_db, RECOVERY_THRESHOLD_DB};
use fbgforge::array::trust::FrameTest;
use fbgforge_studies::reconstruct_scaling::scaling_problem_and_frames;
use std::time::Instant;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize| args.get(i).map(String::as_str);
    let method = Method::from_name(arg(0).unwrap_or("bnb"))?;
    let cells: usize = arg(1).unwrap_or("64").parse()?;
    let mut settings = MethodSettings::for_method(method);
    if let Some(p) = arg(2) {
        settings = settings.with_penalty(p.parse()?);
    }
    if let Some(b) = arg(3) {
        match &mut settings {
            MethodSettings::BranchAndBound(bnb) => bnb.node_budget = b.parse()?,
            MethodSettings::De(de) => de.reference_node_budget = b.parse()?,
            _ => anyhow::bail!("a work budget belongs to bnb (or de's bnb reference)"),
        }
    }
    let per_load: usize = arg(4).unwrap_or("50").parse()?;
    let reps: usize = arg(5).unwrap_or("3").parse::<usize>()?.max(1);
    let (problem, loads, truth, shifts) = scaling_problem_and_frames(cells, per_load, 1)?;
    let (m, n) = (problem.n_gratings(), problem.n_cells());
    let r = build(&problem, &settings)?;
    let test = FrameTest::new(&problem, 4);
    // Per load count of the answer: (frames, best-of-reps test time sum, µs).
    let mut tests = [(0usize, 0.0f64); 8];
    let (mut times, mut work) = (Vec::new(), Vec::new());
    let (mut recovered, mut snr_sum, mut not_converged) = ([0usize; 5], 0.0, 0usize);
    for ((y, x), &k) in shifts.iter().zip(&truth).zip(&loads) {
        let mut best = f64::INFINITY;
        let mut rec = r.reconstruct(y);
        for _ in 0..reps {
            let t = Instant::now();
            rec = r.reconstruct(y);
            best = best.min(1e6 * t.elapsed().as_secs_f64());
        }
        times.push(best);
        work.push(rec.iterations as f64);
        let mut best_test = f64::INFINITY;
        for _ in 0..reps {
            let mut tested = rec.clone();
            let t = Instant::now();
            test.assess(y, &mut tested);
            best_test = best_test.min(1e6 * t.elapsed().as_secs_f64());
        }
        let held = rec.loads_g.iter().filter(|v| **v > 0.0).count().min(7);
        tests[held].0 += 1;
        tests[held].1 += best_test;
        let snr = snr_db(x, &rec.loads_g);
        snr_sum += snr;
        if snr >= RECOVERY_THRESHOLD_DB {
            recovered[k] += 1;
        }
        if !rec.converged {
            not_converged += 1;
        }
    }
    let frames = times.len() as f64;
    let mean_us = times.iter().sum::<f64>() / frames;
    let mean_work = work.iter().sum::<f64>() / frames;
    let ns_per_unit = 1e3 * mean_us / mean_work.max(1.0);
    times.sort_by(f64::total_cmp);
    println!(
        "{} {m}×{n} λ {:?} budget {:?}: median {:.1} µs, mean {mean_us:.1} µs per frame; mean work {mean_work:.0}; {ns_per_unit:.2} ns per unit ({:.3} per n, {:.4} per n·m); recovered {:?} of {per_load} per load count; mean SNR {:.2} dB; {not_converged} not converged",
        method.name(),
        settings.penalty(),
        match settings {
            MethodSettings::BranchAndBound(bnb) => Some(bnb.node_budget),
            _ => None,
        },
        times[times.len() / 2],
        ns_per_unit / n as f64,
        ns_per_unit / (n * m) as f64,
        &recovered[1..],
        snr_sum / frames
    );
    for (k, &(count, sum)) in tests.iter().enumerate().filter(|(_, t)| t.0 > 0) {
        println!(
            "frame test, answers of {k} loads ({count} frames): measured {:.1} µs, estimated {:.1} µs",
            sum / count as f64,
            1e-3 * estimated_test_ns(m, n, k)
        );
    }
    Ok(())
}
