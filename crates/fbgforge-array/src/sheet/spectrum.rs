//! The spectrum each grating of the array will make: the transfer-matrix model
//! (`fbgforge_spectra::grating`, docs/spectra.md §8) fed with the sheet model's strain
//! along the grating, for the indenter on each cell, over the array's force range
//! (`array.ulimit_g`).
//!
//! The profile comes from the same solve as the sensing matrix
//! ([`super::SheetSolution::strain_profile_per_n`]): the bar's axial strain sampled at
//! the grating's ends and at every segment edge between them, which joined by straight
//! lines is the model's strain along the grating; its mean is the matrix's entry (in
//! strain per newton), not an approximation of it. The model is linear, so the
//! profile at force F is F times the profile per newton. A load centred on a grating
//! strains it symmetrically; a load a cell away along its fiber puts a gradient across
//! it, which chirps its reflection.

use super::{gratings_of, SheetSolution, NEWTONS_PER_GRAM};
use crate::profile::{cell_label, ArrayLayout};
use crate::spec::Design;
use anyhow::{anyhow, Context, Result};
use fbgforge_model::prediction::spectrum::{forward_against, GratingSpectrum, ProfileSource};
use fbgforge_spectra::grating::{unstrained_shape, CleanPeakCriteria, StrainProfile};
use rayon::prelude::*;
use serde::Serialize;

/// One grating's spectrum under the indenter at one place.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoadSpectrum {
    /// Grating name.
    pub grating: String,
    /// The cell the indenter is centred on (`None` for a load placed elsewhere).
    pub cell: Option<String>,
    /// Where the indenter is centred, mm from the sheet centre.
    pub load_at_mm: [f64; 2],
    /// Positions of the profile's samples from the grating's start, mm.
    pub profile_z_mm: Vec<f64>,
    /// The fiber's strain per newton at those positions, µε/N.
    pub profile_microstrain_per_n: Vec<f64>,
    /// The profile's mean (trapezoids over its samples), µε/N: the sensing matrix's
    /// entry in strain.
    pub mean_microstrain_per_n: f64,
    /// The array's force range, g (`array.ulimit_g`).
    pub force_range_g: f64,
    /// The spectrum at the top of the range and whether it stays one clean peak from 0
    /// up to it (forces in N: `force_range_n` = `force_range_g` × 9.80665 mN/g).
    pub spectrum: GratingSpectrum,
}

impl LoadSpectrum {
    /// The force where the reflection stops being one clean peak, g.
    pub fn clean_limit_g(&self) -> Option<f64> {
        self.spectrum
            .clean_limit_force_n
            .map(|f| f / NEWTONS_PER_GRAM)
    }
}

/// Every grating under the indenter on every cell, and the warnings they earn.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArraySpectra {
    /// The array's force range, g.
    pub force_range_g: f64,
    /// One entry per grating and cell, gratings outer.
    pub loads: Vec<LoadSpectrum>,
    /// One line per grating whose reflection chirps or splits inside the range under a
    /// load on some cell, naming the cell and the load.
    pub warnings: Vec<String>,
}

/// Mean of a piecewise-linear profile (trapezoids).
///
/// ```
/// use fbgforge_array::sheet::spectrum::profile_mean;
/// // 0 → 2 over the first mm, then flat at 2 for 3 mm: (1 + 6) / 4.
/// assert_eq!(profile_mean(&[0.0, 1.0, 4.0], &[0.0, 2.0, 2.0]), 1.75);
/// ```
pub fn profile_mean(z_mm: &[f64], strain: &[f64]) -> f64 {
    let len = z_mm.last().copied().unwrap_or(0.0) - z_mm.first().copied().unwrap_or(0.0);
    if len <= 0.0 {
        return strain.first().copied().unwrap_or(0.0);
    }
    z_mm.windows(2)
        .zip(strain.windows(2))
        .map(|(z, e)| 0.5 * (e[0] + e[1]) * (z[1] - z[0]))
        .sum::<f64>()
        / len
}

/// The array's force range of `design`, g.
fn range_g(design: &Design) -> Result<f64> {
    let a = design
        .array
        .as_ref()
        .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
    Ok(a.ulimit_g)
}

/// The spectrum grating `index` of `design` makes under the indenter at `load_mm`
/// (`cell`: its label when the load is a cell's), over the array's force range, by the
/// sheet model's profile in `solution` (solved for this design).
pub fn load_spectrum(
    design: &Design,
    solution: &SheetSolution,
    index: usize,
    (load_mm, cell): ((f64, f64), Option<String>),
) -> Result<LoadSpectrum> {
    let criteria = CleanPeakCriteria::default();
    let (name, grating) = bragg_of(design, index)?;
    let unloaded = unstrained_shape(&grating, &criteria)
        .map_err(|e| anyhow!("spectrum of grating `{name}`: {e}"))?;
    let g = gratings_of(design)?[index];
    let (z, e) = solution.strain_profile_per_n(&g, load_mm);
    one_load(
        (design, &name, &grating, &unloaded),
        (z, e),
        (load_mm, cell),
    )
}

/// Name and transfer-matrix grating of the design's array grating `index`.
fn bragg_of(design: &Design, index: usize) -> Result<(String, fbgforge_spectra::Grating)> {
    let a = design
        .array
        .as_ref()
        .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
    let g = a
        .gratings
        .get(index)
        .ok_or_else(|| anyhow!("the array has no grating {index}"))?;
    let bragg = design
        .bragg_grating(&g.name)
        .with_context(|| format!("grating `{}` is not in the design", g.name))?;
    Ok((g.name.clone(), bragg))
}

