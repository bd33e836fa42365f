//! Reconstruction methods behind one trait, with one result type.
//!
//! Every method solves the same [`SensingProblem`] (matrix, bounds, normalisation) for
//! one frame of shifts at a time and returns a [`Reconstruction`] that says whether the
//! method converged. Methods are interchangeable: [`build`] turns a method's
//! [`MethodSettings`] (each method has its own settings type, in its own file) into a
//! `Box<dyn Reconstructor>` that has already precomputed whatever depends only on the
//! matrix, so a long stream pays that cost once. Which method a caller gets, and with
//! which settings, is decided in one place: [`crate::reconstruct()`].
//!
//! * `support`: exact ℓ0-penalised bounded least squares — every support of up to
//!   m cells is tried (246 for 8 cells and 6 gratings, pseudo-inverses precomputed), the one with the
//!   smallest ‖Âz − y‖² + λ·|S| wins. This is the paper's objective with p → 0, solved
//!   exactly instead of stochastically.
//! * `wsupport` (the default): the same enumeration, but each support is fitted by
//!   generalised least squares and scored by −2 ln of its Laplace-approximated
//!   evidence under the noise that leaves the span of its columns (interrogator
//!   resolution, the additivity error of simultaneous loads, calibration noise; see
//!   [`NoisePrior`]) with a uniform prior over load counts and a uniform prior on each
//!   load over the array's rated range [min_load, ulimit], plus a small λ·|S|.
//! * `nnls`: Lawson–Hanson non-negative least squares, then the upper bound enforced
//!   by a bounded projected-gradient polish (no sparsity prior beyond x ≥ 0).
//! * `lasso`: ½‖Âz − y‖² + λ‖z‖₁ over the box, by FISTA with adaptive restart.
//! * `omp`: non-negative orthogonal matching pursuit; a cell is added only while it
//!   lowers ‖Âz − y‖² by more than λ (the same trade-off as `support`, greedily).
//! * `de`: the paper's replica — ‖Âz − y‖² + σ Σ z_jᵖ with p = 0.01, DE/rand/1/bin,
//!   150 individuals, ≤ 1500 generations (see [`crate::solvers::differential_evolution`]).
//!
//! No method returns NaN: a frame with a non-finite shift gives all-zero loads marked
//! not converged, and every load is clamped into [0, ulimit].

mod bnb;
pub(crate) mod bounded;
mod de;
mod lasso;
mod nnls;
mod omp;
mod support;

pub use bnb::{BnbSettings, DEFAULT_NODE_BUDGET};
pub use de::{DeSettings, PenalisedCost};
pub use lasso::LassoSettings;
pub use nnls::NnlsSettings;
pub use omp::OmpSettings;
pub use support::{NoisePrior, SupportSettings, WeightedSupportSettings};

use super::problem::SensingProblem;
use super::ArrayError;
use nalgebra::{DMatrix, DVector};
use serde::{Serialize, Serializer};

/// The outcome of reconstructing one frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reconstruction {
    /// Load on each cell, g, within [0, ulimit].
    pub loads_g: Vec<f64>,
    /// Whether the method met its own convergence test (exact methods: always, unless
    /// the input was unusable).
    pub converged: bool,
    /// Whether the answer is the proven optimum of the method's own objective: the
    /// exact searches when they completed (`support`; `bnb` within its work budget;
    /// `wsupport` unless it skipped a bounded solve on its heuristic), the convex
    /// methods when they met their optimality test (`nnls`, `lasso`); never `omp`
    /// (greedy) or `de` (stochastic).
    pub certified: bool,
    /// Iterations (DE generations, FISTA steps, OMP atoms, supports tried).
    pub iterations: u64,
    /// ‖A x − y‖, pm (with a common-mode term: after the best common offset).
    pub residual_pm: f64,
    /// χ² of the residual under the problem's uncertainty, the loads refitted with
    /// its weights (filled by the frame test, [`crate::trust`]; 0 from a method
    /// alone; NaN for an unusable frame).
    pub chi2: f64,
    /// Degrees of freedom of that χ²: gratings − loads (− 1 with a common-mode term).
    pub dof: usize,
    /// P(χ²_dof ≥ χ²): the frame is `inconsistent` below the significance (1 with no
    /// degree of freedom; NaN for an unusable frame).
    pub p_value: f64,
    /// The closest distinct rival (an answer ≥ 12 dB away, loads in the rated
    /// range): its penalised χ² minus the answer's (negative: it fits better); how
    /// well the array separates the answer from its nearest rival at this noise
    /// (information, not a flag). None: no distinct rival within the quantile of the
    /// run's significance (rivals further away are not evaluated).
    pub rival_margin_chi2: Option<f64>,
    /// The rival test's p-value (Bonferroni-corrected over the rivals considered):
    /// P(a rival explains the frame this much better than it explains the answer's
    /// own prediction | the answer is true). The frame is `ambiguous` below a third
    /// of the significance. None: no distinct rival was evaluated.
    pub rival_p_value: Option<f64>,
    /// Loads below the rated range the answer had, removed (the smaller support
    /// refitted) before the test.
    pub pruned_loads: usize,
    /// With loads pruned: P(the fit without them is no worse than chance), a
    /// likelihood-ratio test; `below_range` below the significance (the frame needs
    /// a load the array is not rated for).
    pub below_range_p_value: Option<f64>,
    /// At the ceiling: the largest p-value of a fit with a load above the ceiling
    /// (None: none has every load positive and one above ulimit); `overload` at or
    /// above the significance.
    pub overload_p_value: Option<f64>,
    /// The frame's common offset, pm per unit of mean temperature weight (with a
    /// common-mode term).
    pub common_mode_pm: Option<f64>,
    /// Why the frame should not be trusted; empty when it can be (filled by
    /// [`crate::reconstruct()`]).
    pub flags: FrameFlags,
}

