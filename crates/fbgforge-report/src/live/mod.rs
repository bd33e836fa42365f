//! What a live run shows: a terminal view (a text heat map of the array's cells, or a
//! force table of the module's gratings, with the tare's state, rate, latency, drops
//! and bad frames), redrawn a few times a second ([`TerminalSink`]), or one JSON object
//! per line for programs ([`JsonlSink`]); and what it keeps: the raw peaks as a log
//! ([`record::RecordSink`]), ROS 2 messages in MCAP ([`publish::McapSink`]) and the
//! browser view ([`publish::WebSink`]): the `LiveSink`s of `fbgforge live`. The view
//! and the end-of-run summary keep to [`WIDTH`] columns, a terminal's default: the
//! grid's cells narrow with their number, and text lines wrap at spaces. Texts name the
//! request's fields in the front end's words ([`crate::verify::Words`]).

pub mod publish;
pub mod record;

use crate::verify::{own_words, Words};
use fbgforge_live::interpret::Reading;
use fbgforge_live::sink::{FrameReading, LiveInfo, LiveSink};
use fbgforge_live::stats::{LiveSummary, Stats};
use fbgforge_live::tare::{TareChange, TareState};
use serde::Serialize;
use std::io::{self, Write};
use std::time::{Duration, Instant};

/// One JSON object per line: `start`, then `frame`, `tare`, `bad` and `event` lines,
/// then a `summary`.
pub struct JsonlSink<W: Write> {
    out: W,
    words: Words,
}

impl<W: Write> JsonlSink<W> {
    /// Write to `out` (give it a buffer; it is flushed after every batch).
    pub fn new(out: W) -> Self {
        JsonlSink {
            out,
            words: own_words,
        }
    }

    /// The texts (events, bad frames, the summary) in `words`.
    pub fn with_words(self, words: Words) -> Self {
        JsonlSink { words, ..self }
    }

    fn line<T: Serialize>(&mut self, kind: &str, value: &T) -> io::Result<()> {
        let mut v = serde_json::to_value(value).map_err(io::Error::other)?;
        if let serde_json::Value::Object(m) = &mut v {
            m.insert("type".into(), kind.into());
        }
        serde_json::to_writer(&mut self.out, &v).map_err(io::Error::other)?;
        self.out.write_all(b"\n")
    }

    /// A line whose texts may name the request's fields: in the sink's words.
    fn text_line<T: Serialize>(&mut self, kind: &str, value: &T) -> io::Result<()> {
        let mut v = serde_json::to_value(value).map_err(io::Error::other)?;
        if let serde_json::Value::Object(m) = &mut v {
            m.insert("type".into(), kind.into());
        }
        let text = serde_json::to_string(&v).map_err(io::Error::other)?;
        self.out.write_all((self.words)(&text).as_bytes())?;
        self.out.write_all(b"\n")
    }
}

impl<W: Write> LiveSink for JsonlSink<W> {
    fn start(&mut self, info: &LiveInfo) -> io::Result<()> {
        self.line("start", info)?;
        self.out.flush()
    }
    fn reading(&mut self, r: &FrameReading) -> io::Result<()> {
        self.line("frame", r)
    }
    fn tare(&mut self, change: &TareChange) -> io::Result<()> {
        self.text_line("tare", change)?;
        self.out.flush()
    }
    fn bad(&mut self, kind: &str, message: &str) -> io::Result<()> {
        self.text_line(
            "bad",
            &serde_json::json!({ "kind": kind, "message": message }),
        )
    }
    fn event(&mut self, event: &str, message: &str) -> io::Result<()> {
        self.text_line(
            "event",
            &serde_json::json!({ "event": event, "message": message }),
        )
    }
    fn tick(&mut self, _: &Stats, _: Duration) -> io::Result<()> {
        self.out.flush()
    }
    fn finish(&mut self, summary: &LiveSummary) -> io::Result<()> {
        self.text_line("summary", summary)?;
        self.out.flush()
    }
}

