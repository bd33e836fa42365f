//! Peaks to gratings: the gratings a verification reads and their wavelength windows,
//! the temperature reference's track, each strain grating's temperature-compensated
//! shift (a missing grating a warning, or an error when a core was named), and the
//! primary grating the clocks are aligned on.

use super::options::{check_window, AnalysisOptions};
use crate::logs::assign::{self, GratingTrack, GratingWindow};
use crate::logs::{LogWarnings, PeakLog};
use crate::segment::percentile;
use crate::spec::{Design, GratingRole};
use anyhow::{bail, Result};

/// The gratings a verification reads: the strain gratings (of one core, if asked),
/// the temperature reference, and their wavelength windows.
pub(super) struct GratingSelection<'a> {
    pub(super) strain: Vec<&'a crate::spec::ModuleGrating>,
    reference: Option<&'a crate::spec::ModuleGrating>,
    pub(super) windows: Vec<GratingWindow>,
    /// Window half-width, nm.
    pub(super) hw: f64,
}

/// Check the core asked for, and pick the gratings and their wavelength windows.
fn select_gratings<'a>(
    design: &Design,
    module: &'a crate::spec::Module,
    opts: &AnalysisOptions,
) -> Result<GratingSelection<'a>> {
    if let Some(c) = &opts.core {
        if !module.cores.iter().any(|x| &x.name == c) {
            let names: Vec<&str> = module.cores.iter().map(|c| c.name.as_str()).collect();
            bail!(
                "design `{}` has no core named `{c}`; its cores are: {}",
                design.name,
                names.join(", ")
            );
        }
    }
    let all_nominals: Vec<f64> = module
        .gratings
        .iter()
        .map(|g| g.bragg_wavelength_nm)
        .collect();
    let hw = opts
        .window_half_width_nm
        .unwrap_or_else(|| assign::default_half_width_nm(&all_nominals));
    check_window(hw)?;
    let strain: Vec<_> = module
        .gratings
        .iter()
        .filter(|g| g.role == GratingRole::Strain && (opts.core.is_none() || g.core == opts.core))
        .collect();
    let reference = module.gratings.iter().find(|g| {
        g.role == GratingRole::TemperatureReference
            && (g.core.is_none() || opts.core.is_none() || g.core == opts.core)
    });
    let mut windows: Vec<GratingWindow> = strain
        .iter()
        .map(|g| GratingWindow::new(&g.name, g.bragg_wavelength_nm, hw))
        .collect();
    if let Some(r) = reference {
        windows.push(GratingWindow::new(&r.name, r.bragg_wavelength_nm, hw));
    }
    Ok(GratingSelection {
        strain,
        reference,
        windows,
        hw,
    })
}

/// The strain gratings' shifts: peaks assigned to gratings, temperature removed.
pub(super) struct GratingShifts<'a> {
    pub(super) selection: GratingSelection<'a>,
    pub(super) tracks: Vec<GratingTrack>,
    /// The reference grating used, if any.
    pub(super) reference_grating: Option<String>,
    /// (strain grating index, compensated shift in pm per row) of each grating used.
    pub(super) used: Vec<(usize, Vec<f64>)>,
    /// Strain gratings of the core under test with too few peaks (missing channels).
    pub(super) missing: Vec<String>,
}

/// Assign the peaks to the gratings and remove temperature with the reference grating.
pub(super) fn grating_shifts<'a>(
    design: &Design,
    module: &'a crate::spec::Module,
    log: &PeakLog,
    opts: &AnalysisOptions,
    tw: &[f64],
    warnings: &mut LogWarnings,
) -> Result<GratingShifts<'a>> {
    let selection = select_gratings(design, module, opts)?;
    let tracks = assign::assign(log, &selection.windows);
    let tracked = Tracked {
        design,
        log,
        tracks: &tracks,
        min_rows: (log.rows() / 10).max(2),
        hw: selection.hw,
    };
    let ref_track = reference_track(&tracked, selection.reference, tw, warnings);
    let core_named = opts.core.is_some();
    let (used, missing) = strain_shifts(
        &tracked,
        &selection.strain,
        ref_track.as_ref(),
        core_named,
        warnings,
    )?;
    let reference_grating = ref_track.as_ref().map(|(t, _)| t.window.name.clone());
    Ok(GratingShifts {
        selection,
        tracks,
        reference_grating,
        used,
        missing,
    })
}

/// The primary grating: the one with the largest response.
pub(super) fn primary_grating(used: &[(usize, Vec<f64>)]) -> usize {
    let spread = |s: &[f64]| percentile(s, 0.98) - percentile(s, 0.02);
    (0..used.len())
        .max_by(|&x, &y| spread(&used[x].1).total_cmp(&spread(&used[y].1)))
        .unwrap_or(0)
}

