//! The `reconstruct` study's flag part (`-- reconstruct --part flags`, issue 35):
//! recovery, flag recall and false-flag rate of every method under every fault,
//! whether the stream diagnosis names the faulty grating (and nothing else), and the
//! trade-off between false flags and recall as the test's significance varies (a ROC
//! per method).
//!
//! Its own generator ([`gen`]): three arrays (the paper's 6 × 8, a 10 × 20
//! hexagonal sheet, a 16 × 64 grid), streams of 200 frames with a noise level drawn
//! per stream (0.25, 0.5 or 1 pm, stated as it is), 0–4 loads of 30–240 g, the
//! paper's ± 4 % additivity, and fourteen scenarios (clean, the paper's faults, and
//! the ones this issue adds: drift, swapped channels, saturation, a stuck or noisy
//! grating, a temperature drift, overloads, absurd shifts). Seeds start at
//! [`SEED_OFFSET`] + the study's seed: no method or threshold was tuned on them.
//!
//! A frame is recovered when its SNR is ≥ 12 dB (an unusable frame never is); flag
//! recall is the share of missed frames carrying a flag, the false-flag rate the
//! share of recovered frames carrying one. Each stream is reconstructed once at the
//! significance [`RUN_SIGNIFICANCE`] and its frames' flags are recomputed at every
//! significance of the ROC from their test statistics
//! ([`fbgforge::array::methods::Reconstruction::flags_at`], exact above the run's).

pub mod gen;
pub mod oracle;

use anyhow::Result;
use fbgforge::array::methods::{Method, ReadingSettings, Reconstruction, DEFAULT_MAX_LOADS};
use fbgforge::array::problem::{SensingProblem, Uncertainty, PAPER_MIN_LOAD_G};
use fbgforge::array::protocol::{snr_db, RECOVERY_THRESHOLD_DB};
use fbgforge::array::reconstruct::{reconstruct, Frames, MethodRequest, Reconstructed};
use fbgforge::array::trust::{rival_quantile, FrameTest, DEFAULT_SIGNIFICANCE, OCCAM_CHI2, TESTS};
use fbgforge::output::{write_csv, write_json};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::progress::{Progress, Quiet};
use gen::{arrays, stream, ArrayDef, Expect, Fault, Stream, ULIMIT_G};
use rayon::prelude::*;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// The study's seeds start here.
pub const SEED_OFFSET: u64 = 35_000;

/// Significance the streams are reconstructed at: the smallest of the ROC, so that
/// every larger one is exact from the frames' statistics.
pub const RUN_SIGNIFICANCE: f64 = 1e-4;

/// Significances of the ROC curves.
pub const ROC_SIGNIFICANCES: [f64; 10] = [1e-4, 3e-4, 1e-3, 3e-3, 0.01, 0.02, 0.05, 0.1, 0.2, 0.4];

/// A frame's answer is wrong when some cell's load is off by more than this, g (the
/// rated range's lower end, 10 % of its 250 g top): what a lab would call a wrong
/// load, whatever the SNR.
pub const WRONG_LOAD_G: f64 = PAPER_MIN_LOAD_G;

/// …or when its loaded cells are not the truth's, a cell counting as loaded from
/// this load, g (half the rated lower end).
pub const LOADED_FROM_G: f64 = 0.5 * PAPER_MIN_LOAD_G;

/// Frames per stream (full run; `--quick`: 60).
pub const STREAM_FRAMES: usize = 200;

/// What is run on every stream.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Entry {
    Default,
    Named(Method),
}

impl Entry {
    fn all(arr: &ArrayDef) -> Vec<Entry> {
        let mut v = vec![Entry::Default, Entry::Named(Method::BranchAndBound)];
        if arr.enumerations {
            v.push(Entry::Named(Method::Support));
            v.push(Entry::Named(Method::WeightedSupport));
        }
        v.extend([
            Entry::Named(Method::Lasso),
            Entry::Named(Method::Omp),
            Entry::Named(Method::Nnls),
        ]);
        v
    }

    fn name(self) -> String {
        match self {
            Entry::Default => "default".into(),
            Entry::Named(m) => m.name().into(),
        }
    }
}

/// One frame's outcome: recovered, and its flags at every significance of the ROC.
#[derive(Debug, Clone)]
struct FrameOutcome {
    recovered: bool,
    /// The answer is wrong ([`wrong_answer`]).
    wrong: bool,
    /// The stream's fault was named by its diagnosis (and removed or corrected).
    named: bool,
    flagged: Vec<bool>,
    /// Flag words at the default significance.
    words: Vec<&'static str>,
    /// Penalised χ² of the nearest rival less the answer's (None: no rival).
    margin: Option<f64>,
    /// A wrong answer held against the truth ([`classify_wrong`]; None: a right
    /// answer, or frames not solved on the stated problem).
    class: Option<WrongClass>,
}

