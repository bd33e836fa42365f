//! Issue 35, item 3: the trade of an "ambiguous: a rival within the noise" flag.
//! Beside the stated test's flags (significance 0.05), a frame is also flagged when
//! its nearest rival (an explanation >= 12 dB from the answer, §11.1) has a
//! penalised chi2 within a margin M of the answer's (`rival_margin_chi2` < M): a
//! likelihood-ratio margin of exp(M / 2). For each M, per array: false flags = right
//! answers flagged, recall = wrong answers flagged (a wrong answer: some cell off by
//! more than 25 g, or a loaded cell missed or added), on the flag study's clean and
//! fault streams (pooled; default method, 100 us budget). Results: docs/array.md §11.7.
//!
//! `cargo run --release -p fbgforge-studies --example margin_roc -- [streams]`

use fbgforge_studies::reconstruct_flags::gen::{arrays, Fault};
use fbgforge_studies::reconstruct_flags::{default_answers_of, wrong_answer, STREAM_FRAMES};

const MARGINS: [f64; 8] = [0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0];

/// Per frame: wrong, flagged by the stated test, rival margin (None: no rival).
fn frames_of(a: usize, fault: Fault, s: u64) -> Vec<(bool, bool, Option<f64>)> {
    let (st, done) = default_answers_of(a, fault, s, STREAM_FRAMES).unwrap();
    st.truth_g
        .iter()
        .zip(&done.frames)
        .map(|(x, r)| {
            (
                wrong_answer(x, &r.loads_g),
                !r.flags_at(0.05).trusted(),
                r.rival_margin_chi2,
            )
        })
        .collect()
}

fn main() {
    let streams: u64 = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(3);
    let arrs = arrays(false);
    println!(
        "| array | data | wrong / frames | M = {} |",
        MARGINS.map(|m| m.to_string()).join(" | ")
    );
    for (a, arr) in arrs.iter().enumerate() {
        let ns = if a == 2 { streams.min(2) } else { streams };
        for (data, faults) in [
            ("clean", vec![Fault::Clean]),
            ("faults", Fault::ALL[1..].to_vec()),
        ] {
            let mut all = Vec::new();
            for &fault in &faults {
                for s in 0..ns {
                    all.extend(frames_of(a, fault, s));
                }
            }
            let wrong = all.iter().filter(|f| f.0).count();
            let right = all.len() - wrong;
            let cells: Vec<String> = MARGINS
                .iter()
                .map(|&m| {
                    let flag = |f: &(bool, bool, Option<f64>)| f.1 || f.2.is_some_and(|d| d < m);
                    let ff = all.iter().filter(|f| !f.0 && flag(f)).count();
                    let rc = all.iter().filter(|f| f.0 && flag(f)).count();
                    format!(
                        "{:.1} / {:.1}",
                        100.0 * ff as f64 / right.max(1) as f64,
                        100.0 * rc as f64 / wrong.max(1) as f64
                    )
                })
                .collect();
            println!(
                "| {} | {data} | {wrong} / {} | {} |",
                arr.name,
                all.len(),
                cells.join(" | ")
            );
        }
    }
}
