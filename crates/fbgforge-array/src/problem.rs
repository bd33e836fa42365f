//! The reconstruction problem, kept apart from the methods that solve it.
//!
//! Given a sensing matrix A (pm/g) and a frame of grating shifts y (pm), find cell
//! loads x (g) with A x ≈ y, 0 ≤ x ≤ ulimit, and few non-zero loads.
//!
//! Column normalisation (the paper's step, "so that the search for the sparsest
//! solution does not favour sensors with higher sensitivities"): every method works in
//! the scaled unknowns z_j = ‖a_j‖ · x_j, for which the matrix Â = A · diag(1/‖a_j‖) has
//! unit columns. z is in pm (the shift a load would cause on a unit-norm column), the
//! bounds become 0 ≤ z_j ≤ ulimit · ‖a_j‖, and loads are recovered as x_j = z_j / ‖a_j‖.
//! This changes nothing for exact least squares but it changes which support a sparsity
//! penalty prefers, and it makes an ℓ1 penalty treat every cell alike. Without
//! normalisation the scale is 1 (z = x, in g).
//!
//! The problem also carries the array's load range: ulimit (the most a cell can carry)
//! and `min_load_g` (the least load a loaded cell carries: the paper's array is rated
//! for 25–250 g per cell). `min_load_g` is a prior over loads, not a hard bound: the
//! likelihood search (`wsupport`) puts its uniform prior on [min_load, ulimit] and
//! charges a support for the posterior mass its fit leaves below min_load; the other
//! methods ignore it. 0 disables it.

use super::ArrayError;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// What the readings and the matrix are known to be off by: the basis of every
/// per-frame test (the χ² residual test of `inconsistent`, the margin of `ambiguous`).
/// The variance of grating i's reading for loads x (g) is
/// σ² + Σ_j s_ij² x_j² + [two or more loads] (ρ ŷ_i)²,
/// with σ the interrogator's resolution, s the per-entry standard deviation of the
/// sensing matrix and ρ the relative additivity error of simultaneous loads.
#[derive(Debug, Clone, PartialEq)]
pub struct Uncertainty {
    /// The interrogator's noise, standard deviation of one shift, pm.
    pub resolution_pm: f64,
    /// Standard deviation of each entry of the sensing matrix, pm/g (rows gratings,
    /// columns cells): from the scatter of repeated calibrations, a stated percentage,
    /// or by default one calibration reading per column ([`Uncertainty::paper`]).
    pub matrix_sd_pm_per_g: DMatrix<f64>,
    /// Relative standard deviation of each reading when two or more loads act
    /// (additivity error; the paper's ± 4 % uniform bound gives 0.04/√3).
    pub additivity_sd_frac: f64,
}

/// Load each column of the paper's matrix was calibrated with, g (one reading).
pub(crate) const PAPER_CALIBRATION_LOAD_G: f64 = 200.0;

/// Bound of the paper's additivity error (uniform ± 4 %, docs/array.md §4).
pub(crate) const PAPER_ADDITIVITY_FRAC: f64 = 0.04;

impl Uncertainty {
    /// The paper's measurement for an m × n matrix read at `resolution_pm`: every
    /// column calibrated with one reading at 200 g (entry sd = σ / 200 g), the ± 4 %
    /// additivity error as a standard deviation of 0.04/√3.
    pub fn paper(m: usize, n: usize, resolution_pm: f64) -> Self {
        Uncertainty {
            resolution_pm,
            matrix_sd_pm_per_g: DMatrix::from_element(
                m,
                n,
                resolution_pm / PAPER_CALIBRATION_LOAD_G,
            ),
            additivity_sd_frac: PAPER_ADDITIVITY_FRAC / 3f64.sqrt(),
        }
    }