impl Reconstruction {
    /// An answer from elsewhere (another tool, the truth of a synthetic frame), to
    /// be judged by the frame test ([`crate::trust::FrameTest::assess`]): its loads,
    /// g, and nothing else.
    ///
    /// ```
    /// use fbgforge_array::methods::Reconstruction;
    /// let r = Reconstruction::answer(vec![0.0, 120.0]);
    /// assert!(r.converged && !r.certified && r.flags.trusted());
    /// ```
    pub fn answer(loads_g: Vec<f64>) -> Self {
        Self::untested(loads_g, true, 0)
    }

    /// A method's answer before the frame test: loads, convergence and work; the
    /// test's fields empty.
    pub(crate) fn untested(loads_g: Vec<f64>, converged: bool, iterations: u64) -> Self {
        Reconstruction {
            loads_g,
            converged,
            certified: false,
            iterations,
            residual_pm: 0.0,
            chi2: 0.0,
            dof: 0,
            p_value: 1.0,
            rival_margin_chi2: None,
            rival_p_value: None,
            pruned_loads: 0,
            below_range_p_value: None,
            overload_p_value: None,
            common_mode_pm: None,
            flags: FrameFlags::default(),
        }
    }

    /// An unusable frame (wrong length, a non-finite shift or one beyond the
    /// interrogator's window): no loads (NaN: never zero loads that look like an
    /// answer), flagged `unusable`.
    pub(crate) fn unusable(n_cells: usize) -> Self {
        let mut r = Reconstruction::untested(vec![f64::NAN; n_cells], false, 0);
        r.residual_pm = f64::NAN;
        r.chi2 = f64::NAN;
        r.p_value = f64::NAN;
        r.flags = FrameFlags {
            unusable: true,
            ..FrameFlags::default()
        };
        r
    }
}

/// One frame in, one reconstruction out; precomputed state lives in the implementor.
pub trait Reconstructor: Send + Sync {
    /// The method this reconstructor runs.
    fn method(&self) -> Method;
    /// Reconstruct the loads of one frame of shifts (pm, one per grating).
    fn reconstruct(&self, shifts_pm: &[f64]) -> Reconstruction;
    /// The objective the method minimises, at loads `loads_g` (g) for this frame
    /// (lower is better; the method's working units), or None for a method that
    /// minimises none it could be held to (`omp` is greedy; `wsupport` scores
    /// supports, not loads). A method that says it converged must not return loads
    /// whose objective is above that of any other admissible loads — the truth
    /// included (a test).
    fn objective(&self, _shifts_pm: &[f64], _loads_g: &[f64]) -> Option<f64> {
        None
    }
}

/// Method used when none is named: the most accurate one that keeps up with
/// 10 000 frames/s (see the `reconstruct` study and docs/array.md).
pub const DEFAULT_METHOD: Method = Method::WeightedSupport;

/// A reconstruction method as registered: its name, its settings for given readings
/// and its tuning grid. Each method file defines one entry and its own settings type
/// (the knobs only it has); [`Method::ALL`] is the registry and [`MethodSettings`]
/// has one variant per method, so a new method is one file, one line in `ALL` and
/// one variant (with its two arms in `MethodSettings::knobs`).
pub(crate) struct MethodEntry {
    /// Name used on the command line and in tables.
    pub name: &'static str,
    /// Grid of penalty weights searched when tuning on a validation set.
    pub penalty_grid: fn() -> Vec<f64>,
    /// The method's settings for readings of this kind (its defaults follow the
    /// prior: e.g. the ℓ0 penalty of `support` and `bnb` follows the resolution).
    defaults: fn(&ReadingSettings) -> MethodSettings,
}

