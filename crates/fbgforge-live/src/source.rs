//! Where live frames come from: a log file an interrogator is still writing (ENLIGHT,
//! I-MON, CSV), standard input (one frame of peaks per line), or a Hyperion peak
//! stream over TCP. Each source runs on its own thread and sends [`SourceEvent`]s into a
//! bounded queue; a frame that finds the queue full is dropped and counted, so a slow
//! consumer never makes the reader fall behind the instrument.

use super::hyperion::{self, StreamDecoder};
use crate::logs::{ReadOptions, RowReader};
use std::io::{BufRead, Read};
use std::net::{TcpStream, ToSocketAddrs};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// One frame of peaks as read.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The instrument's frame counter (Hyperion), if it has one.
    pub serial: Option<u64>,
    /// The frame's own time, s (instrument timestamp or log time), if it has one.
    pub time_s: Option<f64>,
    /// Whether `time_s` claims to be wall-clock time since 1970, read as it was made
    /// (an instrument's timestamp, a row appended to a followed log; not a row
    /// replayed from a log's past): its age may then be measured, if the clock agrees
    /// with this machine's (the watch decides).
    pub wall_clock: bool,
    /// Peak wavelengths, nm.
    pub peaks_nm: Vec<f64>,
    /// When the frame was read.
    pub received: Instant,
    /// Where it came from, for messages: `line 12`, `serial 4711`.
    pub origin: String,
}

impl Frame {
    /// A log row read by the row reader as a frame (a followed log's, or a finished
    /// log replayed by `replay`): the log's time, no serial.
    pub(crate) fn of_log_row(
        row: crate::logs::LogRow,
        wall_clock: bool,
        received: Instant,
        origin: String,
    ) -> Frame {
        Frame {
            serial: None,
            time_s: Some(row.time_s),
            wall_clock,
            peaks_nm: row.peaks_nm,
            received,
            origin,
        }
    }
}

/// What a source reports.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceEvent {
    /// A frame.
    Frame(Frame),
    /// A frame that could not be read: counted by `kind`, named by `message`.
    Bad {
        /// Warning kind (`malformed_frame`, `unreadable_line`, ...).
        kind: String,
        /// What was wrong, and where.
        message: String,
    },
    /// Frames the instrument numbered that never arrived (serial-number gap).
    Missed(u64),
    /// Connected (or reconnected) to the named source.
    Connected(String),
    /// The connection dropped; the source will try again.
    Disconnected(String),
    /// The source has ended: end of input, or a limit the request set.
    End(String),
    /// The source is lost: (re)connecting was given up, or the file being followed
    /// could no longer be read. Ends the watch, which reports it apart from an end.
    Lost(String),
}

/// Where to read from.
#[derive(Debug, Clone)]
pub enum SourceSpec {
    /// A growing log file.
    Tail {
        /// The file.
        path: PathBuf,
        /// Replay the rows already in the file (default: start at its end).
        from_start: bool,
        /// End after the file has not grown for this long, s (default: never).
        idle_exit_s: Option<f64>,
        /// Format and date order.
        read: ReadOptions,
    },
    /// Standard input, one frame of peaks (nm) per line.
    Stdin,
    /// A Hyperion peak stream.
    Hyperion {
        /// `host:port`.
        address: String,
        /// Give up after failing to (re)connect for this long, s.
        give_up_s: f64,
    },
}

/// How a source is read, besides where it is: a followed log's format, replay and
/// idle end, and how long to try (re)connecting to an instrument.
#[derive(Debug, Clone, Default)]
pub struct SourceOptions {
    /// Format and date order of a followed log (detected when `None`).
    pub read: ReadOptions,
    /// Replay the rows already in a followed log (default: start at its end).
    pub from_start: bool,
    /// End after a followed log has not grown for this long, s (default: never).
    pub idle_exit_s: Option<f64>,
    /// Give up after failing to (re)connect to an instrument for this long, s.
    pub give_up_s: f64,
}

impl SourceOptions {
    /// Check the times: each a finite number of seconds ≥ 0.
    pub fn validate(&self) -> anyhow::Result<()> {
        if !(self.give_up_s.is_finite() && self.give_up_s >= 0.0) {
            anyhow::bail!(
                "SourceOptions.give_up_s must be a number of seconds ≥ 0, got {}",
                self.give_up_s
            );
        }
        if let Some(s) = self.idle_exit_s.filter(|s| !(s.is_finite() && *s >= 0.0)) {
            anyhow::bail!("SourceOptions.idle_exit_s must be a number of seconds ≥ 0, got {s}");
        }
        Ok(())
    }
}

