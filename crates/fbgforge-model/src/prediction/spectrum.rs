//! The spectrum a design will make: each grating's reflection by the transfer-matrix
//! model (`fbgforge_spectra::grating`, docs/spectra.md §8) under the model's strain
//! *profile* along it, over the design's force range.
//!
//! The profile is the FE's: the axial strain per newton sampled along the grating at
//! the quadrature points of its mean, read from the very solve that gave the row's
//! nominal K (no extra FE solve). It is scaled so that its mean is the row's nominal
//! strain per newton (exactly 1 for FE rows; for closed-form rows the FE shape carries
//! the closed form's level). A closed-form row with no FE solve behind it
//! (`--fidelity closed-form`, or no design interval asked) gets a uniform profile at
//! the closed form's strain, and says so. The model is linear: the profile at force F
//! is F times the profile per newton.
//!
//! Per grating: the peak shift and FWHM change at the requested force, whether the
//! reflection stays one clean peak over the force range (`CleanPeakCriteria`: no side
//! lobe within 6 dB, FWHM grown by at most 50 %), and the force where it stops
//! ([`fbgforge_spectra::grating::clean_peak_limit`], bisected between the range's
//! eight steps). A grating that chirps or splits inside the range is warned.

use super::{config_of, ModelledPrediction, PredictionRequest};
use crate::fem::AxialStrainProfile;
use crate::model::Configuration;
use crate::spec::Design;
use anyhow::{Context, Result};
use fbgforge_spectra::grating::{
    clean_peak_limit_against, spectrum_shape_against, unstrained_shape, CleanPeakCriteria, Grating,
    LoadCase, SpectrumShape, StrainProfile,
};
use rayon::prelude::*;
use serde::Serialize;

/// Steps of the force range at which the shape is evaluated before bisection.
pub const RANGE_STEPS: usize = 8;

/// Where a grating's strain profile came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ProfileSource {
    /// Sampled along the grating in the FE solve of the row's nominal.
    Fem,
    /// Uniform at the closed form's mean strain: no FE solve ran for this row.
    UniformClosedForm,
    /// Sampled along the grating's fiber in the array's sheet model
    /// (`fbgforge_array::sheet::spectrum`), from the solve that gives its mean.
    Sheet,
}

/// The reflection spectrum one grating will make over the design's force range.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GratingSpectrum {
    /// Where the strain profile came from.
    pub strain_profile: ProfileSource,
    /// Samples of the profile along the grating.
    pub profile_samples: usize,
    /// Spread of the strain along the grating (largest − smallest sample) per newton,
    /// µε/N.
    pub strain_span_microstrain_per_n: f64,
    /// The force range's top, N: `[module.limits].max_force_n`, else the requested force.
    pub force_range_n: f64,
    /// Where the range came from: `design` or `request`.
    pub force_range_from: &'static str,
    /// The force the shift and FWHM below are given at (the requested force), N.
    pub at_force_n: f64,
    /// Shift of the reflection peak at that force, pm.
    pub peak_shift_pm: f64,
    /// Peak shift over force, pm/N (to compare with the row's K).
    pub peak_shift_per_n_pm_per_n: f64,
    /// FWHM of the unloaded grating's reflection, pm.
    pub fwhm_unloaded_pm: f64,
    /// FWHM at the requested force, pm.
    pub fwhm_pm: f64,
    /// FWHM change at the requested force, %.
    pub fwhm_change_pct: f64,
    /// FWHM change at the top of the force range, %.
    pub fwhm_change_at_range_pct: f64,
    /// Lobes within 6 dB of the peak at the top of the force range (1: one peak).
    pub lobes_at_range: usize,
    /// The highest side lobe at the top of the force range, dB below the peak.
    pub highest_side_lobe_at_range_db: Option<f64>,
    /// Whether the unloaded grating is one clean peak.
    pub clean_unloaded: bool,
    /// Whether the reflection is one clean peak at the requested force.
    pub clean_at_force: bool,
    /// Whether it stays one clean peak from zero to the top of the force range.
    pub clean_over_range: bool,
    /// The smallest force at which it stops being one clean peak, N; `None` when it
    /// stays clean over the whole range.
    pub clean_limit_force_n: Option<f64>,
}

