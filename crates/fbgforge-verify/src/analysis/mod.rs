//! The analysis of one verification run: alignment of the two clocks, the lag model,
//! loading pulses, and the figures of merit per grating.
//!
//! Frames: every time in the results is in seconds from the first row of the
//! wavelength log, on the wavelength log's clock. The clock offset is
//! `force clock − wavelength clock` for the same instant.
//!
//! Steps (see `docs/verify.md` for the reasoning):
//! 1. peaks → gratings by window, temperature removed with the reference grating;
//! 2. clock offset: cross-correlation of the force with the largest shift gives a
//!    coarse value (offset minus the response's lag), then the lag model
//!    ([`super::fit`]) is fitted jointly with the offset, first on a decimated copy of
//!    the whole overlap, then at full rate on its first stretch;
//! 3. per grating: the lag model with the offset fixed gives K (static sensitivity,
//!    with its standard error), τ and r; baseline and linear drift are removed;
//! 4. the force is resampled onto the wavelength log's times (the common time base),
//!    and Δλ against F gives the linear slope, R², hysteresis and non-linearity;
//! 5. pulses are found in the force log; per pulse the peak force, the peak shift and
//!    the lag between the two peaks (vertices of parabolas through the top 5 %);
//! 6. before any fit, the force log is checked for saturation and gaps
//!    ([`crate::force_check`]): the pulses they touch are left out; after the
//!    first measurement, a drift of the primary grating's segment lags over the run is
//!    read as clock skew ([`crate::skew`]) and, when it stands out of its
//!    uncertainty, the force clock is warped and every grating measured again.
//!
//! One stage per file: the options (`options`) and the results (`results`); peaks to
//! gratings with temperature removed (`gratings`); the force log on the wavelength
//! clock, compression positive, cut into pulses (`force`); the clock offset
//! (`clocks`); per grating (`measure`) the K fit pieces (`sensitivity`, on the
//! strided copies of `fit_data`), the segment lags and Δt_max (`lags`), Q and when
//! it is defined (`quality`), hysteresis and non-linearity (`linearity`); and the
//! assembly of the whole measurement (`assemble`, [`analyse`]). What several stages
//! share is defined here, so the stages import one way: the force log on the
//! wavelength clock ([`ForceFrame`], made by `force`, read by `clocks`), the aligned
//! clocks ([`AlignedClocks`], made by `clocks`, read by `force`), what every grating's
//! measurement shares ([`GratingContext`]) and a grating's lag figures
//! ([`LagFigures`], made by `lags`, read by `quality`).

mod alignment;
mod assemble;
mod clocks;
mod fit_data;
mod force;
mod gratings;
mod instrument;
mod lags;
mod linearity;
mod measure;
mod options;
mod quality;
mod response;
mod results;
mod sensitivity;
mod series;
mod slow;
mod stretch;

use crate::logs::assign::GratingTrack;
use crate::segment::Segmentation;

pub use super::segment::{detect_pulses, percentile, PulseSpan};
pub use alignment::MIN_PRESSES;
pub use assemble::{analyse, analyse_assigned, analyse_owned};
pub use gratings::grating_windows;
pub use linearity::hysteresis_and_linearity;
pub use options::{AnalysisOptions, MAX_OFFSET_RANGE_S, MAX_RESOLUTION_PM, MAX_WINDOW_NM};
pub use response::hysteresis_limit_percent_span;
pub use results::{
    AlignmentCheck, BoundKind, ForceTrust, GratingResult, InstrumentCheck, Measurement,
    OffsetCandidate, PressMatch, PulseGain, PulseResult, QualityBound, Series, ShiftPress,
    SlowTest,
};

/// The force log's times on the wavelength log's clock, before the residual offset.
struct ForceFrame<'f> {
    /// Prior for the clock offset: 0 for two wall clocks, aligned starts otherwise, s.
    prior: f64,
    /// How far the estimated offset may lie from the prior, s.
    range: f64,
    /// Force times in the wavelength frame, before the residual offset, s (taken by
    /// the alignment, which makes them the aligned times).
    u: Vec<f64>,
    /// Force, N (compression positive): the force log's own column unless it was
    /// negated (no copy of it: 29 MB at 1 h × 1 kHz).
    fval: std::borrow::Cow<'f, [f64]>,
    /// The span searched for the offset, s.
    a: f64,
    b: f64,
}

/// The two clocks aligned.
struct AlignedClocks {
    /// Force clock − wavelength clock, s.
    offset: f64,
    /// `estimated` or `given`.
    source: &'static str,
    /// Force log times on the wavelength clock, s.
    fu: Vec<f64>,
    /// First and last force time on the wavelength clock, s.
    fa: f64,
    fb: f64,
    /// The alignment against its rivals (candidates and evidence; the presses are
    /// counted once the force is cut into pulses).
    check: results::AlignmentCheck,
}

/// Measurement of one grating in a verification: what every grating shares.
struct GratingContext<'a> {
    module: &'a crate::spec::Module,
    strain: &'a [&'a crate::spec::ModuleGrating],
    tracks: &'a [GratingTrack],
    /// The gratings used and their shifts.
    shifts: &'a gratings::GratingShifts<'a>,
    /// Wavelength log times, s from its first row.
    tw: &'a [f64],
    /// Force log times, aligned to the wavelength clock, s.
    fu: &'a [f64],
    /// Force, N (compression positive).
    fval: &'a [f64],
    /// Force at the wavelength log's rows, N (NaN outside the force log).
    fc: &'a [f64],
    /// Time span both logs cover, s.
    span: (f64, f64),
    /// The force log's protocol and segments (force-sample indices).
    seg: &'a Segmentation,
    resolution_pm: f64,
    /// Window half-width, nm.
    hw: f64,
    /// Timing uncertainty carried into absolute lags (0 when the lags are relative), s.
    timing_s: f64,
    /// True when the clock offset was estimated (lags relative to it).
    relative: bool,
    /// The rows' own timing uncertainty (whole-second timestamps), s, whatever the
    /// offset: it opens an apparent loop.
    row_timing_s: f64,
    /// Stretches of the force clock (`fu`) whose shift is left out of every fit, s.
    excluded_s: &'a [(f64, f64)],
    /// Rows of the wavelength log outside those stretches.
    row_ok: &'a [bool],
    /// Pulses left out (untrusted force), indices from 0.
    untrusted: &'a [usize],
    /// The design (the materials' hysteresis limits).
    design: &'a crate::spec::Design,
}

/// A grating's lags: per segment, and summarised.
struct LagFigures {
    /// Per segment, with the systematic allowance in each uncertainty.
    pulses: Vec<PulseResult>,
    summary: Option<crate::lag::LagSummary>,
    mean_lag_s: f64,
    /// Δt_max and its uncertainty (timing included), s.
    max_lag_s: f64,
    max_lag_uncertainty_s: f64,
}