/// The terminal view: redrawn at most `refresh` apart when `redraw` (a terminal),
/// printed once at the end otherwise.
pub struct TerminalSink<W: Write> {
    out: W,
    redraw: bool,
    refresh: Duration,
    last_draw: Option<Instant>,
    info: Option<LiveInfo>,
    last: Option<FrameReading>,
    tare: Option<TareChange>,
    keys: bool,
    events: Vec<String>,
    stats: Stats,
    elapsed: Duration,
    words: Words,
}

impl<W: Write> TerminalSink<W> {
    /// `redraw`: clear and redraw the screen (a terminal); else one view at the end.
    pub fn new(out: W, redraw: bool) -> Self {
        TerminalSink {
            out,
            redraw,
            refresh: Duration::from_millis(100),
            last_draw: None,
            info: None,
            last: None,
            tare: None,
            keys: false,
            events: Vec::new(),
            stats: Stats::default(),
            elapsed: Duration::ZERO,
            words: own_words,
        }
    }

    /// The texts (events, bad frames, the summary) in `words`.
    pub fn with_words(self, words: Words) -> Self {
        TerminalSink { words, ..self }
    }

    /// Say which keys steer the run (`t` tare again, `q` quit): the caller reads them.
    pub fn with_keys(self, keys: bool) -> Self {
        TerminalSink { keys, ..self }
    }

    fn note(&mut self, s: String) {
        let s = (self.words)(&s);
        self.events.push(s);
        if self.events.len() > 3 {
            self.events.remove(0);
        }
    }

    fn draw(&mut self) -> io::Result<()> {
        let Some(info) = &self.info else {
            return Ok(());
        };
        let tare = self.tare.as_ref().map(|t| TareChange {
            message: (self.words)(&t.message),
            ..t.clone()
        });
        let text = render(
            info,
            &View {
                last: self.last.as_ref(),
                tare: tare.as_ref(),
                keys: self.keys,
            },
            &self.stats,
            self.elapsed,
            &self.events,
        );
        if self.redraw {
            // Home, clear, draw.
            write!(self.out, "\x1b[H\x1b[2J{text}")?;
        } else {
            write!(self.out, "{text}")?;
        }
        self.out.flush()
    }
}

impl<W: Write> LiveSink for TerminalSink<W> {
    fn start(&mut self, info: &LiveInfo) -> io::Result<()> {
        self.info = Some(info.clone());
        if self.redraw {
            self.draw()?;
        }
        Ok(())
    }
    fn reading(&mut self, r: &FrameReading) -> io::Result<()> {
        self.last = Some(r.clone());
        Ok(())
    }
    fn tare(&mut self, change: &TareChange) -> io::Result<()> {
        if change.state != TareState::Resting {
            // The loads of the old tare are no longer shown.
            self.last = None;
        }
        if change.state != TareState::Waiting
            || self
                .tare
                .as_ref()
                .is_none_or(|t| t.state != TareState::Waiting)
        {
            self.note(format!(
                "tare {} ({}): {}",
                change.state.word(),
                change.origin,
                change.message
            ));
        }
        self.tare = Some(change.clone());
        Ok(())
    }
    fn bad(&mut self, kind: &str, message: &str) -> io::Result<()> {
        self.note(format!("bad frame ({kind}): {message}"));
        Ok(())
    }
    fn event(&mut self, event: &str, message: &str) -> io::Result<()> {
        self.note(format!("{event}: {message}"));
        Ok(())
    }
    fn tick(&mut self, stats: &Stats, elapsed: Duration) -> io::Result<()> {
        self.stats = stats.clone();
        self.elapsed = elapsed;
        if self.redraw && self.last_draw.is_none_or(|t| t.elapsed() >= self.refresh) {
            self.last_draw = Some(Instant::now());
            self.draw()?;
        }
        Ok(())
    }
    fn finish(&mut self, summary: &LiveSummary) -> io::Result<()> {
        self.draw()?;
        writeln!(self.out, "{}", summary_text_in(summary, self.words))?;
        self.out.flush()
    }
}

