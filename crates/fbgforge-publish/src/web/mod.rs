//! A browser view of a live run: [`serve`] answers on a plain `std::net::TcpListener`
//! (no async runtime) with
//!
//! * `GET /`: one self-contained HTML page (inline CSS and JavaScript; it fetches
//!   nothing but `/events`, and its `Content-Security-Policy` forbids anything else),
//!   with the latest frame already in it;
//! * `GET /events`: a Server-Sent Events stream, one `data:` line of JSON per frame
//!   ([`FrameView::to_json`]); as soon as a client connects it gets the latest frame
//!   (for a module, the frames of the last 10 s of frame time, at most 600 and 8 MiB,
//!   so that its traces start full), then every frame pushed;
//! * `GET /frame.json`: the latest frame (`204 No Content` before the first).
//!
//! The page draws an array's heat map (each cell coloured by its load, the value printed
//! in it; the cell element carries `data-cell="<label>"` and `data-load="<value>"`) or a
//! module's force traces (the last 10 s per core, an SVG polyline each, and a legend
//! whose entries carry `data-core` and `data-force`), the frame's flags (`data-flag`)
//! and the tare state (`#tare`, `data-tare="resting|waiting|refused|nominal"`).
//!
//! [`WebView::push`] never blocks: each client has a queue of
//! [`WebOptions::client_queue_frames`] frames, and a client whose queue is full (a slow
//! or stalled browser) is dropped and counted ([`ViewStats::clients_dropped_slow`]);
//! its browser reconnects by itself (`retry: 1000`) and starts again from the latest
//! frame. Push at the display's rate (10–30 frames/s), not every frame of a 1 kHz
//! stream. Dropping the [`WebView`] stops the server: the listener closes, every
//! connection is shut down and every thread joined.

mod server;

use std::io;
use std::net::ToSocketAddrs;
use std::time::Duration;

use serde_json::{json, Value};

use crate::data::{PublishError, TareState};

pub use server::{ViewStats, WebView};

/// The unit of an array's cell loads in the view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoadUnit {
    /// Grams (the terminal view's unit).
    Grams,
    /// Newtons.
    Newtons,
}

impl LoadUnit {
    /// `g` or `N`.
    pub fn symbol(self) -> &'static str {
        match self {
            LoadUnit::Grams => "g",
            LoadUnit::Newtons => "N",
        }
    }
}

/// An array's cells as the view draws them.
#[derive(Debug, Clone, PartialEq)]
pub struct ArrayView {
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    /// `nx × ny` labels, row-major from the bottom (−y) row, each row from −x to +x
    /// (the page draws +y up).
    pub cell_labels: Vec<String>,
    /// The load of each cell, in `load_unit`, in the order of `cell_labels`; NaN for
    /// none.
    pub cell_loads: Vec<f64>,
    /// Unit of `cell_loads` and `full_scale`.
    pub load_unit: LoadUnit,
    /// The load drawn in the darkest colour (the design's ulimit), in `load_unit`;
    /// `None` scales to the frame's largest load.
    pub full_scale: Option<f64>,
}

/// A module's cores as the view draws them.
#[derive(Debug, Clone, PartialEq)]
pub struct ModuleView {
    /// The cores.
    pub core_labels: Vec<String>,
    /// Force along the module axis per core, N; `None` where it could not be read.
    pub core_forces_n: Vec<Option<f64>>,
}

/// What a frame shows: an array's loads or a module's forces.
#[derive(Debug, Clone, PartialEq)]
pub enum ReadingView {
    /// Heat map.
    Array(ArrayView),
    /// Force traces.
    Module(ModuleView),
}

/// One frame for the browser view.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameView {
    /// The design's name (page title).
    pub design_name: String,
    /// The frame's time, ns (the traces' time axis).
    pub frame_time_ns: u64,
    /// Loads or forces.
    pub reading: ReadingView,
    /// The frame's trust flags, one word each.
    pub flags: Vec<String>,
    /// The tare state.
    pub tare: TareState,
}

