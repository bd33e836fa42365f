//! The model's stated error, the interval a design is held to, and its strain margin
//! (docs/model.md §5.8).
//!
//! **Model error** of a prediction row, a fraction of |K|: the discretisation of an FE
//! reading (the step its Richardson extrapolation took from the fine mesh, at least
//! [`DISCRETISATION_FLOOR`]) plus a modelling term per model and case, documented from
//! the comparison with independent solutions ([`modelling_fraction`]). The nominal K
//! must lie inside the bounding contact readings widened by it; where it does not, the
//! model is wrong there and the row says so.
//!
//! **Design interval** of a row: every reading the design's spec implies, each widened
//! by its own model's error: in Case I the nominal and K at both ends of the contact
//! window the family rule allows (for a design on the default radius); in Case II the
//! nominal, the closed form and the FE reading of the stated `cylinders`. A design is
//! held to its far end (the largest |K|): the strain at the design's largest force is
//! computed there.

use serde::Serialize;

/// Smallest discretisation term stated for an FE reading: below it the Richardson
/// step does not bound the remaining error (Case II's sliding reading converges
/// non-monotonically by up to 0.35 %, docs/fem.md §5.3).
pub const DISCRETISATION_FLOOR: f64 = 0.005;

/// The largest model error the policy states as holding: above it the row says that
/// the mesh is too coarse or the model does not hold there.
pub const MAX_MODEL_ERROR: f64 = 0.15;

/// Share of the strain limit a design keeps free at the far end of its design interval
/// (the optimiser holds |ε| ≤ (1 − this) × limit there; `predict` states the margin).
pub const STRAIN_MARGIN_FRACTION: f64 = 0.05;

/// Which model and reading a K comes from, for its modelling term.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorSource {
    /// The closed form, Case II.
    #[serde(rename = "closed_form_case_ii")]
    ClosedFormCaseII,
    /// The closed form, Case I: nowhere within 8 % of any FE reading (docs/model.md §9);
    /// no error is stated.
    #[serde(rename = "closed_form_case_i")]
    ClosedFormCaseI,
    /// The FE model, Case I, any contact reading.
    #[serde(rename = "fem_case_i")]
    FemCaseI,
    /// The FE model, Case II, any contact reading.
    #[serde(rename = "fem_case_ii")]
    FemCaseII,
}

/// The modelling term of `source` (`None`: not stated), with where it comes from.
///
/// - Closed form, Case II, **0.08**: the policy answers Case II by the closed form
///   where it was measured within 8 % of the FE model (docs/model.md §9), and that is
///   the term it states. Against this project's bonded FE the closed form lay
///   −0.9 … +3.5 % over the `fem` study's 32 grid points (D 10–40 mm, core t/R
///   0.05–0.65), but −5.7 … +2.8 % over the `model-error` study's 40 random designs
///   (thin caps and domes varied too; its first run, with a 4 % term, found 6 rows
///   of 2 designs outside their widened readings); that FE lies 0.08 % from the
///   independent axisymmetric FE on the paper's module (reference §5: −169.90
///   against −169.77 pm/N; the closed form −170.68).
/// - FE, Case I, **0.09**: this project's default reading lay 4.0–10.5 % below the
///   independent FE on every shipped and held-out design (issue 38: −10.5 % at 16 mm
///   against its finer mesh, −5.6 % at 34 mm, −4.0 … −7.7 % on six held-out designs),
///   of which the mesh explained up to 2.3 % (16 mm); the rest, up to 8.2 %, is how
///   pillars and ties are represented, which neither code settles; the two codes
///   differed by −8 … +6 % on the written designs.
/// - FE, Case II, **0.14**: the sliding reading 13 % above the independent FE on the
///   10 mm written design (−194.5 against −172.0 pm/N), the bonded reading within
///   0.1 % (34 mm); over the last two rounds `--fidelity fem` and the independent FE
///   differed by −16 … +13 %: the −16 % comparison lies outside this term.
pub fn modelling_fraction(source: ErrorSource) -> Option<f64> {
    match source {
        ErrorSource::ClosedFormCaseII => Some(0.08),
        ErrorSource::ClosedFormCaseI => None,
        ErrorSource::FemCaseI => Some(0.09),
        ErrorSource::FemCaseII => Some(0.14),
    }
}