/// A registered method: a handle on its [`MethodEntry`], compared by name.
#[derive(Clone, Copy)]
pub struct Method(&'static MethodEntry);

/// The methods by name, so callers can write `Method::WeightedSupport`.
#[allow(non_upper_case_globals)]
impl Method {
    /// Exact ℓ0-penalised bounded least squares over enumerated supports.
    pub const Support: Method = Method(&support::SUPPORT);
    /// Like `Support`, each support scored by its evidence under the paper's noise.
    pub const WeightedSupport: Method = Method(&support::WEIGHTED_SUPPORT);
    /// Non-negative least squares (Lawson–Hanson) with the upper bound enforced.
    pub const Nnls: Method = Method(&nnls::ENTRY);
    /// Bounded LASSO by FISTA.
    pub const Lasso: Method = Method(&lasso::ENTRY);
    /// Non-negative orthogonal matching pursuit.
    pub const Omp: Method = Method(&omp::ENTRY);
    /// The paper's sparse differential evolution.
    pub const De: Method = Method(&de::ENTRY);
    /// The `support` objective solved exactly by branch and bound (arrays of any size).
    pub const BranchAndBound: Method = Method(&bnb::ENTRY);
}

impl Method {
    /// The registry: every method, fastest exact one first.
    pub const ALL: [Method; 7] = [
        Method::WeightedSupport,
        Method::Support,
        Method::BranchAndBound,
        Method::Nnls,
        Method::Lasso,
        Method::Omp,
        Method::De,
    ];

    /// Name used on the command line and in tables.
    pub fn name(self) -> &'static str {
        self.0.name
    }

    /// Parse a method name (case-insensitive).
    pub fn from_name(name: &str) -> Result<Method, ArrayError> {
        Method::ALL
            .iter()
            .copied()
            .find(|m| m.name().eq_ignore_ascii_case(name.trim()))
            .ok_or_else(|| ArrayError::UnknownMethod {
                name: name.to_string(),
                known: Method::ALL.map(|m| m.name()).join(", "),
            })
    }

    /// Whether the method has a penalty weight to tune.
    pub(crate) fn has_penalty(self) -> bool {
        MethodSettings::for_method(self).penalty().is_some()
    }

    /// Default penalty weight (working units; see each method's settings), 0 for a
    /// method without one: the median of the values tuned on the validation sets of
    /// five seeded runs of the paper's protocol with column normalisation (the
    /// `reconstruct` study prints the tuned values); for `wsupport`, chosen on seeds
    /// 1001–1020 of the protocol (disjoint from the study's 1–20) and checked on
    /// 2001–2040.
    pub fn default_penalty(self) -> f64 {
        MethodSettings::for_method(self).penalty().unwrap_or(0.0)
    }

    /// Grid of penalty weights searched when tuning on a validation set.
    pub fn penalty_grid(self) -> Vec<f64> {
        (self.0.penalty_grid)()
    }
}

impl PartialEq for Method {
    fn eq(&self, other: &Method) -> bool {
        self.name() == other.name()
    }
}

impl Eq for Method {}

impl std::hash::Hash for Method {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        self.name().hash(h)
    }
}

impl std::fmt::Debug for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for Method {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// The usual penalty grid: 13 doublings from 1/16.
fn doubling_grid() -> Vec<f64> {
    (0..13).map(|k| 0.0625 * 2f64.powi(k)).collect()
}

/// Why a frame should not be trusted; all false when it can be.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FrameFlags {
    /// The residual exceeds what the stated uncertainty explains (χ² test).
    pub inconsistent: bool,
    /// A load sits at ulimit.
    pub ceiling: bool,
    /// The frame is consistent with a load above ulimit.
    pub overload: bool,
    /// A loaded cell carries less than the rated minimum load.
    pub below_range: bool,
    /// Another answer ≥ 12 dB away explains the frame better than the answer could
    /// by chance (the rival test, [`crate::trust`]).
    pub ambiguous: bool,
    /// The method did not converge (`bnb`: stopped at its work budget). A note, not
    /// part of the trust test: the answer is judged like any other, and an answer a
    /// better explanation beats beyond chance is `ambiguous`.
    pub unconverged: bool,
    /// The frame could not be used (wrong length, non-finite shift).
    pub unusable: bool,
}

impl FrameFlags {
    /// The flag words in the order they are written.
    pub(crate) const WORDS: [&'static str; 7] = [
        "inconsistent",
        "ceiling",
        "overload",
        "below_range",
        "ambiguous",
        "unconverged",
        "unusable",
    ];

    fn bits(&self) -> [bool; 7] {
        [
            self.inconsistent,
            self.ceiling,
            self.overload,
            self.below_range,
            self.ambiguous,
            self.unconverged,
            self.unusable,
        ]
    }

