//! Shape of a reflection spectrum: peak shift, FWHM and its change, lobes, and whether
//! it is still one clean peak; the force at which a loaded grating stops being one.

use serde::{Deserialize, Serialize};

use super::{Grating, Sections, StrainProfile};
use crate::error::SpectrumError;

/// When a reflection spectrum counts as one clean peak.
///
/// A *lobe* is a local maximum of the reflectivity that stands at least
/// `min_lobe_prominence_db` above the higher of the two dips that separate it from any
/// higher point (its topographic prominence, in dB) and lies within
/// `side_lobe_margin_db` of the highest maximum. The spectrum is *one clean peak* when it
/// has exactly one lobe (so every side lobe is more than `side_lobe_margin_db` below the
/// peak) and its FWHM has grown by at most `max_fwhm_growth_pct` % over the unstrained
/// grating's.
///
/// Defaults: X = 6 dB (a side lobe above a quarter of the peak is taken for a second
/// peak by the finder, whose `lobe_fraction` is also 0.25), Y = 50 % (the widths the
/// estimators and the bound were sized for), 1 dB prominence (ripples on a chirped flat
/// top smaller than that do not make separate lobes).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CleanPeakCriteria {
    /// X: side lobes must be more than this many dB below the peak.
    pub side_lobe_margin_db: f64,
    /// Y: largest FWHM growth over the unstrained grating, %.
    pub max_fwhm_growth_pct: f64,
    /// Smallest prominence of a lobe, dB.
    pub min_lobe_prominence_db: f64,
}

impl Default for CleanPeakCriteria {
    fn default() -> Self {
        CleanPeakCriteria {
            side_lobe_margin_db: 6.0,
            max_fwhm_growth_pct: 50.0,
            min_lobe_prominence_db: 1.0,
        }
    }
}

/// Summary of a reflection spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpectrumShape {
    /// Wavelength of the highest reflectivity (3-point parabola on the samples), nm.
    pub peak_wavelength_nm: f64,
    /// Shift of that peak from the reference (unstrained) peak, pm.
    pub peak_shift_pm: f64,
    /// Highest reflectivity.
    pub peak_reflectivity: f64,
    /// Width between the half-maximum crossings that enclose the peak, pm.
    pub fwhm_pm: f64,
    /// FWHM change over the reference, %.
    pub fwhm_change_pct: f64,
    /// Number of lobes (see [`CleanPeakCriteria`]).
    pub lobes: usize,
    /// Level of the highest other local maximum with the lobe prominence, dB relative to
    /// the peak (negative); `None` when there is none.
    pub highest_side_lobe_db: Option<f64>,
    /// One clean peak (see [`CleanPeakCriteria`]).
    pub clean: bool,
}

fn db(x: f64) -> f64 {
    10.0 * x.max(1e-300).log10()
}

/// Prominence of local maximum `i` in dB.
fn prominence_db(r: &[f64], i: usize) -> f64 {
    let mut left = r[i];
    for j in (0..i).rev() {
        if r[j] > r[i] {
            break;
        }
        left = left.min(r[j]);
    }
    let mut right = r[i];
    for &v in &r[i + 1..] {
        if v > r[i] {
            break;
        }
        right = right.min(v);
    }
    db(r[i]) - db(left.max(right))
}

