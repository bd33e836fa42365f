//! From peaks to gratings: wavelength windows around the design's nominal values,
//! gaps where a peak dropped out, and temperature removal with the reference grating.
//!
//! Each grating owns the window nominal ± half-width. The default half-width is half
//! the smallest spacing between the nominal wavelengths (so windows never overlap),
//! capped at 2.5 nm (250 N at 10 pm/N, or 250 K of temperature, before a peak leaves
//! it). When several peaks fall in one window in one row, the one nearest the grating's
//! previous value is taken and the row is counted as ambiguous.

use crate::logs::PeakLog;
use serde::Serialize;

/// Largest default half-width of a window, nm.
pub(crate) const MAX_DEFAULT_HALF_WIDTH_NM: f64 = 2.5;

/// A grating to look for in a log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GratingWindow {
    /// Grating name from the spec.
    pub name: String,
    /// Nominal Bragg wavelength, nm.
    pub nominal_nm: f64,
    /// Half-width of its window, nm.
    pub half_width_nm: f64,
}

impl GratingWindow {
    /// The window nominal ± `half_width_nm` of the grating `name`.
    pub fn new(name: &str, nominal_nm: f64, half_width_nm: f64) -> Self {
        GratingWindow {
            name: name.to_string(),
            nominal_nm,
            half_width_nm,
        }
    }
}

/// Default half-width for a set of nominal wavelengths, nm.
pub fn default_half_width_nm(nominals: &[f64]) -> f64 {
    let mut v = nominals.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    let min_gap = v
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    (min_gap / 2.0).min(MAX_DEFAULT_HALF_WIDTH_NM)
}

/// One grating's wavelength, row by row (NaN where no peak fell in its window).
///
/// Stored compactly as each row's offset from the window's nominal wavelength in pm,
/// as f32: half the memory of f64 wavelengths (an hour at 1 kHz: 14 MB a grating, not
/// 29). Within a window (at most ±2.5 nm = ±2500 pm) an f32 keeps 24 bits, so the
/// stored offset is within 1.5e-4 pm of the log's (6e-8 of it, relative), far
/// below any interrogator's resolution (≥ 0.1 pm); a sensitivity fitted to the shifts
/// moves by ~1e-7 relative, not by 1e-12.
#[derive(Debug, Clone, PartialEq)]
pub struct GratingTrack {
    /// The window it was read with.
    pub window: GratingWindow,
    /// Wavelength per log row as the offset from `window.nominal_nm`, pm; NaN = dropped
    /// out.
    pub offset_pm: Vec<f32>,
    /// Rows with a peak in the window.
    pub rows_present: usize,
    /// Rows with more than one peak in the window.
    pub rows_ambiguous: usize,
    /// Standard error of each row's wavelength, pm, as the log states it (peaks found
    /// in spectra, a peaks log with standard errors); NaN where it states none, and
    /// empty when the log states none at all (a plain peak log: no column of NaNs).
    pub std_error_pm: Vec<f64>,
}

impl GratingTrack {
    /// The offset of row `i` from the nominal wavelength, pm (NaN: no peak).
    pub fn offset_pm_at(&self, i: usize) -> f64 {
        f64::from(self.offset_pm[i])
    }

    /// The wavelength of row `i`, nm (NaN: no peak).
    ///
    /// ```
    /// use fbgforge_core::logs::assign::{GratingTrack, GratingWindow};
    /// let t = GratingTrack {
    ///     window: GratingWindow::new("FBG1", 1546.295, 2.5),
    ///     offset_pm: vec![12.5, f32::NAN],
    ///     rows_present: 1,
    ///     rows_ambiguous: 0,
    ///     std_error_pm: Vec::new(),
    /// };
    /// assert!((t.wavelength_nm_at(0) - 1546.3075).abs() < 1e-9);
    /// assert!(t.wavelength_nm_at(1).is_nan());
    /// ```
    pub fn wavelength_nm_at(&self, i: usize) -> f64 {
        self.window.nominal_nm + self.offset_pm_at(i) * 1e-3
    }

    /// Every row's offset from the nominal wavelength as f64, pm (NaN: no peak).
    pub fn offsets_pm(&self) -> Vec<f64> {
        self.offset_pm.iter().map(|&o| f64::from(o)).collect()
    }
}

/// A wavelength as a track stores it: its offset from `nominal_nm` in pm, as f32.
fn stored_offset_pm(wavelength_nm: f64, nominal_nm: f64) -> f32 {
    ((wavelength_nm - nominal_nm) * 1e3) as f32
}