    /// The words of the flags of the trust test that are set (`unconverged`, a note,
    /// is counted apart and shows as `certified` false).
    pub fn words(&self) -> Vec<&'static str> {
        Self::WORDS
            .iter()
            .zip(self.bits())
            .filter(|(w, b)| *b && **w != "unconverged")
            .map(|(w, _)| *w)
            .collect()
    }

    /// True when no flag of the trust test is set (`unconverged` is a note): the
    /// frame can be trusted.
    pub fn trusted(&self) -> bool {
        self.words().is_empty()
    }

    /// The flags as one CSV field: the words joined by `;` (empty when trusted).
    pub fn field(&self) -> String {
        self.words().join(";")
    }
}

impl Serialize for FrameFlags {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.words().serialize(s)
    }
}

/// What a reconstruction knows of the readings before it sees a frame: how many
/// loads act at once at most and how noisy the interrogator is. Every method's
/// defaults follow it ([`MethodSettings::for_prior`]); the default method choice
/// synthesises its probe frames from it when it has none of the caller's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReadingSettings {
    /// Most simultaneous loads (supports grow as C(n, ≤ K); capped at the number of
    /// gratings by the methods).
    pub max_loads: usize,
    /// The interrogator's resolution: the noise standard deviation of a shift, pm.
    pub resolution_pm: f64,
}

impl ReadingSettings {
    /// The paper's readings: up to [`DEFAULT_MAX_LOADS`] loads, 0.5 pm resolution.
    pub fn paper() -> Self {
        ReadingSettings {
            max_loads: DEFAULT_MAX_LOADS,
            resolution_pm: NoisePrior::paper().resolution_pm,
        }
    }

    /// Check both fields: at least one load, a positive finite resolution.
    pub fn check(&self) -> Result<(), ArrayError> {
        if self.max_loads == 0 {
            return Err(ArrayError::Input(
                "ReadingSettings.max_loads must be at least 1".into(),
            ));
        }
        check_resolution(self.resolution_pm)
            .map_err(|e| ArrayError::Input(format!("ReadingSettings.resolution_pm: {e}")))
    }
}

impl Default for ReadingSettings {
    fn default() -> Self {
        ReadingSettings::paper()
    }
}

/// A resolution must be a positive, finite noise in pm.
pub fn check_resolution(resolution_pm: f64) -> Result<(), ArrayError> {
    if resolution_pm.is_finite() && resolution_pm > 0.0 {
        Ok(())
    } else {
        Err(ArrayError::Input(format!(
            "the interrogator resolution must be a positive noise in pm, got {resolution_pm}"
        )))
    }
}

/// The settings of one method, each method's own type (defined in its file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "method")]
pub enum MethodSettings {
    /// `support`.
    #[serde(rename = "support")]
    Support(SupportSettings),
    /// `wsupport`.
    #[serde(rename = "wsupport")]
    WeightedSupport(WeightedSupportSettings),
    /// `bnb`.
    #[serde(rename = "bnb")]
    BranchAndBound(BnbSettings),
    /// `nnls`.
    #[serde(rename = "nnls")]
    Nnls(NnlsSettings),
    /// `lasso`.
    #[serde(rename = "lasso")]
    Lasso(LassoSettings),
    /// `omp`.
    #[serde(rename = "omp")]
    Omp(OmpSettings),
    /// `de`.
    #[serde(rename = "de")]
    De(DeSettings),
}

/// What every method's settings type answers. A method without a penalty or a load
/// cap keeps the `None` defaults.
trait Knobs {
    /// The method these settings are for.
    fn method(&self) -> Method;
    /// Build the method's reconstructor from the matrix-only precomputation.
    fn build(&self, common: Common) -> Result<Box<dyn Reconstructor>, ArrayError>;
    /// The penalty weight, if the method has one (working units).
    fn penalty_mut(&mut self) -> Option<&mut f64> {
        None
    }
    /// The most simultaneous loads it considers, if it has a cap.
    fn max_loads_mut(&mut self) -> Option<&mut usize> {
        None
    }
}

impl MethodSettings {
    /// The method's settings for the paper's readings ([`ReadingSettings::paper`]).
    pub fn for_method(method: Method) -> Self {
        Self::for_prior(method, &ReadingSettings::paper())
    }

    /// The method's settings for readings of this kind: its own rule (e.g. the ℓ0
    /// penalty of `support` and `bnb` from the resolution,
    /// [`l0_penalty_for_resolution`]), every other knob its default. The one rule a
    /// named method and the default choice both follow.
    pub fn for_prior(method: Method, prior: &ReadingSettings) -> Self {
        (method.0.defaults)(prior)
    }

    /// Each variant as the trait every settings type implements.
    fn knobs(&self) -> &dyn Knobs {
        match self {
            MethodSettings::Support(s) => s,
            MethodSettings::WeightedSupport(s) => s,
            MethodSettings::BranchAndBound(s) => s,
            MethodSettings::Nnls(s) => s,
            MethodSettings::Lasso(s) => s,
            MethodSettings::Omp(s) => s,
            MethodSettings::De(s) => s,
        }
    }

