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
//! assembly of the whole measurement (`assemble`, [`analyse`]).

mod assemble;
mod clocks;
mod fit_data;
mod force;
mod gratings;
mod lags;
mod linearity;
mod measure;
mod options;
mod quality;
mod results;
mod sensitivity;

pub use super::segment::{detect_pulses, percentile, PulseSpan};
pub use assemble::analyse;
pub use linearity::hysteresis_and_linearity;
pub use options::AnalysisOptions;
pub use results::{
    BoundKind, ForceTrust, GratingResult, Measurement, PulseResult, QualityBound, Series,
};