/// Why a wrong answer was given, from the truth's penalised χ² under the frame
/// test's weights against the answer's ([`FrameTest::hold_against`]; issue 35).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WrongClass {
    /// The answer's penalised χ² less the truth's (positive: the truth explains the
    /// frame better on the methods' own objective).
    pub truth_gain_chi2: f64,
    /// The truth offered as a rival would have made the frame `ambiguous` at the
    /// default significance.
    pub truth_would_flag: bool,
    /// The truth's support is one cell from the answer's (a load added, dropped or
    /// moved): a rival the test already evaluates.
    pub one_cell_away: bool,
    /// The answer's loaded cells are the truth's (a load off by more than 25 g).
    pub same_cells: bool,
    /// The same gain on the ℓ0 methods' own objective (χ² with the interrogator
    /// resolution alone, plus the same price per load: [`own_objective_test`]):
    /// where (a) holds but this does not exceed the chance level, the method's
    /// objective, not its search, preferred the answer.
    pub truth_gain_own_chi2: f64,
    /// The answer is the proven optimum of the method's own objective.
    pub certified: bool,
    /// Loads below the range were pruned from the method's answer before the test
    /// (the answer held is then not the method's own).
    pub pruned: bool,
    /// The truth is one of the answers the ℓ0 methods search (at most
    /// [`DEFAULT_MAX_LOADS`] loads, none above the ceiling): else no search could
    /// return it.
    pub truth_searched: bool,
    /// The truth is a rival of the answer (≥ 12 dB from it once refitted, on other
    /// cells): else the rival test cannot weigh it, by construction.
    pub truth_is_rival: bool,
    /// Loads of the truth and of the answer: the answer's χ² less the truth's,
    /// unpenalised, is `truth_gain_chi2` − 16 × (answer loads − truth loads).
    pub loads: (usize, usize),
}

impl WrongClass {
    /// The answer's χ² less the truth's without the price of a load: negative in
    /// class (c) while the truth fits better unpenalised means the penalty, not the
    /// noise, made the wrong answer the optimum.
    pub fn truth_gain_unpenalised_chi2(&self) -> f64 {
        let (t, a) = self.loads;
        self.truth_gain_chi2 - OCCAM_CHI2 * (a as f64 - t as f64)
    }
}

impl WrongClass {
    /// (a) a search failure: the truth beats the answer on the objective by more
    /// than the chance level ([`chance_level_chi2`]).
    pub fn search_failure(&self) -> bool {
        self.truth_gain_chi2 > chance_level_chi2()
    }

    /// (c) the noise made the wrong answer the optimum: it is no worse than the truth.
    pub fn answer_better(&self) -> bool {
        self.truth_gain_chi2 <= 0.0
    }
}

/// The chance level of the classification: the rival quantile at the default
/// significance (χ²₁ at 0.95, 3.84), the margin within which the frame test's
/// rival search looks for rivals of the answer.
pub fn chance_level_chi2() -> f64 {
    rival_quantile(DEFAULT_SIGNIFICANCE)
}

/// The loaded cells of loads `x`, g (from [`LOADED_FROM_G`]).
fn cells_of(x: &[f64]) -> Vec<usize> {
    (0..x.len()).filter(|&j| x[j] >= LOADED_FROM_G).collect()
}

/// The frame test of `problem` with the interrogator resolution as the only noise:
/// its penalised χ² is the ℓ0 methods' own objective (‖Ax − y‖²/σ² + 16 per load,
/// λ = 16 σ²), loads in the rated range.
pub fn own_objective_test(problem: &SensingProblem) -> Result<FrameTest> {
    let (m, n) = (problem.n_gratings(), problem.n_cells());
    let unc = Uncertainty {
        resolution_pm: problem.uncertainty.resolution_pm,
        matrix_sd_pm_per_g: nalgebra::DMatrix::zeros(m, n),
        additivity_sd_frac: 0.0,
    };
    let p = problem.clone().with_uncertainty(unc)?;
    Ok(FrameTest::new(&p, DEFAULT_MAX_LOADS))
}

/// Hold the truth `truth_g` of frame `shifts_pm` against its tested answer `r`,
/// under the frame test's weights (`test`) and on the methods' own objective
/// (`own`, [`own_objective_test`]): None when the frame is unusable or the test
/// cannot fit the truth's cells.
pub fn classify_wrong(
    test: &FrameTest,
    own: &FrameTest,
    shifts_pm: &[f64],
    truth_g: &[f64],
    r: &Reconstruction,
) -> Option<WrongClass> {
    let truth = cells_of(truth_g);
    let held = test.hold_against(shifts_pm, r, &truth)?;
    let held_own = own.hold_against(shifts_pm, r, &truth)?;
    let answer: Vec<usize> = (0..r.loads_g.len())
        .filter(|&j| r.loads_g[j] > 0.0)
        .collect();
    let only_truth = truth.iter().filter(|j| !answer.contains(j)).count();
    let only_answer = answer.iter().filter(|j| !truth.contains(j)).count();
    Some(WrongClass {
        truth_gain_chi2: held.answer_penalised_chi2 - held.penalised_chi2,
        truth_would_flag: held
            .rival_p_value
            .is_some_and(|p| p < DEFAULT_SIGNIFICANCE / TESTS),
        one_cell_away: only_truth <= 1 && only_answer <= 1,
        same_cells: only_truth == 0 && only_answer == 0,
        truth_gain_own_chi2: held_own.answer_penalised_chi2 - held_own.penalised_chi2,
        certified: r.certified,
        pruned: r.pruned_loads > 0,
        truth_searched: truth.len() <= DEFAULT_MAX_LOADS
            && truth_g.iter().all(|&v| v <= test.problem().ulimit_g),
        truth_is_rival: held.rival_p_value.is_some(),
        loads: (truth.len(), answer.len()),
    })
}