/// `profile` times `force_n`.
fn scaled(profile: &StrainProfile, force_n: f64) -> StrainProfile {
    match profile {
        StrainProfile::Uniform(e) => StrainProfile::Uniform(e * force_n),
        StrainProfile::Linear { start, end } => StrainProfile::Linear {
            start: start * force_n,
            end: end * force_n,
        },
        StrainProfile::Samples { z_mm, strain } => StrainProfile::Samples {
            z_mm: z_mm.clone(),
            strain: strain.iter().map(|e| e * force_n).collect(),
        },
    }
}

/// The spectrum `grating` makes under `per_n` (strain per newton along it) at
/// `at_force_n`, and whether and where it stops being one clean peak between zero and
/// `force_range_n` (the profile scales with the force).
///
/// ```
/// use fbgforge_model::prediction::spectrum::{forward, ProfileSource};
/// use fbgforge_spectra::grating::{CleanPeakCriteria, Grating, StrainProfile};
/// let g = Grating { length_mm: 5.0, index_modulation: 2e-4, ..Grating::default() };
/// // −20 µε/N, uniform: a blue shift of λ_B(1 − p_e)ε per newton and no chirp.
/// let s = forward(&g, &StrainProfile::Uniform(-20e-6), 10.0, 50.0, &CleanPeakCriteria::default())?;
/// let expected_pm = -200e-6 * 1550.0 * (1.0 - 0.22) * 1e3;
/// assert!((s.peak_shift_pm - expected_pm).abs() < 0.01 * expected_pm.abs());
/// assert!(s.clean_over_range && s.clean_limit_force_n.is_none());
/// # Ok::<(), fbgforge_spectra::SpectrumError>(())
/// ```
pub fn forward(
    grating: &Grating,
    per_n: &StrainProfile,
    at_force_n: f64,
    force_range_n: f64,
    criteria: &CleanPeakCriteria,
) -> Result<GratingSpectrum, fbgforge_spectra::SpectrumError> {
    let unloaded = unstrained_shape(grating, criteria)?;
    forward_against(
        grating,
        &unloaded,
        per_n,
        (at_force_n, force_range_n),
        criteria,
    )
}