/// A horizontal bar of `width` cells for `frac` of full scale (eighth blocks).
fn bar(frac: f64, width: usize) -> String {
    const EIGHTHS: [char; 8] = [' ', '▏', '▎', '▍', '▌', '▋', '▊', '▉'];
    let f = if frac.is_finite() {
        frac.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let eighths = (f * (width * 8) as f64).round() as usize;
    let mut s: String = "█".repeat(eighths / 8);
    if !eighths.is_multiple_of(8) && s.chars().count() < width {
        s.push(EIGHTHS[eighths % 8]);
    }
    while s.chars().count() < width {
        s.push(' ');
    }
    s
}

fn us(v: f64) -> String {
    if !v.is_finite() {
        "–".into()
    } else if v < 10_000.0 {
        format!("{v:.0} µs")
    } else {
        format!("{:.1} ms", v / 1000.0)
    }
}

/// Columns the terminal view and the summary keep to: the one terminal width.
pub use crate::terminal::WIDTH;

/// `text` wrapped to `width` columns by the terminal's one rule
/// ([`crate::terminal::Wrap`]): continuation lines indented by four, and a word longer
/// than a line cut with `…` (the view is redrawn in place: every line must fit).
pub(crate) fn fit_width(text: &str, width: usize) -> String {
    crate::terminal::Wrap::TERMINAL
        .width(width)
        .indent(4)
        .cut_long_words()
        .text(text)
}

/// What the terminal view shows besides the counters: the last reading (of the tare
/// in force), the tare's last change, and whether keys steer the run.
#[derive(Debug, Clone, Copy, Default)]
pub struct View<'a> {
    /// The last reading, if it was read against the tare in force.
    pub last: Option<&'a FrameReading>,
    /// The tare's last change.
    pub tare: Option<&'a TareChange>,
    /// Whether `t` (tare again) and `q` (quit) are read from the keyboard.
    pub keys: bool,
}

/// The terminal view as text, within [`WIDTH`] columns.
pub fn render(
    info: &LiveInfo,
    view: &View<'_>,
    stats: &Stats,
    elapsed: Duration,
    events: &[String],
) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "fbgforge live · {} · {}", info.design, info.source);
    let _ = writeln!(s, "{}", info.description);
    let last = view.last;
    match (last.map(|r| &r.reading), info.grid) {
        (
            Some(Reading::Loads {
                loads_g,
                residual_pm,
                ..
            }),
            Some(grid),
        ) => write_load_grid(&mut s, info, loads_g, *residual_pm, grid),
        (
            Some(Reading::Forces {
                forces_n,
                delta_t_k,
            }),
            _,
        ) => write_forces(&mut s, info, forces_n, *delta_t_k),
        _ => write_no_reading(&mut s, info, view.tare, stats),
    }
    // The frame's flags: the array's trust flags (the same words as reconstruct's
    // CSV) and below_tare.
    if let Some(r) = last {
        let words = r.flag_words();
        if !words.is_empty() {
            let _ = writeln!(
                s,
                "  NOT TRUSTED: {} (see docs/live.md, Flags)",
                words.join(", ")
            );
        }
    }
    write_tare_line(&mut s, info, view, stats);
    write_status(&mut s, last, stats, elapsed, events);
    fit_width(&s, WIDTH)
}

/// No reading to show: why (waiting for rest, refused, or no frame yet).
fn write_no_reading(s: &mut String, info: &LiveInfo, tare: Option<&TareChange>, stats: &Stats) {
    use std::fmt::Write as _;
    match tare.map(|t| t.state) {
        Some(TareState::Refused) => {
            let t = tare.expect("matched");
            let _ = writeln!(
                s,
                "  TARE REFUSED: the sensor never came to rest ({}): no loads are shown",
                t.moving.join(", ")
            );
            let _ = writeln!(s, "  {}", t.message);
        }
        Some(TareState::Waiting) => {
            let t = tare.expect("matched");
            let _ = writeln!(s, "  {}", t.message);
        }
        _ => {
            let _ = writeln!(
                s,
                "  waiting for frames ({} frames taken for the tare, which needs {} frames and {} s at rest; keep the sensor unloaded)",
                stats.tare_frames, info.tare_frames, info.tare_s
            );
        }
    }
}