/// The wrong answers of a row by class (frames solved on the stated problem).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct WrongClasses {
    /// Wrong answers classified.
    pub classified: usize,
    /// (a) the truth better on the objective by more than the chance level.
    pub search_failure: usize,
    /// (b) the truth better by at most the chance level.
    pub within_chance: usize,
    /// (c) the answer no worse than the truth.
    pub answer_better: usize,
    /// Of (c), answers on the truth's own cells (a load off by more than 25 g).
    pub answer_better_same_cells: usize,
    /// Of (c), answers better than the truth by more than the chance level.
    pub answer_better_beyond_chance: usize,
    /// Of (c), answers the truth beats without the price of a load: the penalty,
    /// not the fit, made them better.
    pub answer_better_by_penalty: usize,
    /// Of (a), flagged at the default significance.
    pub search_failure_flagged: usize,
    /// Of (a), the truth one cell from the answer.
    pub search_failure_one_cell: usize,
    /// Of (a), answers certified optimal on the method's own objective.
    pub search_failure_certified: usize,
    /// Of (a), answers with loads below the range pruned before the test.
    pub search_failure_pruned: usize,
    /// Of (a), the method's own answer (nothing pruned), the truth among the answers
    /// searched, and better on the method's own objective by more than the chance
    /// level too: the method's search missed it.
    pub search_missed: usize,
    /// Of those, flagged at the default significance.
    pub search_missed_flagged: usize,
    /// Wrong answers the truth, offered as a rival, would have flagged `ambiguous`.
    pub truth_would_flag: usize,
    /// Wrong answers whose truth is no rival of them (within 12 dB, or on the
    /// answer's own cells): the rival test cannot weigh it, by its definition.
    pub truth_no_rival: usize,
}

impl WrongClasses {
    fn of(frames: &[&FrameOutcome], d: usize) -> Self {
        let mut c = WrongClasses::default();
        for f in frames {
            let Some(k) = f.class.filter(|_| f.wrong) else {
                continue;
            };
            c.classified += 1;
            if k.search_failure() {
                c.search_failure += 1;
                c.search_failure_flagged += usize::from(f.flagged[d]);
                c.search_failure_one_cell += usize::from(k.one_cell_away);
                c.search_failure_certified += usize::from(k.certified);
                c.search_failure_pruned += usize::from(k.pruned);
                if k.truth_searched && !k.pruned && k.truth_gain_own_chi2 > chance_level_chi2() {
                    c.search_missed += 1;
                    c.search_missed_flagged += usize::from(f.flagged[d]);
                }
            } else if k.answer_better() {
                c.answer_better += 1;
                c.answer_better_same_cells += usize::from(k.same_cells);
                c.answer_better_beyond_chance +=
                    usize::from(k.truth_gain_chi2 < -chance_level_chi2());
                c.answer_better_by_penalty += usize::from(k.truth_gain_unpenalised_chi2() > 0.0);
            } else {
                c.within_chance += 1;
            }
            c.truth_would_flag += usize::from(k.truth_would_flag);
            c.truth_no_rival += usize::from(!k.truth_is_rival);
        }
        c
    }
}

/// One stream's outcome for one entry.
#[derive(Debug, Clone)]
struct StreamOutcome {
    frames: Vec<FrameOutcome>,
    picked: String,
    diagnosis_right: bool,
    wrong_suspects: usize,
    common_mode: bool,
    estimated_us: Option<f64>,
    measured_us: f64,
}

/// One row of the table: an entry on an array under a fault, pooled over streams.
#[derive(Debug, Clone, Serialize)]
pub struct FlagRow {
    /// Array.
    pub array: String,
    /// Scenario.
    pub fault: &'static str,
    /// Method (`default → <picks>`).
    pub method: String,
    /// Frames.
    pub frames: usize,
    /// RR, %.
    pub rr_pct: f64,
    /// Frames missed (below 12 dB or unusable).
    pub missed: usize,
    /// Flagged among missed frames, % (default significance).
    pub recall_pct: Option<f64>,
    /// Flagged among recovered frames, % (default significance).
    pub false_flag_pct: Option<f64>,
    /// Frames whose answer is wrong ([`wrong_answer`]).
    pub wrong: usize,
    /// Recall on wrong answers: among frames whose answer is wrong, flagged or in a
    /// stream whose fault the diagnosis named (and removed or corrected), %.
    pub recall_wrong_pct: Option<f64>,
    /// Among frames whose answer is wrong, flagged, %.
    pub flagged_wrong_pct: Option<f64>,
    /// False flags on right answers: flagged among frames whose answer is right, %.
    pub false_flag_right_pct: Option<f64>,
    /// Frames flagged `ceiling` (default significance), and how many of them have a
    /// wrong answer: the flag is then right, not a false alarm.
    pub ceiling_frames: (usize, usize),
    /// Streams whose diagnosis found what the fault should give and nothing else.
    pub diagnosis_right: usize,
    /// Suspects named that were not the fault's, over all streams.
    pub wrong_suspects: usize,
    /// Streams where a common offset was fitted.
    pub common_mode_streams: usize,
    /// Streams.
    pub streams: usize,
    /// Share of frames carrying each flag word at the default significance, %.
    pub flag_pct: Vec<(String, f64)>,
    /// The wrong answers by class: the truth held against the answer under the
    /// frame test's weights ([`WrongClasses`]).
    pub wrong_classes: WrongClasses,
    /// Mean estimated time per frame (default choice), µs.
    pub estimated_us: Option<f64>,
    /// Mean measured time per frame, µs.
    pub measured_us: f64,
}

/// One point of a ROC curve.
#[derive(Debug, Clone, Serialize)]
pub struct RocPoint {
    /// Array.
    pub array: String,
    /// `clean` or `faults` (every other scenario pooled).
    pub data: &'static str,
    /// Method.
    pub method: String,
    /// Significance.
    pub significance: f64,
    /// Flagged among recovered frames, %.
    pub false_flag_pct: f64,
    /// Flagged among missed frames, %.
    pub recall_pct: f64,
}

fn pct(num: usize, den: usize) -> Option<f64> {
    (den > 0).then(|| 100.0 * num as f64 / den as f64)
}