/// A K's stated error as a fraction of |K|.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModelError {
    /// Discretisation: the Richardson step over |K| (at least [`DISCRETISATION_FLOOR`]);
    /// 0 for the closed form.
    pub discretisation_fraction: f64,
    /// Modelling: [`modelling_fraction`] of the model and case.
    pub modelling_fraction: f64,
    /// Their sum: K may be off by this fraction of |K| either way.
    pub total_fraction: f64,
    /// Which model and case the modelling term is for.
    pub source: ErrorSource,
}

impl ModelError {
    /// The error of a K from `source` whose Richardson step was `step_pm_per_n` (`None`:
    /// the closed form, or an FE solve without extrapolation). `None` when the
    /// source states no error.
    ///
    /// ```
    /// use fbgforge_model::prediction::{ErrorSource, ModelError};
    /// let e = ModelError::of(ErrorSource::FemCaseI, 100.0, Some(2.0)).unwrap();
    /// assert!((e.discretisation_fraction - 0.02).abs() < 1e-12);
    /// assert!((e.total_fraction - 0.11).abs() < 1e-12);
    /// // A tiny step is floored; the closed form has no mesh.
    /// let f = ModelError::of(ErrorSource::FemCaseII, -170.0, Some(0.01)).unwrap();
    /// assert_eq!(f.discretisation_fraction, 0.005);
    /// assert_eq!(ModelError::of(ErrorSource::ClosedFormCaseII, -170.0, None).unwrap().total_fraction, 0.08);
    /// assert!(ModelError::of(ErrorSource::ClosedFormCaseI, 109.0, None).is_none());
    /// ```
    pub fn of(source: ErrorSource, k_pm_per_n: f64, step_pm_per_n: Option<f64>) -> Option<Self> {
        let modelling = modelling_fraction(source)?;
        let discretisation = match (source, step_pm_per_n) {
            (ErrorSource::ClosedFormCaseI | ErrorSource::ClosedFormCaseII, _) => 0.0,
            (_, Some(step)) if k_pm_per_n != 0.0 => {
                (step / k_pm_per_n).abs().max(DISCRETISATION_FLOOR)
            }
            (_, Some(_)) => f64::INFINITY,
            (_, None) => DISCRETISATION_FLOOR,
        };
        Some(ModelError {
            discretisation_fraction: discretisation,
            modelling_fraction: modelling,
            total_fraction: discretisation + modelling,
            source,
        })
    }

    /// `k` widened by this error: (low, high) by value.
    pub fn widen(&self, k: f64) -> (f64, f64) {
        let d = self.total_fraction * k.abs();
        (k - d, k + d)
    }
}

/// The readings a row's design interval is made of, pm/N (each widened by its own
/// model's error in the interval).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IntervalReadings {
    /// Case I on the default contact radius: K with the domes' contact radius at the
    /// low and the high end of the window (1.30 and 1.48 × the apex patch).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact_window_pm_per_n: Option<[f64; 2]>,
    /// Case II: the FE reading of the spec's stated `cylinders` (domes in contact over
    /// the whole dome).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stated_cylinders_pm_per_n: Option<f64>,
    /// Case II: the closed form.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub closed_form_pm_per_n: Option<f64>,
}

/// The interval spanned by readings `(K, error)`, each widened by its error: (low, high)
/// by value. Readings without a stated error count at their value.
///
/// ```
/// use fbgforge_model::prediction::{design_interval, ErrorSource, ModelError};
/// let fe = ModelError::of(ErrorSource::FemCaseII, -190.0, Some(0.0)).unwrap();
/// let cf = ModelError::of(ErrorSource::ClosedFormCaseII, -180.0, None).unwrap();
/// let [lo, hi] = design_interval(&[(-180.0, Some(cf)), (-190.0, Some(fe))]);
/// // The FE reading's 14.5 % (modelling 14 % + the 0.5 % discretisation floor) spans
/// // both ends; the closed form's 8 % lies inside.
/// assert!((lo - (-190.0 * 1.145)).abs() < 1e-9);
/// assert!((hi - (-190.0 * 0.855)).abs() < 1e-9);
/// ```
pub fn design_interval(readings: &[(f64, Option<ModelError>)]) -> [f64; 2] {
    readings
        .iter()
        .map(|(k, e)| e.map_or((*k, *k), |e| e.widen(*k)))
        .fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], (a, b)| {
            [lo.min(a), hi.max(b)]
        })
}

