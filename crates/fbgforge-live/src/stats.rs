//! Counters of a live run: frames, drops, bad frames by kind, reconnections, and the
//! latency distribution (a log-spaced histogram, so hours at 1 kHz cost a few kB).

use crate::logs::LogWarnings;
use crate::tare::TareState;
use serde::Serialize;

/// Latency histogram: buckets 2 % wide from 0.1 µs to about 100 s.
#[derive(Debug, Clone)]
pub struct Histogram {
    counts: Vec<u64>,
    n: u64,
    sum: f64,
    max: f64,
}

const BUCKET_RATIO: f64 = 1.02;
const FLOOR_US: f64 = 0.1;
const BUCKETS: usize = 1400;

impl Default for Histogram {
    fn default() -> Self {
        Histogram {
            counts: vec![0; BUCKETS],
            n: 0,
            sum: 0.0,
            max: 0.0,
        }
    }
}

impl Histogram {
    /// Record one value, µs (negative values count as 0).
    pub fn add(&mut self, us: f64) {
        if !us.is_finite() {
            return;
        }
        let v = us.max(0.0);
        let b = if v <= FLOOR_US {
            0
        } else {
            (((v / FLOOR_US).ln() / BUCKET_RATIO.ln()) as usize + 1).min(BUCKETS - 1)
        };
        self.counts[b] += 1;
        self.n += 1;
        self.sum += v;
        self.max = self.max.max(v);
    }

    /// Number of values.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// The q-quantile (0–1), µs, to within the 2 % bucket width (upper bucket edge).
    pub fn quantile(&self, q: f64) -> f64 {
        if self.n == 0 {
            return f64::NAN;
        }
        let target = ((q.clamp(0.0, 1.0) * self.n as f64).ceil() as u64).max(1);
        let mut acc = 0;
        for (b, &c) in self.counts.iter().enumerate() {
            acc += c;
            if acc >= target {
                let upper = FLOOR_US * BUCKET_RATIO.powi(b as i32);
                return upper.min(self.max);
            }
        }
        self.max
    }

    /// Summary for reports.
    pub fn summary(&self) -> LatencySummary {
        LatencySummary {
            count: self.n,
            mean_us: if self.n > 0 {
                self.sum / self.n as f64
            } else {
                f64::NAN
            },
            p50_us: self.quantile(0.5),
            p99_us: self.quantile(0.99),
            max_us: if self.n > 0 { self.max } else { f64::NAN },
        }
    }
}

/// A latency distribution as reported, µs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LatencySummary {
    /// Values recorded.
    pub count: u64,
    /// Mean, µs.
    pub mean_us: f64,
    /// Median, µs.
    pub p50_us: f64,
    /// 99th percentile, µs.
    pub p99_us: f64,
    /// Largest, µs.
    pub max_us: f64,
}

/// Frames lost before they could be read.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Dropped {
    /// Frames the instrument numbered that never arrived (serial-number gaps: the
    /// network, a reconnection).
    pub serial_gaps: u64,
    /// Frames dropped because the live mode fell behind (its queue was full).
    pub queue_overflow: u64,
    /// Both.
    pub total: u64,
}

/// Everything counted in a live run.
#[derive(Debug, Clone, Default)]
pub struct Stats {
    /// Frames read from the source.
    pub frames_in: u64,
    /// Frames taken into the tare window while waiting for rest (not read).
    pub tare_frames: u64,
    /// Frames not read because the tare was refused.
    pub refused_frames: u64,
    /// Where the tare stands now.
    pub tare: TareState,
    /// Re-tares asked for (key, control line, Python, library).
    pub tare_requests: u64,
    /// Re-tares made because the sensor settled below a tare that had held a load.
    pub retares_below_tare: u64,
    /// Readings below the tare (flagged `below_tare`).
    pub below_tare: u64,
    /// Frames turned into readings.
    pub frames_out: u64,
    /// Frames that could not be used (also counted by kind in `bad`).
    pub bad_frames: u64,
    /// Bad frames and other events, by kind, with the first occurrence named.
    pub bad: LogWarnings,
    /// Frames with more than one peak in a grating's window (used, not bad).
    pub ambiguous_frames: u64,
    /// Frames lost.
    pub dropped: Dropped,
    /// Connections re-established after a drop.
    pub reconnects: u64,
    /// Array frames whose method did not converge.
    pub not_converged: u64,
    /// Readings carrying a flag (an array's trust flags, `below_tare`).
    pub flagged: u64,
    /// Receive → reading, µs.
    pub latency: Histogram,
    /// Instrument timestamp → reading, µs (wall-clock sources only: meaningful when the
    /// instrument's clock is the machine's, as with the simulated interrogator).
    pub age: Histogram,
}

/// The run's summary, as printed and as the last JSON line.
#[derive(Debug, Clone, Serialize)]
pub struct LiveSummary {
    /// Design name.
    pub design: String,
    /// The source read.
    pub source: String,
    /// Why the run ended.
    pub ended: String,
    /// Whether it ended because the source was lost ((re)connecting given up, the
    /// followed file unreadable or deleted) rather than at its end or a limit.
    pub source_lost: bool,
    /// Whether it ended because an output closed (a pipe whose reader ended).
    pub output_closed: bool,
    /// Wall time from the first frame to the end, s.
    pub elapsed_s: f64,
    /// The frames' own clock (instrument timestamp or log time) from the first frame
    /// to the last, s, when they carry one.
    pub clock_span_s: Option<f64>,
    /// Frames read.
    pub frames_in: u64,
    /// Frames turned into readings.
    pub frames_out: u64,
    /// Frames per second from the first frame to the last: by the frames' own clock
    /// where they carry one (a replayed log gives the rate it was written at, not how
    /// fast it was read), else by when they were read.
    pub rate_hz: f64,
    /// Where the tare stood at the end.
    pub tare: TareState,
    /// Frames taken into the tare window while waiting for rest (not read).
    pub tare_frames: u64,
    /// Frames not read because the tare was refused.
    pub refused_frames: u64,
    /// Re-tares asked for.
    pub tare_requests: u64,
    /// Re-tares made because the sensor settled below a tare that had held a load.
    pub retares_below_tare: u64,
    /// Frames that could not be used.
    pub bad_frames: u64,
    /// Bad frames and events by kind, with the first occurrence named.
    pub bad: LogWarnings,
    /// Frames with two peaks in one window.
    pub ambiguous_frames: u64,
    /// Frames lost before they could be read.
    pub dropped: Dropped,
    /// Reconnections.
    pub reconnects: u64,
    /// Array frames whose method did not converge.
    pub not_converged: u64,
    /// Readings carrying a flag (an array's trust flags, `below_tare`).
    pub flagged: u64,
    /// Readings below the tare.
    pub below_tare: u64,
    /// Receive → reading, µs.
    pub latency: LatencySummary,
    /// Instrument timestamp → reading, µs (only where the stream's clock is this
    /// machine's wall clock).
    pub age: LatencySummary,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_are_within_the_bucket_width() {
        let mut h = Histogram::default();
        for v in 1..=1000 {
            h.add(v as f64);
        }
        let s = h.summary();
        assert_eq!(s.count, 1000);
        assert!((s.mean_us - 500.5).abs() < 1e-9);
        assert!((s.p50_us / 500.0 - 1.0).abs() < 0.021, "{}", s.p50_us);
        assert!((s.p99_us / 990.0 - 1.0).abs() < 0.021, "{}", s.p99_us);
        assert_eq!(s.max_us, 1000.0);
        assert!(Histogram::default().quantile(0.5).is_nan());
    }
}
