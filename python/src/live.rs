//! The live mode from Python: `fbgforge::live::run` on its own thread, its sink
//! handing each start, reading, tare change, bad frame, event and the summary to
//! Python through a bounded channel. A Python consumer slower than an instrument makes
//! the run's own queue overflow, where the dropped frames are counted, exactly as a
//! slow terminal would; a file is read whole (unless `realtime`). `tare()` asks the
//! run to tare again, `stop()` ends it (`fbgforge::live::control::LiveControl`).

use crate::convert::{to_py, to_py_words};
use crate::errors::{self, err_named, input, must_exist};
use fbgforge::live::control::LiveControl;
use fbgforge::live::interpret::{calibration_from_verify_json, InterpretOptions, Reading};
use fbgforge::live::sink::{FrameReading, LiveInfo, LiveSink};
use fbgforge::live::source::{SourceOptions, SourceSpec};
use fbgforge::live::stats::LiveSummary;
use fbgforge::live::tare::TareChange;
use fbgforge::live::LiveRequest;
use numpy::ndarray::Array1;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::BTreeMap;
use std::io;
use std::path::PathBuf;
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// What the run's thread tells Python.
enum Message {
    Start(LiveInfo),
    Reading(FrameReading),
    Tare(TareChange),
    Bad(String, String),
    Event(String, String),
    Done(Result<LiveSummary, String>),
}

/// A sink that passes everything on; an error once Python has gone.
struct ChannelSink(SyncSender<Message>);

impl ChannelSink {
    fn send(&self, m: Message) -> io::Result<()> {
        self.0
            .send(m)
            .map_err(|_| io::Error::new(io::ErrorKind::BrokenPipe, "the Python reader is gone"))
    }
}

impl LiveSink for ChannelSink {
    fn start(&mut self, info: &LiveInfo) -> io::Result<()> {
        self.send(Message::Start(info.clone()))
    }
    fn reading(&mut self, r: &FrameReading) -> io::Result<()> {
        self.send(Message::Reading(r.clone()))
    }
    fn tare(&mut self, change: &TareChange) -> io::Result<()> {
        self.send(Message::Tare(TareChange {
            message: errors::py_words(&change.message),
            ..change.clone()
        }))
    }
    fn bad(&mut self, kind: &str, message: &str) -> io::Result<()> {
        self.send(Message::Bad(kind.into(), errors::py_words(message)))
    }
    fn event(&mut self, event: &str, message: &str) -> io::Result<()> {
        self.send(Message::Event(event.into(), errors::py_words(message)))
    }
}

/// A running watch: next() gives `(kind, payload)` until `("summary", …)`.
#[pyclass(module = "fbgforge._fbgforge")]
pub struct LiveStream {
    rx: Mutex<Option<Receiver<Message>>>,
    control: Arc<LiveControl>,
}

/// One reading as a dict: numbers as floats (NaN where a peak was missing), the
/// loads or forces as a numpy array, every other field as the library names it.
fn reading_dict<'py>(py: Python<'py>, r: &FrameReading) -> PyResult<Bound<'py, PyAny>> {
    let d = to_py(py, r)?.cast_into::<PyDict>()?;
    d.set_item("serial", r.serial)?;
    d.set_item("time_s", r.time_s.unwrap_or(f64::NAN))?;
    d.set_item("age_us", r.age_us.unwrap_or(f64::NAN))?;
    d.set_item(
        "peaks_nm",
        Array1::from(r.peaks_nm.clone()).into_pyarray(py),
    )?;
    d.set_item(
        "shifts_pm",
        Array1::from(r.shifts_pm.clone()).into_pyarray(py),
    )?;
    d.set_item("flag_words", r.flag_words())?;
    match &r.reading {
        Reading::Loads { loads_g, .. } => {
            d.set_item("loads_g", Array1::from(loads_g.clone()).into_pyarray(py))?;
        }
        Reading::Forces {
            forces_n,
            delta_t_k,
        } => {
            d.set_item(
                "forces_n",
                Array1::from_iter(forces_n.iter().map(|f| f.unwrap_or(f64::NAN))).into_pyarray(py),
            )?;
            d.set_item("delta_t_k", delta_t_k.unwrap_or(f64::NAN))?;
        }
    }
    Ok(d.into_any())
}