    /// Variance of each reading (pm²) for loads `loads_g` whose prediction is
    /// `predicted_pm`.
    pub(crate) fn reading_variances_pm2(&self, loads_g: &[f64], predicted_pm: &[f64]) -> Vec<f64> {
        let several = loads_g.iter().filter(|&&x| x > 0.0).count() >= 2;
        let s2 = self.resolution_pm * self.resolution_pm;
        let rho2 = self.additivity_sd_frac * self.additivity_sd_frac;
        predicted_pm
            .iter()
            .enumerate()
            .map(|(i, &yh)| {
                let matrix: f64 = loads_g
                    .iter()
                    .enumerate()
                    .filter(|(_, &x)| x > 0.0)
                    .map(|(j, &x)| {
                        let s = self.matrix_sd_pm_per_g[(i, j)] * x;
                        s * s
                    })
                    .sum();
                let additivity = if several { rho2 * yh * yh } else { 0.0 };
                (s2 + matrix + additivity).max(1e-300)
            })
            .collect()
    }
}

/// Serialized summary of an [`Uncertainty`] (the matrix term as its median relative
/// sd), as the JSON summary reports it.
#[derive(Debug, Clone, Serialize)]
pub struct UncertaintySummary {
    /// Interrogator noise, pm.
    pub resolution_pm: f64,
    /// Median of s_ij / |A_ij| over the matrix, %.
    pub matrix_sd_median_pct: f64,
    /// Largest s_ij / |A_ij|, %.
    pub matrix_sd_max_pct: f64,
    /// Relative additivity sd, %.
    pub additivity_sd_pct: f64,
}

/// Matrix, bounds and scaling shared by every frame of a stream.
#[derive(Debug, Clone)]
pub struct SensingProblem {
    /// The sensing matrix as given, pm/g (rows gratings, columns cells).
    pub sensitivity_pm_per_g: DMatrix<f64>,
    /// Largest load per cell, g.
    pub ulimit_g: f64,
    /// Smallest load a loaded cell carries, g (0: no lower limit). A prior used by
    /// `wsupport` only; see the module doc.
    pub min_load_g: f64,
    /// Whether the methods work with unit-norm columns.
    pub normalised: bool,
    /// The matrix the methods solve with: A, or A with unit columns.
    pub working: DMatrix<f64>,
    /// Scale per cell: z_j = scale_j · x_j (the column norm, or 1).
    pub scale: DVector<f64>,
    /// Upper bound of each working unknown: ulimit · scale_j.
    pub upper: DVector<f64>,
    /// Smallest load of a loaded cell in working units: min_load · scale_j.
    pub lower: DVector<f64>,
    /// What the readings and the matrix are off by (per-frame flags).
    pub uncertainty: Uncertainty,
    /// The common-mode (temperature) direction of the readings, unit length, when the
    /// problem fits a per-frame common offset: the methods then solve the matrix and
    /// frames with this direction projected out (see [`Self::with_common_mode`]).
    pub common_mode: Option<DVector<f64>>,
    /// Whether a whole stream is searched for faulty gratings (dead, stuck, drifting,
    /// swapped, saturated, noisy), which are then left out or corrected
    /// ([`crate::reconstruct()`], [`crate::faults`]; on by default).
    pub diagnose_stream: bool,
    /// The weights of a common-mode term the stream diagnosis fits when the frames
    /// call for it (all 1 by default; None: never unless asked with
    /// [`Self::with_common_mode`]).
    pub auto_common_mode: Option<Vec<f64>>,
    /// The interrogator's window: the largest shift a grating can report, pm (either
    /// sign). A frame with a larger shift is refused (`unusable`, no loads): its peak
    /// would have left the grating's window ([`DEFAULT_WINDOW_PM`] unless set).
    pub window_pm: f64,
    /// The significance of the per-frame test behind the flags
    /// ([`crate::trust`]; [`crate::trust::DEFAULT_SIGNIFICANCE`] unless set).
    pub significance: f64,
}

/// The interrogator window when none is given, pm: the widest window a grating gets
/// by default when peaks are assigned to gratings (`logs::assign`, 2.5 nm): a shift
/// beyond it could not have been read as this grating's.
pub const DEFAULT_WINDOW_PM: f64 = 2500.0;

/// The paper's rated load range per cell starts at 25 g (reference §2: 25–250 g).
pub const PAPER_MIN_LOAD_G: f64 = 25.0;