impl SourceSpec {
    /// Whether the source holds its frames until they are read (a file, standard
    /// input): then reading it need not drop any. An instrument does not wait.
    pub fn holds_frames(&self) -> bool {
        !matches!(self, SourceSpec::Hyperion { .. })
    }

    /// The file a source reads, if it is one.
    pub fn path(&self) -> Option<&Path> {
        match self {
            SourceSpec::Tail { path, .. } => Some(path),
            _ => None,
        }
    }

    /// Parse a source's name: `-` is standard input, `hyperion://HOST[:PORT]` or
    /// `tcp://HOST:PORT` a Hyperion stream (default port 51972), anything else a file;
    /// `opts` checked ([`SourceOptions::validate`]) and kept where the source uses them.
    pub fn parse(text: &str, opts: SourceOptions) -> anyhow::Result<SourceSpec> {
        opts.validate()?;
        if text == "-" {
            return Ok(SourceSpec::Stdin);
        }
        for scheme in ["hyperion://", "tcp://"] {
            if let Some(rest) = text.strip_prefix(scheme) {
                let rest = rest.trim_end_matches('/');
                let address = if has_port(rest) {
                    rest.to_string()
                } else {
                    format!("{rest}:{}", hyperion::PEAK_STREAM_PORT)
                };
                return Ok(SourceSpec::Hyperion {
                    address,
                    give_up_s: opts.give_up_s,
                });
            }
        }
        Ok(SourceSpec::Tail {
            path: PathBuf::from(text),
            from_start: opts.from_start,
            idle_exit_s: opts.idle_exit_s,
            read: opts.read,
        })
    }

    /// A short description for the view.
    pub fn describe(&self) -> String {
        match self {
            SourceSpec::Tail { path, .. } => format!("tail {}", path.display()),
            SourceSpec::Stdin => "standard input".to_string(),
            SourceSpec::Hyperion { address, .. } => format!("hyperion {address}"),
        }
    }
}

fn has_port(hostport: &str) -> bool {
    match hostport.rsplit_once(':') {
        // `::1` alone is an IPv6 address without a port; `[::1]:4000` has one.
        Some((host, port)) => {
            !host.ends_with(':')
                && port.parse::<u16>().is_ok()
                && (!host.starts_with('[') || host.ends_with(']'))
        }
        None => false,
    }
}

/// The sending half shared by every source: counts frames dropped on a full queue and
/// stops when asked.
#[derive(Clone)]
pub struct Outlet {
    tx: SyncSender<SourceEvent>,
    /// Frames dropped because the queue was full.
    pub overflow: Arc<AtomicU64>,
    /// Set by the consumer to stop the source.
    pub stop: Arc<AtomicBool>,
    /// Wait for room in the queue instead of dropping: a file or standard input holds
    /// its frames until they are read, so a replay loses none ([`Outlet::waiting`]).
    wait_for_room: bool,
}

impl Outlet {
    /// A new outlet over `tx` that drops frames finding the queue full (an instrument
    /// does not wait for its reader).
    pub fn new(tx: SyncSender<SourceEvent>, stop: Arc<AtomicBool>) -> Self {
        Outlet {
            tx,
            overflow: Arc::new(AtomicU64::new(0)),
            stop,
            wait_for_room: false,
        }
    }

    /// This outlet, waiting for room in the queue when `wait` (every frame is read).
    pub fn waiting(self, wait: bool) -> Self {
        Outlet {
            wait_for_room: wait,
            ..self
        }
    }

    fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Send a frame, dropping it (counted) when the queue is full, or waiting for room
    /// ([`Outlet::waiting`]). False when the consumer is gone.
    fn frame(&self, f: Frame) -> bool {
        if self.wait_for_room {
            return self.tx.send(SourceEvent::Frame(f)).is_ok();
        }
        match self.tx.try_send(SourceEvent::Frame(f)) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) => {
                self.overflow.fetch_add(1, Ordering::Relaxed);
                true
            }
            Err(TrySendError::Disconnected(_)) => false,
        }
    }

    /// Send any other event, waiting for room (they are rare). False when the consumer
    /// is gone.
    fn event(&self, e: SourceEvent) -> bool {
        self.tx.send(e).is_ok()
    }
}