/// One line on the tare in force and the keys.
fn write_tare_line(s: &mut String, info: &LiveInfo, view: &View<'_>, stats: &Stats) {
    use std::fmt::Write as _;
    let state = match (view.tare, info.tare_frames) {
        (_, 0) => "none (shifts from the nominal wavelengths)".to_string(),
        (Some(t), _) if t.state == TareState::Resting => match t.window_frames {
            Some((a, b)) => format!("at rest on frames {a}–{b} ({})", t.origin),
            None => format!("at rest ({})", t.origin),
        },
        (Some(t), _) => t.state.word().to_string(),
        (None, _) => "waiting".to_string(),
    };
    let keys = if view.keys {
        "   keys: t tare again, q quit"
    } else {
        ""
    };
    let _ = writeln!(
        s,
        "tare: {state}; {} re-tares asked, {} below the tare{keys}",
        stats.tare_requests, stats.retares_below_tare
    );
}

/// The array's loads as a grid of cells (name, load in g, bar of the load over ulimit).
fn write_load_grid(
    s: &mut String,
    info: &LiveInfo,
    loads_g: &[f64],
    residual_pm: f64,
    (nx, ny, ulimit): (usize, usize, f64),
) {
    use std::fmt::Write as _;
    // Cells 9 columns wide, narrower when many must fit in WIDTH (6 + nx × (W + 1));
    // a grid too wide even then is listed instead.
    let w = ((WIDTH - 6) / nx.max(1)).saturating_sub(1).min(9);
    if w < 6 {
        write_load_list(s, info, loads_g, residual_pm, ulimit);
        return;
    }
    let name_w = info
        .outputs
        .iter()
        .map(|n| n.chars().count())
        .max()
        .unwrap_or(1)
        .max(2);
    let line = |l: char, m: char, r: char| {
        let mut t = format!("     {l}");
        for i in 0..nx {
            t.push_str(&"─".repeat(w));
            t.push(if i + 1 == nx { r } else { m });
        }
        t
    };
    let _ = writeln!(s, "{}", line('┌', '┬', '┐'));
    for row in (0..ny).rev() {
        let mut a = format!("{:>5}│", if row + 1 == ny { "+y" } else { "" });
        let mut b = "     │".to_string();
        for col in 0..nx {
            let k = row * nx + col;
            let name = info.outputs.get(k).map_or("?", |n| n.as_str());
            let v = loads_g.get(k).copied().unwrap_or(f64::NAN);
            let frac = v / ulimit;
            let value_w = (w - 2).saturating_sub(name_w).max(1);
            let _ = write!(a, " {name:<name_w$}{v:>value_w$.0} │");
            let _ = write!(b, " {} │", bar(frac, w - 2));
        }
        let _ = writeln!(s, "{a}");
        let _ = writeln!(s, "{b}");
        let _ = writeln!(
            s,
            "{}",
            if row == 0 {
                line('└', '┴', '┘')
            } else {
                line('├', '┼', '┤')
            }
        );
    }
    let total: f64 = loads_g.iter().sum();
    let _ = writeln!(
        s,
        "      −x → +x   loads in g; full bar {ulimit} g; total {total:.0} g; residual {residual_pm:.1} pm"
    );
}

/// A grid too wide for the terminal: the loaded cells, largest first.
fn write_load_list(
    s: &mut String,
    info: &LiveInfo,
    loads_g: &[f64],
    residual_pm: f64,
    ulimit: f64,
) {
    use std::fmt::Write as _;
    let mut idx: Vec<usize> = (0..loads_g.len()).collect();
    idx.sort_by(|&a, &b| loads_g[b].total_cmp(&loads_g[a]));
    let _ = writeln!(s, "  {:<8} {:>9}", "cell", "load g");
    for &k in idx.iter().filter(|&&k| loads_g[k] > 0.0).take(12) {
        let name = info.outputs.get(k).map_or("?", |n| n.as_str());
        let _ = writeln!(
            s,
            "  {name:<8} {:>9.0}  {}",
            loads_g[k],
            bar(loads_g[k] / ulimit, 40)
        );
    }
    let total: f64 = loads_g.iter().sum();
    let _ = writeln!(
        s,
        "  largest of {} cells; full bar {ulimit} g; total {total:.0} g; residual {residual_pm:.1} pm",
        loads_g.len()
    );
}

