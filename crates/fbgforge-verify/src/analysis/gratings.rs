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
use std::borrow::Cow;

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

/// The strain gratings' shifts: peaks assigned to gratings, temperature removed. No
/// shift is kept per row: each (the primary grating's too) is rebuilt from the tracks
/// when a stage needs it ([`GratingShifts::shift_pm`], the same values each time), so
/// eight gratings of an hour at 1 kHz hold no column beyond their tracks.
pub(super) struct GratingShifts<'a> {
    pub(super) selection: GratingSelection<'a>,
    pub(super) tracks: Vec<GratingTrack>,
    /// The reference grating used, if any.
    pub(super) reference_grating: Option<String>,
    /// The reference grating's track compensates the shifts (it has enough peaks).
    reference_used: bool,
    /// The rows' times, s (the reference's gaps are filled over them).
    tw: &'a [f64],
    /// Strain grating index (into `selection.strain`) of each grating used.
    pub(super) used: Vec<usize>,
    /// Index into `used` of the primary grating (the largest response).
    pub(super) primary: usize,
    /// Strain gratings of the core under test with too few peaks (missing channels).
    pub(super) missing: Vec<String>,
}

impl GratingShifts<'_> {
    /// The temperature-compensated shift of `used[k]`, pm per row.
    pub(super) fn shift_pm(&self, k: usize) -> Cow<'_, [f64]> {
        let filled = self
            .reference_used
            .then(|| filled_reference(&self.tracks, self.tw))
            .flatten();
        Cow::Owned(compensated(&self.tracks, self.used[k], filled.as_deref()))
    }

    /// The primary grating's shift, pm per row.
    pub(super) fn primary_shift_pm(&self) -> Cow<'_, [f64]> {
        self.shift_pm(self.primary)
    }
}

/// The reference grating's track (the last one) with its gaps filled, pm from its
/// nominal.
fn filled_reference(tracks: &[GratingTrack], tw: &[f64]) -> Option<Vec<f64>> {
    let mut filled = tracks.last()?.offsets_pm();
    assign::fill_gaps_in_place(tw, &mut filled);
    Some(filled)
}

/// The compensated shift of strain grating `i` (the reference, when given, is the last
/// track).
fn compensated(tracks: &[GratingTrack], i: usize, reference: Option<&[f64]>) -> Vec<f64> {
    let r = reference.and_then(|f| tracks.last().map(|t| (t, f)));
    assign::compensated_shift_pm(&tracks[i], r)
}

/// The wavelength windows of the gratings a verification reads, in the order of their
/// tracks (the strain gratings of the core asked for, then the temperature reference):
/// what [`crate::logs::read_peak_log_assigned`] assigns a log's peaks to as it reads it.
pub fn grating_windows(design: &Design, opts: &AnalysisOptions) -> Result<Vec<GratingWindow>> {
    let Some(module) = &design.module else {
        bail!("design `{}` has no [module]", design.name);
    };
    Ok(select_gratings(design, module, opts)?.windows)
}

