//! A live run recorded as an MCAP file of ROS 2 messages ([`McapRecorder`]).
//!
//! Topics (all messages `cdr`-encoded, all schemas `ros2msg`):
//!
//! | topic | type | when | content |
//! |---|---|---|---|
//! | `/fbgforge/<core>/wrench` | `geometry_msgs/msg/WrenchStamped` | module, each frame with that core's force | `force.z` = the force along the module axis, N; x, y and torque 0; `frame_id` `fbgforge_<core>` |
//! | `/fbgforge/cells` | `std_msgs/msg/Float64MultiArray` | array, each frame | load per cell, N, in the design's cell order; one dimension `cells` (size = stride = number of cells) |
//! | `/fbgforge/contact` | `geometry_msgs/msg/PointStamped` | array, each frame with a contact | load-weighted contact centroid, m; `frame_id` `fbgforge_array` |
//! | `/fbgforge/peaks` | `std_msgs/msg/Float64MultiArray` | each frame | peak wavelength per grating, nm (NaN where the peak was missing); one dimension `gratings` |
//! | `/fbgforge/flags` | `std_msgs/msg/String` | each frame | the frame's trust flags, comma-separated (`inconsistent, ceiling`); empty when trusted |
//! | `/fbgforge/tare` | `std_msgs/msg/String` | first frame and each change | `resting`, `waiting`, `nominal`, or `refused: moving gratings …` |
//!
//! `<core>` is the core's label as a ROS name token ([`crate::ros_name_token`]). Every
//! message of a frame has log time = publish time = the frame time in ns, and the
//! header stamps hold the same time. Each channel's metadata holds the design name and
//! the unit; the labels of cells and gratings (JSON arrays) are in the metadata of
//! `/fbgforge/cells` and `/fbgforge/peaks`, and in a metadata record `fbgforge`.
//!
//! **Atomic file.** The recorder writes `<file>.partial` beside `<file>` and renames it
//! on [`McapRecorder::finish`]: `<file>` is never a half-written recording. A recorder
//! dropped without `finish` (a panic, an early return) leaves `<file>.partial`, which
//! holds everything recorded so far and, when the drop could still write it, a valid
//! summary; after a crash with no drop at all, `mcap recover` restores it. A stale
//! `<file>.partial` from an earlier run is overwritten.
//!
//! Chunks are not compressed: the `mcap` crate's `zstd` and `lz4` features build C
//! libraries, and this crate stays pure Rust.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::data::*;
use crate::ros2::{
    Float64MultiArray, Header, Point, PointStamped, Ros2Message, StringMessage, Time, Vector3,
    Wrench, WrenchStamped,
};

/// What the sensor is: a module (forces per core) or an array (loads per cell).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SensorLayout {
    /// A module design: one wrench topic per core.
    Module {
        /// The cores, in the order of [`ModuleReading::core_forces_n`].
        core_labels: Vec<String>,
    },
    /// An array design: per-cell loads and a contact centroid.
    Array {
        /// The cells in the design's order, the order of [`ArrayReading::cell_loads_n`].
        cell_labels: Vec<String>,
    },
}

/// What a recording is of.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecorderSetup {
    /// The design's name (channel metadata).
    pub design_name: String,
    /// Module or array, with its labels.
    pub sensor: SensorLayout,
    /// The gratings, in the order of the readings' `peaks_nm`.
    pub grating_labels: Vec<String>,
}

/// One frame of a module design.
#[derive(Debug, Clone, Copy)]
pub struct ModuleReading<'a> {
    /// The frame's time, ns (the stream's clock; since 1970 for a live instrument).
    pub frame_time_ns: u64,
    /// Force along the module axis per core, N; `None` where it could not be read (no
    /// wrench is published for that core in this frame).
    pub core_forces_n: &'a [Option<f64>],
    /// Peak wavelength per grating, nm; `None` for a missing peak (published as NaN).
    pub peaks_nm: &'a [Option<f64>],
    /// The frame's trust flags, one word each.
    pub flags: &'a [String],
    /// The tare state at this frame.
    pub tare: &'a TareState,
}