/// [`forward`] against the grating's unloaded shape already computed
/// ([`unstrained_shape`] with the same criteria): the reference of every loaded shape,
/// computed once per grating however many rows or loads it answers.
pub fn forward_against(
    grating: &Grating,
    unloaded: &SpectrumShape,
    per_n: &StrainProfile,
    (at_force_n, force_range_n): (f64, f64),
    criteria: &CleanPeakCriteria,
) -> Result<GratingSpectrum, fbgforge_spectra::SpectrumError> {
    let at = spectrum_shape_against(grating, &scaled(per_n, at_force_n), unloaded, criteria)?;
    let range = force_range_n.abs();
    let cases: Vec<LoadCase> = if range > 0.0 {
        (1..=RANGE_STEPS)
            .map(|k| {
                let f = range * k as f64 / RANGE_STEPS as f64;
                LoadCase {
                    force_n: f,
                    strain: scaled(per_n, f),
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    let limit = clean_peak_limit_against(grating, &cases, unloaded, criteria)?;
    let top = limit.shapes.last().map_or(unloaded, |(_, s)| s);
    let samples = grating.sections;
    let eps = per_n.at_sections(grating.length_mm, samples);
    let span = eps.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - eps.iter().copied().fold(f64::INFINITY, f64::min);
    Ok(GratingSpectrum {
        strain_profile: ProfileSource::Fem,
        profile_samples: match per_n {
            StrainProfile::Samples { z_mm, .. } => z_mm.len(),
            _ => 1,
        },
        strain_span_microstrain_per_n: 1e6 * span,
        force_range_n: range,
        force_range_from: "request",
        at_force_n,
        peak_shift_pm: at.peak_shift_pm,
        peak_shift_per_n_pm_per_n: if at_force_n == 0.0 {
            f64::NAN
        } else {
            at.peak_shift_pm / at_force_n
        },
        fwhm_unloaded_pm: unloaded.fwhm_pm,
        fwhm_pm: at.fwhm_pm,
        fwhm_change_pct: at.fwhm_change_pct,
        fwhm_change_at_range_pct: top.fwhm_change_pct,
        lobes_at_range: top.lobes,
        highest_side_lobe_at_range_db: top.highest_side_lobe_db,
        clean_unloaded: limit.unstrained_clean,
        clean_at_force: at.clean,
        clean_over_range: limit.force_n.is_none(),
        clean_limit_force_n: limit.force_n,
    })
}

/// The FE profile per newton as the transfer-matrix model's input, scaled so that its
/// mean is `mean_per_n` (the row's nominal).
fn fe_profile(p: &AxialStrainProfile, mean_per_n: f64) -> Result<StrainProfile> {
    let m = p.mean();
    let scale = if m != 0.0 { mean_per_n / m } else { 1.0 };
    StrainProfile::samples(p.z_mm.clone(), p.strain.iter().map(|e| e * scale).collect())
        .map_err(|e| anyhow::anyhow!("{e}"))
}

/// The warning a row carries when its grating does not stay one clean peak.
fn warning(name: &str, s: &GratingSpectrum) -> Option<String> {
    if !s.clean_unloaded {
        return Some(format!(
            "grating `{name}` is not one clean peak even unloaded (side lobes within 6 dB): lower [fiber].index_modulation or apodise ([fiber].apodisation)"
        ));
    }
    let f = s.clean_limit_force_n?;
    let how = if s.lobes_at_range > 1 {
        format!("splits into {} lobes", s.lobes_at_range)
    } else {
        format!("chirps (FWHM {:+.0} %)", s.fwhm_change_at_range_pct)
    };
    Some(format!(
        "grating `{name}`: the strain along it ({:.2} µε/N from end to end) stops its reflection being one clean peak at {f:.3} N, inside the force range 0–{} N ({}); at {} N it {how}: peaks found there are the estimator's guess",
        s.strain_span_microstrain_per_n, s.force_range_n, s.force_range_from, s.force_range_n
    ))
}

/// The spectrum of one row's grating and the warning it earns.
fn row_spectrum(
    design: &Design,
    request: &PredictionRequest,
    (range, from): (f64, &'static str),
    fe: Option<&AxialStrainProfile>,
    row: &ModelledPrediction,
    unloaded: &[(String, Grating, SpectrumShape)],
) -> Result<(GratingSpectrum, Option<String>)> {
    let p = &row.detail.prediction;
    let (_, grating, reference) = unloaded
        .iter()
        .find(|(n, _, _)| *n == p.grating)
        .with_context(|| format!("grating `{}` is not in the design", p.grating))?;
    let lambda = row.detail.bragg_wavelength_nm;
    let per_n = p.sensitivity_pm_per_n / design.fiber.shift_pm(lambda, 1.0, 0.0);
    let (input, source) = match fe {
        Some(fe) if !fe.strain.is_empty() => (fe_profile(fe, per_n)?, ProfileSource::Fem),
        _ => (
            StrainProfile::Uniform(per_n),
            ProfileSource::UniformClosedForm,
        ),
    };
    let mut s = forward_against(
        grating,
        reference,
        &input,
        (request.force_n, range),
        &CleanPeakCriteria::default(),
    )
    .with_context(|| format!("spectrum of grating `{}`", p.grating))?;
    s.strain_profile = source;
    s.force_range_from = from;
    let w = warning(&p.grating, &s);
    Ok((s, w))
}

/// Predict the spectrum of every row's grating (`profile`: the FE profile of a
/// configuration's grating under the design's reading, when one was solved), rows in
/// parallel, and warn the rows whose grating chirps or splits inside the force range.
pub(super) fn attach<'a>(
    design: &Design,
    request: &PredictionRequest,
    profile: impl Fn(&Configuration, &str) -> Option<&'a AxialStrainProfile> + Sync,
    rows: &mut [ModelledPrediction],
) -> Result<()> {
    let limits = design.module.as_ref().and_then(|m| m.limits);
    let range = limits.map_or((request.force_n.abs(), "request"), |l| {
        (l.max_force_n, "design")
    });
    // Each grating's unloaded shape once, however many rows (cases, inserts) read it.
    let mut names: Vec<&str> = rows
        .iter()
        .map(|r| r.detail.prediction.grating.as_str())
        .collect();
    names.sort_unstable();
    names.dedup();
    let criteria = CleanPeakCriteria::default();
    let unloaded: Vec<(String, Grating, SpectrumShape)> = names
        .par_iter()
        .filter_map(|&n| design.bragg_grating(n).map(|g| (n, g)))
        .map(|(n, g)| {
            let s = unstrained_shape(&g, &criteria)
                .with_context(|| format!("spectrum of grating `{n}`"))?;
            Ok((n.to_string(), g, s))
        })
        .collect::<Result<_>>()?;
    let spectra: Vec<Result<(GratingSpectrum, Option<String>)>> = rows
        .par_iter()
        .map(|row| {
            let p = &row.detail.prediction;
            row_spectrum(
                design,
                request,
                range,
                profile(&config_of(p), &p.grating),
                row,
                &unloaded,
            )
        })
        .collect();
    for (row, s) in rows.iter_mut().zip(spectra) {
        let (s, w) = s?;
        if let Some(w) = w {
            row.detail.prediction.warnings.push(w);
        }
        row.spectrum = Some(s);
    }
    Ok(())
}

/// Apex force at which a design without `[module.limits]` is checked at design time, N
/// (`predict`'s default force).
pub const DESIGN_CHECK_FORCE_N: f64 = 10.0;

/// The design-time check `build` and `optimize` run: every strain grating's spectrum
/// over the design's force range (`[module.limits].max_force_n`, else
/// [`DESIGN_CHECK_FORCE_N`]) by the FE strain profile of every configuration, one
/// warning per grating and configuration whose reflection chirps or splits inside the
/// range, with the force where it starts. One FE solve per configuration at the
/// default mesh level, no band; empty for a design without a module.
///
/// ```
/// use fbgforge_model::fem::GeometryCache;
/// use fbgforge_model::prediction::spectrum::design_warnings;
/// let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
/// let d = fbgforge_core::design::load(&root.join("designs/clip-on-34mm.toml"))?;
/// // The shipped module's 5 mm gratings stay one clean peak.
/// assert!(design_warnings(&d, &GeometryCache::default())?.is_empty());
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn design_warnings(design: &Design, cache: &crate::fem::GeometryCache) -> Result<Vec<String>> {
    let Some(m) = &design.module else {
        return Ok(Vec::new());
    };
    let request = PredictionRequest {
        force_n: m.limits.map_or(DESIGN_CHECK_FORCE_N, |l| l.max_force_n),
        fidelity: super::FidelityChoice::Fem,
        band: false,
        design_interval: false,
        spectrum: true,
        refine_to_level: None,
        cache: cache.clone(),
        ..PredictionRequest::default()
    };
    let rows = super::predict(design, &request)?;
    Ok(rows
        .iter()
        .filter_map(|row| {
            let p = &row.detail.prediction;
            let w = warning(&p.grating, row.spectrum.as_ref()?)?;
            let config = match &p.insert {
                Some(i) => format!("{} Case {} {i}", p.core, p.case),
                None => format!("{} Case {}", p.core, p.case),
            };
            Some(format!("{config}: {w}"))
        })
        .collect())
}