/// The smallest load of a loaded cell when none is given: the paper's 25 g, or no
/// lower end (0) for an array rated for 25 g or less in total, rather than an error
/// about a value the user never gave.
pub fn default_min_load_g(ulimit_g: f64) -> f64 {
    if PAPER_MIN_LOAD_G < ulimit_g {
        PAPER_MIN_LOAD_G
    } else {
        0.0
    }
}

impl SensingProblem {
    /// Check the matrix and the bound, then derive the working matrix. The smallest
    /// load starts at 0 (no lower limit); set it with [`Self::with_min_load_g`].
    pub fn new(
        sensitivity_pm_per_g: DMatrix<f64>,
        ulimit_g: f64,
        normalised: bool,
    ) -> Result<Self, ArrayError> {
        let (m, n) = sensitivity_pm_per_g.shape();
        if m == 0 || n == 0 {
            return Err(ArrayError::Input(format!(
                "the sensing matrix is empty ({m} gratings × {n} cells)"
            )));
        }
        if let Some(((i, j), v)) = sensitivity_pm_per_g
            .iter()
            .enumerate()
            .map(|(k, v)| ((k % m, k / m), v))
            .find(|(_, v)| !v.is_finite())
        {
            return Err(ArrayError::Input(format!(
                "sensing matrix entry (grating row {}, cell column {}) is {v}; expected a finite pm/g value",
                i + 1,
                j + 1
            )));
        }
        if !(ulimit_g.is_finite() && ulimit_g > 0.0) {
            return Err(ArrayError::Input(format!(
                "ulimit must be a positive load in g, got {ulimit_g}"
            )));
        }
        let mut p = SensingProblem {
            uncertainty: Uncertainty::paper(m, n, 0.5),
            working: sensitivity_pm_per_g.clone(),
            sensitivity_pm_per_g,
            ulimit_g,
            min_load_g: 0.0,
            normalised,
            scale: DVector::zeros(n),
            upper: DVector::zeros(n),
            lower: DVector::zeros(n),
            common_mode: None,
            diagnose_stream: true,
            auto_common_mode: Some(vec![1.0; m]),
            window_pm: DEFAULT_WINDOW_PM,
            significance: crate::trust::significance::DEFAULT_SIGNIFICANCE,
        };
        p.derive_working()?;
        Ok(p)
    }

    /// The working matrix, scales and bounds from the matrix, the normalisation and
    /// the common-mode direction (projected out of every column when set).
    fn derive_working(&mut self) -> Result<(), ArrayError> {
        let n = self.sensitivity_pm_per_g.ncols();
        let mut working = self.sensitivity_pm_per_g.clone();
        if let Some(w) = &self.common_mode {
            for j in 0..n {
                let c = w.dot(&working.column(j));
                working.column_mut(j).axpy(-c, w, 1.0);
            }
        }
        let norms: Vec<f64> = (0..n).map(|j| working.column(j).norm()).collect();
        let full: Vec<f64> = (0..n)
            .map(|j| self.sensitivity_pm_per_g.column(j).norm())
            .collect();
        if let Some(j) = full.iter().position(|&v| v <= 0.0) {
            return Err(ArrayError::Input(format!(
                "cell column {} of the sensing matrix is all zero: no grating sees that cell",
                j + 1
            )));
        }
        if let Some(j) = (0..n).find(|&j| norms[j] <= 1e-9 * full[j]) {
            return Err(ArrayError::Input(format!(
                "cell column {} of the sensing matrix shifts every grating as a temperature change does: with the common-mode term its load cannot be told from temperature (drop ReconstructRequest.common_mode)",
                j + 1
            )));
        }
        let scale = if self.normalised {
            DVector::from_vec(norms)
        } else {
            DVector::from_element(n, 1.0)
        };
        for j in 0..n {
            let s = scale[j];
            working.column_mut(j).iter_mut().for_each(|v| *v /= s);
        }
        self.upper = scale.map(|s| s * self.ulimit_g);
        self.lower = scale.map(|s| s * self.min_load_g);
        self.working = working;
        self.scale = scale;
        Ok(())
    }