/// Assigns one frame's peaks to gratings, frame after frame: each peak to the grating
/// with the nearest nominal wavelength, if it lies within that grating's window; of
/// several peaks in one window, the one nearest the grating's previous value. The one
/// rule of the verifier ([`assign`]) and the live mode.
#[derive(Debug, Clone)]
pub struct PeakTracker {
    windows: Vec<GratingWindow>,
    /// Indices of `windows` sorted by nominal wavelength, and those nominals.
    order: Vec<usize>,
    sorted_nm: Vec<f64>,
    last_nm: Vec<f64>,
    hits: Vec<u32>,
}

impl PeakTracker {
    /// A tracker for `windows`, each grating starting at its nominal wavelength.
    pub fn new(windows: Vec<GratingWindow>) -> Self {
        let mut order: Vec<usize> = (0..windows.len()).collect();
        order.sort_by(|&a, &b| windows[a].nominal_nm.total_cmp(&windows[b].nominal_nm));
        let sorted_nm = order.iter().map(|&g| windows[g].nominal_nm).collect();
        let last_nm = windows.iter().map(|w| w.nominal_nm).collect();
        let hits = vec![0; windows.len()];
        PeakTracker {
            windows,
            order,
            sorted_nm,
            last_nm,
            hits,
        }
    }

    /// The windows, in the order of the outputs.
    pub fn windows(&self) -> &[GratingWindow] {
        &self.windows
    }

    /// Wavelength of each grating in this frame into `out`, nm (NaN: no peak in its
    /// window); returns whether any window held more than one peak. [`Self::hits`]
    /// then tells how many peaks each window held.
    pub fn assign_frame(&mut self, peaks: &[f64], out: &mut Vec<f64>) -> bool {
        out.clear();
        out.resize(self.windows.len(), f64::NAN);
        self.hits.iter_mut().for_each(|h| *h = 0);
        let sorted = &self.sorted_nm;
        for &p in peaks {
            let k = sorted.partition_point(|&l| l < p);
            let nearest = match (k.checked_sub(1), sorted.get(k)) {
                (Some(a), Some(&hi)) => {
                    if p - sorted[a] <= hi - p {
                        a
                    } else {
                        k
                    }
                }
                (Some(a), None) => a,
                (None, Some(_)) => k,
                (None, None) => continue,
            };
            let g = self.order[nearest];
            let w = &self.windows[g];
            if (p - w.nominal_nm).abs() > w.half_width_nm {
                continue;
            }
            if self.hits[g] == 0 || (p - self.last_nm[g]).abs() < (out[g] - self.last_nm[g]).abs() {
                out[g] = p;
            }
            self.hits[g] += 1;
        }
        let mut ambiguous = false;
        for ((&hits, last), &w) in self
            .hits
            .iter()
            .zip(self.last_nm.iter_mut())
            .zip(out.iter())
        {
            if hits > 0 {
                *last = w;
                ambiguous |= hits > 1;
            }
        }
        ambiguous
    }

    /// How many peaks each window held in the last frame.
    pub fn hits(&self) -> &[u32] {
        &self.hits
    }
}

/// Assign peaks to gratings, row by row, with one [`PeakTracker`].
pub fn assign(log: &PeakLog, windows: &[GratingWindow]) -> Vec<GratingTrack> {
    let n = log.rows();
    // A plain peak log states no standard errors: no per-row column of NaNs (9 × 29 MB
    // for an hour at 1 kHz).
    let n_errors = if log.uncertainty.is_some() { n } else { 0 };
    let mut a = StreamAssigner::new(windows);
    a.reserve(n);
    for t in &mut a.tracks {
        t.std_error_pm = vec![f64::NAN; n_errors];
    }
    for i in 0..n {
        let (peaks, _) = log.row(i);
        a.push_row(peaks);
        if let Some(q) = log.row_quality(i) {
            for (g, track) in a.tracks.iter_mut().enumerate() {
                let w = a.frame[g];
                if !w.is_finite() {
                    continue;
                }
                if let Some(j) = peaks.iter().position(|&p| p == w) {
                    track.std_error_pm[i] = q[j].std_error_pm;
                }
            }
        }
    }
    a.tracks
}

/// Peaks assigned to gratings as the rows arrive, in file order: the rule of
/// [`assign`], for a log read block by block whose peaks are never held whole (an
/// hour at 1 kHz with eight peaks a row: 317 MB of table against 115 MB of tracks).
/// Rows arriving in file order are the rows in time order only when the log's times
/// never run back; the reader checks that ([`super::read_peak_log_assigned`]).
#[derive(Debug, Clone)]
pub(crate) struct StreamAssigner {
    tracker: PeakTracker,
    tracks: Vec<GratingTrack>,
    frame: Vec<f64>,
}

