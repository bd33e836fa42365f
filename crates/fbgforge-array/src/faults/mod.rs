//! Faults seen only across frames, and what is done about them: the stream
//! diagnosis behind [`crate::reconstruct()`] and `fbgforge reconstruct`.
//!
//! A grating is tested as a suspect by its residual history — how its readings
//! compare, frame after frame, with what the *other* gratings predict for it (the
//! loads reconstructed without it, "leave one out"), or with the whole fit:
//!
//! * **dead or stuck** ([`dead`]): its reading hardly varies while the others
//!   predict large variations: left out;
//! * **drifting** ([`drift`]): its leave-one-out residual has a trend in time (a
//!   robust line, t-statistic and size both large): corrected by that trend;
//! * **saturated** ([`saturation`]): its largest readings sit on a flat top while the
//!   others predict more: left out of the frames at its top;
//! * **swapped** ([`residuals`]): two gratings whose readings, exchanged, fit the
//!   frames far better: exchanged back;
//! * **noisy** ([`residuals`]): its leave-one-out residual scatters far more than the
//!   other gratings': left out;
//!
//! and a **common offset** ([`offset`]: every grating moving together, a temperature
//! change since the tare) is fitted when the frames call for it: the common-mode
//! term lowers the frames' χ² significantly, and not through one grating alone.
//!
//! Everything works on a bounded sample of the stream ([`StreamSample`]: frames
//! spread over it, its strongest frames, each grating's largest readings), so a
//! stream of any length is diagnosed in the same memory, and with one method
//! whatever method reconstructs the frames (`bnb`, certified up to a work budget):
//! every method gets the same diagnosis.

mod dead;
mod drift;
mod offset;
mod residuals;
mod sample;
mod saturation;

pub use sample::StreamSample;

use super::methods::{build, BnbSettings, MethodSettings, ReadingSettings, Reconstructor};
use super::problem::SensingProblem;
use super::trust::FrameTest;
use super::ArrayError;
use serde::Serialize;

/// Work budget of the diagnosis's `bnb` per frame (units of
/// [`BnbSettings::node_budget`], about 1 ms at 16 × 64).
pub(crate) const DIAGNOSIS_WORK: u64 = 200_000;

/// Why a grating is suspect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum SuspectReason {
    /// Its reading hardly varies while the others predict large variations.
    #[serde(rename = "dead or stuck")]
    DeadOrStuck,
    /// Its reading has a trend in time against the others' prediction.
    #[serde(rename = "drifting")]
    Drifting,
    /// Its readings and another grating's fit far better exchanged.
    #[serde(rename = "swapped")]
    Swapped,
    /// Its largest readings sit on a flat top the others predict above.
    #[serde(rename = "saturated")]
    Saturated,
    /// Its residuals are outliers even where no load acts near it.
    #[serde(rename = "noisy")]
    Noisy,
}

impl SuspectReason {
    /// The reason in words (as serialised).
    pub fn words(self) -> &'static str {
        match self {
            SuspectReason::DeadOrStuck => "dead or stuck",
            SuspectReason::Drifting => "drifting",
            SuspectReason::Swapped => "swapped",
            SuspectReason::Saturated => "saturated",
            SuspectReason::Noisy => "noisy",
        }
    }
}

/// A grating found faulty across the frames.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuspectGrating {
    /// Row of the grating in the sensing matrix.
    pub index: usize,
    /// Its name (filled by the caller that knows the names; else empty).
    pub name: String,
    /// Why it is suspect.
    pub reason: SuspectReason,
    /// The other grating of a swapped pair (row).
    pub partner: Option<usize>,
    /// Its name.
    pub partner_name: Option<String>,
    /// What the frames showed, with the numbers.
    pub evidence: String,
    /// What was done about it.
    pub remedy: String,
    /// Frames the test used.
    pub frames: usize,
}

/// What the diagnosis changes in every frame before it is reconstructed (rows of
/// the matrix as given).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Corrections {
    /// Pairs of rows whose readings are exchanged.
    pub swaps: Vec<(usize, usize)>,
    /// Per drifting grating (row, offset pm, slope pm per frame): its reading less
    /// offset + slope × frame index.
    pub trends: Vec<(usize, f64, f64)>,
    /// Rows left out of every frame.
    pub dropped: Vec<usize>,
    /// Per saturated grating (row, top pm): frames where it reads at least the top
    /// (less two resolutions) are solved without it.
    pub clipped: Vec<(usize, f64)>,
}