/// The problem a user would state for this stream: the matrix seen, the 25–250 g
/// range, the stream's resolution, the matrix's stated error when calibrated.
fn problem_for(st: &Stream) -> Result<SensingProblem> {
    problem_at(st, RUN_SIGNIFICANCE)
}

/// [`problem_for`] with the per-frame test at `significance` (the studies' examples
/// read their flags at the library's default).
pub fn problem_at(st: &Stream, significance: f64) -> Result<SensingProblem> {
    let (m, n) = st.matrix.shape();
    let mut unc = Uncertainty::paper(m, n, st.resolution_pm);
    if let Some(pct) = st.matrix_sd_pct {
        unc.matrix_sd_pm_per_g = st.matrix.map(|v| v.abs() * pct / 100.0);
    }
    Ok(SensingProblem::new(st.matrix.clone(), ULIMIT_G, true)?
        .with_min_load_g(PAPER_MIN_LOAD_G)?
        .with_uncertainty(unc)?
        .with_significance(significance)?)
}

/// The stream's frames reconstructed on `problem` as a user would ask (gratings
/// fbg1…, at most four loads, the stream's resolution).
pub fn reconstruct_stream(
    st: &Stream,
    problem: &SensingProblem,
    request: &MethodRequest,
) -> Result<Reconstructed> {
    let names: Vec<String> = (1..=st.matrix.nrows()).map(|i| format!("fbg{i}")).collect();
    let prior = ReadingSettings {
        max_loads: DEFAULT_MAX_LOADS,
        resolution_pm: st.resolution_pm,
    };
    let frames = Frames {
        gratings: &names,
        shifts_pm: &st.shifts_pm,
    };
    Ok(reconstruct(problem, frames, &prior, request, &Quiet)?)
}

/// The examples' stream: array `a` of the full study (`arrays(false)`), scenario
/// `fault`, repetition `s`, with the study's seed 1 (the flag study's own stream s
/// when it runs every scenario), and the default method's answers on it (100 µs
/// budget, the frame test at the library's default significance).
pub fn default_answers_of(
    a: usize,
    fault: Fault,
    s: u64,
    frames: usize,
) -> Result<(Stream, Reconstructed)> {
    let f = Fault::ALL
        .iter()
        .position(|&x| x == fault)
        .expect("every scenario is in Fault::ALL") as u64;
    let seed = SEED_OFFSET + 1 + 7919 * s + 104_729 * f + 1_299_709 * a as u64;
    let st = stream(&arrays(false)[a], fault, frames, seed);
    let p = problem_at(&st, DEFAULT_SIGNIFICANCE)?;
    let done = reconstruct_stream(&st, &p, &MethodRequest::Default { budget_us: 100.0 })?;
    Ok((st, done))
}

/// Whether the diagnosis found what the stream's fault should give, and how many
/// suspects it named besides.
fn judge_diagnosis(st: &Stream, done: &Reconstructed) -> (bool, usize) {
    let mut matched = vec![false; done.suspect_gratings.len()];
    let mut right = true;
    let cm = done.diagnosis.common_mode.fitted;
    for e in &st.expect {
        match e {
            Expect::Nothing => right &= !cm,
            Expect::CommonMode => right &= cm,
            Expect::Grating(g, reason) => {
                let hit = done
                    .suspect_gratings
                    .iter()
                    .position(|s| s.index == *g && s.reason.words() == *reason);
                right &= hit.is_some();
                if let Some(k) = hit {
                    matched[k] = true;
                }
            }
            Expect::Pair(a, b) => {
                for (k, s) in done.suspect_gratings.iter().enumerate() {
                    let pair = (
                        s.index.min(s.partner.unwrap_or(usize::MAX)),
                        s.index.max(s.partner.unwrap_or(0)),
                    );
                    if s.reason.words() == "swapped" && pair == (*a, *b) {
                        matched[k] = true;
                    }
                }
                right &= matched.iter().filter(|x| **x).count() >= 2;
            }
        }
    }
    if !st.expect.contains(&Expect::CommonMode) && cm && !st.expect.contains(&Expect::Nothing) {
        right = false;
    }
    let wrong = matched.iter().filter(|x| !**x).count();
    (right && wrong == 0, wrong)
}

/// Whether an answer is wrong as a lab counts it: some cell's load off by more than
/// [`WRONG_LOAD_G`], or a loaded cell missed or added (loaded from
/// [`LOADED_FROM_G`]); an unusable frame (no loads) is wrong.
pub fn wrong_answer(truth_g: &[f64], loads_g: &[f64]) -> bool {
    truth_g.iter().zip(loads_g).any(|(t, x)| {
        !x.is_finite()
            || (t - x).abs() > WRONG_LOAD_G
            || (*t >= LOADED_FROM_G) != (*x >= LOADED_FROM_G)
    })
}

fn outcome(st: &Stream, done: &Reconstructed) -> StreamOutcome {
    let (diagnosis_right, wrong_suspects) = judge_diagnosis(st, done);
    let named = diagnosis_right && !st.expect.contains(&Expect::Nothing);
    // The truth is held against the answer only where the frames were solved on the
    // stated problem (no grating left out or corrected, no offset fitted).
    let test = done.setup.test();
    let stated = done.suspect_gratings.is_empty()
        && !done.diagnosis.common_mode.fitted
        && test.problem().n_gratings() == st.matrix.nrows();
    let own = own_objective_test(test.problem()).ok();
    let frames = st
        .truth_g
        .iter()
        .zip(&done.frames)
        .zip(&st.shifts_pm)
        .map(
            |((x0, r), y): ((&Vec<f64>, &Reconstruction), &Vec<f64>)| FrameOutcome {
                recovered: snr_db(x0, &r.loads_g) >= RECOVERY_THRESHOLD_DB,
                wrong: wrong_answer(x0, &r.loads_g),
                class: own
                    .as_ref()
                    .filter(|_| stated && wrong_answer(x0, &r.loads_g))
                    .and_then(|own| classify_wrong(test, own, y, x0, r)),
                named,
                flagged: ROC_SIGNIFICANCES
                    .iter()
                    .map(|&a| !r.flags_at(a).trusted())
                    .collect(),
                words: r.flags_at(DEFAULT_SIGNIFICANCE).words(),
                margin: r.rival_margin_chi2,
            },
        )
        .collect();
    StreamOutcome {
        frames,
        picked: done.setup.method.name().into(),
        diagnosis_right,
        wrong_suspects,
        common_mode: done.diagnosis.common_mode.fitted,
        estimated_us: done.budget.as_ref().map(|b| b.estimated_mean_us),
        measured_us: done.time_per_frame_us,
    }
}