impl StreamAssigner {
    /// An assigner for `windows`, no row read yet.
    pub(crate) fn new(windows: &[GratingWindow]) -> Self {
        StreamAssigner {
            tracker: PeakTracker::new(windows.to_vec()),
            tracks: windows
                .iter()
                .map(|w| GratingTrack {
                    window: w.clone(),
                    offset_pm: Vec::new(),
                    rows_present: 0,
                    rows_ambiguous: 0,
                    std_error_pm: Vec::new(),
                })
                .collect(),
            frame: Vec::with_capacity(windows.len()),
        }
    }

    /// Room for `rows` more rows in every track (reserved exactly: a doubled
    /// capacity would cost as much as the tracks).
    pub(crate) fn reserve(&mut self, rows: usize) {
        for t in &mut self.tracks {
            t.offset_pm.reserve_exact(rows);
        }
    }

    /// The next row's peaks, nm.
    pub(crate) fn push_row(&mut self, peaks: &[f64]) {
        self.tracker.assign_frame(peaks, &mut self.frame);
        for (g, (track, &hits)) in self.tracks.iter_mut().zip(self.tracker.hits()).enumerate() {
            track
                .offset_pm
                .push(stored_offset_pm(self.frame[g], track.window.nominal_nm));
            if hits > 0 {
                track.rows_present += 1;
                if hits > 1 {
                    track.rows_ambiguous += 1;
                }
            }
        }
    }

    /// The rows of a table's part: row k's peaks are `peaks[row_start[k]..row_start[k
    /// + 1]]`.
    pub(crate) fn push_rows(&mut self, row_start: &[usize], peaks: &[f64]) {
        for w in row_start.windows(2) {
            self.push_row(&peaks[w[0]..w[1]]);
        }
    }

    /// The tracks of the rows pushed.
    pub(crate) fn finish(mut self) -> Vec<GratingTrack> {
        for t in &mut self.tracks {
            t.offset_pm.shrink_to_fit();
        }
        self.tracks
    }
}

/// The standard error of the least-squares slope of y against `x` that the standard
/// errors `sigma` of the y values alone give (every other noise left out):
/// √(Σ (xᵢ − x̄)² σᵢ²) / Σ (xᵢ − x̄)², over the rows where x and σ are finite. How
/// much of a sensitivity's uncertainty the peaks' own uncertainty makes (K in pm/N from
/// x the force in N and σ in pm); `None` without two such rows or a spread in x.
///
/// ```
/// use fbgforge_core::logs::assign::slope_std_error_from_errors;
/// // Equal errors σ: σ / √(Σ (x − x̄)²), here 0.5 / √10.
/// let se = slope_std_error_from_errors(&[0.0, 1.0, 2.0, 3.0, 4.0], &[0.5; 5]).unwrap();
/// assert!((se - 0.5 / 10f64.sqrt()).abs() < 1e-12);
/// ```
pub fn slope_std_error_from_errors(x: &[f64], sigma: &[f64]) -> Option<f64> {
    let rows: Vec<(f64, f64)> = x
        .iter()
        .zip(sigma)
        .filter(|(a, s)| a.is_finite() && s.is_finite())
        .map(|(a, s)| (*a, *s))
        .collect();
    if rows.len() < 2 {
        return None;
    }
    let mean = rows.iter().map(|r| r.0).sum::<f64>() / rows.len() as f64;
    let sxx: f64 = rows.iter().map(|r| (r.0 - mean).powi(2)).sum();
    if sxx.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let var: f64 = rows.iter().map(|r| (r.0 - mean).powi(2) * r.1 * r.1).sum();
    Some(var.sqrt() / sxx)
}

/// Fill NaN gaps by linear interpolation (ends take the nearest value). Used for the
/// reference grating only: temperature changes slowly, so a dropped reference peak
/// should not cost the strain sample beside it.
pub fn fill_gaps(t: &[f64], v: &[f64]) -> Vec<f64> {
    let mut out = v.to_vec();
    fill_gaps_in_place(t, &mut out);
    out
}