/// Shape of a sampled reflection spectrum against a reference (peak nm, FWHM nm); without
/// one the shift and the change are 0.
pub fn reflection_shape(
    wavelengths_nm: &[f64],
    reflectivity: &[f64],
    reference: Option<(f64, f64)>,
    criteria: &CleanPeakCriteria,
) -> Result<SpectrumShape, SpectrumError> {
    let (x, r) = (wavelengths_nm, reflectivity);
    if x.len() != r.len() || x.len() < 3 {
        return Err(SpectrumError::Invalid(
            "reflection shape: need 3 or more samples".into(),
        ));
    }
    let (k, peak) =
        r.iter().enumerate().fold(
            (0, f64::NEG_INFINITY),
            |m, (k, &v)| if v > m.1 { (k, v) } else { m },
        );
    if !(peak > 0.0) {
        return Err(SpectrumError::Invalid(
            "reflection shape: no reflection".into(),
        ));
    }
    let peak_nm = if k > 0 && k + 1 < x.len() {
        let (y0, y1, y2) = (r[k - 1], r[k], r[k + 1]);
        let denom = y0 - 2.0 * y1 + y2;
        if denom < 0.0 {
            x[k] + 0.5 * (y0 - y2) / denom * 0.5 * (x[k + 1] - x[k - 1])
        } else {
            x[k]
        }
    } else {
        x[k]
    };
    let half = 0.5 * peak;
    let cross = |a: usize, b: usize| x[a] + (half - r[a]) / (r[b] - r[a]) * (x[b] - x[a]);
    let left = (0..k)
        .rev()
        .find(|&j| r[j] < half)
        .map(|j| cross(j, j + 1))
        .unwrap_or(x[0]);
    let right = (k + 1..r.len())
        .find(|&j| r[j] < half)
        .map(|j| cross(j - 1, j))
        .unwrap_or(x[x.len() - 1]);
    let fwhm = right - left;
    let mut lobes = 1;
    let mut highest: Option<f64> = None;
    for i in 1..r.len() - 1 {
        if i == k || !(r[i] > r[i - 1] && r[i] >= r[i + 1]) {
            continue;
        }
        if prominence_db(r, i) < criteria.min_lobe_prominence_db {
            continue;
        }
        let level = db(r[i]) - db(peak);
        highest = Some(highest.map_or(level, |h: f64| h.max(level)));
        if level > -criteria.side_lobe_margin_db {
            lobes += 1;
        }
    }
    let (shift_pm, change_pct) = match reference {
        Some((p, f)) => (1e3 * (peak_nm - p), 100.0 * (fwhm / f - 1.0)),
        None => (0.0, 0.0),
    };
    Ok(SpectrumShape {
        peak_wavelength_nm: peak_nm,
        peak_shift_pm: shift_pm,
        peak_reflectivity: peak,
        fwhm_pm: 1e3 * fwhm,
        fwhm_change_pct: change_pct,
        lobes,
        highest_side_lobe_db: highest,
        clean: lobes == 1 && change_pct <= criteria.max_fwhm_growth_pct,
    })
}

/// A wavelength grid that covers every local Bragg wavelength of the profile with a
/// margin of 4 uniform-grating bandwidths, at a step of 1/100 bandwidth (at most 40,000
/// points).
pub fn auto_grid(grating: &Grating, strain: &StrainProfile) -> Vec<f64> {
    let eps = strain.at_sections(grating.length_mm, grating.sections);
    let lo = eps
        .iter()
        .map(|&e| grating.local_bragg_nm(e))
        .fold(f64::INFINITY, f64::min);
    let hi = eps
        .iter()
        .map(|&e| grating.local_bragg_nm(e))
        .fold(f64::NEG_INFINITY, f64::max);
    let bw = grating.uniform_bandwidth_nm();
    let (start, end) = (lo - 4.0 * bw, hi + 4.0 * bw);
    let n = (((end - start) / (bw / 100.0)).ceil() as usize).clamp(200, 40_000);
    let step = (end - start) / (n - 1) as f64;
    (0..n).map(|i| start + step * i as f64).collect()
}

fn shape_on_grid(
    grating: &Grating,
    strain: &StrainProfile,
    reference: Option<(f64, f64)>,
    criteria: &CleanPeakCriteria,
) -> Result<SpectrumShape, SpectrumError> {
    grating.validate()?;
    let grid = auto_grid(grating, strain);
    let sections = Sections::new(grating, strain);
    let r: Vec<f64> = grid
        .iter()
        .map(|&w| sections.reflectivity(grating, w))
        .collect();
    reflection_shape(&grid, &r, reference, criteria)
}

/// Shape of the grating's reflection under `strain`, against the unstrained grating.
///
/// ```
/// use fbgforge_spectra::grating::{spectrum_shape, CleanPeakCriteria, Grating, StrainProfile};
/// let g = Grating::default();
/// let s = spectrum_shape(&g, &StrainProfile::Uniform(200e-6), &CleanPeakCriteria::default()).unwrap();
/// assert!((s.peak_shift_pm - 200.0 * g.strain_sensitivity_pm_per_microstrain()).abs() < 1.0);
/// assert!(s.clean && s.fwhm_change_pct.abs() < 1.0);
/// ```
pub fn spectrum_shape(
    grating: &Grating,
    strain: &StrainProfile,
    criteria: &CleanPeakCriteria,
) -> Result<SpectrumShape, SpectrumError> {
    let unstrained = unstrained_shape(grating, criteria)?;
    spectrum_shape_against(grating, strain, &unstrained, criteria)
}

/// The unstrained grating's shape: the reference every loaded shape is measured
/// against. Callers that shape one grating many times compute it once and pass it to
/// [`spectrum_shape_against`] and [`clean_peak_limit_against`].
///
/// ```
/// use fbgforge_spectra::grating::{unstrained_shape, spectrum_shape_against, spectrum_shape, CleanPeakCriteria, Grating, StrainProfile};
/// let (g, c) = (Grating::default(), CleanPeakCriteria::default());
/// let reference = unstrained_shape(&g, &c).unwrap();
/// let strain = StrainProfile::Linear { start: 0.0, end: 300e-6 };
/// assert_eq!(spectrum_shape_against(&g, &strain, &reference, &c).unwrap(), spectrum_shape(&g, &strain, &c).unwrap());
/// ```
pub fn unstrained_shape(
    grating: &Grating,
    criteria: &CleanPeakCriteria,
) -> Result<SpectrumShape, SpectrumError> {
    shape_on_grid(grating, &StrainProfile::Uniform(0.0), None, criteria)
}