    /// [`Self::knobs`], mutably.
    fn knobs_mut(&mut self) -> &mut dyn Knobs {
        match self {
            MethodSettings::Support(s) => s,
            MethodSettings::WeightedSupport(s) => s,
            MethodSettings::BranchAndBound(s) => s,
            MethodSettings::Nnls(s) => s,
            MethodSettings::Lasso(s) => s,
            MethodSettings::Omp(s) => s,
            MethodSettings::De(s) => s,
        }
    }

    /// The method these settings are for.
    pub fn method(&self) -> Method {
        self.knobs().method()
    }

    /// The penalty weight (working units), or None for a method without one (`nnls`).
    pub fn penalty(&self) -> Option<f64> {
        // Settings are Copy: read through the one accessor each type writes.
        let mut copy = *self;
        copy.knobs_mut().penalty_mut().map(|p| *p)
    }

    /// The same settings with the penalty weight `penalty` (a method without one is
    /// returned unchanged: see [`Method::has_penalty`]).
    pub fn with_penalty(mut self, penalty: f64) -> Self {
        if let Some(p) = self.knobs_mut().penalty_mut() {
            *p = penalty;
        }
        self
    }

    /// The most simultaneous loads the method considers, or None for a method that
    /// has no cap (`nnls`, `lasso`, `omp`).
    pub fn max_loads(&self) -> Option<usize> {
        let mut copy = *self;
        copy.knobs_mut().max_loads_mut().map(|k| *k)
    }

    /// The same settings with the load cap `max_loads` (a method without one is
    /// returned unchanged).
    pub fn with_max_loads(mut self, max_loads: usize) -> Self {
        if let Some(k) = self.knobs_mut().max_loads_mut() {
            *k = max_loads;
        }
        self
    }
}

/// The penalty of the ℓ0 objective (`support`, `bnb`) for an interrogator
/// whose readings have a noise of `resolution_pm` (standard deviation, pm):
/// λ = 16 σ² (pm², the price of one more load in squared residual). The factor is the
/// paper's calibration: λ = 4 was tuned on its protocol (σ = 0.5 pm, the default);
/// with σ = 0.25 pm it gives λ = 1, what the validation frames of the scaling study
/// (σ = 0.25 pm plus 3 % relative noise) chose independently at 6 × 8, 12 × 32,
/// 16 × 64 and 32 × 256 (docs/array.md §10.6). It does not grow with the number of
/// cells: at fixed noise the tuned λ did not (4 at 8 × 16, 0.25 at 24 × 128, 1
/// elsewhere).
pub fn l0_penalty_for_resolution(resolution_pm: f64) -> f64 {
    16.0 * resolution_pm * resolution_pm
}

/// Most simultaneous loads assumed when neither the caller nor the design says: the
/// paper tests up to four (reference §2, Table 3).
pub const DEFAULT_MAX_LOADS: usize = 4;

/// Build a reconstructor for `problem` with a method's `settings` (which name the
/// method), precomputing what depends only on the matrix.
pub fn build(
    problem: &SensingProblem,
    settings: &MethodSettings,
) -> Result<Box<dyn Reconstructor>, ArrayError> {
    if let Some(p) = settings.penalty() {
        if !(p.is_finite() && p >= 0.0) {
            return Err(ArrayError::Input(format!(
                "penalty must be a finite value ≥ 0, got {p}"
            )));
        }
    }
    let inner = settings.knobs().build(Common::new(problem))?;
    Ok(match &problem.common_mode {
        Some(_) => Box::new(CommonMode {
            problem: problem.clone(),
            inner,
        }),
        None => inner,
    })
}

/// A method solving a problem with a common-mode term: every frame has the common
/// direction projected out before the method sees it, and the frame's common offset
/// is reported with the answer.
struct CommonMode {
    problem: SensingProblem,
    inner: Box<dyn Reconstructor>,
}

impl Reconstructor for CommonMode {
    fn method(&self) -> Method {
        self.inner.method()
    }
    fn reconstruct(&self, shifts_pm: &[f64]) -> Reconstruction {
        if self.problem.check_shifts(shifts_pm).is_err() {
            return self.inner.reconstruct(shifts_pm);
        }
        let mut r = self
            .inner
            .reconstruct(&self.problem.project_frame(shifts_pm));
        r.common_mode_pm = self.problem.common_offset_pm(&r.loads_g, shifts_pm);
        r
    }
    fn objective(&self, shifts_pm: &[f64], loads_g: &[f64]) -> Option<f64> {
        if self.problem.check_shifts(shifts_pm).is_err() {
            return None;
        }
        self.inner
            .objective(&self.problem.project_frame(shifts_pm), loads_g)
    }
}

/// What every method needs: the problem and the Gram matrix of its working matrix.
struct Common {
    problem: SensingProblem,
    /// ÂᵀÂ.
    gram: DMatrix<f64>,
    /// Largest eigenvalue of ÂᵀÂ (the gradient's Lipschitz constant).
    lipschitz: f64,
}