/// Reconstruct one stream with one entry.
fn run_entry(st: &Stream, e: Entry) -> Result<StreamOutcome> {
    let request = match e {
        Entry::Default => MethodRequest::Default { budget_us: 100.0 },
        Entry::Named(method) => MethodRequest::named(method),
    };
    let done = reconstruct_stream(st, &problem_for(st)?, &request)?;
    Ok(outcome(st, &done))
}

/// The index of the default significance in [`ROC_SIGNIFICANCES`].
fn default_index() -> usize {
    ROC_SIGNIFICANCES
        .iter()
        .position(|&a| (a - DEFAULT_SIGNIFICANCE).abs() < 1e-12)
        .expect("the default significance is on the ROC")
}

fn row(arr: &ArrayDef, fault: Fault, e: Entry, outs: &[StreamOutcome]) -> FlagRow {
    let d = default_index();
    let frames: Vec<&FrameOutcome> = outs.iter().flat_map(|o| &o.frames).collect();
    let missed = frames.iter().filter(|f| !f.recovered).count();
    let flagged_missed = frames
        .iter()
        .filter(|f| !f.recovered && f.flagged[d])
        .count();
    let flagged_ok = frames
        .iter()
        .filter(|f| f.recovered && f.flagged[d])
        .count();
    let wrong = frames.iter().filter(|f| f.wrong).count();
    let caught = frames
        .iter()
        .filter(|f| f.wrong && (f.flagged[d] || f.named))
        .count();
    let flagged_wrong = frames.iter().filter(|f| f.wrong && f.flagged[d]).count();
    let flagged_right = frames.iter().filter(|f| !f.wrong && f.flagged[d]).count();
    let mut picks: Vec<String> = Vec::new();
    for o in outs {
        if !picks.contains(&o.picked) {
            picks.push(o.picked.clone());
        }
    }
    let words = [
        "inconsistent",
        "ambiguous",
        "below_range",
        "ceiling",
        "overload",
        "unconverged",
        "unusable",
    ];
    FlagRow {
        array: arr.name.into(),
        fault: fault.name(),
        method: match e {
            Entry::Default => format!("default → {}", picks.join("/")),
            Entry::Named(m) => m.name().into(),
        },
        frames: frames.len(),
        rr_pct: pct(frames.len() - missed, frames.len()).unwrap_or(0.0),
        missed,
        recall_pct: pct(flagged_missed, missed),
        false_flag_pct: pct(flagged_ok, frames.len() - missed),
        wrong,
        recall_wrong_pct: pct(caught, wrong),
        flagged_wrong_pct: pct(flagged_wrong, wrong),
        false_flag_right_pct: pct(flagged_right, frames.len() - wrong),
        ceiling_frames: (
            frames
                .iter()
                .filter(|f| f.words.contains(&"ceiling"))
                .count(),
            frames
                .iter()
                .filter(|f| f.wrong && f.words.contains(&"ceiling"))
                .count(),
        ),
        diagnosis_right: outs.iter().filter(|o| o.diagnosis_right).count(),
        wrong_suspects: outs.iter().map(|o| o.wrong_suspects).sum(),
        common_mode_streams: outs.iter().filter(|o| o.common_mode).count(),
        streams: outs.len(),
        flag_pct: words
            .iter()
            .map(|w| {
                let c = frames.iter().filter(|f| f.words.contains(w)).count();
                (w.to_string(), pct(c, frames.len()).unwrap_or(0.0))
            })
            .collect(),
        wrong_classes: WrongClasses::of(&frames, d),
        estimated_us: {
            let v: Vec<f64> = outs.iter().filter_map(|o| o.estimated_us).collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        },
        measured_us: outs.iter().map(|o| o.measured_us).sum::<f64>() / outs.len().max(1) as f64,
    }
}

fn roc(arr: &ArrayDef, e: Entry, data: &'static str, outs: &[&StreamOutcome]) -> Vec<RocPoint> {
    let frames: Vec<&FrameOutcome> = outs.iter().flat_map(|o| &o.frames).collect();
    ROC_SIGNIFICANCES
        .iter()
        .enumerate()
        .map(|(k, &a)| {
            let missed = frames.iter().filter(|f| !f.recovered).count();
            let fm = frames
                .iter()
                .filter(|f| !f.recovered && f.flagged[k])
                .count();
            let fo = frames
                .iter()
                .filter(|f| f.recovered && f.flagged[k])
                .count();
            RocPoint {
                array: arr.name.into(),
                data,
                method: e.name(),
                significance: a,
                false_flag_pct: pct(fo, frames.len() - missed).unwrap_or(0.0),
                recall_pct: pct(fm, missed).unwrap_or(100.0),
            }
        })
        .collect()
}