    /// The same problem with a per-frame common offset t·w in every reading (a
    /// temperature change since the tare: w_i the temperature sensitivity of grating
    /// i, any positive scale; all equal when unknown). The offset is free, so the
    /// methods solve with w projected out of the matrix and of every frame (the least
    /// squares over t in closed form): min_x ‖P(Ax − y)‖, P = I − ŵŵᵀ. This costs one
    /// of the m readings' worth of information. Errors for a weight vector of the
    /// wrong length, non-finite or all zero, and for a cell whose column is parallel
    /// to w (a load there cannot be told from temperature).
    pub fn with_common_mode(mut self, weights: &[f64]) -> Result<Self, ArrayError> {
        let m = self.n_gratings();
        if weights.len() != m || weights.iter().any(|w| !w.is_finite()) {
            return Err(ArrayError::Input(format!(
                "the common-mode weights must be {m} finite values (one per grating), got {}",
                weights.len()
            )));
        }
        let w = DVector::from_column_slice(weights);
        let norm = w.norm();
        if norm <= 0.0 {
            return Err(ArrayError::Input(
                "the common-mode weights are all zero".into(),
            ));
        }
        self.common_mode = Some(w / norm);
        self.derive_working()?;
        Ok(self)
    }

    /// The same problem with the uncertainty `u` (its matrix term must be m × n,
    /// finite and ≥ 0; the resolution positive; the additivity term ≥ 0).
    pub fn with_uncertainty(mut self, u: Uncertainty) -> Result<Self, ArrayError> {
        let (m, n) = (self.n_gratings(), self.n_cells());
        if u.matrix_sd_pm_per_g.shape() != (m, n) {
            return Err(ArrayError::Input(format!(
                "the matrix uncertainty is {} × {} but the sensing matrix is {m} × {n}",
                u.matrix_sd_pm_per_g.nrows(),
                u.matrix_sd_pm_per_g.ncols()
            )));
        }
        if u.matrix_sd_pm_per_g
            .iter()
            .any(|v| !(v.is_finite() && *v >= 0.0))
        {
            return Err(ArrayError::Input(
                "every entry of the matrix uncertainty must be a finite sd ≥ 0 in pm/g".into(),
            ));
        }
        if !(u.resolution_pm.is_finite() && u.resolution_pm > 0.0) {
            return Err(ArrayError::Input(format!(
                "the interrogator resolution must be a positive noise in pm, got {}",
                u.resolution_pm
            )));
        }
        if !(u.additivity_sd_frac.is_finite() && u.additivity_sd_frac >= 0.0) {
            return Err(ArrayError::Input(format!(
                "the additivity sd must be a fraction ≥ 0, got {}",
                u.additivity_sd_frac
            )));
        }
        self.uncertainty = u;
        Ok(self)
    }

    /// The same problem without the gratings (rows) `drop`: matrix, uncertainty and
    /// common-mode direction lose those rows; bounds, load range and normalisation
    /// stay. Errors when no grating would be left or a cell would be seen by none.
    pub fn without_gratings(&self, drop: &[usize]) -> Result<Self, ArrayError> {
        let m = self.n_gratings();
        let keep: Vec<usize> = (0..m).filter(|i| !drop.contains(i)).collect();
        if keep.is_empty() {
            return Err(ArrayError::Input(
                "no grating would be left to reconstruct with".into(),
            ));
        }
        let rows =
            |a: &DMatrix<f64>| DMatrix::from_fn(keep.len(), a.ncols(), |r, c| a[(keep[r], c)]);
        let mut p = SensingProblem::new(
            rows(&self.sensitivity_pm_per_g),
            self.ulimit_g,
            self.normalised,
        )?
        .with_min_load_g(self.min_load_g)?
        .with_uncertainty(Uncertainty {
            matrix_sd_pm_per_g: rows(&self.uncertainty.matrix_sd_pm_per_g),
            ..self.uncertainty.clone()
        })?;
        p.diagnose_stream = self.diagnose_stream;
        p.auto_common_mode = self
            .auto_common_mode
            .as_ref()
            .map(|w| keep.iter().map(|&i| w[i]).collect());
        p.window_pm = self.window_pm;
        p.significance = self.significance;
        if let Some(w) = &self.common_mode {
            let kept: Vec<f64> = keep.iter().map(|&i| w[i]).collect();
            p = p.with_common_mode(&kept)?;
        }
        Ok(p)
    }