/// Two answers are distinct when one read as the other's truth would miss the 12 dB
/// recovery criterion: ‖x′ − x‖ > 10^(−12/20) ‖x‖.
pub(crate) const DISTINCT_RATIO: f64 = 0.251_188_643_150_958;

/// Work a bounded solve (an active-set solve at the ceiling) counts for in the
/// enumerations' `iterations`, in supports valued: what it costs against valuing one
/// support, measured on the reference machine (`studies/examples/reconstruct_cost.rs`).
pub(crate) const BOUNDED_SOLVE_UNITS: u64 = 100;

/// Largest eigenvalue of a Gram matrix (the Lipschitz constant of its least-squares
/// gradient, FISTA's step), kept above zero.
pub(crate) fn lipschitz(g: &DMatrix<f64>) -> f64 {
    g.clone()
        .symmetric_eigenvalues()
        .iter()
        .copied()
        .fold(0.0, f64::max)
        .max(1e-300)
}

impl Common {
    fn new(problem: &SensingProblem) -> Self {
        let gram = problem.working.transpose() * &problem.working;
        let lipschitz = lipschitz(&gram);
        Common {
            problem: problem.clone(),
            gram,
            lipschitz,
        }
    }

    fn n(&self) -> usize {
        self.problem.n_cells()
    }

    /// Âᵀy, or None when the frame is unusable (wrong length or non-finite).
    fn aty(&self, y: &[f64]) -> Option<DVector<f64>> {
        if self.problem.check_shifts(y).is_err() {
            return None;
        }
        Some(self.problem.working.transpose() * DVector::from_column_slice(y))
    }

    /// Wrap working unknowns into a result (not certified: the exact methods say so
    /// with [`Reconstruction::certified`] afterwards).
    fn finish(&self, z: &[f64], y: &[f64], converged: bool, iterations: u64) -> Reconstruction {
        let loads_g = self.problem.loads_from_working(z);
        let residual_pm = if y.len() == self.problem.n_gratings() {
            self.problem.residual_pm(&loads_g, y)
        } else {
            f64::INFINITY
        };
        let mut r = Reconstruction::untested(loads_g, converged, iterations);
        r.residual_pm = if residual_pm.is_finite() {
            residual_pm
        } else {
            f64::MAX
        };
        r
    }

    /// ‖Âz − y‖² = ‖Ax − y‖² (pm²) and the working unknowns z of loads x (g), or None
    /// for an unusable frame or loads of the wrong length or outside [0, ulimit].
    fn misfit_of(&self, y: &[f64], loads_g: &[f64]) -> Option<(f64, Vec<f64>)> {
        let p = &self.problem;
        if p.check_shifts(y).is_err()
            || loads_g.len() != self.n()
            || loads_g
                .iter()
                .any(|&x| !(x.is_finite() && (0.0..=p.ulimit_g * (1.0 + 1e-12)).contains(&x)))
        {
            return None;
        }
        let r = p.residual_pm(loads_g, y);
        let z = loads_g
            .iter()
            .zip(p.scale.iter())
            .map(|(x, s)| x * s)
            .collect();
        Some((r * r, z))
    }

    /// The answer for a frame that cannot be used.
    fn unusable(&self) -> Reconstruction {
        Reconstruction::unusable(self.n())
    }
}

/// ‖Âz − y‖² from the Gram form: yᵀy − 2 bᵀz + zᵀGz (never below 0).
fn misfit(gram: &DMatrix<f64>, aty: &DVector<f64>, yty: f64, z: &DVector<f64>) -> f64 {
    (yty - 2.0 * aty.dot(z) + z.dot(&(gram * z))).max(0.0)
}

/// FISTA with adaptive restart for ½zᵀGz − bᵀz + λΣz over 0 ≤ z ≤ u.
/// Returns (z, iterations, converged).
fn fista_box(
    gram: &DMatrix<f64>,
    b: &DVector<f64>,
    upper: &DVector<f64>,
    lambda: f64,
    lipschitz: f64,
    start: DVector<f64>,
    max_iter: u64,
) -> (DVector<f64>, u64, bool) {
    let n = b.len();
    let step = 1.0 / lipschitz;
    let project = |v: &mut DVector<f64>| {
        for j in 0..n {
            v[j] = v[j].clamp(0.0, upper[j]);
        }
    };
    let mut z = start;
    project(&mut z);
    let mut v = z.clone();
    let mut t = 1.0f64;
    let scale = upper.amax().max(1e-300);
    for it in 1..=max_iter {
        let grad = gram * &v - b;
        let mut z_new = &v - (grad.add_scalar(lambda)) * step;
        project(&mut z_new);
        let t_new = 0.5 * (1.0 + (1.0 + 4.0 * t * t).sqrt());
        let diff = &z_new - &z;
        // Adaptive restart (O'Donoghue & Candès): drop the momentum when it points uphill.
        let uphill = (&v - &z_new).dot(&diff) > 0.0;
        let momentum = if uphill { 0.0 } else { (t - 1.0) / t_new };
        v = &z_new + &diff * momentum;
        t = if uphill { 1.0 } else { t_new };
        let change = diff.amax();
        z = z_new;
        if change <= 1e-10 * scale {
            return (z, it, true);
        }
    }
    (z, max_iter, false)
}