/// Assign the peaks to the gratings (unless `assigned` holds the tracks already, read
/// with [`grating_windows`]) and remove temperature with the reference grating; a log
/// handed over (`Cow::Owned`) has its peaks (and rows' line numbers) freed once assigned.
pub(super) fn grating_shifts<'a>(
    design: &Design,
    module: &'a crate::spec::Module,
    (log, assigned): (&mut Cow<'_, PeakLog>, Option<Vec<GratingTrack>>),
    opts: &AnalysisOptions,
    tw: &'a [f64],
    warnings: &mut LogWarnings,
) -> Result<GratingShifts<'a>> {
    let selection = select_gratings(design, module, opts)?;
    let tracks = match assigned {
        Some(t) => {
            let same = t.len() == selection.windows.len()
                && t.iter()
                    .zip(&selection.windows)
                    .all(|(t, w)| &t.window == w);
            if !same || t.iter().any(|t| t.offset_pm.len() != tw.len()) {
                bail!("internal: the tracks read with the log are not those of the design's gratings and the log's rows");
            }
            t
        }
        None => assign::assign(log, &selection.windows),
    };
    if let Cow::Owned(l) = log {
        l.drop_peaks();
        // Read only to find the rows on one clock, done by now (14 MB at 3.6 M rows).
        l.line_of_row = Vec::new();
    }
    let log: &PeakLog = log;
    let tracked = Tracked {
        design,
        log,
        tracks: &tracks,
        rows: tw.len(),
        min_rows: (tw.len() / 10).max(2),
        hw: selection.hw,
    };
    let reference_filled = reference_track(&tracked, selection.reference, tw, warnings);
    let core_named = opts.core.is_some();
    let (used, missing) = strain_shifts(&tracked, &selection.strain, core_named, warnings)?;
    let reference_grating = reference_filled
        .as_ref()
        .and_then(|_| tracks.last())
        .map(|t| t.window.name.clone());
    // The primary grating: the one with the largest response (each shift built, its
    // spread read, and only the largest kept; of equals the later one).
    let spread = |s: &[f64]| percentile(s, 0.98) - percentile(s, 0.02);
    let mut primary = (0, f64::NEG_INFINITY);
    for (k, &i) in used.iter().enumerate() {
        let s = compensated(&tracks, i, reference_filled.as_deref());
        let w = spread(&s);
        if k == 0 || w.total_cmp(&primary.1).is_ge() {
            primary = (k, w);
        }
    }
    Ok(GratingShifts {
        selection,
        tracks,
        reference_grating,
        reference_used: reference_filled.is_some(),
        tw,
        used,
        primary: primary.0,
        missing,
    })
}

/// What the grating tracks of a verification were read from and how.
struct Tracked<'a> {
    design: &'a Design,
    log: &'a PeakLog,
    tracks: &'a [GratingTrack],
    /// The log's rows (its times are `tw` by now, not the log's).
    rows: usize,
    /// Fewest rows with a peak for a grating to count as present.
    min_rows: usize,
    /// Window half-width, nm.
    hw: f64,
}

/// The temperature-reference grating's track (the last one) with its gaps filled, or
/// `None` with a warning when the design has none or its peaks are too few.
fn reference_track(
    tr: &Tracked,
    reference: Option<&crate::spec::ModuleGrating>,
    tw: &[f64],
    warnings: &mut LogWarnings,
) -> Option<Vec<f64>> {
    let (design, log, tracks, min_rows, hw) = (tr.design, tr.log, tr.tracks, tr.min_rows, tr.hw);
    match reference {
        Some(r) => {
            let t = tracks.last().filter(|t| t.window.name == r.name);
            match t {
                Some(t) if t.rows_present >= min_rows => filled_reference(tr.tracks, tw),
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

/// The strain gratings present in the log (indices into `strain`) and the names of
/// the missing ones; a missing grating is a warning (an error when a core was named).
fn strain_shifts(
    tr: &Tracked,
    strain: &[&crate::spec::ModuleGrating],
    core_named: bool,
    warnings: &mut LogWarnings,
) -> Result<(Vec<usize>, Vec<String>)> {
    let (log, tracks, min_rows, hw) = (tr.log, tr.tracks, tr.min_rows, tr.hw);
    let rows = tr.rows;
    // A core none of whose gratings appears is not the core under test (a module is
    // tested with one core plugged in): its gratings are not missing, just absent.
    let present = |i: usize| tracks[i].rows_present >= min_rows;
    let core_in_log = |core: &Option<String>| {
        strain
            .iter()
            .enumerate()
            .any(|(i, g)| &g.core == core && present(i))
    };
    let mut used: Vec<usize> = Vec::new();
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
        used.push(i);
    }
    if used.is_empty() {
        bail!("{}: none of the design's strain gratings has peaks in the log (windows ± {hw:.3} nm around their nominal wavelengths)", log.source.display());
    }
    Ok((used, missing))
}