/// Margins M of the "rival within the noise" flag whose trade is charted: a frame
/// is flagged when the stated test flags it at the default significance or its
/// nearest rival's penalised χ² is within M of the answer's (likelihood ratio e^(M/2)).
pub const RIVAL_MARGINS: [f64; 8] = [0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0];

/// One point of the margin ROC: right answers flagged and wrong answers flagged
/// (flags alone, no stream-level naming), %.
#[derive(Debug, Clone)]
pub struct MarginPoint {
    /// Array name.
    pub array: String,
    /// `clean` or `faults` (the other scenarios pooled).
    pub data: &'static str,
    /// The margin M, χ².
    pub margin_chi2: f64,
    /// Wrong answers.
    pub wrong: usize,
    /// Frames.
    pub frames: usize,
    /// Right answers flagged, %.
    pub false_flag_right_pct: f64,
    /// Wrong answers flagged, %.
    pub flagged_wrong_pct: f64,
}

fn margin_roc(arr: &ArrayDef, data: &'static str, outs: &[&StreamOutcome]) -> Vec<MarginPoint> {
    let frames: Vec<&FrameOutcome> = outs.iter().flat_map(|o| &o.frames).collect();
    let wrong = frames.iter().filter(|f| f.wrong).count();
    let k = default_index();
    RIVAL_MARGINS
        .iter()
        .map(|&m| {
            let flag = |f: &&&FrameOutcome| f.flagged[k] || f.margin.is_some_and(|d| d < m);
            let ff = frames.iter().filter(|f| !f.wrong).filter(flag).count();
            let fw = frames.iter().filter(|f| f.wrong).filter(flag).count();
            MarginPoint {
                array: arr.name.into(),
                data,
                margin_chi2: m,
                wrong,
                frames: frames.len(),
                false_flag_right_pct: pct(ff, frames.len() - wrong).unwrap_or(0.0),
                flagged_wrong_pct: pct(fw, wrong).unwrap_or(100.0),
            }
        })
        .collect()
}

fn margin_table(report: &mut String, points: &[MarginPoint]) -> Result<()> {
    writeln!(
        report,
        "### A rival within the noise: false flags (right) % / flagged (wrong) % at each margin M (default method, significance {DEFAULT_SIGNIFICANCE})\n"
    )?;
    write!(report, "| array | data | wrong / frames |")?;
    for m in RIVAL_MARGINS {
        write!(report, " M = {m} |")?;
    }
    writeln!(report)?;
    writeln!(
        report,
        "|---|---|---|{}",
        "---|".repeat(RIVAL_MARGINS.len())
    )?;
    for c in points.chunks(RIVAL_MARGINS.len()) {
        write!(
            report,
            "| {} | {} | {} / {} |",
            c[0].array, c[0].data, c[0].wrong, c[0].frames
        )?;
        for p in c {
            write!(
                report,
                " {:.1} / {:.1} |",
                p.false_flag_right_pct, p.flagged_wrong_pct
            )?;
        }
        writeln!(report)?;
    }
    writeln!(report)?;
    Ok(())
}

/// Run the flag study: tables to `report`, CSV/JSON/SVG to `out`.
pub fn run(
    out: &Path,
    quick: bool,
    seed: u64,
    streams: u64,
    report: &mut String,
) -> Result<Vec<FlagRow>> {
    let frames = if quick { 60 } else { STREAM_FRAMES };
    let streams = if quick { 1 } else { streams.max(1) } as usize;
    let arrays = arrays(quick);
    let faults: Vec<Fault> = if quick {
        vec![
            Fault::Clean,
            Fault::Dead,
            Fault::Drift,
            Fault::Offset,
            Fault::Absurd,
        ]
    } else {
        Fault::ALL.to_vec()
    };
    let jobs: Vec<(usize, usize, usize)> = (0..arrays.len())
        .flat_map(|a| (0..faults.len()).flat_map(move |f| (0..streams).map(move |s| (a, f, s))))
        .collect();
    let bar = crate::progress::Bar::with("flags", jobs.len() as u64);
    let done: Vec<Result<(usize, usize, Vec<StreamOutcome>)>> = jobs
        .par_iter()
        .map(|&(a, f, s)| {
            let arr = &arrays[a];
            let st_seed =
                SEED_OFFSET + seed + 7919 * s as u64 + 104_729 * f as u64 + 1_299_709 * a as u64;
            let st = stream(arr, faults[f], frames, st_seed);
            let outs = Entry::all(arr)
                .into_iter()
                .map(|e| run_entry(&st, e))
                .collect::<Result<Vec<_>>>()?;
            bar.advance(1);
            Ok((a, f, outs))
        })
        .collect();
    bar.end();
    let done = done.into_iter().collect::<Result<Vec<_>>>()?;
    let mut rows = Vec::new();
    let mut rocs = Vec::new();
    let mut margins = Vec::new();
    for (a, arr) in arrays.iter().enumerate() {
        let entries = Entry::all(arr);
        for (k, &e) in entries.iter().enumerate() {
            let of = |f: usize| -> Vec<StreamOutcome> {
                done.iter()
                    .filter(|(da, df, _)| *da == a && *df == f)
                    .map(|(_, _, o)| o[k].clone())
                    .collect()
            };
            for (f, &fault) in faults.iter().enumerate() {
                rows.push(row(arr, fault, e, &of(f)));
            }
            let clean: Vec<StreamOutcome> = of(0);
            let others: Vec<StreamOutcome> = (1..faults.len()).flat_map(of).collect();
            rocs.extend(roc(arr, e, "clean", &clean.iter().collect::<Vec<_>>()));
            rocs.extend(roc(arr, e, "faults", &others.iter().collect::<Vec<_>>()));
            if e == Entry::Default {
                margins.extend(margin_roc(arr, "clean", &clean.iter().collect::<Vec<_>>()));
                margins.extend(margin_roc(
                    arr,
                    "faults",
                    &others.iter().collect::<Vec<_>>(),
                ));
            }
        }
    }
    write_files(out, &rows, &rocs, &arrays)?;
    table(report, &rows, &rocs, streams, frames, seed)?;
    margin_table(report, &margins)?;
    let margin_csv: Vec<Vec<String>> = margins
        .iter()
        .map(|p| {
            vec![
                p.array.clone(),
                p.data.into(),
                format!("{}", p.margin_chi2),
                p.wrong.to_string(),
                p.frames.to_string(),
                format!("{:.2}", p.false_flag_right_pct),
                format!("{:.2}", p.flagged_wrong_pct),
            ]
        })
        .collect();
    write_csv(
        &out.join("flags-margin.csv"),
        &[
            "array",
            "data",
            "margin_chi2",
            "wrong",
            "frames",
            "false_flag_right_pct",
            "flagged_wrong_pct",
        ],
        &margin_csv,
    )?;
    Ok(rows)
}