/// What the grating tracks of a verification were read from and how.
struct Tracked<'a> {
    design: &'a Design,
    log: &'a PeakLog,
    tracks: &'a [GratingTrack],
    /// Fewest rows with a peak for a grating to count as present.
    min_rows: usize,
    /// Window half-width, nm.
    hw: f64,
}

/// The temperature-reference grating's track (the last one) with its gaps filled, or
/// `None` with a warning when the design has none or its peaks are too few.
fn reference_track<'a>(
    tr: &Tracked<'a>,
    reference: Option<&crate::spec::ModuleGrating>,
    tw: &[f64],
    warnings: &mut LogWarnings,
) -> Option<(&'a GratingTrack, Vec<f64>)> {
    let (design, log, tracks, min_rows, hw) = (tr.design, tr.log, tr.tracks, tr.min_rows, tr.hw);
    match reference {
        Some(r) => {
            let t = tracks.last().filter(|t| t.window.name == r.name);
            match t {
                Some(t) if t.rows_present >= min_rows => {
                    Some((t, assign::fill_gaps(tw, &t.wavelength_nm)))
                }
                _ => {
                    warnings.add("reference_missing", || {
                        format!(
                            "{}: the temperature-reference grating `{}` ({} ± {hw:.3} nm) has too few peaks; shifts are NOT temperature compensated",
                            log.source.display(),
                            r.name,
                            r.bragg_wavelength_nm
                        )
                    });
                    None
                }
            }
        }
        None => {
            warnings.add("reference_missing", || {
                format!(
                    "design `{}` has no temperature-reference grating; shifts are not compensated",
                    design.name
                )
            });
            None
        }
    }
}

/// The temperature-compensated shift of every strain grating present in the log, by
/// index into `strain`, and the names of the missing ones; a missing grating is a
/// warning (an error when a core was named).
#[allow(clippy::type_complexity)]
fn strain_shifts(
    tr: &Tracked,
    strain: &[&crate::spec::ModuleGrating],
    ref_track: Option<&(&GratingTrack, Vec<f64>)>,
    core_named: bool,
    warnings: &mut LogWarnings,
) -> Result<(Vec<(usize, Vec<f64>)>, Vec<String>)> {
    let (log, tracks, min_rows, hw) = (tr.log, tr.tracks, tr.min_rows, tr.hw);
    let rows = log.rows();
    // A core none of whose gratings appears is not the core under test (a module is
    // tested with one core plugged in): its gratings are not missing, just absent.
    let present = |i: usize| tracks[i].rows_present >= min_rows;
    let core_in_log = |core: &Option<String>| {
        strain
            .iter()
            .enumerate()
            .any(|(i, g)| &g.core == core && present(i))
    };
    let mut used: Vec<(usize, Vec<f64>)> = Vec::new();
    let mut missing = Vec::new();
    for (i, g) in strain.iter().enumerate() {
        let t = &tracks[i];
        if !present(i) && !core_named && !core_in_log(&g.core) {
            continue;
        }
        if t.rows_present < min_rows {
            let msg = format!(
                "{}: grating `{}` ({} ± {hw:.3} nm) has a peak in only {} of {rows} rows: is its channel connected? (AnalysisOptions.window_half_width_nm widens the window)",
                log.source.display(),
                g.name,
                g.bragg_wavelength_nm,
                t.rows_present
            );
            if core_named {
                bail!("{msg}");
            }
            warnings.add("grating_missing", || msg);
            missing.push(g.name.clone());
            continue;
        }
        // A peak that leaves its window under load is dropped, and the fit then sees
        // only the low-force part of each pulse: K and R² come out biased low.
        let missing = rows - t.rows_present;
        if missing * 50 > rows {
            warnings.add_n("peaks_outside_window", missing, || {
                format!(
                    "{}: grating `{}` has no peak in its window {} ± {hw:.3} nm in {missing} of {rows} rows; if they gather at high force the shift leaves the window and K is biased low (AnalysisOptions.window_half_width_nm widens it)",
                    log.source.display(),
                    g.name,
                    g.bragg_wavelength_nm
                )
            });
        }
        let s = assign::compensated_shift_pm(t, ref_track.map(|(t, f)| (*t, f.as_slice())));
        used.push((i, s));
    }
    if used.is_empty() {
        bail!("{}: none of the design's strain gratings has peaks in the log (windows ± {hw:.3} nm around their nominal wavelengths)", log.source.display());
    }
    Ok((used, missing))
}