/// Start reading `spec` on a new thread.
pub fn spawn(spec: SourceSpec, out: Outlet) -> std::thread::JoinHandle<()> {
    std::thread::Builder::new()
        .name("fbgforge-live-source".into())
        .spawn(move || match spec {
            SourceSpec::Tail {
                path,
                from_start,
                idle_exit_s,
                read,
            } => tail_file(&path, from_start, idle_exit_s, &read, &out),
            SourceSpec::Stdin => {
                let stdin = std::io::stdin();
                read_lines(stdin.lock(), "standard input", &out)
            }
            SourceSpec::Hyperion { address, give_up_s } => {
                hyperion_client(&address, give_up_s, &out)
            }
        })
        .expect("a thread can be started")
}

/// Parse one line of standard input: peak wavelengths in nm separated by spaces,
/// tabs, commas or semicolons. Blank lines and `#` comments give `Ok(None)`.
pub(crate) fn parse_peak_line(line: &str) -> Result<Option<Vec<f64>>, String> {
    let t = line.trim();
    if t.is_empty() || t.starts_with('#') {
        return Ok(None);
    }
    let mut peaks = Vec::new();
    for (i, f) in t
        .split(|c: char| c.is_whitespace() || c == ',' || c == ';')
        .filter(|f| !f.is_empty())
        .enumerate()
    {
        match f.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => peaks.push(v),
            _ => {
                return Err(format!(
                    "field {} `{f}` is not a peak wavelength in nm",
                    i + 1
                ))
            }
        }
    }
    Ok(Some(peaks))
}

/// Frames from text lines (standard input or any reader), until the end of input.
pub(crate) fn read_lines<R: BufRead>(mut r: R, name: &str, out: &Outlet) {
    out.event(SourceEvent::Connected(name.to_string()));
    let mut line = String::new();
    let mut n = 0u64;
    loop {
        if out.stopped() {
            return;
        }
        line.clear();
        match r.read_line(&mut line) {
            Ok(0) => break,
            Ok(_) => {}
            Err(e) => {
                out.event(SourceEvent::End(format!("cannot read {name}: {e}")));
                return;
            }
        }
        n += 1;
        let received = Instant::now();
        let ok = match parse_peak_line(&line) {
            Ok(None) => true,
            Ok(Some(peaks_nm)) => out.frame(Frame {
                serial: None,
                time_s: None,
                wall_clock: false,
                peaks_nm,
                received,
                origin: format!("{name} line {n}"),
            }),
            Err(m) => out.event(SourceEvent::Bad {
                kind: "unreadable_line".into(),
                message: format!("{name} line {n}: {m}"),
            }),
        };
        if !ok {
            return;
        }
    }
    out.event(SourceEvent::End(format!("end of {name}")));
}

/// Follow a log file as it grows (polling: interrogator software writes in bursts,
/// and a 1 ms poll keeps up with 1 kHz without a file-watching dependency).
fn tail_file(
    path: &Path,
    from_start: bool,
    idle_exit_s: Option<f64>,
    read: &ReadOptions,
    out: &Outlet,
) {
    const POLL: Duration = Duration::from_millis(1);
    let started = Instant::now();
    let mut last_growth = Instant::now();
    // Wait for the file and its table header.
    let Some((reader, offset, file)) =
        wait_for_table(path, from_start, idle_exit_s, read, out, started)
    else {
        return;
    };
    out.event(SourceEvent::Connected(format!(
        "{} ({})",
        path.display(),
        reader.describe()
    )));
    // Rows already in the file when the watch began are its past, not the stream.
    let live_from = file.metadata().map_or(u64::MAX, |m| m.len());
    let mut tail = Tail {
        path,
        read,
        from_start,
        out,
        reader,
        offset,
        file,
        pending: Vec::new(),
        pending_from: offset,
        live_from,
        line_no: None,
    };
    let mut chunk = vec![0u8; 1 << 16];
    loop {
        if out.stopped() {
            return;
        }
        if let Err(why) = tail.restart_if_truncated() {
            out.event(SourceEvent::Lost(why));
            return;
        }
        let n = match tail.read_more(&mut chunk) {
            Ok(n) => n,
            Err(e) => {
                out.event(SourceEvent::Lost(format!(
                    "cannot read {}: {e}",
                    path.display()
                )));
                return;
            }
        };
        if n == 0 {
            if idle_for(last_growth, idle_exit_s) {
                out.event(SourceEvent::End(format!(
                    "{} did not grow for {:.1} s",
                    path.display(),
                    idle_exit_s.unwrap_or(0.0)
                )));
                return;
            }
            std::thread::sleep(POLL);
            continue;
        }
        last_growth = Instant::now();
        if tail.pending.is_empty() {
            tail.pending_from = tail.offset;
        }
        tail.offset += n as u64;
        tail.pending.extend_from_slice(&chunk[..n]);
        if !tail.send_complete_lines() {
            return;
        }
    }
}

