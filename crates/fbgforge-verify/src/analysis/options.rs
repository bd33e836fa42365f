//! The options of an analysis: the core, the window half-width, the clock offset
//! (given, or the range it is estimated in) and the interrogator's resolution.

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
