//! Reconstruction in memory: the one place where a method is picked and frames are
//! reconstructed.
//!
//! A caller states the problem (matrix, bounds, normalisation, uncertainty, the
//! significance of the flags), what it knows of the readings ([`ReadingSettings`]:
//! load cap, interrogator resolution) and how to pick the method
//! ([`MethodRequest`]: a named method, whose settings follow the prior with the
//! penalty replaced where given, or the default choice within a per-frame time
//! budget). [`prepare`] makes that decision once, from the problem alone
//! ([`crate::choice`]: deterministic, never from the frames), and builds the method
//! for the matrix; the [`Setup`] then reconstructs frames one at a time (the live
//! mode, Python's `Reconstructor`) or many ([`Setup::reconstruct_frames`]), every
//! frame tested by [`crate::trust`].
//!
//! A whole stream goes through [`StreamRun`]: its sample is diagnosed first
//! ([`crate::faults`]: dead, stuck, drifting, swapped, saturated and noisy gratings
//! named and left out or corrected, a common offset fitted when the frames call for
//! it), then the frames are reconstructed chunk by chunk (memory flat in the number
//! of frames), and the default method's mean estimated time is kept within its
//! budget ([`StreamRun`]'s guard). [`reconstruct`] does both for frames held in
//! memory; `fbgforge reconstruct` ([`crate::run::reconstruct_file`]) streams its
//! file through the same [`StreamRun`] (two passes: the sample, then the chunks;
//! docs/array.md §11.10), and the Python binding and the live mode
//! ([`crate::live::interpret`]) come through here too.

mod stream;

pub use stream::{BudgetNote, StreamEnd, StreamRun, CHUNK_FRAMES};

pub use super::choice::DEFAULT_BUDGET_US;
use super::choice::{check_budget, default_choice, Candidate};
use super::faults::{Diagnosis, StreamSample, SuspectGrating};
pub use super::methods::Method;
use super::methods::{
    build, MethodSettings, ReadingSettings, Reconstruction, Reconstructor, PARALLEL_FROM,
};
use super::problem::SensingProblem;
use super::trust::{FlagCounts, FrameTest};
use super::ArrayError;
use serde::Serialize;
use std::time::Instant;

/// How the method is picked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MethodRequest {
    /// A method by name: its settings for the readings
    /// ([`MethodSettings::for_prior`]), with the penalty weight replaced when given
    /// (refused for a method that has none).
    Named {
        /// The method.
        method: Method,
        /// Its penalty weight (working units), instead of the one the prior gives.
        penalty: Option<f64>,
    },
    /// The default choice: the most accurate method whose estimated time per frame
    /// is within `budget_us` (see [`crate::choice`]).
    Default {
        /// Per-frame time budget, µs.
        budget_us: f64,
    },
}

impl MethodRequest {
    /// A named method with its settings for the readings.
    pub fn named(method: Method) -> Self {
        MethodRequest::Named {
            method,
            penalty: None,
        }
    }

    /// Check the default choice's budget: a positive, finite time.
    pub fn check(&self) -> Result<(), ArrayError> {
        match *self {
            MethodRequest::Named { .. } => Ok(()),
            MethodRequest::Default { budget_us } => check_budget(budget_us)
                .map_err(|e| ArrayError::Input(format!("MethodRequest.budget_us: {e}"))),
        }
    }
}

/// Shift frames named by grating: each frame holds one shift per grating, in the
/// order of `gratings` (the sensing matrix's rows).
#[derive(Debug, Clone, Copy)]
pub struct Frames<'a> {
    /// Grating names, one per row of the sensing matrix.
    pub gratings: &'a [String],
    /// One frame per entry: the shift of each grating, pm.
    pub shifts_pm: &'a [Vec<f64>],
}