/// Whether `idle_exit_s` (if any) has passed since `since`.
fn idle_for(since: Instant, idle_exit_s: Option<f64>) -> bool {
    idle_exit_s.is_some_and(|s| since.elapsed().as_secs_f64() >= s)
}

/// Poll until `path` holds a table header: its reader, the offset to read from and the
/// open file. None when stopped or given up (the end already sent).
fn wait_for_table(
    path: &Path,
    from_start: bool,
    idle_exit_s: Option<f64>,
    read: &ReadOptions,
    out: &Outlet,
    started: Instant,
) -> Option<(RowReader, u64, std::fs::File)> {
    loop {
        if out.stopped() {
            return None;
        }
        // The file existed when the request was checked: gone now, it was deleted.
        if !path.exists() {
            out.event(SourceEvent::Lost(format!(
                "{} was deleted before its table header was written",
                path.display()
            )));
            return None;
        }
        if let Ok(bytes) = std::fs::read(path) {
            let complete = bytes.iter().rposition(|&c| c == b'\n').map_or(0, |p| p + 1);
            if let Ok((reader, body)) = RowReader::new(&bytes[..complete], path, read) {
                let offset = if from_start {
                    body as u64
                } else {
                    complete as u64
                };
                match std::fs::File::open(path) {
                    Ok(f) => return Some((reader, offset, f)),
                    Err(e) => {
                        out.event(SourceEvent::Lost(format!(
                            "cannot open {}: {e}",
                            path.display()
                        )));
                        return None;
                    }
                }
            }
        }
        if idle_for(started, idle_exit_s) {
            out.event(SourceEvent::End(format!(
                "{} holds no log table (ENLIGHT, I-MON or CSV header) after {:.1} s",
                path.display(),
                started.elapsed().as_secs_f64()
            )));
            return None;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A log file being followed: where reading has got to and the incomplete last line.
struct Tail<'a> {
    path: &'a Path,
    read: &'a ReadOptions,
    from_start: bool,
    out: &'a Outlet,
    reader: RowReader,
    /// Bytes of the file read so far.
    offset: u64,
    file: std::fs::File,
    /// Bytes read after the last complete line.
    pending: Vec<u8>,
    /// File offset of the first pending byte.
    pending_from: u64,
    /// File length when the watch began: rows before it are replayed, not live.
    live_from: u64,
    /// Body line number of the last line, when reading from the table's start.
    line_no: Option<u64>,
}

impl Tail<'_> {
    /// A file shorter than what was read was truncated or replaced: start again. An
    /// error naming the file when it is gone (deleted, or its folder).
    fn restart_if_truncated(&mut self) -> Result<(), String> {
        let (path, offset) = (self.path, self.offset);
        let meta = match std::fs::metadata(path) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(format!(
                    "{} was deleted while it was followed",
                    path.display()
                ))
            }
            // Anything else (a permission flicker): try again at the next poll.
            Err(_) => return Ok(()),
        };
        if meta.len() >= offset {
            return Ok(());
        }
        self.out.event(SourceEvent::Bad {
            kind: "file_truncated".into(),
            message: format!(
                "{} shrank from {offset} to {} bytes; reading it again from its table",
                path.display(),
                meta.len()
            ),
        });
        match std::fs::read(path)
            .ok()
            .and_then(|b| RowReader::new(&b, path, self.read).ok())
        {
            Some((r, body)) => {
                self.reader = r;
                self.offset = body as u64;
            }
            None => self.offset = 0,
        }
        self.pending.clear();
        self.pending_from = self.offset;
        self.line_no = None;
        if let Ok(f) = std::fs::File::open(path) {
            self.file = f;
        }
        Ok(())
    }

    /// Read what follows the offset into `chunk`; the number of bytes read.
    fn read_more(&mut self, chunk: &mut [u8]) -> std::io::Result<usize> {
        use std::io::Seek;
        self.file
            .seek(std::io::SeekFrom::Start(self.offset))
            .and_then(|_| self.file.read(chunk))
    }

    /// Send the complete lines pending as frames or bad-line events, keeping the
    /// incomplete rest. False when the consumer is gone.
    fn send_complete_lines(&mut self) -> bool {
        let Some(end) = self.pending.iter().rposition(|&c| c == b'\n') else {
            return true;
        };
        let (path, out) = (self.path, self.out);
        let received = Instant::now();
        let mut line_from = self.pending_from;
        // Line numbers are known only when reading from the table's start.
        for line in self.pending[..end].split(|&c| c == b'\n') {
            let live = line_from >= self.live_from;
            line_from += line.len() as u64 + 1;
            self.line_no =
                self.line_no
                    .map(|l| l + 1)
                    .or(if self.from_start { Some(1) } else { None });
            let origin = match self.line_no {
                Some(l) => format!("{} body line {l}", path.display()),
                None => format!("{}", path.display()),
            };
            let ok = match self.reader.parse(line) {
                Ok(None) => true,
                Ok(Some(row)) => {
                    let wall_clock = live && row.time_s > 1e8;
                    out.frame(Frame::of_log_row(row, wall_clock, received, origin))
                }
                Err((kind, message)) => out.event(SourceEvent::Bad {
                    kind: kind.to_string(),
                    message: format!("{origin}: {message}"),
                }),
            };
            if !ok {
                return false;
            }
        }
        self.pending.drain(..=end);
        self.pending_from += end as u64 + 1;
        true
    }
}