/// [`spectrum_shape`] against an unstrained shape already computed
/// ([`unstrained_shape`] of the same grating and criteria).
pub fn spectrum_shape_against(
    grating: &Grating,
    strain: &StrainProfile,
    unstrained: &SpectrumShape,
    criteria: &CleanPeakCriteria,
) -> Result<SpectrumShape, SpectrumError> {
    let reference = (unstrained.peak_wavelength_nm, 1e-3 * unstrained.fwhm_pm);
    shape_on_grid(grating, strain, Some(reference), criteria)
}

/// The strain profile along a grating at one force.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LoadCase {
    /// Force, N.
    pub force_n: f64,
    /// Strain along the grating at that force.
    pub strain: StrainProfile,
}

/// Where a loaded grating stops being one clean peak.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CleanPeakLimit {
    /// The smallest force at which the reflection is not one clean peak, N (refined by
    /// bisection between the last clean and the first unclean case, strain interpolated
    /// linearly section by section); `None` if it stays clean over every case.
    pub force_n: Option<f64>,
    /// Whether the unstrained grating itself is one clean peak (if not, `force_n` is 0).
    pub unstrained_clean: bool,
    /// The shape at each given case, in increasing force.
    pub shapes: Vec<(f64, SpectrumShape)>,
}

/// Given the strain profiles at increasing forces, the force at which the grating's
/// reflection stops being one clean peak (zero force is taken as zero strain).
pub fn clean_peak_limit(
    grating: &Grating,
    cases: &[LoadCase],
    criteria: &CleanPeakCriteria,
) -> Result<CleanPeakLimit, SpectrumError> {
    let unstrained = unstrained_shape(grating, criteria)?;
    clean_peak_limit_against(grating, cases, &unstrained, criteria)
}

/// [`clean_peak_limit`] against an unstrained shape already computed
/// ([`unstrained_shape`] of the same grating and criteria).
pub fn clean_peak_limit_against(
    grating: &Grating,
    cases: &[LoadCase],
    unstrained: &SpectrumShape,
    criteria: &CleanPeakCriteria,
) -> Result<CleanPeakLimit, SpectrumError> {
    let reference = Some((unstrained.peak_wavelength_nm, 1e-3 * unstrained.fwhm_pm));
    let mut sorted: Vec<&LoadCase> = cases.iter().collect();
    sorted.sort_by(|a, b| a.force_n.total_cmp(&b.force_n));
    let mut shapes = Vec::with_capacity(sorted.len());
    for c in &sorted {
        shapes.push((
            c.force_n,
            shape_on_grid(grating, &c.strain, reference, criteria)?,
        ));
    }
    if !unstrained.clean {
        return Ok(CleanPeakLimit {
            force_n: Some(0.0),
            unstrained_clean: false,
            shapes,
        });
    }
    let Some(first_bad) = shapes.iter().position(|(_, s)| !s.clean) else {
        return Ok(CleanPeakLimit {
            force_n: None,
            unstrained_clean: true,
            shapes,
        });
    };
    let n = grating.sections;
    let upper = sorted[first_bad].strain.at_sections(grating.length_mm, n);
    let (f_lo, lower) = if first_bad == 0 {
        (0.0, vec![0.0; n])
    } else {
        (
            sorted[first_bad - 1].force_n,
            sorted[first_bad - 1]
                .strain
                .at_sections(grating.length_mm, n),
        )
    };
    let f_hi = sorted[first_bad].force_n;
    let dz = grating.length_mm / n as f64;
    let z: Vec<f64> = (0..n).map(|j| (j as f64 + 0.5) * dz).collect();
    let (mut a, mut b) = (0.0, 1.0);
    for _ in 0..30 {
        let t = 0.5 * (a + b);
        let eps: Vec<f64> = lower
            .iter()
            .zip(&upper)
            .map(|(l, u)| l + t * (u - l))
            .collect();
        let profile = if n == 1 {
            StrainProfile::Uniform(eps[0])
        } else {
            StrainProfile::samples(z.clone(), eps)?
        };
        if shape_on_grid(grating, &profile, reference, criteria)?.clean {
            a = t;
        } else {
            b = t;
        }
    }
    Ok(CleanPeakLimit {
        force_n: Some(f_lo + b * (f_hi - f_lo)),
        unstrained_clean: true,
        shapes,
    })
}