/// [`fill_gaps`] in place (a long log's reference track is not copied once more): only
/// the gaps are written, and only finite values are read.
pub fn fill_gaps_in_place(t: &[f64], out: &mut [f64]) {
    let idx: Vec<usize> = (0..out.len()).filter(|&i| out[i].is_finite()).collect();
    if idx.is_empty() {
        return;
    }
    for i in 0..out.len() {
        if out[i].is_finite() {
            continue;
        }
        let k = idx.partition_point(|&j| j < i);
        out[i] = if k == 0 {
            out[idx[0]]
        } else if k == idx.len() {
            out[idx[k - 1]]
        } else {
            let (a, b) = (idx[k - 1], idx[k]);
            out[a] + (out[b] - out[a]) * (t[i] - t[a]) / (t[b] - t[a])
        };
    }
}

/// Median of the finite values among the first `n` finite ones.
pub(crate) fn early_median(v: impl IntoIterator<Item = f64>, n: usize) -> f64 {
    let mut s: Vec<f64> = v.into_iter().filter(|x| x.is_finite()).take(n).collect();
    if s.is_empty() {
        return f64::NAN;
    }
    s.sort_by(|a, b| a.total_cmp(b));
    s[s.len() / 2]
}

/// Shift of a strain grating, pm, relative to its early baseline, with the
/// reference grating's shift removed (scaled by λ_sensor / λ_reference as in
/// [`crate::grating::compensate_temperature_pm`]). Without a reference the raw shift
/// is returned. NaN stays NaN. `reference` is the reference track with the offsets of
/// its gaps filled, pm from its nominal ([`GratingTrack::offsets_pm`], [`fill_gaps`]).
pub fn compensated_shift_pm(
    sensor: &GratingTrack,
    reference: Option<(&GratingTrack, &[f64])>,
) -> Vec<f64> {
    let offsets = sensor.offset_pm.iter().map(|&o| f64::from(o));
    let base = early_median(offsets.clone(), 50);
    match reference {
        None => offsets.map(|o| o - base).collect(),
        Some((r, filled)) => {
            let rbase = early_median(filled.iter().copied(), 50);
            offsets
                .zip(filled)
                .map(|(o, &or)| {
                    crate::grating::compensate_temperature_pm(
                        o - base,
                        sensor.window.nominal_nm,
                        or - rbase,
                        r.window.nominal_nm,
                    )
                })
                .collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::logs::{Clock, LogFormat, LogWarnings};

    fn log_of(rows: &[&[f64]]) -> PeakLog {
        let mut row_start = vec![0];
        let mut peaks = Vec::new();
        for r in rows {
            peaks.extend_from_slice(r);
            row_start.push(peaks.len());
        }
        PeakLog {
            source: "mem".into(),
            format: LogFormat::Csv,
            time_s: (0..rows.len()).map(|i| i as f64).collect(),
            clock: Clock::Relative,
            row_start,
            peak_channel: vec![0; peaks.len()],
            peaks_nm: peaks,
            channels: 1,
            column_names: vec![],
            line_of_row: (0..rows.len() as u32).collect(),
            time_uncertainty_s: 0.0,
            clock_jumps: Vec::new(),
            warnings: LogWarnings::default(),
            uncertainty: None,
        }
    }

    #[test]
    fn windows_assign_peaks_and_keep_gaps() {
        let w = default_half_width_nm(&[1530.0, 1536.0, 1560.0]);
        assert_eq!(w, 2.5);
        assert_eq!(
            default_half_width_nm(&[1520.807, 1523.550]),
            (1523.550 - 1520.807) / 2.0
        );
        let win: Vec<GratingWindow> = [1530.0, 1536.0]
            .iter()
            .enumerate()
            .map(|(i, &l)| GratingWindow {
                name: format!("g{i}"),
                nominal_nm: l,
                half_width_nm: w,
            })
            .collect();
        let log = log_of(&[&[1530.1, 1536.2], &[1536.3], &[1529.9, 1530.6, 1545.0]]);
        let t = assign(&log, &win);
        // Stored as f32 offsets from the nominal: within 1.5e-4 pm of the log's value.
        let near = |got: f64, want: f64| (got - want).abs() < 1.5e-7;
        assert!(near(t[0].wavelength_nm_at(0), 1530.1));
        assert!(t[0].wavelength_nm_at(1).is_nan());
        // Two peaks in the window: the one nearest the previous value (1530.1) wins.
        assert!(near(t[0].wavelength_nm_at(2), 1529.9));
        assert!(near(t[1].wavelength_nm_at(0), 1536.2));
        assert_eq!((t[0].rows_present, t[0].rows_ambiguous), (2, 1));
        assert!(t[1].wavelength_nm_at(2).is_nan());
    }

    /// The compact tracks (f32 offsets from the nominal, pm) against the log's own f64
    /// wavelengths, over the whole window: every row within the stated 1.5e-4 pm, the
    /// shifts as the f64 arithmetic gives them, and a slope fitted to them within 1e-7
    /// relative. Storing the wavelength itself as f32 (ulp 122 pm at 1546 nm) or the
    /// offset in nm would fail each.
    #[test]
    fn compact_tracks_keep_the_logs_wavelengths_to_the_stated_precision() {
        let (l0, hw) = (1546.295, 2.5);
        let n = 20_000;
        // A deterministic spread over the window: a load ramp up to 2.4 nm plus a
        // scatter of odd digits (a linear congruential draw).
        let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
        let mut draw = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let force_n: Vec<f64> = (0..n).map(|i| 240.0 * i as f64 / n as f64).collect();
        let wl: Vec<f64> = force_n
            .iter()
            .map(|f| l0 - 2.45 + 0.01 * f + 1e-3 * draw())
            .collect();
        let rows: Vec<Vec<f64>> = wl.iter().map(|&l| vec![l]).collect();
        let refs: Vec<&[f64]> = rows.iter().map(Vec::as_slice).collect();
        let t = assign(&log_of(&refs), &[GratingWindow::new("g", l0, hw)]);
        let worst_pm = (0..n)
            .map(|i| (t[0].wavelength_nm_at(i) - wl[i]).abs() * 1e3)
            .fold(0.0, f64::max);
        assert!(worst_pm <= 1.5e-4, "worst row off by {worst_pm} pm");
        // The shift from the early baseline: as the f64 wavelengths give it.
        let base = early_median(wl.iter().copied(), 50);
        let exact: Vec<f64> = wl.iter().map(|l| (l - base) * 1e3).collect();
        let compact = compensated_shift_pm(&t[0], None);
        let worst_shift = exact
            .iter()
            .zip(&compact)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst_shift <= 3e-4, "shift off by {worst_shift} pm");
        let slope = |y: &[f64]| {
            let mx = force_n.iter().sum::<f64>() / n as f64;
            let my = y.iter().sum::<f64>() / n as f64;
            let sxy: f64 = force_n
                .iter()
                .zip(y)
                .map(|(x, y)| (x - mx) * (y - my))
                .sum();
            let sxx: f64 = force_n.iter().map(|x| (x - mx).powi(2)).sum();
            sxy / sxx
        };
        let (k_exact, k_compact) = (slope(&exact), slope(&compact));
        assert!((k_exact - 10.0).abs() < 0.01, "K {k_exact} pm/N");
        assert!(
            ((k_compact - k_exact) / k_exact).abs() < 1e-7,
            "K {k_compact} vs {k_exact}"
        );
    }

    #[test]
    fn reference_removes_a_pure_temperature_ramp() {
        let fo = crate::grating::FiberOptics::default();
        let (ls, lr) = (1546.295, 1560.146);
        let n = 200;
        let t: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let strain = |i: usize| if i > 100 { 50e-6 } else { 0.0 };
        let s: Vec<f64> = (0..n)
            .map(|i| ls + fo.shift_pm(ls, strain(i), 0.05 * i as f64) * 1e-3)
            .collect();
        let mut r: Vec<f64> = (0..n)
            .map(|i| lr + fo.shift_pm(lr, 0.0, 0.05 * i as f64) * 1e-3)
            .collect();
        r[150] = f64::NAN; // a dropped reference peak is bridged
        let mk = |name: &str, l0: f64, v: Vec<f64>| GratingTrack {
            window: GratingWindow {
                name: name.into(),
                nominal_nm: l0,
                half_width_nm: 2.5,
            },
            rows_present: n,
            rows_ambiguous: 0,
            std_error_pm: vec![f64::NAN; v.len()],
            offset_pm: v.iter().map(|&l| stored_offset_pm(l, l0)).collect(),
        };
        let (st, rt) = (mk("s", ls, s), mk("r", lr, r));
        let filled = fill_gaps(&t, &rt.offsets_pm());
        let c = compensated_shift_pm(&st, Some((&rt, &filled)));
        let expect = fo.shift_pm(ls, 50e-6, 0.0);
        // The early median is taken over rows 0..50, where the ramp moves the baseline
        // by the same amount in both gratings: compensation leaves only the strain (to
        // the f32 storage: offsets up to ~110 pm keep ~4e-6 pm).
        for i in [0usize, 99, 150, 199] {
            let want = if i > 100 { expect } else { 0.0 };
            assert!((c[i] - want).abs() < 2e-5, "row {i}: {} vs {want}", c[i]);
        }
    }
}