    /// The same problem with the stream diagnosis on or off (faulty gratings found
    /// across frames and left out or corrected, [`crate::faults`]; on by default).
    pub fn with_diagnosis(mut self, on: bool) -> Self {
        self.diagnose_stream = on;
        self
    }

    /// [`Self::with_diagnosis`] (its name before the diagnosis found more than dead
    /// gratings).
    pub fn with_dead_grating_check(self, on: bool) -> Self {
        self.with_diagnosis(on)
    }

    /// The same problem with the weights of the common-mode term the stream
    /// diagnosis may fit (None: it never fits one; see [`crate::faults`]). Errors for
    /// weights of the wrong length, non-finite or all zero.
    pub fn with_auto_common_mode(mut self, weights: Option<&[f64]>) -> Result<Self, ArrayError> {
        if let Some(w) = weights {
            let m = self.n_gratings();
            if w.len() != m || w.iter().any(|v| !v.is_finite()) || w.iter().all(|v| *v == 0.0) {
                return Err(ArrayError::Input(format!(
                    "the common-mode weights must be {m} finite values (one per grating), not all zero"
                )));
            }
        }
        self.auto_common_mode = weights.map(<[f64]>::to_vec);
        Ok(self)
    }

    /// The same problem with the interrogator window `window_pm` (the largest shift a
    /// grating can report, pm; finite and positive).
    pub fn with_window_pm(mut self, window_pm: f64) -> Result<Self, ArrayError> {
        if !(window_pm.is_finite() && window_pm > 0.0) {
            return Err(ArrayError::Input(format!(
                "the interrogator window must be a positive shift in pm, got {window_pm}"
            )));
        }
        self.window_pm = window_pm;
        Ok(self)
    }

    /// The same problem with the significance `significance` of the per-frame test
    /// (in (0, 0.5]; see [`crate::trust`]).
    pub fn with_significance(mut self, significance: f64) -> Result<Self, ArrayError> {
        crate::trust::significance::check_significance(significance)?;
        self.significance = significance;
        Ok(self)
    }

    /// The summary of the uncertainty for reports.
    pub(crate) fn uncertainty_summary(&self) -> UncertaintySummary {
        let u = &self.uncertainty;
        let mut rel: Vec<f64> = self
            .sensitivity_pm_per_g
            .iter()
            .zip(u.matrix_sd_pm_per_g.iter())
            .filter(|(a, _)| **a != 0.0)
            .map(|(a, s)| 100.0 * s / a.abs())
            .collect();
        rel.sort_by(f64::total_cmp);
        UncertaintySummary {
            resolution_pm: u.resolution_pm,
            matrix_sd_median_pct: rel.get(rel.len() / 2).copied().unwrap_or(0.0),
            matrix_sd_max_pct: rel.last().copied().unwrap_or(0.0),
            additivity_sd_pct: 100.0 * u.additivity_sd_frac,
        }
    }

    /// A frame as the methods see it: with the common-mode direction projected out
    /// (unchanged without one).
    pub(crate) fn project_frame(&self, shifts_pm: &[f64]) -> Vec<f64> {
        let mut y = shifts_pm.to_vec();
        if let Some(w) = &self.common_mode {
            let c: f64 = w.iter().zip(&y).map(|(a, b)| a * b).sum();
            for (v, wi) in y.iter_mut().zip(w.iter()) {
                *v -= c * wi;
            }
        }
        y
    }