/// Bounded least squares restricted to the cells `cols`: exact by the active set
/// ([`bounded::box_qp`]); projected FISTA only for dependent columns. Returns the
/// full-length z (zeros off the support) and whether it converged.
fn bounded_ls_on(c: &Common, aty: &DVector<f64>, cols: &[usize]) -> (DVector<f64>, bool) {
    let n = c.n();
    let k = cols.len();
    let mut z = DVector::zeros(n);
    if k == 0 {
        return (z, true);
    }
    let g = DMatrix::from_fn(k, k, |a, b| c.gram[(cols[a], cols[b])]);
    let b = DVector::from_fn(k, |a, _| aty[cols[a]]);
    let u = DVector::from_fn(k, |a, _| c.problem.upper[cols[a]]);
    if let Some(s) = bounded::box_qp(&g, &b, &DVector::zeros(k), &u) {
        for (a, &j) in cols.iter().enumerate() {
            z[j] = s[a];
        }
        return (z, true);
    }
    if let Some(ch) = g.clone().cholesky() {
        let s = ch.solve(&b);
        if s.iter().zip(u.iter()).all(|(v, ub)| *v >= 0.0 && v <= ub) {
            for (a, &j) in cols.iter().enumerate() {
                z[j] = s[a];
            }
            return (z, true);
        }
    }
    let lip = lipschitz(&g);
    let (s, _, ok) = fista_box(&g, &b, &u, 0.0, lip, DVector::zeros(k), 5000);
    for (a, &j) in cols.iter().enumerate() {
        z[j] = s[a];
    }
    (z, ok)
}

/// Reconstruct every frame of a stream with one method: in parallel (rayon) from 512
/// frames on, reporting no progress.
pub fn reconstruct_stream(
    problem: &SensingProblem,
    settings: &MethodSettings,
    frames: &[Vec<f64>],
) -> Result<Vec<Reconstruction>, ArrayError> {
    let r = build(problem, settings)?;
    Ok(reconstruct_frames(
        r.as_ref(),
        frames,
        &crate::progress::Quiet,
    ))
}

/// Streams of at least this many frames are reconstructed in parallel (rayon).
pub const PARALLEL_FROM: usize = 512;

/// Reconstruct every frame with a reconstructor already built (its set-up paid):
/// in parallel (rayon) from 512 frames on, telling `progress` of each chunk done.
pub fn reconstruct_frames(
    r: &dyn Reconstructor,
    frames: &[Vec<f64>],
    progress: &dyn crate::progress::Progress,
) -> Vec<Reconstruction> {
    use rayon::prelude::*;
    if frames.len() < PARALLEL_FROM {
        return frames.iter().map(|y| r.reconstruct(y)).collect();
    }
    progress.begin("reconstruct", frames.len() as u64);
    let out: Vec<Reconstruction> = frames
        .par_chunks(256)
        .flat_map_iter(|chunk| {
            let v: Vec<Reconstruction> = chunk.iter().map(|y| r.reconstruct(y)).collect();
            progress.advance(chunk.len() as u64);
            v
        })
        .collect();
    progress.end();
    out
}

#[cfg(test)]
mod tests {
    use super::support::{ln_normal_cdf, SupportSearch};
    use super::*;

    #[test]
    fn ln_normal_cdf_matches_tabulated_values_and_the_far_tail() {
        // Φ from tables (Abramowitz & Stegun 26.2), and Φ(−10) = 7.6198530241605e−24.
        for (t, phi) in [
            (0.0, 0.5),
            (1.0, 0.841_344_746_068_543),
            (-1.959_963_985, 0.025),
            (-3.0, 0.001_349_898_031_630_1),
            (2.5, 0.993_790_334_674_224),
        ] {
            let got = ln_normal_cdf(t).exp();
            assert!(
                (got - phi).abs() < 2e-7 * phi.max(1e-3),
                "Φ({t}) = {got}, want {phi}"
            );
        }
        let ln_tail = ln_normal_cdf(-10.0);
        assert!(
            (ln_tail - 7.619_853_024_160_5e-24f64.ln()).abs() < 1e-5,
            "{ln_tail}"
        );
        // Far beyond underflow it stays finite and follows −t²/2.
        let far = ln_normal_cdf(-100.0);
        assert!(far.is_finite() && (far + 5000.0).abs() < 10.0, "{far}");
        assert!(ln_normal_cdf(40.0) <= 0.0 && ln_normal_cdf(40.0) > -1e-12);
    }

