//! `--record FILE`: the raw peaks of a live run as a log the rest of fbgforge reads.
//!
//! `FILE` is a plain CSV wavelength log (`logs::LogFormat::Csv`): a `time_s` column,
//! then one column per tracked grating holding the wavelength `live` found in that
//! grating's window, in nm, written with every digit of the number read (Rust's
//! shortest round-trip form), empty where the window held no peak. Every frame with
//! peaks is a row, in order (row n is frame n: read, taken into the tare, refused or
//! bad). `verify`, `calibrate-array` and `live --from FILE --from-start` read it back
//! exactly; the lines starting with `#` are comments to them and carry what a log has
//! no column for:
//!
//! * `# serial N`: the instrument's frame counter of the next row; each row after it
//!   counts up by one, and a new line comes only where a frame is missing;
//! * `# tare STATE (ORIGIN) at frame N: …`: every change of the tare: waiting (with the
//!   moving gratings), tared at rest (with the window's frames and the baseline of
//!   each grating, nm), refused, and each re-tare asked (`key`, `control`, `python`)
//!   or made because the sensor settled below a tare that held a load (`below_tare`).
//!
//! An array run also writes `<FILE stem>.shifts.csv` beside it: `time_s` and each
//! grating's shift from the tare in force, pm, for every frame that was read, the
//! exact input of `fbgforge reconstruct --shifts` (which, with the method `live` used and
//! `--keep-all-gratings`, gives the loads `live`
//! showed); `# frame N` marks where its rows skip frames of the log, and the tare marks
//! are repeated.
//!
//! Both files are written as `<name>.partial` and renamed when the run ends, so a
//! finished name is never a half-written recording.

use fbgforge_live::sink::{FrameReading, LiveInfo, LiveSink, PeakFrame};
use fbgforge_live::stats::LiveSummary;
use fbgforge_live::tare::{TareChange, TareState};
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// One file being written as `<name>.partial`.
struct Partial {
    path: PathBuf,
    partial: PathBuf,
    out: BufWriter<File>,
}

impl Partial {
    fn create(path: &Path) -> io::Result<Self> {
        let mut name = path.file_name().unwrap_or_default().to_owned();
        name.push(".partial");
        let partial = path.with_file_name(name);
        create_parent(path)?;
        let file = File::create(&partial).map_err(|e| named(&partial, e))?;
        Ok(Partial {
            path: path.to_path_buf(),
            partial,
            out: BufWriter::new(file),
        })
    }

    fn finish(mut self) -> io::Result<()> {
        self.out.flush().map_err(|e| named(&self.partial, e))?;
        self.out
            .get_ref()
            .sync_all()
            .map_err(|e| named(&self.partial, e))?;
        std::fs::rename(&self.partial, &self.path).map_err(|e| named(&self.path, e))
    }
}

/// Make the folder `path` goes into, as every other output does (a lab names
/// `--record runs/today/run.csv` before the folder exists).
pub(crate) fn create_parent(path: &Path) -> io::Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            std::fs::create_dir_all(dir).map_err(|e| named(dir, e))
        }
        _ => Ok(()),
    }
}

fn named(path: &Path, e: io::Error) -> io::Error {
    io::Error::new(e.kind(), format!("{}: {e}", path.display()))
}

/// `<stem>.shifts.csv` beside `path`.
pub fn shifts_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or_else(|| "record".into(), |s| s.to_string_lossy().into_owned());
    path.with_file_name(format!("{stem}.shifts.csv"))
}

/// The record of a live run (see the [module](self)).
pub struct RecordSink {
    /// The peaks log, until the run ends.
    log: Option<Partial>,
    shifts: Option<Partial>,
    path: PathBuf,
    gratings: usize,
    last_serial: Option<u64>,
    last_shift_frame: u64,
    own_time: Option<bool>,
    line: String,
    started: bool,
}

/// A record dropped before its run started (a bad request) leaves no file behind; one
/// dropped mid-run without its summary (a panic) leaves its `.partial` files.
impl Drop for RecordSink {
    fn drop(&mut self) {
        if !self.started {
            if let Some(p) = self.log.take() {
                let _ = std::fs::remove_file(&p.partial);
            }
        }
    }
}

/// A number as read, every digit kept; empty when not finite.
fn push_number(line: &mut String, v: f64) {
    use std::fmt::Write as _;
    if v.is_finite() {
        let _ = write!(line, "{v}");
    }
}

impl RecordSink {
    /// Open `path` (as `path.partial`) for the record; an error naming the file when
    /// it cannot be written. The shifts file is opened at the start, for an array.
    pub fn create(path: &Path) -> io::Result<Self> {
        Ok(RecordSink {
            log: Some(Partial::create(path)?),
            shifts: None,
            path: path.to_path_buf(),
            gratings: 0,
            last_serial: None,
            last_shift_frame: 0,
            own_time: None,
            line: String::new(),
            started: false,
        })
    }

    /// The peaks log's writer; an error once the record is finished.
    fn out(&mut self) -> io::Result<&mut BufWriter<File>> {
        match self.log.as_mut() {
            Some(p) => Ok(&mut p.out),
            None => Err(io::Error::other("the record is already finished")),
        }
    }