#[pymethods]
impl LiveStream {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    /// The next message, waiting with the GIL released (Ctrl-C is honoured).
    fn __next__<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let mut guard = self.rx.lock().expect("not poisoned");
        // The receiver goes with the wait (it cannot be shared) and comes back.
        let Some(mut rx) = guard.take() else {
            return Ok(None);
        };
        let msg = loop {
            let (back, got) = py.detach(move || {
                let got = rx.recv_timeout(Duration::from_millis(100));
                (rx, got)
            });
            rx = back;
            match got {
                Ok(m) => break m,
                Err(RecvTimeoutError::Timeout) => {
                    if let Err(e) = py.check_signals() {
                        self.control.stop_because("interrupted in Python");
                        *guard = Some(rx);
                        return Err(e);
                    }
                }
                Err(RecvTimeoutError::Disconnected) => return Ok(None),
            }
        };
        if !matches!(msg, Message::Done(_)) {
            *guard = Some(rx);
        }
        drop(guard);
        let item = match msg {
            Message::Start(info) => ("start", to_py(py, &info)?),
            Message::Reading(r) => ("frame", reading_dict(py, &r)?),
            Message::Tare(c) => ("tare", to_py(py, &c)?),
            Message::Bad(k, m) => ("bad", (k, m).into_pyobject(py)?.into_any()),
            Message::Event(k, m) => ("event", (k, m).into_pyobject(py)?.into_any()),
            Message::Done(Ok(summary)) => ("summary", to_py_words(py, &summary)?),
            Message::Done(Err(e)) => {
                return Err(input(py, errors::python_words(&e, &[("from", "source")])));
            }
        };
        Ok(Some(item.into_pyobject(py)?.into_any()))
    }

    /// Stop the watch (its summary still follows).
    fn stop(&self) {
        self.control.stop_because("stopped from Python");
    }

    /// Tare again: the frames are not read until a window is at rest.
    fn tare(&self) {
        self.control.request_tare("python");
    }
}

impl Drop for LiveStream {
    fn drop(&mut self) {
        self.control.stop_because("the Python stream was dropped");
    }
}

/// Start watching a stream (see `fbgforge.live`).
#[pyfunction]
#[pyo3(signature = (design_path, source, tare_frames, tare_s, tare_wait_s, window_nm, method,
    resolution_pm, budget_us, core, case, insert, fidelity, k, calibration, format, date_order,
    from_start, idle_exit_s, give_up_s, frames, duration_s, queue, realtime))]
#[allow(clippy::too_many_arguments)]
pub fn live_stream(
    py: Python<'_>,
    design_path: PathBuf,
    source: &str,
    tare_frames: usize,
    tare_s: f64,
    tare_wait_s: f64,
    window_nm: Option<f64>,
    method: Option<String>,
    resolution_pm: f64,
    budget_us: f64,
    core: Option<String>,
    case: Option<&str>,
    insert: Option<String>,
    fidelity: &str,
    k: BTreeMap<String, f64>,
    calibration: Option<PathBuf>,
    format: Option<&str>,
    date_order: Option<&str>,
    from_start: bool,
    idle_exit_s: Option<f64>,
    give_up_s: f64,
    frames: Option<u64>,
    duration_s: Option<f64>,
    queue: usize,
    realtime: bool,
) -> PyResult<LiveStream> {
    if let Some((g, v)) = k.iter().find(|(_, v)| !(v.is_finite() && **v != 0.0)) {
        return Err(input(
            py,
            format!("k[{g:?}] = {v}: K must be a finite, non-zero number of pm/N"),
        ));
    }
    let mut calibrated = match &calibration {
        Some(p) => {
            must_exist(py, p, "calibration")?;
            calibration_from_verify_json(p).map_err(|e| err_named(py, e, &[]))?
        }
        None => BTreeMap::new(),
    };
    calibrated.extend(k);
    let options = SourceOptions {
        read: crate::read_options(py, format, date_order)?,
        from_start,
        idle_exit_s,
        give_up_s,
    };
    let spec = SourceSpec::parse(source, options).map_err(|e| err_named(py, e, &[]))?;
    if let Some(p) = spec.path() {
        must_exist(py, p, "source")?;
    }
    let mut req = LiveRequest::new(design_path, spec);
    req.interpret = InterpretOptions {
        tare_frames,
        tare_s,
        tare_wait_s,
        window_half_width_nm: window_nm,
        core,
        case: crate::parse_case(py, case)?,
        insert,
        fidelity: crate::parse_fidelity(py, fidelity)?,
        calibrated_k_pm_per_n: calibrated,
        method,
        resolution_pm,
        budget_us,
    };
    req.max_frames = frames;
    req.duration_s = duration_s;
    req.queue_frames = queue;
    req.realtime = realtime;
    // Refused here, before the run's thread starts, as a bad value of this call.
    req.validate().map_err(|e| err_named(py, e, &[]))?;
    let (tx, rx) = sync_channel(1024);
    let control = Arc::new(LiveControl::new());
    let run_control = control.clone();
    std::thread::spawn(move || {
        let mut sink = ChannelSink(tx);
        let done = fbgforge::live::run(&req, &mut sink, &run_control).map_err(|e| format!("{e:#}"));
        let _ = sink.send(Message::Done(done));
    });
    Ok(LiveStream {
        rx: Mutex::new(Some(rx)),
        control,
    })
}