    #[test]
    fn each_method_has_its_own_settings_and_follows_the_prior_by_its_own_rule() {
        let prior = ReadingSettings {
            max_loads: 3,
            resolution_pm: 0.25,
        };
        for m in Method::ALL {
            let s = MethodSettings::for_prior(m, &prior);
            assert_eq!(s.method(), m);
            // The JSON tag is the method's registered name.
            let json = serde_json::to_value(s).unwrap();
            assert_eq!(json["method"], m.name(), "{json}");
            // ℓ0 penalty from the resolution for `support` and `bnb` only (λ = 1 at
            // 0.25 pm); every other method keeps its tuned default.
            let want = if m == Method::Support || m == Method::BranchAndBound {
                Some(1.0)
            } else if m == Method::Nnls {
                None
            } else {
                Some(MethodSettings::for_method(m).penalty().unwrap())
            };
            assert_eq!(s.penalty(), want, "{m:?}");
            assert_eq!(m.has_penalty(), want.is_some());
            // The cap belongs to the methods that enumerate or seed supports.
            let capped = [
                Method::Support,
                Method::WeightedSupport,
                Method::BranchAndBound,
                Method::De,
            ]
            .contains(&m);
            assert_eq!(s.max_loads(), capped.then_some(3), "{m:?}");
            // Replacing a knob the method lacks changes nothing.
            assert_eq!(s.with_penalty(7.0).penalty(), want.map(|_| 7.0));
            assert_eq!(s.with_max_loads(2).max_loads(), capped.then_some(2));
        }
    }

    #[test]
    fn fista_box_matches_the_closed_form_in_one_dimension() {
        // min ½ g z² − b z + λ z on [0, u]  →  z = clamp((b − λ)/g, 0, u).
        for (g, b, lambda, u) in [
            (2.0f64, 5.0f64, 1.0f64, 10.0f64),
            (2.0, 5.0, 1.0, 1.5),
            (1.0, 0.5, 1.0, 3.0),
        ] {
            let want = ((b - lambda) / g).clamp(0.0, u);
            let (z, _, ok) = fista_box(
                &DMatrix::from_element(1, 1, g),
                &DVector::from_element(1, b),
                &DVector::from_element(1, u),
                lambda,
                g,
                DVector::zeros(1),
                10_000,
            );
            assert!(ok && (z[0] - want).abs() < 1e-8, "{z} vs {want}");
        }
    }

    #[test]
    fn upper_set_box_solver_matches_fista() {
        // A 3 × 3 problem whose unconstrained optimum exceeds the bound on two loads.
        let g = DMatrix::from_row_slice(3, 3, &[2.0, 0.5, 0.2, 0.5, 1.5, 0.3, 0.2, 0.3, 1.0]);
        let b = DVector::from_vec(vec![9.0, 6.0, 1.5]);
        let u = DVector::from_element(3, 2.5);
        let exact = bounded::box_qp(&g, &b, &DVector::zeros(3), &u).unwrap();
        let (reference, _, ok) = fista_box(&g, &b, &u, 0.0, 3.0, DVector::zeros(3), 100_000);
        assert!(ok);
        assert!(
            (&exact - &reference).amax() < 1e-7,
            "{exact} vs {reference}"
        );
        assert!(exact[0] == 2.5 && exact[1] == 2.5 && exact[2] < 2.5);
    }

    #[test]
    fn support_search_enumerates_every_support_up_to_the_number_of_gratings() {
        let a = DMatrix::from_fn(6, 8, |i, j| {
            1.0 / (1.0 + ((i as f64) - (j as f64) * 0.7).powi(2))
        });
        let p = SensingProblem::new(a, 250.0, true).unwrap();
        let s = SupportSearch::new(Common::new(&p), 1.0, None, 6).unwrap();
        // C(8,1) + … + C(8,6) = 8 + 28 + 56 + 70 + 56 + 28.
        assert_eq!(s.entries.len(), 246);
        assert!(s
            .entries
            .windows(2)
            .all(|w| w[0].cols.len() <= w[1].cols.len()));
        // With at most 4 loads: C(8,1) + … + C(8,4) = 8 + 28 + 56 + 70.
        let s = SupportSearch::new(Common::new(&p), 1.0, None, 4).unwrap();
        assert_eq!(s.entries.len(), 162);
        // 64 cells × 16 gratings with ≤ 4 loads would need 679 120 supports: refused
        // with a clear error that names the method that scales.
        let big = SensingProblem::new(DMatrix::from_element(16, 64, 1.0), 250.0, true).unwrap();
        let e = SupportSearch::new(Common::new(&big), 1.0, None, 4)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("679120") && e.contains("bnb"), "{e}");
    }
}