/// Read a Hyperion peak stream, reconnecting after every dropped connection until
/// reconnecting has failed for `give_up_s` seconds.
fn hyperion_client(address: &str, give_up_s: f64, out: &Outlet) {
    let mut last_serial: Option<u64> = None;
    let mut failing_since: Option<Instant> = None;
    let mut backoff = Duration::from_millis(50);
    let mut ever_connected = false;
    loop {
        if out.stopped() {
            return;
        }
        let connected = connect(address).map_err(|e| format!("cannot connect to {address}: {e}"));
        let stream = match connected {
            Ok(s) => s,
            Err(msg) => {
                let since = *failing_since.get_or_insert_with(Instant::now);
                if since.elapsed().as_secs_f64() >= give_up_s {
                    let what = if ever_connected {
                        "reconnecting"
                    } else {
                        "connecting"
                    };
                    out.event(SourceEvent::Lost(format!(
                        "{msg}; gave up {what} after {give_up_s} s"
                    )));
                    return;
                }
                std::thread::sleep(backoff);
                backoff = (backoff * 2).min(Duration::from_millis(500));
                continue;
            }
        };
        backoff = Duration::from_millis(50);
        ever_connected = true;
        if !out.event(SourceEvent::Connected(format!("hyperion {address}"))) {
            return;
        }
        let why = read_stream(stream, address, &mut last_serial, out);
        match why {
            None => return,
            Some(reason) => {
                if !out.event(SourceEvent::Disconnected(reason)) {
                    return;
                }
                failing_since = Some(Instant::now());
            }
        }
    }
}

