//! Issue 35: a saturated and a noisy grating are named on the flag study's two small
//! arrays (6 × 8 paper, 10 × 20 hex), where the leave-one-out tests alone have too
//! few gratings to spare (before: saturated 2 and 4 of 8 streams, noisy 0 and 2 of
//! 8). Streams from the study's own generator and seeds (`reconstruct --part flags`,
//! stream s of array a and fault f), named exactly: the faulty grating with its
//! reason, nothing else, no common offset.

use fbgforge::array::methods::ReadingSettings;
use fbgforge::array::problem::{SensingProblem, Uncertainty, PAPER_MIN_LOAD_G};
use fbgforge::array::reconstruct::{reconstruct, Frames, MethodRequest};
use fbgforge::progress::Quiet;
use fbgforge_studies::reconstruct_flags::gen::{arrays, stream, Expect, Fault};
use fbgforge_studies::reconstruct_flags::{SEED_OFFSET, STREAM_FRAMES};

const STREAMS: u64 = 8;

/// Whether stream `s` of array `a` under `fault` (the study's seed 1) is diagnosed
/// exactly: Some(true) named right, Some(false) missed; panics on a wrong name.
fn named_exactly(a: usize, fault: Fault, s: u64) -> bool {
    let f = Fault::ALL.iter().position(|&x| x == fault).unwrap() as u64;
    let seed = SEED_OFFSET + 1 + 7919 * s + 104_729 * f + 1_299_709 * a as u64;
    let st = stream(&arrays(true)[a], fault, STREAM_FRAMES, seed);
    let (m, n) = st.matrix.shape();
    let p = SensingProblem::new(st.matrix.clone(), 250.0, true)
        .unwrap()
        .with_min_load_g(PAPER_MIN_LOAD_G)
        .unwrap()
        .with_uncertainty(Uncertainty::paper(m, n, st.resolution_pm))
        .unwrap();
    let names: Vec<String> = (1..=m).map(|i| format!("fbg{i}")).collect();
    let prior = ReadingSettings {
        max_loads: 4,
        resolution_pm: st.resolution_pm,
    };
    let frames = Frames {
        gratings: &names,
        shifts_pm: &st.shifts_pm,
    };
    let budget = MethodRequest::Default { budget_us: 100.0 };
    let done = reconstruct(&p, frames, &prior, &budget, &Quiet).unwrap();
    // A stream without a faulty grating (g = none) must name nothing.
    let (g, reason) = match st.expect[0] {
        Expect::Grating(g, reason) => (g, reason),
        _ => (usize::MAX, ""),
    };
    let wrong: Vec<_> = done
        .suspect_gratings
        .iter()
        .filter(|x| x.index != g || x.reason.words() != reason)
        .collect();
    assert!(
        wrong.is_empty(),
        "{fault:?} a{a} s{s}: also named {wrong:?}"
    );
    // (The 10 × 20 additivity streams fit a common offset, a known miss of the
    // offset rule, §11.7: judged on the faulty-grating streams only.)
    assert!(
        g == usize::MAX || !done.diagnosis.common_mode.fitted,
        "{fault:?} a{a} s{s}"
    );
    done.suspect_gratings.len() == 1
}

fn named_in(a: usize, fault: Fault) -> usize {
    (0..STREAMS).filter(|&s| named_exactly(a, fault, s)).count()
}

#[test]
fn a_saturated_and_a_noisy_grating_are_named_on_the_6x8_array() {
    // Measured: saturated 8 of 8, noisy 7 of 8 (one grating with too few quiet frames).
    assert!(named_in(0, Fault::Saturated) >= 7);
    assert!(named_in(0, Fault::Noisy) >= 6);
}

#[test]
fn a_saturated_and_a_noisy_grating_are_named_on_the_10x20_array() {
    // Measured: saturated 6 of 8 (two streams with 4–5 readings on the top), noisy 7
    // of 8.
    assert!(named_in(1, Fault::Saturated) >= 6);
    assert!(named_in(1, Fault::Noisy) >= 6);
}

/// The new tests name nothing where no grating is faulty: clean streams and the model
/// errors that raise every grating's residual (calibration, additivity ± 30 %).
#[test]
fn no_grating_is_named_on_clean_calibration_or_additivity_streams_of_the_small_arrays() {
    for a in [0, 1] {
        for fault in [Fault::Clean, Fault::Calibration, Fault::Additivity] {
            for s in 0..4 {
                assert!(!named_exactly(a, fault, s));
            }
        }
    }
}