type Bragg<'a> = (
    &'a Design,
    &'a str,
    &'a fbgforge_spectra::Grating,
    &'a fbgforge_spectra::grating::SpectrumShape,
);

fn one_load(
    (design, name, grating, unloaded): Bragg,
    (z, e): (Vec<f64>, Vec<f64>),
    (load_mm, cell): ((f64, f64), Option<String>),
) -> Result<LoadSpectrum> {
    let range_g = range_g(design)?;
    let range_n = range_g * NEWTONS_PER_GRAM;
    let mean = profile_mean(&z, &e);
    let profile = if z.len() >= 2 {
        StrainProfile::samples(z.clone(), e.clone()).map_err(|x| anyhow!("{x}"))?
    } else {
        StrainProfile::Uniform(mean)
    };
    let mut spectrum = forward_against(
        grating,
        unloaded,
        &profile,
        (range_n, range_n),
        &CleanPeakCriteria::default(),
    )
    .map_err(|x| anyhow!("spectrum of grating `{name}`: {x}"))?;
    spectrum.strain_profile = ProfileSource::Sheet;
    spectrum.force_range_from = "design";
    Ok(LoadSpectrum {
        grating: name.to_string(),
        cell,
        load_at_mm: [load_mm.0, load_mm.1],
        profile_z_mm: z,
        profile_microstrain_per_n: e.iter().map(|v| 1e6 * v).collect(),
        mean_microstrain_per_n: 1e6 * mean,
        force_range_g: range_g,
        spectrum,
    })
}

/// The warning a grating earns under a load that stops it being one clean peak.
fn warning(s: &LoadSpectrum) -> Option<String> {
    let where_ = s.cell.as_ref().map_or_else(
        || format!("at ({}, {}) mm", s.load_at_mm[0], s.load_at_mm[1]),
        |c| format!("on cell {c}"),
    );
    if !s.spectrum.clean_unloaded {
        return Some(format!(
            "grating `{}` is not one clean peak even unloaded (side lobes within 6 dB): lower [fiber].index_modulation or apodise ([fiber].apodisation)",
            s.grating
        ));
    }
    let g = s.clean_limit_g()?;
    let how = if s.spectrum.lobes_at_range > 1 {
        format!("splits into {} lobes", s.spectrum.lobes_at_range)
    } else {
        format!(
            "chirps (FWHM {:+.0} %)",
            s.spectrum.fwhm_change_at_range_pct
        )
    };
    Some(format!(
        "grating `{}`: a load {where_} ({:.2} µε/N from end to end along it) stops its reflection being one clean peak at {g:.1} g ({:.3} N), inside the array's range 0–{} g (array.ulimit_g); at {} g it {how}: peaks found there are the estimator's guess",
        s.grating,
        s.spectrum.strain_span_microstrain_per_n,
        g * NEWTONS_PER_GRAM,
        s.force_range_g,
        s.force_range_g
    ))
}

/// Every grating of `design`'s array under the indenter on each cell, by the sheet
/// model solved in `solution`, with a warning for each grating that chirps or splits
/// inside the range (the cell that stops it first).
///
/// ```
/// use fbgforge_array::sheet::{SheetModel, spectrum::array_spectra};
/// let d = fbgforge_core::design::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../designs/tactile-array-60x80.toml")))?;
/// let sol = SheetModel::from_design(&d)?.solve()?;
/// let s = array_spectra(&d, &sol)?;
/// // 6 gratings × 8 cells; the shipped 3 mm gratings stay one clean peak to 250 g.
/// assert_eq!(s.loads.len(), 48);
/// assert!(s.warnings.is_empty() && s.loads.iter().all(|l| l.spectrum.clean_over_range));
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn array_spectra(design: &Design, solution: &SheetSolution) -> Result<ArraySpectra> {
    let a = design
        .array
        .as_ref()
        .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
    let cells = ArrayLayout::from_array(a).cell_centers_mm;
    let gratings = gratings_of(design)?;
    let forces = solution.forces(&cells);
    let criteria = CleanPeakCriteria::default();
    let per_grating: Vec<Result<Vec<LoadSpectrum>>> = (0..gratings.len())
        .into_par_iter()
        .map(|i| {
            let (name, grating) = bragg_of(design, i)?;
            let unloaded = unstrained_shape(&grating, &criteria)
                .map_err(|e| anyhow!("spectrum of grating `{name}`: {e}"))?;
            (0..cells.len())
                .map(|c| {
                    let profile =
                        solution.profile_from_forces(&gratings[i], &forces.column(c).into_owned());
                    one_load(
                        (design, &name, &grating, &unloaded),
                        profile,
                        (cells[c], Some(cell_label(c))),
                    )
                })
                .collect()
        })
        .collect();
    let mut loads = Vec::with_capacity(gratings.len() * cells.len());
    let mut warnings = Vec::new();
    for g in per_grating {
        let g = g?;
        // The cell that stops the grating at the smallest load speaks for it.
        let first = g
            .iter()
            .filter(|s| !s.spectrum.clean_unloaded || s.spectrum.clean_limit_force_n.is_some())
            .min_by(|x, y| {
                let f = |s: &LoadSpectrum| s.spectrum.clean_limit_force_n.unwrap_or(0.0);
                f(x).total_cmp(&f(y))
            });
        if let Some(w) = first.and_then(warning) {
            warnings.push(w);
        }
        loads.extend(g);
    }
    Ok(ArraySpectra {
        force_range_g: range_g(design)?,
        loads,
        warnings,
    })
}