impl Corrections {
    /// Whether nothing is changed.
    pub fn is_empty(&self) -> bool {
        self.swaps.is_empty()
            && self.trends.is_empty()
            && self.dropped.is_empty()
            && self.clipped.is_empty()
    }

    /// Frame `index` (all rows) with the swaps and trends applied.
    pub(crate) fn corrected(&self, index: usize, y: &[f64]) -> Vec<f64> {
        let mut v = y.to_vec();
        for &(a, b) in &self.swaps {
            v.swap(a, b);
        }
        for &(i, offset, slope) in &self.trends {
            v[i] -= offset + slope * index as f64;
        }
        v
    }

    /// The rows a frame keeps (not dropped), in order.
    pub(crate) fn kept(&self, m: usize) -> Vec<usize> {
        (0..m).filter(|i| !self.dropped.contains(i)).collect()
    }
}

/// Whether the frames are reconstructed with a common offset.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CommonModeNote {
    /// Whether the common-mode term is fitted.
    pub fitted: bool,
    /// Who decided: `asked` (on as asked), `off` (off as asked), `auto` (the
    /// diagnosis, from the frames).
    pub decided: &'static str,
    /// Why, in words with the numbers.
    pub reason: String,
}

/// What the diagnosis found and what it changes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    /// Every suspect with its reason and remedy.
    pub suspects: Vec<SuspectGrating>,
    /// Whether a common offset is fitted, and why.
    pub common_mode: CommonModeNote,
    /// What is changed in the frames (not serialised: the suspects say it).
    #[serde(skip)]
    pub corrections: Corrections,
}

/// The settings of the diagnosis's own method: `bnb` for these readings with a work
/// budget of [`DIAGNOSIS_WORK`] per frame.
pub(crate) fn diagnosis_settings(prior: &ReadingSettings) -> MethodSettings {
    MethodSettings::BranchAndBound(BnbSettings {
        node_budget: DIAGNOSIS_WORK,
        ..BnbSettings::for_prior(prior)
    })
}

/// A problem with its diagnosis method and frame test, built once.
pub(crate) struct Solver {
    pub problem: SensingProblem,
    pub method: Box<dyn Reconstructor>,
    pub test: FrameTest,
}

impl Solver {
    pub fn new(problem: SensingProblem, prior: &ReadingSettings) -> Result<Self, ArrayError> {
        Ok(Solver {
            method: build(&problem, &diagnosis_settings(prior))?,
            test: FrameTest::new(&problem, prior.max_loads),
            problem,
        })
    }

    /// The loads of frame `y` (rows of this problem) and the frame's χ² (tested).
    pub fn solve(&self, y: &[f64]) -> crate::methods::Reconstruction {
        let mut r = self.method.reconstruct(y);
        self.test.assess(y, &mut r);
        r
    }

    /// The reading of row `i` of `full` (a problem with one more row, `i` of it left
    /// out here) that the loads of `r` predict, with the common offset if fitted.
    pub fn predict_row(
        &self,
        full: &SensingProblem,
        i: usize,
        r: &crate::methods::Reconstruction,
    ) -> f64 {
        let mut pred: f64 = (0..full.n_cells())
            .map(|j| full.sensitivity_pm_per_g[(i, j)] * r.loads_g[j])
            .sum();
        if let (Some(t), Some(w)) = (r.common_mode_pm, full.common_mode.as_ref()) {
            let keep: Vec<usize> = (0..full.n_gratings()).filter(|&q| q != i).collect();
            let mean_abs = keep.iter().map(|&q| w[q].abs()).sum::<f64>() / keep.len().max(1) as f64;
            pred += w[i] / mean_abs.max(1e-300) * t;
        }
        pred
    }
}

/// Leave-one-out predictions of row `i` of `problem` for `frames` (rows of
/// `problem`): the reading the other gratings' loads predict, and whether that fit
/// passed its own χ² test; None where the fit was unusable. Empty when the problem
/// without row `i` cannot be built.
pub(crate) fn leave_one_out(
    problem: &SensingProblem,
    prior: &ReadingSettings,
    i: usize,
    frames: &[&[f64]],
) -> Result<Vec<Option<(f64, bool)>>, ArrayError> {
    let Ok(reduced) = problem.without_gratings(&[i]) else {
        return Ok(Vec::new());
    };
    let solver = Solver::new(reduced, prior)?;
    Ok(frames
        .iter()
        .map(|y| {
            let yr: Vec<f64> = (0..y.len()).filter(|&q| q != i).map(|q| y[q]).collect();
            let r = solver.solve(&yr);
            if r.flags.unusable {
                return None;
            }
            let ok = !r.flags.inconsistent;
            Some((solver.predict_row(problem, i, &r), ok))
        })
        .collect())
}