fn opt(v: Option<f64>) -> String {
    v.map_or("–".into(), |v| format!("{v:.1}"))
}

fn write_files(out: &Path, rows: &[FlagRow], rocs: &[RocPoint], arrays: &[ArrayDef]) -> Result<()> {
    let header = [
        "array",
        "fault",
        "method",
        "frames",
        "rr_pct",
        "missed",
        "recall_pct",
        "false_flag_pct",
        "wrong",
        "recall_wrong_pct",
        "flagged_wrong_pct",
        "false_flag_right_pct",
        "ceiling_frames",
        "ceiling_wrong",
        "diagnosis_right",
        "wrong_suspects",
        "common_mode_streams",
        "streams",
        "estimated_us",
        "measured_us",
        "wrong_classified",
        "wrong_search_failure",
        "wrong_within_chance",
        "wrong_answer_better",
        "search_failure_flagged",
        "search_failure_one_cell",
        "search_failure_certified",
        "search_failure_pruned",
        "search_missed",
        "search_missed_flagged",
        "wrong_truth_would_flag",
        "answer_better_same_cells",
        "answer_better_beyond_chance",
        "answer_better_by_penalty",
        "truth_no_rival",
    ];
    let csv: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.array.clone(),
                r.fault.into(),
                r.method.clone(),
                r.frames.to_string(),
                format!("{:.2}", r.rr_pct),
                r.missed.to_string(),
                r.recall_pct.map_or(String::new(), |v| format!("{v:.2}")),
                r.false_flag_pct
                    .map_or(String::new(), |v| format!("{v:.2}")),
                r.wrong.to_string(),
                r.recall_wrong_pct
                    .map_or(String::new(), |v| format!("{v:.2}")),
                r.flagged_wrong_pct
                    .map_or(String::new(), |v| format!("{v:.2}")),
                r.false_flag_right_pct
                    .map_or(String::new(), |v| format!("{v:.2}")),
                r.ceiling_frames.0.to_string(),
                r.ceiling_frames.1.to_string(),
                r.diagnosis_right.to_string(),
                r.wrong_suspects.to_string(),
                r.common_mode_streams.to_string(),
                r.streams.to_string(),
                r.estimated_us.map_or(String::new(), |v| format!("{v:.1}")),
                format!("{:.1}", r.measured_us),
                r.wrong_classes.classified.to_string(),
                r.wrong_classes.search_failure.to_string(),
                r.wrong_classes.within_chance.to_string(),
                r.wrong_classes.answer_better.to_string(),
                r.wrong_classes.search_failure_flagged.to_string(),
                r.wrong_classes.search_failure_one_cell.to_string(),
                r.wrong_classes.search_failure_certified.to_string(),
                r.wrong_classes.search_failure_pruned.to_string(),
                r.wrong_classes.search_missed.to_string(),
                r.wrong_classes.search_missed_flagged.to_string(),
                r.wrong_classes.truth_would_flag.to_string(),
                r.wrong_classes.answer_better_same_cells.to_string(),
                r.wrong_classes.answer_better_beyond_chance.to_string(),
                r.wrong_classes.answer_better_by_penalty.to_string(),
                r.wrong_classes.truth_no_rival.to_string(),
            ]
        })
        .collect();
    write_csv(&out.join("flags.csv"), &header, &csv)?;
    write_json(&out.join("flags.json"), &rows)?;
    let roc_csv: Vec<Vec<String>> = rocs
        .iter()
        .map(|p| {
            vec![
                p.array.clone(),
                p.data.into(),
                p.method.clone(),
                format!("{}", p.significance),
                format!("{:.2}", p.false_flag_pct),
                format!("{:.2}", p.recall_pct),
            ]
        })
        .collect();
    write_csv(
        &out.join("flags-roc.csv"),
        &[
            "array",
            "data",
            "method",
            "significance",
            "false_flag_pct",
            "recall_pct",
        ],
        &roc_csv,
    )?;
    write_json(&out.join("flags-roc.json"), &rocs)?;
    for arr in arrays {
        for data in ["clean", "faults"] {
            let mut chart = Chart::new(
                format!(
                    "Flags: recall against false flags as the significance varies, {} ({data})",
                    arr.name
                ),
                "false flags (flagged among recovered frames), %",
                "recall (flagged among missed frames), %",
            );
            let mut methods: Vec<String> = Vec::new();
            for p in rocs
                .iter()
                .filter(|p| p.array == arr.name && p.data == data)
            {
                if !methods.contains(&p.method) {
                    methods.push(p.method.clone());
                }
            }
            for name in &methods {
                let pts: Vec<(f64, f64)> = rocs
                    .iter()
                    .filter(|p| p.array == arr.name && p.data == data && &p.method == name)
                    .map(|p| (p.false_flag_pct, p.recall_pct))
                    .collect();
                chart = chart.with(Series::new(name.clone(), pts, Mark::LinePoints));
            }
            let file = format!(
                "flags-roc-{}-{data}.svg",
                arr.name.split(' ').next().unwrap_or("array")
            );
            chart.write_svg(&out.join(file))?;
        }
    }
    Ok(())
}

