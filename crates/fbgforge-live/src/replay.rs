//! A finished wavelength log read as `live` reads a followed one: the same row reader
//! turns its rows into frames, and the same [`Interpreter`] finds each grating in its
//! window, tares on the first frames at rest and gives each later frame's shifts.
//! `reconstruct DESIGN --log` uses it (then reconstructs the shifts as from a CSV).

use crate::interpret::{InterpretOptions, Interpreter, Skip};
use crate::logs::{ReadOptions, RowReader};
use crate::source::Frame;
use crate::spec::Design;
use anyhow::{Context, Result};
use std::path::Path;
use std::time::Instant;

/// The shifts of a log's frames from its tare.
#[derive(Debug, Clone, PartialEq)]
pub struct TaredLog {
    /// Grating names, in the order of each frame's shifts.
    pub gratings: Vec<String>,
    /// Each read frame's time, s (the log's).
    pub time_s: Vec<f64>,
    /// Each read frame's shifts from the tare, pm (NaN: no peak in the window).
    pub shifts_pm: Vec<Vec<f64>>,
    /// Frames taken into the tare (not read).
    pub tare_frames: usize,
    /// Frames, or rows, that gave nothing, with why (a row unreadable, a peak missing,
    /// the tare refused).
    pub skipped: Vec<String>,
}

/// The frames of the log at `path`, in order, as `live` reads the rows of a followed
/// log; rows that cannot be read are named in the second list.
pub fn log_frames(path: &Path, read: &ReadOptions) -> Result<(Vec<Frame>, Vec<String>)> {
    let bytes =
        std::fs::read(path).with_context(|| format!("cannot read the log {}", path.display()))?;
    let (mut reader, body) = RowReader::new(&bytes, path, read)?;
    let (mut frames, mut bad) = (Vec::new(), Vec::new());
    let received = Instant::now();
    for (i, line) in bytes[body.min(bytes.len())..]
        .split(|&c| c == b'\n')
        .enumerate()
    {
        let origin = format!("{} body line {}", path.display(), i + 1);
        match reader.parse(line) {
            Ok(None) => {}
            // A replayed row is the log's past: its age is not measured.
            Ok(Some(row)) => frames.push(Frame::of_log_row(row, false, received, origin)),
            Err((kind, message)) => bad.push(format!("{origin}: {kind}: {message}")),
        }
    }
    Ok((frames, bad))
}

/// Read the log at `path` for `design` as `live` would with `opts`: each frame's
/// gratings found in their windows, the tare taken on the first frames at rest, the
/// shifts of every later frame from it.
pub fn tare_log(
    design: &Design,
    path: &Path,
    read: &ReadOptions,
    opts: &InterpretOptions,
) -> Result<TaredLog> {
    opts.validate()?;
    let mut interp = Interpreter::new(design, opts)?;
    let (frames, mut skipped) = log_frames(path, read)?;
    let mut out = TaredLog {
        gratings: interp.gratings(),
        time_s: Vec::new(),
        shifts_pm: Vec::new(),
        tare_frames: 0,
        skipped: Vec::new(),
    };
    for frame in &frames {
        match interp.prepare(frame).result {
            Ok(p) => {
                out.time_s.push(frame.time_s.unwrap_or(f64::NAN));
                out.shifts_pm.push(p.shifts_pm);
            }
            Err(Skip::Tare) => out.tare_frames += 1,
            Err(Skip::Refused) => skipped.push(format!(
                "{}: the tare was refused (the sensor never came to rest)",
                frame.origin
            )),
            Err(Skip::Bad(_, message)) => skipped.push(message),
        }
    }
    out.skipped = skipped;
    anyhow::ensure!(
        !out.shifts_pm.is_empty(),
        "{}: no frame read after the tare ({} frames in the tare, {} skipped{})",
        path.display(),
        out.tare_frames,
        out.skipped.len(),
        out.skipped
            .first()
            .map(|s| format!(", first: {s}"))
            .unwrap_or_default()
    );
    Ok(out)
}

impl TaredLog {
    /// Write the shifts as `reconstruct --shifts` reads them: `time_s,<gratings…>`, pm.
    pub fn write_shifts_csv(&self, path: &Path) -> Result<()> {
        let mut header = vec!["time_s".to_string()];
        header.extend(self.gratings.iter().cloned());
        let rows: Vec<Vec<String>> = self
            .time_s
            .iter()
            .zip(&self.shifts_pm)
            .map(|(t, s)| {
                std::iter::once(format!("{t}"))
                    .chain(s.iter().map(|v| format!("{v:.6}")))
                    .collect()
            })
            .collect();
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        crate::output::write_csv(path, &header, &rows)
    }
}
