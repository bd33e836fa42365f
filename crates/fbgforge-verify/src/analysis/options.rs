//! The options of an analysis: the core, the window half-width, the clock offset
//! (given, or the range it is estimated in) and the interrogator's resolution, and
//! their one check ([`AnalysisOptions::validate`]).

use anyhow::{bail, Result};

/// Largest wavelength window half-width, nm (a grating's whole strain range; wider
/// windows swallow the neighbours').
pub const MAX_WINDOW_NM: f64 = 10.0;
/// Largest interrogator resolution, pm.
pub const MAX_RESOLUTION_PM: f64 = 100.0;
/// Largest search range of an estimated clock offset, s (one day).
pub const MAX_OFFSET_RANGE_S: f64 = 86_400.0;

/// Options of the analysis.
#[derive(Debug, Clone)]
pub struct AnalysisOptions {
    /// Analyse only the strain gratings of this core (all present ones otherwise).
    pub core: Option<String>,
    /// Half-width of the wavelength windows, nm (default: see [`assign`](crate::logs::assign)).
    pub window_half_width_nm: Option<f64>,
    /// A known clock offset (force clock − wavelength clock), s; estimated if None.
    pub clock_offset_s: Option<f64>,
    /// How far the estimated offset may lie from the prior (0 for two wall clocks,
    /// aligned starts otherwise), s.
    pub max_clock_offset_s: f64,
    /// Interrogator resolution, pm (default: typical for the log format).
    pub resolution_pm: Option<f64>,
}

impl Default for AnalysisOptions {
    fn default() -> Self {
        AnalysisOptions {
            core: None,
            window_half_width_nm: None,
            clock_offset_s: None,
            max_clock_offset_s: 60.0,
            resolution_pm: None,
        }
    }
}

impl AnalysisOptions {
    /// Check the numbers: each finite and in its range, the error naming the field and
    /// the range.
    pub fn validate(&self) -> Result<()> {
        if let Some(o) = self.clock_offset_s.filter(|o| !o.is_finite()) {
            bail!("the clock offset (AnalysisOptions.clock_offset_s) must be a finite number of seconds, got {o}");
        }
        let range = self.max_clock_offset_s;
        if !(range.is_finite() && (0.0..=MAX_OFFSET_RANGE_S).contains(&range)) {
            bail!("the clock offset's search range (AnalysisOptions.max_clock_offset_s) must be a finite number of seconds in [0, {MAX_OFFSET_RANGE_S}], got {range}");
        }
        if let Some(w) = self.window_half_width_nm {
            check_window(w)?;
        }
        if let Some(r) = self.resolution_pm {
            if !(r > 0.0 && r <= MAX_RESOLUTION_PM) {
                bail!("the interrogator resolution (AnalysisOptions.resolution_pm) must be in (0, {MAX_RESOLUTION_PM}] pm, got {r}");
            }
        }
        Ok(())
    }
}

/// The window half-width in use, given or defaulted from the design, must be in
/// (0, [`MAX_WINDOW_NM`]] nm.
pub(super) fn check_window(hw: f64) -> Result<()> {
    if !(hw > 0.0 && hw <= MAX_WINDOW_NM) {
        bail!("the wavelength window half-width (AnalysisOptions.window_half_width_nm) must be in (0, {MAX_WINDOW_NM}] nm, got {hw}");
    }
    Ok(())
}
