//! Issue 35: why wrong answers on the flag study's streams are not flagged. For
//! every wrong answer of the default method, the truth's penalised χ² under the
//! frame test's weights against the answer's (`classify_wrong`): (a) a search
//! failure, (b) within chance, (c) the answer better; with RR, flagged wrong
//! answers, false flags on right answers and the mean time per frame. The same
//! streams as `-- reconstruct --part flags --repeats 1` (seed 1, stream 0).
//!
//! `cargo run --release -p fbgforge-studies --example wrong_classes -- [scenario …]`
//! (default: clean; `all` for every scenario).

use fbgforge::array::protocol::{snr_db, RECOVERY_THRESHOLD_DB};
use fbgforge_studies::reconstruct_flags::gen::{arrays, Fault};
use fbgforge_studies::reconstruct_flags::{
    chance_level_chi2, classify_wrong, default_answers_of, own_objective_test, wrong_answer,
    STREAM_FRAMES,
};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let verbose = args.iter().any(|a| a == "-v");
    let faults: Vec<Fault> = if args.iter().any(|a| a == "all") {
        Fault::ALL.to_vec()
    } else if args.iter().all(|a| a == "-v") {
        vec![Fault::Clean]
    } else {
        Fault::ALL
            .iter()
            .copied()
            .filter(|f| args.iter().any(|a| a == f.name()))
            .collect()
    };
    println!("chance level {:.2}", chance_level_chi2());
    println!("| array | fault | RR % | wrong | flagged wrong % | false flags right % | (a) [flagged; one cell] missed by search | (b) | (c) | truth would flag | est µs | measured µs |");
    for (a, arr) in arrays(false).iter().enumerate() {
        for &fault in &faults {
            let (st, done) = default_answers_of(a, fault, 0, STREAM_FRAMES).unwrap();
            let stated = done.suspect_gratings.is_empty() && !done.diagnosis.common_mode.fitted;
            let own = own_objective_test(done.setup.test().problem()).unwrap();
            let mut missed = 0;
            let (mut rec, mut wrong, mut fw, mut fr) = (0, 0, 0, 0);
            let (mut ca, mut caf, mut ca1, mut cb, mut cc, mut tw) = (0, 0, 0, 0, 0, 0);
            for ((x0, r), y) in st.truth_g.iter().zip(&done.frames).zip(&st.shifts_pm) {
                let flagged = !r.flags_at(0.05).trusted();
                rec += usize::from(snr_db(x0, &r.loads_g) >= RECOVERY_THRESHOLD_DB);
                if !wrong_answer(x0, &r.loads_g) {
                    fr += usize::from(flagged);
                    continue;
                }
                wrong += 1;
                fw += usize::from(flagged);
                let Some(k) = stated
                    .then(|| classify_wrong(done.setup.test(), &own, y, x0, r))
                    .flatten()
                else {
                    continue;
                };
                tw += usize::from(k.truth_would_flag);
                if verbose && !k.answer_better() {
                    println!(
                        "  (a/b) gain {:.2} own {:.2} unpenalised {:.2} loads {:?} one cell {} would flag {} flagged {flagged} [{}] pruned {} certified {} truth {:?} answer {:?}",
                        k.truth_gain_chi2,
                        k.truth_gain_own_chi2,
                        k.truth_gain_unpenalised_chi2(),
                        k.loads,
                        k.one_cell_away,
                        k.truth_would_flag,
                        r.flags_at(0.05).field(),
                        r.pruned_loads,
                        r.certified,
                        x0.iter().enumerate().filter(|(_, v)| **v > 0.0).map(|(j, v)| (j, v.round())).collect::<Vec<_>>(),
                        r.loads_g.iter().enumerate().filter(|(_, v)| **v > 0.0).map(|(j, v)| (j, v.round())).collect::<Vec<_>>(),
                    );
                }
                if k.search_failure() {
                    ca += 1;
                    caf += usize::from(flagged);
                    ca1 += usize::from(k.one_cell_away);
                    missed += usize::from(k.truth_gain_own_chi2 > chance_level_chi2());
                } else if k.answer_better() {
                    cc += 1;
                    if verbose {
                        println!(
                            "  (c) gain {:.2} own {:.2} unpenalised {:.2} loads truth/answer {:?} one cell {} truth {:?} answer {:?}",
                            k.truth_gain_chi2,
                            k.truth_gain_own_chi2,
                            k.truth_gain_unpenalised_chi2(),
                            k.loads,
                            k.one_cell_away,
                            x0.iter().enumerate().filter(|(_, v)| **v > 0.0).map(|(j, v)| (j, v.round())).collect::<Vec<_>>(),
                            r.loads_g.iter().enumerate().filter(|(_, v)| **v > 0.0).map(|(j, v)| (j, v.round())).collect::<Vec<_>>(),
                        );
                    }
                } else {
                    cb += 1;
                }
            }
            let nf = st.truth_g.len();
            println!(
                "| {} | {} | {:.1} | {wrong} | {:.1} | {:.1} | {ca} [{caf}; {ca1}] {missed} | {cb} | {cc} | {tw} | {:.1} | {:.1} |",
                arr.name,
                fault.name(),
                100.0 * rec as f64 / nf as f64,
                100.0 * fw as f64 / wrong.max(1) as f64,
                100.0 * fr as f64 / (nf - wrong).max(1) as f64,
                done.budget.as_ref().map_or(f64::NAN, |b| b.estimated_mean_us),
                done.time_per_frame_us,
            );
        }
    }
}