/// One frame of an array design.
#[derive(Debug, Clone, Copy)]
pub struct ArrayReading<'a> {
    /// The frame's time, ns.
    pub frame_time_ns: u64,
    /// Load per cell, N, in the design's cell order.
    pub cell_loads_n: &'a [f64],
    /// The load-weighted contact centroid `[x, y, z]`, m, in the array's frame (x, y on
    /// the sheet, +y up as the views draw it; z = 0); `None` when nothing is in contact
    /// (nothing is published on `/fbgforge/contact` for this frame).
    pub contact_centroid_m: Option<[f64; 3]>,
    /// Peak wavelength per grating, nm; `None` for a missing peak (published as NaN).
    pub peaks_nm: &'a [Option<f64>],
    /// The frame's trust flags, one word each.
    pub flags: &'a [String],
    /// The tare state at this frame.
    pub tare: &'a TareState,
}

/// What [`McapRecorder::finish`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordingSummary {
    /// The finished file.
    pub path: PathBuf,
    /// Frames recorded.
    pub frames: u64,
    /// Messages per topic.
    pub messages_per_topic: BTreeMap<String, u64>,
}

impl RecordingSummary {
    /// Messages on every topic.
    pub fn message_count(&self) -> u64 {
        self.messages_per_topic.values().sum()
    }
}

#[derive(Debug)]
struct ChannelSlot {
    id: u16,
    topic: String,
    messages: u64,
}

/// Records a live run as an MCAP file of ROS 2 messages (see the [module](self) for the
/// topics, units and frames).
///
/// ```
/// use fbgforge_publish::{McapRecorder, ModuleReading, RecorderSetup, SensorLayout, TareState};
///
/// let dir = std::env::temp_dir().join(format!("fbgforge-publish-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
/// let path = dir.join("run.mcap");
/// let setup = RecorderSetup {
///     design_name: "clip-on-10mm".into(),
///     sensor: SensorLayout::Module { core_labels: vec!["psc1".into()] },
///     grating_labels: vec!["lambda_11".into(), "lambda_12".into()],
/// };
/// let mut rec = McapRecorder::create(&path, setup)?;
/// assert!(rec.partial_path().exists() && !path.exists());
/// for k in 0..3u64 {
///     rec.record_module(&ModuleReading {
///         frame_time_ns: 1_700_000_000_000_000_000 + k * 1_000_000,
///         core_forces_n: &[Some(5.0)],
///         peaks_nm: &[Some(1549.9), None],
///         flags: &[],
///         tare: &TareState::Resting,
///     })?;
/// }
/// let summary = rec.finish()?;
/// assert!(path.exists());
/// assert_eq!(summary.messages_per_topic["/fbgforge/psc1/wrench"], 3);
/// assert_eq!(summary.messages_per_topic["/fbgforge/tare"], 1); // on change only
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct McapRecorder {
    writer: Option<::mcap::Writer<BufWriter<File>>>,
    final_path: PathBuf,
    partial_path: PathBuf,
    setup: RecorderSetup,
    channels: Vec<ChannelSlot>,
    /// Module: the wrench channel of each core; array: `[cells, contact]`.
    reading_channels: Vec<usize>,
    core_frame_ids: Vec<String>,
    peaks: usize,
    flags: usize,
    tare: usize,
    last_tare: Option<TareState>,
    frames: u64,
    failed: bool,
}

fn check_labels(what: &str, labels: &[String]) -> Result<(), PublishError> {
    if labels.is_empty() {
        return Err(PublishError::Labels(format!("no {what}")));
    }
    let mut seen = std::collections::BTreeSet::new();
    for l in labels {
        if l.is_empty() {
            return Err(PublishError::Labels(format!("an empty {what} label")));
        }
        if !seen.insert(l.as_str()) {
            return Err(PublishError::Labels(format!(
                "{what} label {l:?} given twice"
            )));
        }
    }
    Ok(())
}

