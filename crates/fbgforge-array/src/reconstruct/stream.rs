//! A whole stream, chunk by chunk: the diagnosis made once from the stream's sample,
//! then every chunk of frames corrected (swapped readings exchanged, drifts
//! removed), reduced (faulty gratings left out; a saturated one out of the frames at
//! its top) and reconstructed. Nothing is kept of the frames themselves, so memory
//! does not grow with the stream.
//!
//! **The budget on the mean.** With the default choice, every frame's work (the
//! method's operation count, and the frame test's) is converted into time on the
//! reference machine by the choice's cost model ([`crate::choice`]); when, after a
//! chunk, the mean over the frames so far exceeds the budget by more than
//! [`GUARD_TOLERANCE`] (from [`GUARD_MIN_FRAMES`] frames on), the run says so and
//! moves to the cheaper method for the rest of the stream (`bnb` with a work budget
//! fitted to the budget, or a smaller one). The decision reads no clock: the same
//! stream gets the same answers on any machine. The measured time per frame is
//! reported beside it.

use super::{MethodRequest, Setup};
use crate::choice::{cheaper_settings, estimated_frame_ns};
use crate::faults::{diagnose, Corrections, Diagnosis, StreamSample};
use crate::methods::{ReadingSettings, Reconstruction, PARALLEL_FROM};
use crate::problem::SensingProblem;
use crate::trust::FlagCounts;
use crate::ArrayError;
use serde::Serialize;
use std::time::Instant;

/// Frames reconstructed at a time (read, solved and written per chunk).
pub const CHUNK_FRAMES: usize = 1024;

/// Frames before the budget guard may act.
pub(crate) const GUARD_MIN_FRAMES: usize = 256;

/// How far the mean estimate may exceed the budget before the guard acts.
pub(crate) const GUARD_TOLERANCE: f64 = 0.10;

/// How the budget was kept over a stream (the default choice only).
#[derive(Debug, Clone, Serialize)]
pub struct BudgetNote {
    /// The budget, µs per frame.
    pub budget_us: f64,
    /// Mean estimated time per frame on the reference machine (the method and the
    /// frame test, from their operation counts), µs.
    pub estimated_mean_us: f64,
    /// Mean measured time per frame here, one thread (information only: the
    /// decisions read no clock), µs.
    pub measured_mean_us: f64,
    /// Frame from which a cheaper method took over (None: kept throughout).
    pub switched_at_frame: Option<usize>,
    /// What happened, in words.
    pub note: String,
}

/// A saturated grating's frames: those where its corrected reading is at least
/// `at` are solved by `setup` (the problem without it).
struct Clipped {
    row: usize,
    at: f64,
    setup: Setup,
}

/// The budget guard's state.
struct Guard {
    budget_us: f64,
    switched: Option<(usize, String)>,
}

/// A stream being reconstructed: see the module doc.
pub struct StreamRun {
    setup: Setup,
    original: SensingProblem,
    solved: SensingProblem,
    diagnosis: Diagnosis,
    clipped: Vec<Clipped>,
    next: usize,
    guard: Option<Guard>,
    flag_counts: FlagCounts,
    wall_s: f64,
    cpu_ns: f64,
    estimate_ns: f64,
    threads: usize,
}

/// What a finished stream run hands back.
pub struct StreamEnd {
    /// The set-up of the frames (after the guard, if it acted).
    pub setup: Setup,
    /// The stream's diagnosis.
    pub diagnosis: Diagnosis,
    /// The budget kept (default choice).
    pub budget: Option<BudgetNote>,
    /// Flags over the frames.
    pub flag_counts: FlagCounts,
    /// Wall time per frame, µs.
    pub time_per_frame_us: f64,
    /// Most threads a chunk used.
    pub threads: usize,
}

impl StreamRun {
    /// Diagnose the stream from `sample` (names from `gratings`), then pick and
    /// build the method for the problem the frames will be solved with.
    pub fn start(
        problem: &SensingProblem,
        prior: &ReadingSettings,
        request: &MethodRequest,
        sample: &StreamSample,
        gratings: &[String],
    ) -> Result<Self, ArrayError> {
        prior.check()?;
        request.check()?;
        let (mut diagnosis, solved) = diagnose(problem, prior, sample)?;
        for s in &mut diagnosis.suspects {
            s.name = gratings.get(s.index).cloned().unwrap_or_default();
            s.partner_name = s.partner.and_then(|p| gratings.get(p).cloned());
        }
        let setup = super::prepare(&solved, prior, request, None)?;
        let mut run = StreamRun {
            clipped: Vec::new(),
            guard: match *request {
                MethodRequest::Default { budget_us } => Some(Guard {
                    budget_us,
                    switched: None,
                }),
                MethodRequest::Named { .. } => None,
            },
            original: problem.clone(),
            solved,
            diagnosis,
            setup,
            next: 0,
            flag_counts: FlagCounts::default(),
            wall_s: 0.0,
            cpu_ns: 0.0,
            estimate_ns: 0.0,
            threads: 1,
        };
        run.build_clipped()?;
        Ok(run)
    }

    /// The set-up for the frames where a saturated grating is at its top.
    fn build_clipped(&mut self) -> Result<(), ArrayError> {
        let kept = self.corrections().kept(self.original.n_gratings());
        self.clipped.clear();
        for &(row, at) in &self.diagnosis.corrections.clipped {
            let Some(r) = kept.iter().position(|&i| i == row) else {
                continue;
            };
            let reduced = self.solved.without_gratings(&[r])?;
            let setup = self.setup.for_problem(&reduced, self.setup.settings)?;
            self.clipped.push(Clipped { row, at, setup });
        }
        Ok(())
    }