/// Where the limits are checked: the design's stated largest force and strain limit,
/// or the request's force and the grating's linear limit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LimitCheck {
    /// The force the strain is given at, N.
    pub force_n: f64,
    /// `design` when the design states it (`[module.limits].max_force_n`), else
    /// `request` (`PredictionRequest.force_n`).
    pub force_from: &'static str,
    /// The strain limit, µε.
    pub strain_limit_microstrain: f64,
    /// The nominal strain at that force, µε (signed).
    pub nominal_strain_microstrain: f64,
    /// The far end of the design interval (its largest |K|), pm/N.
    pub far_end_pm_per_n: f64,
    /// The strain at that force with the far end's K, µε (signed): what the design is
    /// held to.
    pub far_end_strain_microstrain: f64,
    /// The limit less |far-end strain|, µε (negative: over the limit).
    pub strain_margin_microstrain: f64,
    /// That margin as a share of the limit, percent.
    pub strain_margin_percent: f64,
    /// Whether the far-end strain keeps [`STRAIN_MARGIN_FRACTION`] of the limit free.
    pub meets_margin: bool,
}

impl LimitCheck {
    /// The check of a row with nominal K `k_nominal` and design interval `[lo, hi]`, at
    /// `force_n` against the strain `limit`, for a grating that shifts `pm_per_strain`
    /// per unit strain.
    pub fn new(
        (force_n, force_from): (f64, &'static str),
        limit: f64,
        k_nominal: f64,
        pm_per_strain: f64,
        [lo, hi]: [f64; 2],
    ) -> Self {
        let far = if hi.abs() >= lo.abs() { hi } else { lo };
        let far_strain = far * force_n / pm_per_strain;
        let margin = limit - far_strain.abs();
        LimitCheck {
            force_n,
            force_from,
            strain_limit_microstrain: limit * 1e6,
            nominal_strain_microstrain: k_nominal * force_n / pm_per_strain * 1e6,
            far_end_pm_per_n: far,
            far_end_strain_microstrain: far_strain * 1e6,
            strain_margin_microstrain: margin * 1e6,
            strain_margin_percent: 100.0 * margin / limit,
            meets_margin: margin >= STRAIN_MARGIN_FRACTION * limit,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_far_end_strain_scales_with_the_far_end_k_and_never_undercuts_nominal_plus_error() {
        let e = ModelError::of(ErrorSource::FemCaseI, 100.0, Some(3.0)).unwrap();
        let window = ModelError::of(ErrorSource::FemCaseI, 120.0, Some(3.6)).unwrap();
        let iv = design_interval(&[(100.0, Some(e)), (120.0, Some(window)), (90.0, Some(e))]);
        // The far end is the window's high end widened: 120 × 1.12.
        assert!((iv[1] - 134.4).abs() < 1e-9, "{iv:?}");
        // 1e6 pm per unit strain: K = 100 pm/N is 1e-4 per newton.
        let c = LimitCheck::new((20.0, "design"), 3e-3, 100.0, 1e6, iv);
        assert!((c.far_end_strain_microstrain - 1e-4 * 1.344 * 20.0 * 1e6).abs() < 1e-6);
        assert!(
            c.far_end_strain_microstrain >= c.nominal_strain_microstrain * (1.0 + e.total_fraction)
        );
        assert!((c.strain_margin_microstrain - (3000.0 - 2688.0)).abs() < 1e-6);
        assert!(c.meets_margin);
        // A blue shift: the far end is the most negative K.
        let b = LimitCheck::new((10.0, "request"), 3e-3, -170.0, 1.2e6, [-190.0, -160.0]);
        assert_eq!(b.far_end_pm_per_n, -190.0);
        assert!(b.far_end_strain_microstrain < b.nominal_strain_microstrain);
    }
}