/// The module's forces, one line per grating, and the temperature compensation.
fn write_forces(s: &mut String, info: &LiveInfo, forces_n: &[Option<f64>], delta_t_k: Option<f64>) {
    use std::fmt::Write as _;
    let scale = forces_n
        .iter()
        .flatten()
        .fold(1.0f64, |m, f| m.max(f.abs()));
    let name_w = info
        .outputs
        .iter()
        .map(|n| n.chars().count())
        .fold(14, usize::max);
    let _ = writeln!(
        s,
        "  {:<name_w$} {:>10} {:>10}",
        "grating", "K pm/N", "force N"
    );
    // The bar takes what the name and the two numbers leave of the line.
    let bar_w = WIDTH.saturating_sub(name_w + 26).min(30);
    for (i, name) in info.outputs.iter().enumerate() {
        let k = info
            .sensitivities_pm_per_n
            .get(i)
            .copied()
            .unwrap_or(f64::NAN);
        match forces_n.get(i).copied().flatten() {
            Some(f) => {
                let _ = writeln!(
                    s,
                    "  {name:<name_w$} {k:>+10.3} {f:>+10.3}  {}",
                    bar(f.abs() / scale, bar_w)
                );
            }
            None => {
                let _ = writeln!(s, "  {name:<name_w$} {k:>+10.3} {:>10}  (no peak)", "–");
            }
        }
    }
    match delta_t_k {
        Some(t) => {
            let _ = writeln!(
                s,
                "  temperature change since the tare: {t:+.2} K (compensated)"
            );
        }
        None => {
            let _ = writeln!(s, "  no temperature reference: forces are not compensated");
        }
    }
}

/// The status lines: last frame, rate, latency, counts, then the recent events.
fn write_status(
    s: &mut String,
    last: Option<&FrameReading>,
    stats: &Stats,
    elapsed: Duration,
    events: &[String],
) {
    use std::fmt::Write as _;
    let secs = elapsed.as_secs_f64();
    let rate = if secs > 0.0 {
        stats.frames_in as f64 / secs
    } else {
        0.0
    };
    let lat = stats.latency.summary();
    let frame = last.map_or("–".into(), |r| match (r.serial, r.time_s) {
        (Some(n), _) => format!("serial {n}"),
        (None, Some(t)) => format!("t {t:.3} s"),
        _ => "–".into(),
    });
    let _ = writeln!(
        s,
        "frame {frame}   {:.0} frames/s   latency p50 {} p99 {} max {}",
        rate,
        us(lat.p50_us),
        us(lat.p99_us),
        us(lat.max_us)
    );
    let d = &stats.dropped;
    let _ = writeln!(
        s,
        "frames {} in, {} read   dropped {} (gaps {}, queue {})   bad {}   reconnects {}",
        stats.frames_in,
        stats.frames_out,
        d.serial_gaps + d.queue_overflow,
        d.serial_gaps,
        d.queue_overflow,
        stats.bad_frames,
        stats.reconnects
    );
    for e in events {
        let _ = writeln!(s, "  {e}");
    }
}

/// The end-of-run summary as text.
pub fn summary_text(x: &LiveSummary) -> String {
    summary_text_in(x, own_words)
}