fn finite_or_null(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

impl FrameView {
    fn check(&self) -> Result<(), PublishError> {
        let mismatch = |what, expected, got| {
            if expected == got {
                Ok(())
            } else {
                Err(PublishError::LengthMismatch {
                    what,
                    expected,
                    got,
                })
            }
        };
        match &self.reading {
            ReadingView::Array(a) => {
                let n = a.nx.checked_mul(a.ny).ok_or(PublishError::LengthMismatch {
                    what: "nx × ny",
                    expected: usize::MAX,
                    got: usize::MAX,
                })?;
                mismatch("cell_labels (nx × ny)", n, a.cell_labels.len())?;
                mismatch("cell_loads", n, a.cell_loads.len())
            }
            ReadingView::Module(m) => {
                mismatch("core_forces_n", m.core_labels.len(), m.core_forces_n.len())
            }
        }
    }

    /// The JSON the page receives:
    ///
    /// ```text
    /// {"kind": "array" | "module", "design", "frame_time_s",
    ///  "flags": [words], "tare": {"state": "resting|waiting|refused|nominal",
    ///                             "text": "refused: moving gratings …", "moving_gratings": [..]},
    ///  "array":  {"nx", "ny", "labels", "loads", "unit": "g" | "N", "full_scale"}   (array)
    ///  "module": {"cores", "forces_n"}                                              (module)}
    /// ```
    ///
    /// Non-finite numbers and missing forces are `null`. Fails when the lengths of
    /// labels and values differ.
    pub fn to_json(&self) -> Result<String, PublishError> {
        self.check()?;
        let moving: &[String] = match &self.tare {
            TareState::Refused { moving_gratings } => moving_gratings,
            _ => &[],
        };
        let mut v = json!({
            "design": self.design_name,
            "frame_time_s": self.frame_time_ns as f64 * 1e-9,
            "flags": self.flags,
            "tare": {"state": self.tare.word(), "text": self.tare.to_string(), "moving_gratings": moving},
        });
        match &self.reading {
            ReadingView::Array(a) => {
                v["kind"] = json!("array");
                v["array"] = json!({
                    "nx": a.nx, "ny": a.ny, "labels": a.cell_labels,
                    "loads": a.cell_loads.iter().map(|&x| finite_or_null(x)).collect::<Vec<_>>(),
                    "unit": a.load_unit.symbol(),
                    "full_scale": a.full_scale.filter(|x| x.is_finite() && *x > 0.0),
                });
            }
            ReadingView::Module(m) => {
                v["kind"] = json!("module");
                let forces: Vec<Value> = m
                    .core_forces_n
                    .iter()
                    .map(|f| f.map_or(Value::Null, finite_or_null))
                    .collect();
                v["module"] = json!({"cores": m.core_labels, "forces_n": forces});
            }
        }
        Ok(v.to_string())
    }
}

/// Limits of the browser view.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WebOptions {
    /// Frames queued per client before it is dropped as slow.
    pub client_queue_frames: usize,
    /// Event-stream clients served at once; more get `503`.
    pub max_clients: usize,
    /// How long one write to a client may block before it is dropped.
    pub write_timeout: Duration,
}

impl Default for WebOptions {
    fn default() -> Self {
        WebOptions {
            client_queue_frames: 64,
            max_clients: 32,
            write_timeout: Duration::from_secs(2),
        }
    }
}

/// Starts the browser view on `addr` (e.g. `127.0.0.1:8080`; port 0 picks a free one)
/// with the default [`WebOptions`].
///
/// ```
/// use std::io::{Read, Write};
/// use fbgforge_publish::web::{serve, ArrayView, FrameView, LoadUnit, ReadingView};
/// use fbgforge_publish::TareState;
///
/// let view = serve("127.0.0.1:0")?;
/// view.push(&FrameView {
///     design_name: "tactile-array-60x80".into(),
///     frame_time_ns: 1_000_000_000,
///     reading: ReadingView::Array(ArrayView {
///         nx: 2,
///         ny: 1,
///         cell_labels: vec!["A".into(), "B".into()],
///         cell_loads: vec![0.0, 100.0],
///         load_unit: LoadUnit::Grams,
///         full_scale: Some(250.0),
///     }),
///     flags: vec![],
///     tare: TareState::Resting,
/// })?;
/// // What a browser gets first from the event stream: the latest frame.
/// let mut s = std::net::TcpStream::connect(view.local_addr())?;
/// s.write_all(b"GET /events HTTP/1.1\r\nHost: x\r\n\r\n")?;
/// let mut got = String::new();
/// let mut buf = [0; 4096];
/// while !got.contains("100.0]") {
///     let n = s.read(&mut buf)?;
///     assert!(n > 0);
///     got.push_str(std::str::from_utf8(&buf[..n])?);
/// }
/// assert!(got.starts_with("HTTP/1.1 200 OK"));
/// assert!(got.contains("text/event-stream"));
/// assert!(got.contains(r#""loads":[0.0,100.0]"#));
/// drop(view); // closes the stream and joins every thread
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn serve(addr: impl ToSocketAddrs) -> io::Result<WebView> {
    serve_with(addr, WebOptions::default())
}

/// [`serve`] with other limits.
pub fn serve_with(addr: impl ToSocketAddrs, options: WebOptions) -> io::Result<WebView> {
    WebView::start(addr, options)
}

/// The page, with `/*INITIAL_FRAME*/` where the latest frame's JSON goes.
pub(crate) const PAGE_TEMPLATE: &str = include_str!("page.html");

/// The page with `frame_json` (or nothing) as its initial frame. `<` is escaped so that
/// no label can close the script element.
pub fn page_html(frame_json: Option<&str>) -> String {
    let initial = frame_json.map_or(String::new(), |j| j.replace('<', "\\u003c"));
    PAGE_TEMPLATE.replacen("/*INITIAL_FRAME*/", &initial, 1)
}

#[cfg(test)]
mod tests;
