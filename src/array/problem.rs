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
}

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
        let norms: Vec<f64> = (0..n)
            .map(|j| sensitivity_pm_per_g.column(j).norm())
            .collect();
        if let Some(j) = norms.iter().position(|&v| v <= 0.0) {
            return Err(ArrayError::Input(format!(
                "cell column {} of the sensing matrix is all zero: no grating sees that cell",
                j + 1
            )));
        }
        let scale = if normalised {
            DVector::from_vec(norms)
        } else {
            DVector::from_element(n, 1.0)
        };
        let mut working = sensitivity_pm_per_g.clone();
        for j in 0..n {
            let s = scale[j];
            working.column_mut(j).iter_mut().for_each(|v| *v /= s);
        }
        let upper = scale.map(|s| s * ulimit_g);
        let lower = DVector::zeros(n);
        Ok(SensingProblem {
            sensitivity_pm_per_g,
            ulimit_g,
            min_load_g: 0.0,
            normalised,
            working,
            scale,
            upper,
            lower,
        })
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
    pub fn loads_from_working(&self, z: &[f64]) -> Vec<f64> {
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

    /// ‖A x − y‖ in pm for loads x in g.
    pub fn residual_pm(&self, loads_g: &[f64], shifts_pm: &[f64]) -> f64 {
        let x = DVector::from_column_slice(loads_g);
        let y = DVector::from_column_slice(shifts_pm);
        (&self.sensitivity_pm_per_g * x - y).norm()
    }

    /// Check a frame of shifts: right length and finite values.
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
        Ok(())
    }
}
