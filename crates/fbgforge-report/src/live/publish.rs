//! `--mcap FILE` and `--serve ADDR`: a live run for robots and browsers, through the
//! plain-data writers of `fbgforge-publish`.
//!
//! * [`McapSink`]: every frame as ROS 2 messages in an MCAP file. A module publishes
//!   its core's force on `/fbgforge/<core>/wrench` (`geometry_msgs/msg/WrenchStamped`,
//!   `force.z` along the module axis, N: the mean of the core's strain gratings that
//!   read a force in the frame); an array its cell loads on `/fbgforge/cells`
//!   (`std_msgs/msg/Float64MultiArray`, N) and the load-weighted centroid of the cell
//!   centres on `/fbgforge/contact` (`geometry_msgs/msg/PointStamped`, m, when
//!   anything is loaded); both the peaks (nm), the flags and the tare state. Frames
//!   with no reading (the tare, a refused tare, a frame lacking a grating) publish
//!   their peaks, flags and tare state only.
//! * [`WebSink`]: the browser view, pushed at most [`WEB_PUSH_HZ`] times a second (a
//!   display's rate, not the stream's) and at every change of the tare.
//!
//! The frame time is the frame's own (s since 1970 for an instrument), else seconds
//! since the first frame.

use fbgforge_live::interpret::Reading;
use fbgforge_live::sink::{FrameReading, LiveInfo, LiveSink, PeakFrame};
use fbgforge_live::stats::LiveSummary;
use fbgforge_live::tare::{TareChange, TareState};
use fbgforge_publish::web::{ArrayView, FrameView, LoadUnit, ModuleView, ReadingView};
use fbgforge_publish::{
    ArrayReading, McapRecorder, ModuleReading, PublishError, RecorderSetup, SensorLayout, WebView,
};
use std::io;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Standard gravity: grams-force to newtons.
const N_PER_G: f64 = 9.806_65e-3;

/// How often the browser view is pushed at most, frames per second.
pub const WEB_PUSH_HZ: f64 = 20.0;

fn io_err(e: PublishError) -> io::Error {
    io::Error::other(e.to_string())
}

/// The tare as the publisher words it.
fn tare_of(c: Option<&TareChange>, nominal: bool) -> fbgforge_publish::TareState {
    use fbgforge_publish::TareState as P;
    match c.map(|c| (c.state, c)) {
        None if nominal => P::Nominal,
        None => P::Waiting,
        Some((TareState::Waiting, _)) => P::Waiting,
        Some((TareState::Resting, _)) => P::Resting,
        Some((TareState::Nominal, _)) => P::Nominal,
        Some((TareState::Refused, c)) => P::Refused {
            moving_gratings: c.moving.clone(),
        },
    }
}

/// A frame's time, ns: its own, else seconds since the first frame.
fn frame_time_ns(time_s: Option<f64>, received_s: f64) -> u64 {
    let t = time_s.unwrap_or(received_s);
    if t.is_finite() && t > 0.0 {
        (t * 1e9).round() as u64
    } else {
        0
    }
}

fn optional(peaks_nm: &[f64]) -> Vec<Option<f64>> {
    peaks_nm
        .iter()
        .map(|&p| p.is_finite().then_some(p))
        .collect()
}

/// The load-weighted centroid of the cell centres, m (z = 0); `None` unloaded.
pub fn contact_centroid_m(loads_g: &[f64], centers_mm: &[(f64, f64)]) -> Option<[f64; 3]> {
    let mut total = 0.0;
    let (mut x, mut y) = (0.0, 0.0);
    for (&l, &(cx, cy)) in loads_g.iter().zip(centers_mm) {
        if l.is_finite() && l > 0.0 {
            total += l;
            x += l * cx;
            y += l * cy;
        }
    }
    (total > 0.0).then(|| [x / total * 1e-3, y / total * 1e-3, 0.0])
}

/// A module's core force: the mean of its strain gratings' forces read in this frame.
pub fn core_force_n(forces_n: &[Option<f64>]) -> Option<f64> {
    let read: Vec<f64> = forces_n.iter().flatten().copied().collect();
    (!read.is_empty()).then(|| read.iter().sum::<f64>() / read.len() as f64)
}