/// [`summary_text`] in a front end's `words` (before the lines are fitted to
/// [`WIDTH`]).
pub fn summary_text_in(x: &LiveSummary, words: Words) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "ended: {}", x.ended);
    let _ = writeln!(
        s,
        "{} frames in {:.2} s ({}{:.0} frames/s): {} read, {} tare, {} bad, {} ambiguous; dropped {} (serial gaps {}, queue overflow {}); {} reconnects",
        x.frames_in,
        x.elapsed_s,
        // Frames read much faster than their clock ran (a log replayed): say over how
        // long they were written, which the rate is of.
        match x.clock_span_s {
            Some(c) if x.elapsed_s < 0.5 * c => format!("{c:.2} s by their own clock, "),
            _ => String::new(),
        },
        x.rate_hz,
        x.frames_out,
        x.tare_frames,
        x.bad_frames,
        x.ambiguous_frames,
        x.dropped.total,
        x.dropped.serial_gaps,
        x.dropped.queue_overflow,
        x.reconnects
    );
    let _ = write!(
        s,
        "latency (receive → reading): p50 {} p99 {} max {}",
        us(x.latency.p50_us),
        us(x.latency.p99_us),
        us(x.latency.max_us)
    );
    if x.age.count > 0 {
        let _ = write!(
            s,
            "\nage (instrument timestamp → reading): p50 {} p99 {} max {}",
            us(x.age.p50_us),
            us(x.age.p99_us),
            us(x.age.max_us)
        );
    }
    for (kind, w) in &x.bad.counts {
        let _ = write!(s, "\n  {kind}: {} (first: {})", w.count, w.first);
    }
    fit_width(&words(&s), WIDTH)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reading's fields the view tests do not look at.
    fn reading_base() -> FrameReading {
        FrameReading {
            frame: 1,
            serial: None,
            time_s: None,
            received_s: 0.0,
            reading: Reading::Forces {
                forces_n: Vec::new(),
                delta_t_k: None,
            },
            below_tare: false,
            peaks_nm: Vec::new(),
            shifts_pm: Vec::new(),
            latency_us: 0.0,
            age_us: None,
        }
    }

    #[test]
    fn bars_fill_in_eighths_and_keep_their_width() {
        assert_eq!(bar(0.0, 4), "    ");
        assert_eq!(bar(1.0, 4), "████");
        assert_eq!(bar(0.5, 4), "██  ");
        assert_eq!(bar(1.0 / 32.0, 4), "▏   ");
        assert_eq!(bar(f64::NAN, 3), "   ");
        assert_eq!(bar(7.0, 3).chars().count(), 3);
    }

    fn busy_stats() -> Stats {
        let mut st = Stats {
            frames_in: 123_456_789,
            frames_out: 123_456_000,
            tare_frames: 200,
            bad_frames: 98_765,
            reconnects: 12_345,
            ..Stats::default()
        };
        st.dropped.serial_gaps = 4_567_890;
        st.dropped.queue_overflow = 1_234_567;
        for v in [12.0, 3_456.0, 98_765.0] {
            st.latency.add(v);
        }
        st
    }

    fn array_info(nx: usize, ny: usize) -> LiveInfo {
        LiveInfo {
            design: "tactile-array-with-a-rather-long-name-60x80-placed-optimised".into(),
            kind: "array",
            source: "hyperion://192.168.100.200:51972 (reconnecting after a drop)".into(),
            description: "array 8×2 cells, 6 gratings, method wsupport (resolution 0.5 pm), with a description long enough to wrap".into(),
            outputs: (0..nx * ny).map(crate::profile::cell_label).collect(),
            gratings: vec!["fbg1".into()],
            grid: Some((nx, ny, 250.0)),
            method: Some("wsupport".into()),
            sensitivities_pm_per_n: Vec::new(),
            core: None,
            cell_centers_mm: Vec::new(),
            tare_frames: 200,
            tare_s: 1.0,
            tare_wait_s: 30.0,
            resolution_pm: 0.5,
        }
    }

    fn assert_fits(text: &str) {
        for line in text.lines() {
            assert!(
                line.chars().count() <= WIDTH,
                "{} columns: {line}",
                line.chars().count()
            );
        }
    }

    #[test]
    fn the_array_view_fits_80_columns_at_any_grid_width() {
        let events = vec![
            "bad frame (wrong_peak_count): frame 123456 has 7 peaks in the window of fbg3 where one was expected, the frame was skipped".to_string(),
        ];
        // 4 cells across: the full 9-column cells; 8: narrower; 16: a list.
        for nx in [4, 8, 16] {
            let info = array_info(nx, 2);
            let reading = FrameReading {
                serial: Some(u64::MAX),
                time_s: None,
                reading: Reading::Loads {
                    loads_g: (0..2 * nx).map(|k| 25.0 * k as f64).collect(),
                    converged: true,
                    residual_pm: 1234.5,
                    certified: false,
                    flags: crate::array::trust::FrameFlags {
                        ceiling: true,
                        inconsistent: true,
                        ..Default::default()
                    },
                },
                latency_us: 12.0,
                age_us: None,
                ..reading_base()
            };
            let text = render(
                &info,
                &View {
                    last: Some(&reading),
                    ..View::default()
                },
                &busy_stats(),
                Duration::from_secs(3),
                &events,
            );
            assert_fits(&text);
            // The status line under the loads is one line with its residual, four
            // digits and all (issue 40: it wrapped at two).
            assert!(
                text.lines()
                    .any(|l| l.contains("total") && l.ends_with("residual 1234.5 pm")),
                "{text}"
            );
            assert!(
                text.contains("NOT TRUSTED: inconsistent, ceiling"),
                "the frame's flags are shown:\n{text}"
            );
            // Every cell's label is still shown (in the grid or, for 16, the list of
            // loaded cells, which holds the 12 largest).
            let shown = info.outputs.iter().filter(|n| {
                text.lines().any(|l| {
                    l.split(|c: char| !c.is_alphanumeric())
                        .any(|w| w == n.as_str())
                })
            });
            assert_eq!(shown.count(), if nx == 16 { 12 } else { 2 * nx }, "{text}");
        }
        // The grid lines stay whole: no box line was wrapped.
        let reading = FrameReading {
            serial: Some(1),
            time_s: None,
            reading: Reading::Loads {
                loads_g: vec![100.0; 16],
                converged: true,
                residual_pm: 0.1,
                certified: true,
                flags: Default::default(),
            },
            latency_us: 1.0,
            age_us: None,
            ..reading_base()
        };
        let text = render(
            &array_info(8, 2),
            &View {
                last: Some(&reading),
                ..View::default()
            },
            &Stats::default(),
            Duration::from_secs(1),
            &[],
        );
        let top = text.lines().find(|l| l.contains('┌')).unwrap();
        assert!(top.ends_with('┐') && top.chars().count() <= WIDTH, "{top}");
    }

    #[test]
    fn the_module_view_and_the_summary_fit_80_columns() {
        let info = LiveInfo {
            design: "clip-on-34mm".into(),
            kind: "module",
            source: "stdin".into(),
            description: "module core psc2, Case I (insert_light_green), K from the model policy (FE with the design's contact), reference lambda_temp".into(),
            outputs: vec!["lambda_21_long_grating_name".into(), "lambda_22".into()],
            gratings: vec![],
            grid: None,
            method: None,
            sensitivities_pm_per_n: vec![-170.684, -169.647],
            core: Some("psc2".into()),
            cell_centers_mm: Vec::new(),
            tare_frames: 50,
            tare_s: 1.0,
            tare_wait_s: 30.0,
            resolution_pm: 0.5,
        };
        let reading = FrameReading {
            serial: None,
            time_s: Some(123456.789),
            reading: Reading::Forces {
                forces_n: vec![Some(-12345.678), None],
                delta_t_k: Some(-12.5),
            },
            latency_us: 5.0,
            age_us: None,
            ..reading_base()
        };
        let text = render(
            &info,
            &View {
                last: Some(&reading),
                ..View::default()
            },
            &busy_stats(),
            Duration::from_secs(2),
            &[],
        );
        assert_fits(&text);
        assert!(text.contains("lambda_21_long_grating_name") && text.contains("(no peak)"));
        let st = busy_stats();
        let mut bad = crate::logs::LogWarnings::default();
        bad.add("wrong_peak_count", || "frame 123456 has 7 peaks in the window of fbg3 where one was expected; the frame was skipped and counted".into());
        let summary = LiveSummary {
            design: info.design.clone(),
            source: info.source.clone(),
            ended: "gave up reconnecting to hyperion://192.168.100.200:51972 after 10 attempts over 30 s".into(),
            elapsed_s: 123456.0,
            clock_span_s: Some(123455.9),
            frames_in: st.frames_in,
            frames_out: st.frames_out,
            rate_hz: 1000.0,
            tare: TareState::Resting,
            tare_frames: 200,
            refused_frames: 0,
            tare_requests: 1,
            retares_below_tare: 0,
            bad_frames: st.bad_frames,
            bad,
            ambiguous_frames: 77,
            dropped: st.dropped,
            reconnects: st.reconnects,
            not_converged: 0,
            flagged: 12,
            below_tare: 0,
            source_lost: true,
            output_closed: false,
            latency: st.latency.summary(),
            age: st.latency.summary(),
        };
        let text = summary_text(&summary);
        assert_fits(&text);
        // Wrapping moved words, it did not drop them.
        for word in ["reconnects", "attempts", "counted", "max"] {
            assert!(text.contains(word), "{word}: {text}");
        }
    }

    #[test]
    fn long_lines_wrap_at_spaces_and_short_ones_stay() {
        assert_eq!(fit_width("aaaa bbbb cccc", 10), "aaaa bbbb\n    cccc");
        assert_eq!(fit_width("short\nline", 80), "short\nline");
        let cut = fit_width(&"x".repeat(30), 10);
        assert_eq!(cut.chars().count(), 6, "{cut}");
        assert!(cut.ends_with('…'));
    }

    #[test]
    fn the_view_says_why_it_shows_no_load_and_which_keys_steer_it() {
        let info = LiveInfo {
            design: "tactile-array-60x80".into(),
            kind: "array",
            source: "hyperion 127.0.0.1:1".into(),
            description: "array".into(),
            outputs: "ABCDEFGH".chars().map(String::from).collect(),
            gratings: (1..=6).map(|k| format!("fbg{k}")).collect(),
            grid: Some((4, 2, 250.0)),
            method: Some("wsupport".into()),
            sensitivities_pm_per_n: Vec::new(),
            core: None,
            cell_centers_mm: Vec::new(),
            tare_frames: 50,
            tare_s: 1.0,
            tare_wait_s: 30.0,
            resolution_pm: 0.5,
        };
        let change = |state: TareState, message: &str| TareChange {
            state,
            origin: "start".into(),
            frame: 1200,
            moving: vec!["fbg2".into(), "fbg4".into()],
            unseen: Vec::new(),
            baseline_nm: Vec::new(),
            window_frames: None,
            window_s: None,
            waited_s: 0.2,
            message: message.into(),
        };
        let stats = Stats::default();
        let waiting = change(TareState::Waiting, "waiting for the sensor to be at rest before taring (0.2 of 30.0 s): moving: fbg2 (spread 5.49 pm, trend -33.54 pm); keep it unloaded");
        let view = View {
            last: None,
            tare: Some(&waiting),
            keys: true,
        };
        let text = render(&info, &view, &stats, Duration::from_secs(1), &[]);
        // Long lines wrap at 80 columns: read the words across the wraps.
        let words = text.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(
            words.contains("waiting for the sensor to be at rest"),
            "{text}"
        );
        assert!(words.contains("moving: fbg2 (spread 5.49 pm"), "{text}");
        assert!(
            text.contains("tare: waiting;") && text.contains("keys: t tare again, q quit"),
            "{text}"
        );
        let refused = change(TareState::Refused, "refused to tare");
        let view = View {
            last: None,
            tare: Some(&refused),
            keys: false,
        };
        let text = render(&info, &view, &stats, Duration::from_secs(1), &[]);
        let words = text.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(
            words.contains("TARE REFUSED") && words.contains("(fbg2, fbg4): no loads are shown"),
            "{text}"
        );
        assert!(!text.contains("keys:"), "{text}");
        let mut rested = change(TareState::Resting, "tared");
        rested.origin = "key".into();
        rested.window_frames = Some((1100, 2100));
        let view = View {
            last: None,
            tare: Some(&rested),
            keys: true,
        };
        let text = render(&info, &view, &stats, Duration::from_secs(1), &[]);
        assert!(
            text.contains("tare: at rest on frames 1100–2100 (key)"),
            "{text}"
        );
    }
}