    fn comment(&mut self, text: &str) -> io::Result<()> {
        let out = self.out()?;
        for l in text.lines() {
            writeln!(out, "# {l}")?;
        }
        if let Some(s) = self.shifts.as_mut() {
            for l in text.lines() {
                writeln!(s.out, "# {l}")?;
            }
        }
        Ok(())
    }

    fn header(&mut self, info: &LiveInfo) -> io::Result<()> {
        let names = info.gratings.join(",");
        let tare = if info.tare_frames == 0 {
            "none: shifts from the nominal wavelengths".to_string()
        } else {
            format!(
                "a window of at least {} frames and {} s at rest within the resolution {} pm",
                info.tare_frames, info.tare_s, info.resolution_pm
            )
        };
        let w = self.out()?;
        writeln!(
            w,
            "# fbgforge live recording (fbgforge {})",
            env!("CARGO_PKG_VERSION")
        )?;
        writeln!(
            w,
            "# design {} ({}); source {}",
            info.design, info.kind, info.source
        )?;
        writeln!(w, "# {}", info.description)?;
        writeln!(w, "# columns: time_s, then each grating's peak wavelength in nm as live found it in the grating's window (empty: no peak)")?;
        writeln!(w, "# time_s: the frame's own time, s, where the source gives one; else s since the first frame")?;
        writeln!(w, "# tare: {tare}")?;
        writeln!(w, "# row n is frame n; `# serial N` gives the instrument's frame counter of the next row, counting up by one after it")?;
        writeln!(w, "time_s,{names}")?;
        if info.kind == "array" {
            let mut s = Partial::create(&shifts_path(&self.path))?;
            writeln!(s.out, "# fbgforge live recording: the shifts of the frames read (fbgforge reconstruct --shifts)")?;
            writeln!(
                s.out,
                "# design {}; the peaks are in {}",
                info.design,
                self.path.display()
            )?;
            writeln!(s.out, "# columns: time_s, then each grating's shift from the tare in force, pm; `# frame N`: the next row is frame N of the peaks")?;
            writeln!(s.out, "time_s,{names}")?;
            self.shifts = Some(s);
        }
        self.gratings = info.gratings.len();
        Ok(())
    }

    fn time_of(&mut self, time_s: Option<f64>, received_s: f64) -> io::Result<f64> {
        let own = time_s.is_some();
        if self.own_time.is_some_and(|o| o != own) {
            self.comment(if own {
                "time_s from here: the frame's own time"
            } else {
                "time_s from here: s since the first frame"
            })?;
        }
        self.own_time = Some(own);
        Ok(time_s.unwrap_or(received_s))
    }
}

impl LiveSink for RecordSink {
    fn start(&mut self, info: &LiveInfo) -> io::Result<()> {
        self.started = true;
        self.header(info).map_err(|e| named(&self.path, e))
    }

    fn peaks(&mut self, f: &PeakFrame<'_>) -> io::Result<()> {
        if let Some(n) = f.serial {
            if self.last_serial.is_none_or(|l| l.checked_add(1) != Some(n)) {
                writeln!(self.out()?, "# serial {n}")?;
            }
            self.last_serial = Some(n);
        }
        let t = self.time_of(f.time_s, f.received_s)?;
        self.line.clear();
        push_number(&mut self.line, t);
        for &p in f.peaks_nm {
            self.line.push(',');
            push_number(&mut self.line, p);
        }
        self.line.push('\n');
        let line = std::mem::take(&mut self.line);
        self.out()?.write_all(line.as_bytes())?;
        self.line = line;
        if let (Some(s), Some(shifts)) = (self.shifts.as_mut(), f.shifts_pm) {
            if f.frame != self.last_shift_frame + 1 {
                writeln!(s.out, "# frame {}", f.frame)?;
            }
            self.last_shift_frame = f.frame;
            self.line.clear();
            push_number(&mut self.line, t);
            for &v in shifts {
                self.line.push(',');
                push_number(&mut self.line, v);
            }
            self.line.push('\n');
            s.out.write_all(self.line.as_bytes())?;
        }
        Ok(())
    }

    fn reading(&mut self, _r: &FrameReading) -> io::Result<()> {
        Ok(())
    }

    fn tare(&mut self, c: &TareChange) -> io::Result<()> {
        let mut text = format!(
            "tare {} ({}) at frame {}: {}",
            c.state.word(),
            c.origin,
            c.frame,
            c.message
        );
        if c.state == TareState::Resting && !c.baseline_nm.is_empty() {
            text.push_str("\nbaseline nm:");
            for v in &c.baseline_nm {
                text.push(' ');
                push_number(&mut text, *v);
            }
        }
        self.comment(&text)
    }

    fn finish(&mut self, summary: &LiveSummary) -> io::Result<()> {
        self.comment(&format!(
            "ended: {}; {} frames, {} read, {} tare, {} refused, {} bad; dropped {}",
            summary.ended,
            summary.frames_in,
            summary.frames_out,
            summary.tare_frames,
            summary.refused_frames,
            summary.bad_frames,
            summary.dropped.total
        ))?;
        // Rename both files even when one fails; the first error names its file.
        let first = self.log.take().map_or(Ok(()), Partial::finish);
        let second = self.shifts.take().map_or(Ok(()), Partial::finish);
        first.and(second)
    }
}