/// How the default method was chosen (absent when a method was named).
#[derive(Debug, Clone, Serialize)]
pub struct ChoiceSummary {
    /// Per-frame budget, µs.
    pub budget_us: f64,
    /// Which method and why, in one sentence.
    pub reason: String,
    /// Whether the probe frames were frames of the data (else synthetic).
    pub probed_on_data: bool,
    /// Every method considered, most accurate first.
    pub candidates: Vec<Candidate>,
}

/// The method picked for a problem and built for its matrix, ready for frames.
pub struct Setup {
    /// The method.
    pub method: Method,
    /// The settings it was built with.
    pub settings: MethodSettings,
    /// The readings the settings follow.
    pub prior: ReadingSettings,
    /// Why this method, in one sentence (`<name> as named` for a named method).
    pub reason: String,
    /// How the default choice went (None when a method was named).
    pub choice: Option<ChoiceSummary>,
    /// Time to pick and build the method (for the default choice, probing the
    /// candidates too), ms. Not part of the per-frame time.
    pub setup_ms: f64,
    reconstructor: Box<dyn Reconstructor>,
    checker: FrameTest,
}

impl std::fmt::Debug for Setup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Setup")
            .field("method", &self.method)
            .field("settings", &self.settings)
            .field("reason", &self.reason)
            .finish_non_exhaustive()
    }
}

impl Setup {
    /// Reconstruct one frame (pm, one shift per grating in the matrix's row order),
    /// tested: its flags, χ², p-value and rival margin ([`crate::trust`]).
    pub fn reconstruct(&self, shifts_pm: &[f64]) -> Reconstruction {
        let mut r = self.reconstructor.reconstruct(shifts_pm);
        self.checker.assess(shifts_pm, &mut r);
        r
    }

    /// The method's answer alone, untested (no flags, loads below the range kept).
    pub fn solve(&self, shifts_pm: &[f64]) -> Reconstruction {
        self.reconstructor.reconstruct(shifts_pm)
    }

    /// The frame test every answer goes through.
    pub fn test(&self) -> &FrameTest {
        &self.checker
    }

    /// Reconstruct many frames, in parallel from [`PARALLEL_FROM`] frames on,
    /// telling `progress` of the frames done; every frame tested.
    pub fn reconstruct_frames(
        &self,
        frames: &[Vec<f64>],
        progress: &dyn crate::progress::Progress,
    ) -> Vec<Reconstruction> {
        use rayon::prelude::*;
        if frames.len() < PARALLEL_FROM {
            let out = frames.iter().map(|y| self.reconstruct(y)).collect();
            progress.advance(frames.len() as u64);
            return out;
        }
        frames
            .par_chunks(128)
            .flat_map_iter(|chunk| {
                let v: Vec<Reconstruction> = chunk.iter().map(|y| self.reconstruct(y)).collect();
                progress.advance(chunk.len() as u64);
                v
            })
            .collect()
    }

    /// The problem the method was built for (the gratings kept).
    pub fn problem(&self) -> &SensingProblem {
        self.checker.problem()
    }

    /// The penalty weight in use (0 for a method without one), as summaries print it.
    pub fn penalty(&self) -> f64 {
        self.settings.penalty().unwrap_or(0.0)
    }

    /// The same method and settings built for `problem` (another set of gratings, a
    /// common offset): what a stream's diagnosis needs, the choice unchanged.
    pub(crate) fn for_problem(
        &self,
        problem: &SensingProblem,
        settings: MethodSettings,
    ) -> Result<Setup, ArrayError> {
        let t0 = Instant::now();
        let reconstructor = build(problem, &settings)?;
        Ok(Setup {
            method: settings.method(),
            settings,
            prior: self.prior,
            reason: self.reason.clone(),
            choice: self.choice.clone(),
            setup_ms: 1e3 * t0.elapsed().as_secs_f64(),
            reconstructor,
            checker: FrameTest::new(problem, self.prior.max_loads),
        })
    }
}