/// The frame `y` (all rows) as the problem of `corrections` sees it: corrected, the
/// dropped rows removed.
pub(crate) fn view(corrections: &Corrections, index: usize, y: &[f64]) -> Vec<f64> {
    let v = corrections.corrected(index, y);
    corrections.kept(y.len()).iter().map(|&i| v[i]).collect()
}

/// Diagnose a stream from its sample: find the suspects and decide the common
/// offset, for `problem` as given (its rows all the stream's gratings; a common
/// mode fitted as asked, or decided here when `problem.auto_common_mode` holds the
/// weights). Returns the diagnosis and the problem the frames are reconstructed with
/// (dropped rows removed, the common mode as decided).
pub fn diagnose(
    problem: &SensingProblem,
    prior: &ReadingSettings,
    sample: &StreamSample,
) -> Result<(Diagnosis, SensingProblem), ArrayError> {
    let m = problem.n_gratings();
    let mut corr = Corrections::default();
    let mut suspects = Vec::new();
    let asked = problem.common_mode.is_some();
    let auto = (!asked).then(|| problem.auto_common_mode.clone()).flatten();
    let mut current = problem.clone();
    let on = problem.diagnose_stream && m >= 3;
    if on {
        dead::find(&current, prior, sample, &mut corr, &mut suspects)?;
        current = problem.without_gratings(&corr.dropped)?;
        let weights = common_weights(problem, &corr, auto.as_deref());
        let histories = drift::find(
            problem,
            &current,
            weights.as_deref(),
            prior,
            sample,
            &mut corr,
            &mut suspects,
        )?;
        residuals::find_swapped(problem, &current, prior, sample, &mut corr, &mut suspects)?;
        let before = corr.dropped.len();
        residuals::find_noisy(
            problem.uncertainty.resolution_pm,
            &histories,
            &mut corr,
            &mut suspects,
        );
        if corr.dropped.len() == before {
            residuals::find_noisy_quiet(
                problem,
                &current,
                prior,
                sample,
                &mut corr,
                &mut suspects,
            )?;
        }
        if corr.dropped.len() != before {
            current = problem.without_gratings(&corr.dropped)?;
        }
    }
    let common_mode = match (&auto, asked) {
        (_, true) => CommonModeNote {
            fitted: true,
            decided: "asked",
            reason: "a common offset is fitted in every frame, as asked".into(),
        },
        (None, false) => CommonModeNote {
            fitted: false,
            decided: "off",
            reason: "no common offset is fitted, as asked".into(),
        },
        (Some(_), false) => {
            let kept = common_weights(problem, &corr, auto.as_deref()).unwrap_or_default();
            let (fit, reason) = offset::called_for(&current, &kept, prior, sample, &corr)?;
            if fit {
                current = current.with_common_mode(&kept)?;
            }
            CommonModeNote {
                fitted: fit,
                decided: "auto",
                reason,
            }
        }
    };
    if on {
        saturation::find(problem, &current, prior, sample, &mut corr, &mut suspects)?;
    }
    Ok((
        Diagnosis {
            suspects,
            common_mode,
            corrections: corr,
        },
        current,
    ))
}

/// The common-mode weights of the rows `corrections` keeps: as asked, or the
/// automatic ones (None: neither).
fn common_weights(
    problem: &SensingProblem,
    corrections: &Corrections,
    auto: Option<&[f64]>,
) -> Option<Vec<f64>> {
    let kept = corrections.kept(problem.n_gratings());
    if problem.common_mode.is_some() {
        return None;
    }
    auto.map(|w| kept.iter().map(|&i| w[i]).collect())
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Temperature weights of an array's gratings for the common-mode term: each
/// grating's temperature sensitivity (bare fiber, ∝ its Bragg wavelength:
/// [`crate::grating::FiberOptics::temperature_sensitivity_pm_per_k`]), scaled to a
/// mean of 1.
pub(crate) fn temperature_weights(bragg_wavelengths_nm: &[f64]) -> Vec<f64> {
    let optics = crate::grating::FiberOptics::default();
    let s: Vec<f64> = bragg_wavelengths_nm
        .iter()
        .map(|&l| optics.temperature_sensitivity_pm_per_k(l))
        .collect();
    let mu = mean(&s);
    s.iter().map(|v| v / mu).collect()
}