/// `--mcap FILE`: the run as ROS 2 messages in MCAP (see the [module](self)).
pub struct McapSink {
    path: PathBuf,
    rec: Option<McapRecorder>,
    info: Option<LiveInfo>,
    tare: Option<TareChange>,
}

impl McapSink {
    /// Record to `path` (written as `path.partial` until the run ends). Fails at once,
    /// naming the file, when it cannot be written.
    pub fn create(path: &Path) -> io::Result<Self> {
        let mut name = path.file_name().unwrap_or_default().to_owned();
        name.push(".partial");
        let probe = path.with_file_name(name);
        super::record::create_parent(path)?;
        std::fs::File::create(&probe)
            .and_then(|_| std::fs::remove_file(&probe))
            .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", probe.display())))?;
        Ok(McapSink {
            path: path.to_path_buf(),
            rec: None,
            info: None,
            tare: None,
        })
    }

    fn rec(&mut self) -> io::Result<&mut McapRecorder> {
        self.rec
            .as_mut()
            .ok_or_else(|| io::Error::other("the MCAP recording is not open"))
    }

    fn nominal(&self) -> bool {
        self.info.as_ref().is_some_and(|i| i.tare_frames == 0)
    }
}

impl LiveSink for McapSink {
    fn start(&mut self, info: &LiveInfo) -> io::Result<()> {
        let sensor = match &info.core {
            Some(core) => SensorLayout::Module {
                core_labels: vec![core.clone()],
            },
            None => SensorLayout::Array {
                cell_labels: info.outputs.clone(),
            },
        };
        let setup = RecorderSetup {
            design_name: info.design.clone(),
            sensor,
            grating_labels: info.gratings.clone(),
        };
        self.rec = Some(McapRecorder::create(&self.path, setup).map_err(io_err)?);
        self.info = Some(info.clone());
        Ok(())
    }

    fn peaks(&mut self, f: &PeakFrame<'_>) -> io::Result<()> {
        if f.outcome == "read" {
            return Ok(());
        }
        let tare = tare_of(self.tare.as_ref(), self.nominal());
        let flags = if f.outcome == "bad" {
            vec!["unusable".to_string()]
        } else {
            Vec::new()
        };
        let t = frame_time_ns(f.time_s, f.received_s);
        self.rec()?
            .record_unread(t, &optional(f.peaks_nm), &flags, &tare)
            .map_err(io_err)
    }

    fn reading(&mut self, r: &FrameReading) -> io::Result<()> {
        let tare = tare_of(self.tare.as_ref(), self.nominal());
        let flags: Vec<String> = r.flag_words().iter().map(|w| w.to_string()).collect();
        let peaks = optional(&r.peaks_nm);
        let t = frame_time_ns(r.time_s, r.received_s);
        let centers = self
            .info
            .as_ref()
            .map(|i| i.cell_centers_mm.clone())
            .unwrap_or_default();
        let rec = self.rec()?;
        match &r.reading {
            Reading::Loads { loads_g, .. } => {
                let loads_n: Vec<f64> = loads_g.iter().map(|g| g * N_PER_G).collect();
                rec.record_array(&ArrayReading {
                    frame_time_ns: t,
                    cell_loads_n: &loads_n,
                    contact_centroid_m: contact_centroid_m(loads_g, &centers),
                    peaks_nm: &peaks,
                    flags: &flags,
                    tare: &tare,
                })
            }
            Reading::Forces { forces_n, .. } => rec.record_module(&ModuleReading {
                frame_time_ns: t,
                core_forces_n: &[core_force_n(forces_n)],
                peaks_nm: &peaks,
                flags: &flags,
                tare: &tare,
            }),
        }
        .map_err(io_err)
    }

    fn tare(&mut self, change: &TareChange) -> io::Result<()> {
        self.tare = Some(change.clone());
        Ok(())
    }

    fn finish(&mut self, _summary: &LiveSummary) -> io::Result<()> {
        match self.rec.take() {
            Some(rec) => rec.finish().map(|_| ()).map_err(io_err),
            None => Ok(()),
        }
    }
}