fn connect(address: &str) -> std::io::Result<TcpStream> {
    let mut last = std::io::Error::new(
        std::io::ErrorKind::NotFound,
        "the address resolves to nothing",
    );
    for a in address.to_socket_addrs()? {
        match TcpStream::connect_timeout(&a, Duration::from_secs(2)) {
            Ok(s) => {
                s.set_nodelay(true).ok();
                // A read timeout lets the thread notice a stop request.
                s.set_read_timeout(Some(Duration::from_millis(200))).ok();
                return Ok(s);
            }
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// Count the frames between the last serial number and `serial` as missed (or a
/// restart when it went back), and remember `serial`.
fn note_serial(serial: u64, last_serial: &mut Option<u64>, out: &Outlet) {
    if let Some(prev) = *last_serial {
        if serial > prev + 1 {
            out.event(SourceEvent::Missed(serial - prev - 1));
        } else if serial <= prev {
            out.event(SourceEvent::Bad {
                kind: "serial_restart".into(),
                message: format!(
                    "serial number went back from {prev} to {serial} (instrument restarted?)"
                ),
            });
        }
    }
    *last_serial = Some(serial);
}

/// Read frames until the connection drops (Some(reason)), or the stream ends or the
/// consumer stops (None).
fn read_stream(
    mut s: TcpStream,
    address: &str,
    last_serial: &mut Option<u64>,
    out: &Outlet,
) -> Option<String> {
    let mut dec = StreamDecoder::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut silent_since = Instant::now();
    loop {
        if out.stopped() {
            return None;
        }
        let n = match s.read(&mut buf) {
            Ok(0) => return Some(format!("{address} closed the connection")),
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                // An instrument streams continuously: 10 s of silence is a dead link.
                if silent_since.elapsed() > Duration::from_secs(10) {
                    return Some(format!("{address} sent nothing for 10 s"));
                }
                continue;
            }
            Err(e) => return Some(format!("connection to {address} failed: {e}")),
        };
        silent_since = Instant::now();
        let received = Instant::now();
        dec.push(&buf[..n]);
        while let Some(r) = dec.next_frame() {
            let ok = match r {
                Ok(f) => {
                    note_serial(f.serial_number, last_serial, out);
                    out.frame(Frame {
                        serial: Some(f.serial_number),
                        time_s: Some(f.timestamp_s),
                        wall_clock: true,
                        origin: format!("serial {}", f.serial_number),
                        peaks_nm: f.peaks_nm,
                        received,
                    })
                }
                Err(hyperion::FrameError::EndOfStream(why)) => {
                    out.event(SourceEvent::End(format!("{address}: {why}")));
                    return None;
                }
                Err(e) => {
                    // A malformed frame whose serial is known is counted once, as bad:
                    // the serials go on from it, so it leaves no gap.
                    if let hyperion::FrameError::Malformed {
                        serial: Some(n), ..
                    } = e
                    {
                        note_serial(n, last_serial, out);
                    }
                    let lost = matches!(e, hyperion::FrameError::FramingLost(_));
                    let ok = out.event(SourceEvent::Bad {
                        kind: e.kind().to_string(),
                        message: e.to_string(),
                    });
                    if lost {
                        return Some(format!("{address}: {e}"));
                    }
                    ok
                }
            };
            if !ok {
                return None;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn source_names_parse_to_the_right_kind() {
        let opts = |from_start, idle_exit_s| SourceOptions {
            read: ReadOptions::default(),
            from_start,
            idle_exit_s,
            give_up_s: 5.0,
        };
        assert!(matches!(
            SourceSpec::parse("-", opts(false, None)).unwrap(),
            SourceSpec::Stdin
        ));
        let addr = |s: &str| match SourceSpec::parse(s, opts(false, None)).unwrap() {
            SourceSpec::Hyperion { address, give_up_s } => {
                assert_eq!(give_up_s, 5.0);
                address
            }
            other => panic!("{other:?}"),
        };
        assert_eq!(addr("hyperion://10.0.0.55"), "10.0.0.55:51972");
        assert_eq!(addr("tcp://127.0.0.1:4000"), "127.0.0.1:4000");
        assert_eq!(addr("hyperion://localhost/"), "localhost:51972");
        assert!(matches!(
            SourceSpec::parse("Peaks.20250320140346.txt", opts(true, Some(1.0))).unwrap(),
            SourceSpec::Tail {
                from_start: true,
                ..
            }
        ));
    }

    #[test]
    fn peak_lines_take_any_separator_and_name_a_bad_field() {
        assert_eq!(
            parse_peak_line("1520.8 1523.55,1526.7;\t1530.6\n").unwrap(),
            Some(vec![1520.8, 1523.55, 1526.7, 1530.6])
        );
        assert_eq!(parse_peak_line("  # comment").unwrap(), None);
        assert_eq!(parse_peak_line("").unwrap(), None);
        let e = parse_peak_line("1520.8 abc").unwrap_err();
        assert!(e.contains("field 2 `abc`"), "{e}");
        assert!(parse_peak_line("1520.8 NaN").is_err());
        assert!(parse_peak_line("-3").is_err());
    }
}