fn check_setup(setup: &RecorderSetup) -> Result<(), PublishError> {
    check_labels("grating", &setup.grating_labels)?;
    match &setup.sensor {
        SensorLayout::Array { cell_labels } => check_labels("cell", cell_labels),
        SensorLayout::Module { core_labels } => {
            check_labels("core", core_labels)?;
            let mut topics = BTreeMap::new();
            for c in core_labels {
                if let Some(other) = topics.insert(wrench_topic(c), c) {
                    return Err(PublishError::Labels(format!(
                        "cores {other:?} and {c:?} would share the topic {}",
                        wrench_topic(c)
                    )));
                }
            }
            Ok(())
        }
    }
}

fn json_labels(labels: &[String]) -> String {
    serde_json::to_string(labels).expect("strings serialise")
}

fn partial_path_of(path: &Path) -> Result<PathBuf, PublishError> {
    let name = path.file_name().ok_or_else(|| PublishError::Io {
        path: path.to_owned(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"),
    })?;
    let mut partial = name.to_owned();
    partial.push(".partial");
    Ok(path.with_file_name(partial))
}

fn meta(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
    pairs
        .iter()
        .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
        .collect()
}

impl McapRecorder {
    /// Starts a recording to `path` (written as `<path>.partial` until
    /// [`finish`](Self::finish)): the header, schemas, channels and a metadata record.
    pub fn create(path: impl AsRef<Path>, setup: RecorderSetup) -> Result<Self, PublishError> {
        check_setup(&setup)?;
        let final_path = path.as_ref().to_owned();
        let partial_path = partial_path_of(&final_path)?;
        // The folder is made as for every other output file of fbgforge.
        if let Some(dir) = final_path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| PublishError::Io {
                path: dir.to_owned(),
                source,
            })?;
        }
        let file = File::create(&partial_path).map_err(|source| PublishError::Io {
            path: partial_path.clone(),
            source,
        })?;
        let options = ::mcap::WriteOptions::new()
            .compression(None)
            .profile("ros2")
            .library(format!("fbgforge-publish {}", env!("CARGO_PKG_VERSION")));
        let writer = options.create(BufWriter::new(file))?;
        let mut rec = McapRecorder {
            writer: Some(writer),
            final_path,
            partial_path,
            setup,
            channels: Vec::new(),
            reading_channels: Vec::new(),
            core_frame_ids: Vec::new(),
            peaks: 0,
            flags: 0,
            tare: 0,
            last_tare: None,
            frames: 0,
            failed: false,
        };
        rec.add_channels()?;
        rec.write_metadata_record()?;
        Ok(rec)
    }

    fn add_channel<M: Ros2Message>(
        &mut self,
        topic: &str,
        extra: &[(&str, &str)],
    ) -> Result<usize, PublishError> {
        let w = self.writer.as_mut().expect("open while recording");
        let schema = w.add_schema(M::TYPE_NAME, "ros2msg", M::schema_text().as_bytes())?;
        let mut metadata = meta(extra);
        metadata.insert("design".into(), self.setup.design_name.clone());
        let id = w.add_channel(schema, topic, "cdr", &metadata)?;
        self.channels.push(ChannelSlot {
            id,
            topic: topic.to_owned(),
            messages: 0,
        });
        Ok(self.channels.len() - 1)
    }

    fn add_channels(&mut self) -> Result<(), PublishError> {
        match self.setup.sensor.clone() {
            SensorLayout::Module { core_labels } => {
                for core in &core_labels {
                    let frame_id = core_frame_id(core);
                    let extra = [
                        ("core", core.as_str()),
                        ("unit", "N"),
                        ("frame_id", frame_id.as_str()),
                        ("axis", "force.z: along the module axis; x, y and torque 0"),
                    ];
                    let slot = self.add_channel::<WrenchStamped>(&wrench_topic(core), &extra)?;
                    self.reading_channels.push(slot);
                    self.core_frame_ids.push(frame_id);
                }
            }
            SensorLayout::Array { cell_labels } => {
                let labels = json_labels(&cell_labels);
                let extra = [("unit", "N"), ("dimension", DIM_CELLS), ("labels", &labels)];
                let cells = self.add_channel::<Float64MultiArray>(TOPIC_CELLS, &extra)?;
                let extra = [("unit", "m"), ("frame_id", FRAME_ID_ARRAY)];
                let contact = self.add_channel::<PointStamped>(TOPIC_CONTACT, &extra)?;
                self.reading_channels = vec![cells, contact];
            }
        }
        let labels = json_labels(&self.setup.grating_labels);
        let extra = [
            ("unit", "nm"),
            ("dimension", DIM_GRATINGS),
            ("labels", &labels),
            ("missing", "NaN"),
        ];
        self.peaks = self.add_channel::<Float64MultiArray>(TOPIC_PEAKS, &extra)?;
        let extra = [("format", "trust flags, comma-separated; empty when trusted")];
        self.flags = self.add_channel::<StringMessage>(TOPIC_FLAGS, &extra)?;
        let extra = [
            (
                "format",
                "resting | waiting | nominal | refused: moving gratings …",
            ),
            ("published", "on the first frame and on each change"),
        ];
        self.tare = self.add_channel::<StringMessage>(TOPIC_TARE, &extra)?;
        Ok(())
    }

    fn write_metadata_record(&mut self) -> Result<(), PublishError> {
        let (kind, key, labels) = match &self.setup.sensor {
            SensorLayout::Module { core_labels } => ("module", "core_labels", core_labels),
            SensorLayout::Array { cell_labels } => ("array", "cell_labels", cell_labels),
        };
        let metadata = meta(&[
            ("design", &self.setup.design_name),
            ("kind", kind),
            (key, &json_labels(labels)),
            ("grating_labels", &json_labels(&self.setup.grating_labels)),
            (
                "units",
                "force N, load N, position m, wavelength nm, time ns",
            ),
        ]);
        let record = ::mcap::records::Metadata {
            name: "fbgforge".into(),
            metadata,
        };
        self.writer
            .as_mut()
            .expect("open while recording")
            .write_metadata(&record)?;
        Ok(())
    }

    /// The file being written until [`finish`](Self::finish): `<path>.partial`.
    pub fn partial_path(&self) -> &Path {
        &self.partial_path
    }

    /// The file [`finish`](Self::finish) renames the recording to.
    pub fn path(&self) -> &Path {
        &self.final_path
    }

    /// Frames recorded so far.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    fn put<M: Ros2Message>(
        &mut self,
        slot: usize,
        time_ns: u64,
        msg: &M,
    ) -> Result<(), PublishError> {
        let ch = &mut self.channels[slot];
        let header = ::mcap::records::MessageHeader {
            channel_id: ch.id,
            // ROS 2's sequence numbers wrap too; MCAP's is 32-bit.
            sequence: ch.messages as u32,
            log_time: time_ns,
            publish_time: time_ns,
        };
        let w = self.writer.as_mut().expect("open while recording");
        w.write_to_known_channel(&header, &msg.to_cdr())?;
        ch.messages += 1;
        Ok(())
    }

    fn ready(&self, given: &'static str) -> Result<(), PublishError> {
        if self.failed || self.writer.is_none() {
            return Err(PublishError::Poisoned);
        }
        let setup = match self.setup.sensor {
            SensorLayout::Module { .. } => "module",
            SensorLayout::Array { .. } => "array",
        };
        if setup != given {
            return Err(PublishError::WrongKind { setup, given });
        }
        Ok(())
    }

    fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), PublishError> {
        if expected == got {
            Ok(())
        } else {
            Err(PublishError::LengthMismatch {
                what,
                expected,
                got,
            })
        }
    }

    /// Peaks, flags and (when it changed) the tare state: every frame's messages.
    fn put_common(
        &mut self,
        time_ns: u64,
        peaks_nm: &[Option<f64>],
        flags: &[String],
        tare: &TareState,
    ) -> Result<(), PublishError> {
        let peaks = peaks_nm.iter().map(|p| p.unwrap_or(f64::NAN)).collect();
        self.put(
            self.peaks,
            time_ns,
            &Float64MultiArray::labelled_1d(DIM_GRATINGS, peaks),
        )?;
        let text = StringMessage {
            data: flags.join(", "),
        };
        self.put(self.flags, time_ns, &text)?;
        if self.last_tare.as_ref() != Some(tare) {
            let text = StringMessage {
                data: tare.to_string(),
            };
            self.put(self.tare, time_ns, &text)?;
            self.last_tare = Some(tare.clone());
        }
        self.frames += 1;
        Ok(())
    }

    /// Runs `f`; an error leaves the recorder failed (the file stays `.partial`).
    fn guarded(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<(), PublishError>,
    ) -> Result<(), PublishError> {
        let r = f(self);
        if r.is_err() {
            self.failed = true;
        }
        r
    }

    /// Records one frame of a module design: a wrench per core that has a force, the
    /// peaks, the flags, and the tare state when it changed.
    pub fn record_module(&mut self, r: &ModuleReading<'_>) -> Result<(), PublishError> {
        self.ready("module")?;
        let cores = self.reading_channels.len();
        Self::check_len("core_forces_n", cores, r.core_forces_n.len())?;
        Self::check_len(
            "peaks_nm",
            self.setup.grating_labels.len(),
            r.peaks_nm.len(),
        )?;
        let stamp = Time::from_ns(r.frame_time_ns).ok_or(PublishError::FrameTimeOutOfRange {
            frame_time_ns: r.frame_time_ns,
        })?;
        self.guarded(|rec| {
            for (k, force_n) in r.core_forces_n.iter().enumerate() {
                let Some(force_n) = *force_n else { continue };
                let msg = WrenchStamped {
                    header: Header {
                        stamp,
                        frame_id: rec.core_frame_ids[k].clone(),
                    },
                    wrench: Wrench {
                        force: Vector3 {
                            x: 0.0,
                            y: 0.0,
                            z: force_n,
                        },
                        torque: Vector3::default(),
                    },
                };
                rec.put(rec.reading_channels[k], r.frame_time_ns, &msg)?;
            }
            rec.put_common(r.frame_time_ns, r.peaks_nm, r.flags, r.tare)
        })
    }

    /// Records one frame of an array design: the cell loads, the contact centroid (when
    /// there is one), the peaks, the flags, and the tare state when it changed.
    pub fn record_array(&mut self, r: &ArrayReading<'_>) -> Result<(), PublishError> {
        self.ready("array")?;
        let cells = match &self.setup.sensor {
            SensorLayout::Array { cell_labels } => cell_labels.len(),
            SensorLayout::Module { .. } => unreachable!("checked by ready"),
        };
        Self::check_len("cell_loads_n", cells, r.cell_loads_n.len())?;
        Self::check_len(
            "peaks_nm",
            self.setup.grating_labels.len(),
            r.peaks_nm.len(),
        )?;
        let stamp = Time::from_ns(r.frame_time_ns).ok_or(PublishError::FrameTimeOutOfRange {
            frame_time_ns: r.frame_time_ns,
        })?;
        self.guarded(|rec| {
            let loads = Float64MultiArray::labelled_1d(DIM_CELLS, r.cell_loads_n.to_vec());
            rec.put(rec.reading_channels[0], r.frame_time_ns, &loads)?;
            if let Some([x, y, z]) = r.contact_centroid_m {
                let msg = PointStamped {
                    header: Header {
                        stamp,
                        frame_id: FRAME_ID_ARRAY.to_owned(),
                    },
                    point: Point { x, y, z },
                };
                rec.put(rec.reading_channels[1], r.frame_time_ns, &msg)?;
            }
            rec.put_common(r.frame_time_ns, r.peaks_nm, r.flags, r.tare)
        })
    }

    /// Records one frame that gave no reading (taken into the tare window while
    /// waiting for rest, read while the tare was refused, or lacking a grating): its
    /// peaks, its flags, and the tare state when it changed. Nothing is published on
    /// the wrench, cells or contact topics for it.
    ///
    /// ```
    /// use fbgforge_publish::{McapRecorder, RecorderSetup, SensorLayout, TareState};
    ///
    /// let dir = std::env::temp_dir().join(format!("fbgforge-publish-unread-{}", std::process::id()));
    /// std::fs::create_dir_all(&dir)?;
    /// let setup = RecorderSetup {
    ///     design_name: "clip-on-10mm".into(),
    ///     sensor: SensorLayout::Module { core_labels: vec!["psc1".into()] },
    ///     grating_labels: vec!["lambda_11".into()],
    /// };
    /// let mut rec = McapRecorder::create(dir.join("run.mcap"), setup)?;
    /// rec.record_unread(1_000, &[Some(1549.9)], &[], &TareState::Waiting)?;
    /// let summary = rec.finish()?;
    /// assert_eq!(summary.frames, 1);
    /// assert_eq!(summary.messages_per_topic["/fbgforge/psc1/wrench"], 0);
    /// assert_eq!(summary.messages_per_topic["/fbgforge/tare"], 1);
    /// # std::fs::remove_dir_all(&dir)?;
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn record_unread(
        &mut self,
        frame_time_ns: u64,
        peaks_nm: &[Option<f64>],
        flags: &[String],
        tare: &TareState,
    ) -> Result<(), PublishError> {
        if self.failed || self.writer.is_none() {
            return Err(PublishError::Poisoned);
        }
        Self::check_len("peaks_nm", self.setup.grating_labels.len(), peaks_nm.len())?;
        Time::from_ns(frame_time_ns).ok_or(PublishError::FrameTimeOutOfRange { frame_time_ns })?;
        self.guarded(|rec| rec.put_common(frame_time_ns, peaks_nm, flags, tare))
    }

    /// Writes the summary, syncs the file to disk and renames `<path>.partial` to
    /// `<path>`. After an earlier error the `.partial` file is left and this fails.
    pub fn finish(mut self) -> Result<RecordingSummary, PublishError> {
        if self.failed {
            return Err(PublishError::Poisoned);
        }
        let mut writer = self.writer.take().ok_or(PublishError::Poisoned)?;
        writer.finish()?;
        let io_err = |path: &Path| {
            let path = path.to_owned();
            move |source| PublishError::Io { path, source }
        };
        let file = writer
            .into_inner()
            .into_inner()
            .map_err(|e| io_err(&self.partial_path)(e.into_error()))?;
        file.sync_all().map_err(io_err(&self.partial_path))?;
        drop(file);
        std::fs::rename(&self.partial_path, &self.final_path).map_err(io_err(&self.final_path))?;
        // The rename itself is made durable by syncing the directory (best effort: not
        // every platform can open a directory).
        if let Some(dir) = self.final_path.parent() {
            let dir = if dir.as_os_str().is_empty() {
                Path::new(".")
            } else {
                dir
            };
            if let Ok(d) = File::open(dir) {
                let _ = d.sync_all();
            }
        }
        Ok(RecordingSummary {
            path: self.final_path.clone(),
            frames: self.frames,
            messages_per_topic: self
                .channels
                .iter()
                .map(|c| (c.topic.clone(), c.messages))
                .collect(),
        })
    }
}

impl std::fmt::Debug for McapRecorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapRecorder")
            .field("partial_path", &self.partial_path)
            .field("final_path", &self.final_path)
            .field("frames", &self.frames)
            .field("failed", &self.failed)
            .finish_non_exhaustive()
    }
}