/// Pick the method for `problem` and build it: a named method with its settings for
/// `prior`, else the default choice, made from the problem alone (its size and
/// matrix, [`crate::choice`]). `_probe` is no longer used: the choice does not
/// depend on the frames a stream happens to start with (kept for the callers that
/// pass frames or None).
pub fn prepare(
    problem: &SensingProblem,
    prior: &ReadingSettings,
    request: &MethodRequest,
    _probe: Option<&[Vec<f64>]>,
) -> Result<Setup, ArrayError> {
    prior.check()?;
    request.check()?;
    let t0 = Instant::now();
    let (settings, reason, choice, reconstructor) = match *request {
        MethodRequest::Named { method, penalty } => {
            let mut settings = MethodSettings::for_prior(method, prior);
            if let Some(p) = penalty {
                if !method.has_penalty() {
                    return Err(ArrayError::Input(format!(
                        "`{}` has no penalty weight to set",
                        method.name()
                    )));
                }
                settings = settings.with_penalty(p);
            }
            let r = build(problem, &settings)?;
            (settings, format!("{} as named", method.name()), None, r)
        }
        MethodRequest::Default { budget_us } => {
            let c = default_choice(problem, prior, budget_us)?;
            let summary = ChoiceSummary {
                budget_us,
                reason: c.reason.clone(),
                probed_on_data: false,
                candidates: c.candidates,
            };
            (c.settings, c.reason, Some(summary), c.reconstructor)
        }
    };
    Ok(Setup {
        method: settings.method(),
        settings,
        prior: *prior,
        reason,
        choice,
        setup_ms: 1e3 * t0.elapsed().as_secs_f64(),
        reconstructor,
        checker: FrameTest::new(problem, prior.max_loads),
    })
}

/// Frames reconstructed, with the set-up that did it.
#[derive(Debug)]
pub struct Reconstructed {
    /// The method, its settings and why (for the problem the frames were solved
    /// with: the gratings kept, the common offset as decided).
    pub setup: Setup,
    /// One result per frame, in order.
    pub frames: Vec<Reconstruction>,
    /// Wall time of reconstructing the frames alone, per frame, µs (all threads).
    pub time_per_frame_us: f64,
    /// Threads used for the frames (in parallel from [`PARALLEL_FROM`] frames per
    /// chunk on).
    pub threads: usize,
    /// Gratings found faulty across the frames (names as given), each with its
    /// reason and what was done (the diagnosis's suspects).
    pub suspect_gratings: Vec<SuspectGrating>,
    /// The stream's diagnosis: the suspects and whether a common offset is fitted.
    pub diagnosis: Diagnosis,
    /// The default choice's budget kept on the mean (None for a named method).
    pub budget: Option<BudgetNote>,
    /// How many frames carry each flag.
    pub flag_counts: FlagCounts,
}