    fn corrections(&self) -> &Corrections {
        &self.diagnosis.corrections
    }

    /// The stream's diagnosis.
    pub fn diagnosis(&self) -> &Diagnosis {
        &self.diagnosis
    }

    /// The set-up solving the frames now.
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// Frame `index` of the stream: corrected, reduced and reconstructed, with the
    /// time it took (ns).
    fn one(&self, index: usize, y: &[f64]) -> (Reconstruction, f64) {
        let t = Instant::now();
        let n = self.original.n_cells();
        if self.original.check_shifts(y).is_err() {
            return (Reconstruction::unusable(n), 0.0);
        }
        let corr = self.corrections();
        let v = corr.corrected(index, y);
        let kept = corr.kept(y.len());
        let clip = self.clipped.iter().find(|c| v[c.row] >= c.at);
        let rows: Vec<f64> = kept
            .iter()
            .filter(|&&i| clip.is_none_or(|c| c.row != i))
            .map(|&i| v[i])
            .collect();
        let setup = clip.map_or(&self.setup, |c| &c.setup);
        let r = setup.reconstruct(&rows);
        (r, 1e9 * t.elapsed().as_secs_f64())
    }

    /// Reconstruct the next chunk of the stream (frames in order), telling
    /// `progress`; then let the budget guard act.
    pub fn reconstruct_chunk(
        &mut self,
        frames: &[Vec<f64>],
        progress: &dyn crate::progress::Progress,
    ) -> Vec<Reconstruction> {
        use rayon::prelude::*;
        let t = Instant::now();
        let start = self.next;
        let out: Vec<(Reconstruction, f64)> = if frames.len() >= PARALLEL_FROM {
            self.threads = self.threads.max(rayon::current_num_threads());
            frames
                .par_iter()
                .enumerate()
                .map(|(k, y)| self.one(start + k, y))
                .collect()
        } else {
            frames
                .iter()
                .enumerate()
                .map(|(k, y)| self.one(start + k, y))
                .collect()
        };
        self.wall_s += t.elapsed().as_secs_f64();
        self.next += frames.len();
        let (m, n) = (self.solved.n_gratings(), self.solved.n_cells());
        let mut results = Vec::with_capacity(out.len());
        for (r, ns) in out {
            self.flag_counts.add(&r.flags);
            self.cpu_ns += ns;
            if !r.flags.unusable {
                self.estimate_ns += estimated_frame_ns(&self.setup.settings, m, n, &r);
            }
            results.push(r);
        }
        progress.advance(frames.len() as u64);
        self.guard_budget();
        results
    }

    /// After a chunk: move to a cheaper method when the mean estimate exceeds the
    /// budget (see the module doc).
    fn guard_budget(&mut self) {
        let Some(g) = &self.guard else { return };
        if g.switched.is_some() || self.next < GUARD_MIN_FRAMES {
            return;
        }
        let mean_us = 1e-3 * self.estimate_ns / self.next as f64;
        if mean_us <= g.budget_us * (1.0 + GUARD_TOLERANCE) {
            return;
        }
        let budget_us = g.budget_us;
        let Some((settings, why)) =
            cheaper_settings(&self.solved, &self.setup.settings, budget_us, mean_us)
        else {
            return;
        };
        let Ok(setup) = self.setup.for_problem(&self.solved, settings) else {
            return;
        };
        let note = format!(
            "after {} frames the mean estimate was {mean_us:.1} µs per frame, over the {budget_us} µs budget: {why} for the rest of the stream",
            self.next
        );
        self.setup = Setup {
            reason: format!("{}; {note}", self.setup.reason),
            ..setup
        };
        if self.build_clipped().is_err() {
            self.clipped.clear();
        }
        if let Some(g) = &mut self.guard {
            g.switched = Some((self.next, note));
        }
    }

    /// End the run: what it did, with the budget's outcome.
    pub fn finish(self) -> StreamEnd {
        let frames = self.next.max(1) as f64;
        let budget = self.guard.map(|g| {
            let estimated_mean_us = 1e-3 * self.estimate_ns / frames;
            let measured_mean_us = 1e-3 * self.cpu_ns / frames;
            let note = match &g.switched {
                Some((_, note)) => note.clone(),
                None if estimated_mean_us <= g.budget_us * (1.0 + GUARD_TOLERANCE) => format!(
                    "kept: {estimated_mean_us:.1} µs per frame on average (estimated on the reference machine) within {} µs",
                    g.budget_us
                ),
                None => format!(
                    "over: {estimated_mean_us:.1} µs per frame on average (estimated) against {} µs, and no cheaper method to move to",
                    g.budget_us
                ),
            };
            let note = if measured_mean_us > g.budget_us * (1.0 + GUARD_TOLERANCE) {
                format!("{note}; measured here {measured_mean_us:.1} µs per frame (one thread): this machine or its load is slower than the reference")
            } else {
                note
            };
            BudgetNote {
                budget_us: g.budget_us,
                estimated_mean_us,
                measured_mean_us,
                switched_at_frame: g.switched.map(|(f, _)| f),
                note,
            }
        });
        StreamEnd {
            setup: self.setup,
            diagnosis: self.diagnosis,
            budget,
            flag_counts: self.flag_counts,
            time_per_frame_us: 1e6 * self.wall_s / frames,
            threads: self.threads,
        }
    }
}
