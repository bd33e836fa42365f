//! Issue 35: the best any flag can do on clean streams. For the default method's
//! answers (100 µs budget) on the flag study's clean streams, P(answer right | y) is
//! computed exactly under the generator's own prior and likelihood
//! (`reconstruct_flags::oracle`); flagging the frames where it is lowest is the best
//! flag there is (Neyman–Pearson). Per array: the oracle's recall (wrong answers
//! flagged) at false flags (right answers flagged) 1, 2, 5, 10, 20 % and at the
//! stated test's own false-flag rate, the stated test's point (α = 0.05), a Wilson
//! 95 % interval on the recall at 5 %, and the Bayes answer's recovery (the answer
//! maximising P(right | y)) beside the default's. Results: docs/array.md §11.7.
//!
//! `cargo run --release -p fbgforge-studies --example oracle_flags -- [streams] [grid_streams]`
//! (streams per array at 6 × 8 and 10 × 20, default 10; at 16 × 64, default 0: not run)

use fbgforge_studies::reconstruct_flags::gen::arrays;
use fbgforge_studies::reconstruct_flags::oracle::{
    judge_clean_stream, oracle_point, oracle_threshold, supports, wilson_pct, JudgedFrame,
    OracleSettings,
};
use fbgforge_studies::reconstruct_flags::STREAM_FRAMES;

const FALSE_FLAGS_PCT: [f64; 5] = [1.0, 2.0, 5.0, 10.0, 20.0];

fn pct(a: usize, b: usize) -> f64 {
    100.0 * a as f64 / b.max(1) as f64
}

fn row(name: &str, streams: u64, all: &[JudgedFrame]) -> String {
    let wrong = all.iter().filter(|f| f.wrong).count();
    let right = all.len() - wrong;
    let ff = all.iter().filter(|f| !f.wrong && f.flagged).count();
    let rc = all.iter().filter(|f| f.wrong && f.flagged).count();
    let (at_ff, at_hit, _) = oracle_point(all, ff as f64 / right.max(1) as f64);
    let cells: Vec<String> = FALSE_FLAGS_PCT
        .iter()
        .map(|&f| {
            let (_, hit, n) = oracle_point(all, f / 100.0);
            if f == 5.0 {
                let (lo, hi) = wilson_pct(hit, n);
                format!("**{:.1}** [{lo:.1}, {hi:.1}]", pct(hit, n))
            } else {
                format!("{:.1}", pct(hit, n))
            }
        })
        .collect();
    let bayes = all.iter().filter(|f| f.bayes_right).count();
    let expected: f64 = all.iter().map(|f| f.bayes_p_right).sum();
    let expected_default: f64 = all.iter().map(|f| f.p_right).sum();
    format!(
        "| {name} | {streams} × {} | {wrong} / {} | {:.1} / {:.1} | {:.1} / {:.1} | {} | {:.1} ({:.1}) | {:.1} ({:.1}) |",
        all.len() / streams.max(1) as usize,
        all.len(),
        pct(ff, right),
        pct(rc, wrong),
        100.0 * at_ff,
        pct(at_hit, wrong),
        cells.join(" | "),
        pct(right, all.len()),
        100.0 * expected_default / all.len() as f64,
        pct(bayes, all.len()),
        100.0 * expected / all.len() as f64,
    )
}

fn main() {
    let arg = |i: usize, d: u64| {
        std::env::args()
            .nth(i)
            .map(|s| s.parse().expect("streams: a whole number"))
            .unwrap_or(d)
    };
    let streams = arg(1, 10);
    let grid_streams = arg(2, 0);
    let settings = OracleSettings::default();
    let mut kinds = Vec::new();
    println!(
        "| array | streams × frames | wrong / frames | stated test: false flags / recall % | oracle at the test's false flags: false flags / recall % | oracle recall % at false flags 1 % | 2 % | 5 % [Wilson 95 %] | 10 % | 20 % | default right % (expected) | Bayes answer right % (expected) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (a, arr) in arrays(false).iter().enumerate() {
        let ns = if a == 2 { grid_streams } else { streams };
        if ns == 0 {
            println!("| {} | not computed | | | | | | | | | | |", arr.name);
            continue;
        }
        let all_supports = supports(arr.cells.len());
        let mut all = Vec::new();
        for s in 0..ns {
            all.extend(judge_clean_stream(a, s, STREAM_FRAMES, &all_supports, &settings).unwrap());
        }
        println!("{}", row(arr.name, ns, &all));
        kinds.push((arr.name, all));
    }
    println!();
    println!("| array | wrong answers | kind | count | stated test flags | oracle flags at 5 % false flags |");
    println!("|---|---|---|---|---|---|");
    for (name, all) in &kinds {
        let (_, threshold) = oracle_threshold(all, 0.05);
        for (kind, same) in [
            ("its cells, a load > 25 g off", true),
            ("other cells (a load missed, added or moved)", false),
        ] {
            let of: Vec<&JudgedFrame> = all
                .iter()
                .filter(|f| f.wrong && f.same_cells == same)
                .collect();
            let test = of.iter().filter(|f| f.flagged).count();
            let oracle = of.iter().filter(|f| f.p_right < threshold).count();
            println!(
                "| {name} | {} | {kind} | {} | {test} | {oracle} |",
                all.iter().filter(|f| f.wrong).count(),
                of.len()
            );
        }
    }
}