/// Reconstruct `frames` for `problem`: diagnose the stream (faulty gratings, a
/// common offset), pick and build the method once ([`prepare`]), then every frame,
/// chunk by chunk ([`StreamRun`]); `progress` hears the frames.
///
/// ```
/// use fbgforge_array::kernel::{matrix_from_positions, paper_layout, DistanceKernel};
/// use fbgforge_array::methods::ReadingSettings;
/// use fbgforge_array::problem::SensingProblem;
/// use fbgforge_array::{reconstruct, Frames, MethodRequest};
///
/// // The paper's array: 8 cells, 6 gratings, its distance kernel; ulimit 250 g.
/// let (cells, gratings) = paper_layout();
/// let a = matrix_from_positions(&cells, &gratings, &DistanceKernel::paper());
/// let problem = SensingProblem::new(a.clone(), 250.0, true)?;
/// // One frame: 120 g on cell B and 60 g on cell G, read without noise.
/// let load = nalgebra::DVector::from_column_slice(&[0.0, 120.0, 0.0, 0.0, 0.0, 0.0, 60.0, 0.0]);
/// let shifts: Vec<f64> = (&a * load).iter().copied().collect();
/// let names: Vec<String> = (1..=6).map(|i| format!("fbg{i}")).collect();
/// let frames = [shifts];
/// let done = reconstruct(
///     &problem,
///     Frames { gratings: &names, shifts_pm: &frames },
///     &ReadingSettings::paper(),
///     &MethodRequest::Default { budget_us: 100.0 },
///     &fbgforge_core::progress::Quiet,
/// )?;
/// let x = &done.frames[0].loads_g;
/// assert!((x[1] - 120.0).abs() < 0.5 && (x[6] - 60.0).abs() < 0.5, "{x:?}");
/// assert!(done.frames[0].flags.trusted());
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn reconstruct(
    problem: &SensingProblem,
    frames: Frames<'_>,
    prior: &ReadingSettings,
    request: &MethodRequest,
    progress: &dyn crate::progress::Progress,
) -> Result<Reconstructed, ArrayError> {
    if frames.gratings.len() != problem.n_gratings() {
        return Err(ArrayError::Input(format!(
            "the frames name {} gratings ({}) but the sensing matrix has {}",
            frames.gratings.len(),
            frames.gratings.join(", "),
            problem.n_gratings()
        )));
    }
    let mut sample = StreamSample::new(problem);
    for y in frames.shifts_pm {
        sample.push(y);
    }
    let mut run = StreamRun::start(problem, prior, request, &sample, frames.gratings)?;
    progress.begin("reconstruct", frames.shifts_pm.len() as u64);
    let mut results = Vec::with_capacity(frames.shifts_pm.len());
    for chunk in frames.shifts_pm.chunks(CHUNK_FRAMES) {
        results.extend(run.reconstruct_chunk(chunk, progress));
    }
    progress.end();
    let end = run.finish();
    Ok(Reconstructed {
        setup: end.setup,
        time_per_frame_us: end.time_per_frame_us,
        threads: end.threads,
        suspect_gratings: end.diagnosis.suspects.clone(),
        diagnosis: end.diagnosis,
        budget: end.budget,
        flag_counts: end.flag_counts,
        frames: results,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{matrix_from_positions, paper_layout, DistanceKernel};
    use crate::methods::{l0_penalty_for_resolution, DEFAULT_MAX_LOADS};
    use crate::progress::Quiet;
    use nalgebra::{DMatrix, DVector};

    fn paper_problem() -> (DMatrix<f64>, SensingProblem) {
        let (c, g) = paper_layout();
        let a = matrix_from_positions(&c, &g, &DistanceKernel::paper());
        let p = SensingProblem::new(a.clone(), 250.0, true).unwrap();
        (a, p)
    }

    /// Frames of 1–3 loads with a small deterministic disturbance, so that the
    /// penalty matters.
    fn frames(a: &DMatrix<f64>) -> Vec<Vec<f64>> {
        let loads = [
            vec![0.0, 120.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            vec![200.0, 0.0, 0.0, 0.0, 0.0, 0.0, 50.0, 0.0],
            vec![0.0, 0.0, 100.0, 0.0, 50.0, 0.0, 0.0, 200.0],
            vec![0.0, 30.0, 0.0, 0.0, 0.0, 40.0, 0.0, 0.0],
        ];
        loads
            .iter()
            .enumerate()
            .map(|(f, x)| {
                let y = a * DVector::from_column_slice(x);
                y.iter()
                    .enumerate()
                    .map(|(i, v)| v + 0.7 * (((3 * f + 5 * i) % 7) as f64 - 3.0) / 3.0)
                    .collect()
            })
            .collect()
    }

    fn names(m: usize) -> Vec<String> {
        (1..=m).map(|i| format!("fbg{i}")).collect()
    }

    #[test]
    fn a_named_method_gets_its_settings_for_the_readings() {
        let (a, p) = paper_problem();
        let ys = frames(&a);
        let gratings = names(6);
        let frames = Frames {
            gratings: &gratings,
            shifts_pm: &ys,
        };
        let prior = ReadingSettings {
            max_loads: 3,
            resolution_pm: 0.25,
        };
        for method in [Method::Support, Method::BranchAndBound] {
            let done =
                reconstruct(&p, frames, &prior, &MethodRequest::named(method), &Quiet).unwrap();
            // λ = 16 σ² = 1 at 0.25 pm, not the paper's 4; the cap as given.
            assert_eq!(done.setup.settings.penalty(), Some(1.0));
            assert_eq!(done.setup.settings.max_loads(), Some(3));
            assert_eq!(done.setup.method, method);
            assert!(done.setup.choice.is_none());
            // Exactly what building those settings by hand gives, frame by frame.
            let by_hand = build(&p, &MethodSettings::for_prior(method, &prior)).unwrap();
            let checker = FrameTest::new(&p, prior.max_loads);
            for (y, got) in ys.iter().zip(&done.frames) {
                let mut want = by_hand.reconstruct(y);
                checker.assess(y, &mut want);
                assert_eq!(&want, got);
            }
        }
        // A penalty given replaces the prior's; a method without one refuses it.
        let named = MethodRequest::Named {
            method: Method::BranchAndBound,
            penalty: Some(0.5),
        };
        let s = prepare(&p, &prior, &named, None).unwrap();
        assert_eq!(s.settings.penalty(), Some(0.5));
        let nnls = MethodRequest::Named {
            method: Method::Nnls,
            penalty: Some(0.5),
        };
        let e = prepare(&p, &prior, &nnls, None).unwrap_err().to_string();
        assert!(e.contains("nnls") && e.contains("no penalty"), "{e}");
    }

    #[test]
    fn the_default_request_is_the_default_choice_made_from_the_problem_alone() {
        let (a, p) = paper_problem();
        let ys = frames(&a);
        let gratings = names(6);
        let frames = Frames {
            gratings: &gratings,
            shifts_pm: &ys,
        };
        let prior = ReadingSettings {
            max_loads: DEFAULT_MAX_LOADS,
            resolution_pm: 0.25,
        };
        // 5 µs: `wsupport` (162 supports × 120 ns) is over, `support` within.
        let request = MethodRequest::Default { budget_us: 5.0 };
        let done = reconstruct(&p, frames, &prior, &request, &Quiet).unwrap();
        let c = default_choice(&p, &prior, 5.0).unwrap();
        assert_eq!(done.setup.method, Method::Support);
        assert_eq!(
            (done.setup.method, done.setup.settings),
            (c.method, c.settings)
        );
        assert_eq!(
            done.setup.settings.penalty(),
            Some(l0_penalty_for_resolution(0.25))
        );
        let summary = done.setup.choice.as_ref().unwrap();
        assert!(!summary.probed_on_data && summary.reason == done.setup.reason);
        let checker = FrameTest::new(&p, prior.max_loads);
        for (y, got) in ys.iter().zip(&done.frames) {
            let mut want = c.reconstructor.reconstruct(y);
            checker.assess(y, &mut want);
            assert_eq!(&want, got);
        }
    }

    #[test]
    fn frames_must_name_the_matrix_gratings_and_the_prior_is_checked() {
        let (a, p) = paper_problem();
        let ys = frames(&a);
        let five = names(5);
        let short = Frames {
            gratings: &five,
            shifts_pm: &ys,
        };
        let request = MethodRequest::named(Method::Nnls);
        let e = reconstruct(&p, short, &ReadingSettings::paper(), &request, &Quiet)
            .unwrap_err()
            .to_string();
        assert!(e.contains("5 gratings") && e.contains("has 6"), "{e}");
        for bad in [
            ReadingSettings {
                max_loads: 0,
                ..ReadingSettings::paper()
            },
            ReadingSettings {
                resolution_pm: f64::NAN,
                ..ReadingSettings::paper()
            },
        ] {
            assert!(prepare(&p, &bad, &request, None).is_err(), "{bad:?}");
        }
    }
}