    /// The same problem with the smallest load of a loaded cell set to `min_load_g`
    /// (g; 0 disables it). It must be finite, ≥ 0 and below ulimit.
    pub fn with_min_load_g(mut self, min_load_g: f64) -> Result<Self, ArrayError> {
        if !(min_load_g.is_finite() && min_load_g >= 0.0) {
            return Err(ArrayError::Input(format!(
                "min_load must be a load ≥ 0 in g (0 disables it), got {min_load_g}"
            )));
        }
        if min_load_g >= self.ulimit_g {
            return Err(ArrayError::Input(format!(
                "min_load ({min_load_g} g) must be below ulimit ({} g)",
                self.ulimit_g
            )));
        }
        self.min_load_g = min_load_g;
        self.lower = self.scale.map(|s| s * min_load_g);
        Ok(self)
    }

    /// Number of gratings.
    pub fn n_gratings(&self) -> usize {
        self.working.nrows()
    }

    /// Number of cells.
    pub fn n_cells(&self) -> usize {
        self.working.ncols()
    }

    /// Loads in g from working unknowns, clamped into [0, ulimit] (a guard against
    /// round-off only: every method already keeps z inside its bounds).
    pub(crate) fn loads_from_working(&self, z: &[f64]) -> Vec<f64> {
        z.iter()
            .zip(self.scale.iter())
            .map(|(&zj, &s)| {
                let x = zj / s;
                if x.is_finite() {
                    x.clamp(0.0, self.ulimit_g)
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// ‖A x − y‖ in pm for loads x in g (with a common-mode term: ‖P(Ax − y)‖, the
    /// residual after the best common offset).
    pub fn residual_pm(&self, loads_g: &[f64], shifts_pm: &[f64]) -> f64 {
        let r = self.residual_vector_pm(loads_g, shifts_pm);
        r.iter().map(|v| v * v).sum::<f64>().sqrt()
    }

    /// y − A x per grating, pm (with a common-mode term: after removing the best
    /// common offset, P(y − Ax)).
    pub(crate) fn residual_vector_pm(&self, loads_g: &[f64], shifts_pm: &[f64]) -> Vec<f64> {
        let x = DVector::from_column_slice(loads_g);
        let y = DVector::from_column_slice(shifts_pm);
        let r = y - &self.sensitivity_pm_per_g * x;
        self.project_frame(r.as_slice())
    }

    /// The common offset of a frame at loads x along the common-mode direction, pm
    /// per unit weight (t of t·w with the weights as given, scaled to mean |w| = 1);
    /// None without a common-mode term.
    pub(crate) fn common_offset_pm(&self, loads_g: &[f64], shifts_pm: &[f64]) -> Option<f64> {
        let w = self.common_mode.as_ref()?;
        let x = DVector::from_column_slice(loads_g);
        let y = DVector::from_column_slice(shifts_pm);
        let r = y - &self.sensitivity_pm_per_g * x;
        // ŵ has unit norm; weights scaled to mean |w| = 1 are ŵ·m/Σ|ŵ|.
        let mean_abs = w.iter().map(|v| v.abs()).sum::<f64>() / w.len() as f64;
        Some(w.dot(&r) * mean_abs)
    }

    /// Check a frame of shifts: right length, finite values within the interrogator's
    /// window.
    pub fn check_shifts(&self, shifts_pm: &[f64]) -> Result<(), ArrayError> {
        if shifts_pm.len() != self.n_gratings() {
            return Err(ArrayError::Input(format!(
                "a frame holds {} shifts but the sensing matrix has {} gratings",
                shifts_pm.len(),
                self.n_gratings()
            )));
        }
        if let Some(i) = shifts_pm.iter().position(|v| !v.is_finite()) {
            return Err(ArrayError::Input(format!(
                "shift of grating {} is {}; expected a finite value in pm",
                i + 1,
                shifts_pm[i]
            )));
        }
        if let Some(i) = shifts_pm.iter().position(|v| v.abs() > self.window_pm) {
            return Err(ArrayError::Input(format!(
                "shift of grating {} is {} pm, beyond the interrogator window of ± {} pm: not a reading of this grating",
                i + 1,
                shifts_pm[i],
                self.window_pm
            )));
        }
        Ok(())
    }
}