fn table(
    report: &mut String,
    rows: &[FlagRow],
    rocs: &[RocPoint],
    streams: usize,
    frames: usize,
    seed: u64,
) -> Result<()> {
    writeln!(
        report,
        "## Flags and diagnosis ({streams} stream(s) × {frames} frames per array and fault, seeds from {}; significance {DEFAULT_SIGNIFICANCE})\n",
        SEED_OFFSET + seed
    )?;
    writeln!(
        report,
        "Recall (SNR): flagged among frames below 12 dB (or unusable); false flags (SNR): flagged among frames at or above it. Wrong: frames whose answer has a load off by more than {WRONG_LOAD_G} g or a loaded cell missed or added (loaded from {LOADED_FROM_G} g); recall (wrong): of those, flagged or in a stream whose fault the diagnosis named and removed or corrected (flagged alone in brackets); false flags (right): flagged among the other frames. Diagnosis: streams whose suspects and common offset are the fault's and nothing else.\n"
    )?;
    writeln!(
        report,
        "| array | fault | method | RR % | missed | recall (SNR) % | false flags (SNR) % | wrong | recall (wrong) % [flagged] | false flags (right) % | diagnosis | wrong suspects | cm streams | est µs | measured µs |"
    )?;
    writeln!(
        report,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    )?;
    for r in rows {
        writeln!(
            report,
            "| {} | {} | {} | {:.1} | {} | {} | {} | {} | {} [{}] | {} | {}/{} | {} | {} | {} | {:.1} |",
            r.array,
            r.fault,
            r.method,
            r.rr_pct,
            r.missed,
            opt(r.recall_pct),
            opt(r.false_flag_pct),
            r.wrong,
            opt(r.recall_wrong_pct),
            opt(r.flagged_wrong_pct),
            opt(r.false_flag_right_pct),
            r.diagnosis_right,
            r.streams,
            r.wrong_suspects,
            r.common_mode_streams,
            opt(r.estimated_us),
            r.measured_us
        )?;
    }
    writeln!(
        report,
        "\n### Wrong answers by class (default method): the truth's penalised χ² under the frame test's weights against the answer's\n"
    )?;
    writeln!(
        report,
        "(a) search failure: the truth better by more than {:.2} (the rival quantile at {DEFAULT_SIGNIFICANCE}); (b) within chance: better by at most that; (c) the answer no worse. Of (a), missed by the search: the answer is the method's own (no load pruned), the truth is among the answers searched (at most {DEFAULT_MAX_LOADS} loads, none above the ceiling) and beats it by more than that on the method's own objective too (χ² with the resolution alone, 16 per load). Streams whose diagnosis left a grating out, corrected one or fitted an offset are not classified.\n",
        chance_level_chi2()
    )?;
    writeln!(
        report,
        "| array | fault | wrong | classified | (a) truth better [flagged; one cell away; certified; pruned] | of (a), missed by the search [flagged] | (b) within chance | (c) answer better [same cells; by more than chance; by the penalty] | truth as a rival would flag | truth no rival (within 12 dB or the answer's cells) |"
    )?;
    writeln!(report, "|---|---|---|---|---|---|---|---|---|---|")?;
    for r in rows.iter().filter(|r| r.method.starts_with("default")) {
        let c = &r.wrong_classes;
        writeln!(
            report,
            "| {} | {} | {} | {} | {} [{}; {}; {}; {}] | {} [{}] | {} | {} [{}; {}; {}] | {} | {} |",
            r.array,
            r.fault,
            r.wrong,
            c.classified,
            c.search_failure,
            c.search_failure_flagged,
            c.search_failure_one_cell,
            c.search_failure_certified,
            c.search_failure_pruned,
            c.search_missed,
            c.search_missed_flagged,
            c.within_chance,
            c.answer_better,
            c.answer_better_same_cells,
            c.answer_better_beyond_chance,
            c.answer_better_by_penalty,
            c.truth_would_flag,
            c.truth_no_rival
        )?;
    }
    writeln!(
        report,
        "\n### ROC: false flags % / recall % at each significance\n"
    )?;
    write!(report, "| array | data | method |")?;
    for a in ROC_SIGNIFICANCES {
        write!(report, " {a} |")?;
    }
    writeln!(report)?;
    writeln!(
        report,
        "|---|---|---|{}",
        "---|".repeat(ROC_SIGNIFICANCES.len())
    )?;
    let mut seen: Vec<(String, &str, String)> = Vec::new();
    for p in rocs {
        let key = (p.array.clone(), p.data, p.method.clone());
        if seen.contains(&key) {
            continue;
        }
        seen.push(key.clone());
        write!(report, "| {} | {} | {} |", key.0, key.1, key.2)?;
        for q in rocs
            .iter()
            .filter(|q| q.array == key.0 && q.data == key.1 && q.method == key.2)
        {
            write!(report, " {:.1} / {:.1} |", q.false_flag_pct, q.recall_pct)?;
        }
        writeln!(report)?;
    }
    writeln!(report)?;
    Ok(())
}