/// `--serve ADDR`: the browser view, pushed at a display's rate (see the
/// [module](self)).
pub struct WebSink {
    view: WebView,
    info: Option<LiveInfo>,
    tare: Option<TareChange>,
    last: Option<FrameReading>,
    last_push: Option<Instant>,
    every: Duration,
}

impl WebSink {
    /// Push to `view` (started by the caller: [`fbgforge_publish::serve`]).
    pub fn new(view: WebView) -> Self {
        WebSink {
            view,
            info: None,
            tare: None,
            last: None,
            last_push: None,
            every: Duration::from_secs_f64(1.0 / WEB_PUSH_HZ),
        }
    }

    /// The view's address, `http://HOST:PORT/`.
    pub fn url(&self) -> String {
        self.view.url()
    }

    fn frame_view(&self) -> Option<FrameView> {
        let info = self.info.as_ref()?;
        let n = info.outputs.len();
        let (values, flags, time_ns): (Vec<Option<f64>>, Vec<String>, u64) = match &self.last {
            Some(r) => (
                match &r.reading {
                    Reading::Loads { loads_g, .. } => loads_g.iter().map(|&v| Some(v)).collect(),
                    Reading::Forces { forces_n, .. } => forces_n.clone(),
                },
                r.flag_words().iter().map(|w| w.to_string()).collect(),
                frame_time_ns(r.time_s, r.received_s),
            ),
            None => (vec![None; n], Vec::new(), 0),
        };
        let reading = match info.grid {
            Some((nx, ny, ulimit_g)) => ReadingView::Array(ArrayView {
                nx,
                ny,
                cell_labels: info.outputs.clone(),
                cell_loads: values.iter().map(|v| v.unwrap_or(f64::NAN)).collect(),
                load_unit: LoadUnit::Grams,
                full_scale: Some(ulimit_g),
            }),
            None => ReadingView::Module(ModuleView {
                core_labels: info.outputs.clone(),
                core_forces_n: values,
            }),
        };
        Some(FrameView {
            design_name: info.design.clone(),
            frame_time_ns: time_ns,
            reading,
            flags,
            tare: tare_of(self.tare.as_ref(), info.tare_frames == 0),
        })
    }

    fn push(&mut self) -> io::Result<()> {
        if let Some(v) = self.frame_view() {
            self.view.push(&v).map_err(io_err)?;
            self.last_push = Some(Instant::now());
        }
        Ok(())
    }
}

impl LiveSink for WebSink {
    fn start(&mut self, info: &LiveInfo) -> io::Result<()> {
        self.info = Some(info.clone());
        self.push()
    }

    fn reading(&mut self, r: &FrameReading) -> io::Result<()> {
        self.last = Some(r.clone());
        if self.last_push.is_none_or(|t| t.elapsed() >= self.every) {
            self.push()?;
        }
        Ok(())
    }

    fn tare(&mut self, change: &TareChange) -> io::Result<()> {
        self.tare = Some(change.clone());
        if change.state != TareState::Resting {
            // Loads of the old tare are no longer shown.
            self.last = None;
        }
        self.push()
    }

    fn finish(&mut self, _summary: &LiveSummary) -> io::Result<()> {
        self.push()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_contact_is_the_load_weighted_centre_and_the_core_force_the_mean() {
        let centers = [(-30.0, -15.0), (-10.0, -15.0), (10.0, 15.0)];
        assert_eq!(contact_centroid_m(&[0.0, 0.0, 0.0], &centers), None);
        let c = contact_centroid_m(&[100.0, 0.0, 300.0], &centers).unwrap();
        assert!((c[0] - 0.0).abs() < 1e-12 && (c[1] - 0.0075).abs() < 1e-12 && c[2] == 0.0);
        assert_eq!(core_force_n(&[Some(4.0), None, Some(5.0)]), Some(4.5));
        assert_eq!(core_force_n(&[None]), None);
        assert_eq!(frame_time_ns(Some(1.5), 9.0), 1_500_000_000);
        assert_eq!(frame_time_ns(None, 2.0), 2_000_000_000);
    }
}
