//! A scripted module run and a scripted array run recorded as MCAP, read back:
//!
//! * always, in Rust: the `mcap` crate's reader (header, schemas, channels, statistics,
//!   metadata, every message) and this crate's CDR decoder;
//! * when `FBGFORGE_PYTHON` names a Python with the PyPI packages `mcap` and
//!   `mcap-ros2-support`, by `tests/read_mcap.py`, which decodes every message with
//!   them (and re-encodes each to compare bytes). Under `CI=true` that Python is
//!   required: CI must not pass without the outside reader.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use fbgforge_publish::ros2::{
    Float64MultiArray, PointStamped, Ros2Message, StringMessage, WrenchStamped,
};
use fbgforge_publish::{
    ArrayReading, McapRecorder, ModuleReading, PublishError, RecorderSetup, SensorLayout, TareState,
};
use serde_json::Value;

const T0_NS: u64 = 1_700_000_000_000_000_000;
const MS: u64 = 1_000_000;
/// 100 g in N.
const G100_N: f64 = 0.1 * 9.806_65;

fn labels(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// The module script: 10 frames at 1 kHz; tare waiting for 3 frames, then resting;
/// psc1 ramps 0, 0.5, … 4.5 N; psc2 holds 5 N but misses frame 4; frame 7 misses the
/// peak of lambda_22; frame 5 is flagged `ceiling`.
fn module_force(core: usize, k: u64) -> Option<f64> {
    match core {
        0 => Some(0.5 * k as f64),
        _ => (k != 4).then_some(5.0),
    }
}
const GRATINGS_MODULE: [&str; 5] = [
    "lambda_11",
    "lambda_12",
    "lambda_21",
    "lambda_22",
    "lambda_ref",
];

fn module_peak(g: usize, k: u64) -> Option<f64> {
    (!(k == 7 && g == 3)).then_some(1530.0 + 5.0 * g as f64 + 0.001 * k as f64)
}

fn record_module(path: &Path) {
    let setup = RecorderSetup {
        design_name: "clip-on-10mm".into(),
        sensor: SensorLayout::Module {
            core_labels: labels(&["psc1", "psc2"]),
        },
        grating_labels: labels(&GRATINGS_MODULE),
    };
    let mut rec = McapRecorder::create(path, setup).unwrap();
    for k in 0..10u64 {
        let forces = [module_force(0, k), module_force(1, k)];
        let peaks: Vec<_> = (0..5).map(|g| module_peak(g, k)).collect();
        let flags = if k == 5 { labels(&["ceiling"]) } else { vec![] };
        let tare = if k < 3 {
            TareState::Waiting
        } else {
            TareState::Resting
        };
        rec.record_module(&ModuleReading {
            frame_time_ns: T0_NS + k * MS,
            core_forces_n: &forces,
            peaks_nm: &peaks,
            flags: &flags,
            tare: &tare,
        })
        .unwrap();
    }
    assert!(!path.exists(), "the final file appears only on finish");
    let summary = rec.finish().unwrap();
    assert_eq!(summary.frames, 10);
    assert_eq!(summary.message_count(), 10 + 9 + 10 + 10 + 2);
}

/// The array script: 6 frames at 1 kHz over cells A–H; 100 g on B in frames 2–4
/// (contact at B's centre), nothing else; frame 0 waits for rest, frame 1 on rests;
/// frame 3 is flagged `inconsistent`.
const CELLS: [&str; 8] = ["A", "B", "C", "D", "E", "F", "G", "H"];
const CENTRE_B_M: [f64; 3] = [0.0225, 0.0075, 0.0];

fn array_loads(k: u64) -> Vec<f64> {
    let mut loads = vec![0.0; 8];
    if (2..=4).contains(&k) {
        loads[1] = G100_N;
    }
    loads
}

fn record_array(path: &Path) {
    let setup = RecorderSetup {
        design_name: "tactile-array-60x80".into(),
        sensor: SensorLayout::Array {
            cell_labels: labels(&CELLS),
        },
        grating_labels: labels(&["g1", "g2", "g3", "g4", "g5", "g6"]),
    };
    let mut rec = McapRecorder::create(path, setup).unwrap();
    for k in 0..6u64 {
        let loads = array_loads(k);
        let peaks: Vec<_> = (0..6).map(|g| Some(1540.0 + g as f64)).collect();
        let flags = if k == 3 {
            labels(&["inconsistent"])
        } else {
            vec![]
        };
        let tare = if k == 0 {
            TareState::Waiting
        } else {
            TareState::Resting
        };
        rec.record_array(&ArrayReading {
            frame_time_ns: T0_NS + k * MS,
            cell_loads_n: &loads,
            contact_centroid_m: (2..=4).contains(&k).then_some(CENTRE_B_M),
            peaks_nm: &peaks,
            flags: &flags,
            tare: &tare,
        })
        .unwrap();
    }
    let summary = rec.finish().unwrap();
    assert_eq!(summary.message_count(), 6 + 3 + 6 + 6 + 2);
}

/// Every message of the file, decoded by this crate, grouped by topic.
#[derive(Default, Debug)]
struct Decoded {
    wrench: BTreeMap<String, Vec<(u64, WrenchStamped)>>,
    arrays: BTreeMap<String, Vec<(u64, Float64MultiArray)>>,
    points: Vec<(u64, PointStamped)>,
    strings: BTreeMap<String, Vec<(u64, String)>>,
}

/// The structural check with the `mcap` crate's reader.
fn read_back(path: &Path, design: &str) -> Decoded {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&bytes)
        .unwrap()
        .expect("a summary section");
    for schema in summary.schemas.values() {
        assert_eq!(schema.encoding, "ros2msg");
        let text = std::str::from_utf8(&schema.data).unwrap();
        let want = fbgforge_publish::ros2::schema::full_text(&schema.name).unwrap();
        assert_eq!(text, want, "schema {}", schema.name);
    }
    for ch in summary.channels.values() {
        assert_eq!(ch.message_encoding, "cdr", "{}", ch.topic);
        assert_eq!(ch.metadata["design"], design, "{}", ch.topic);
        assert!(ch.topic.starts_with("/fbgforge/"), "{}", ch.topic);
    }
    let meta_index = &summary.metadata_indexes;
    assert_eq!(meta_index.len(), 1);
    let meta = mcap::read::metadata(&bytes, &meta_index[0]).unwrap();
    assert_eq!(meta.name, "fbgforge");
    assert_eq!(meta.metadata["design"], design);

    let mut out = Decoded::default();
    let mut count = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        count += 1;
        assert_eq!(m.log_time, m.publish_time);
        let topic = m.channel.topic.clone();
        let schema = m.channel.schema.as_ref().expect("a schema").name.clone();
        let t = m.log_time;
        match schema.as_str() {
            "geometry_msgs/msg/WrenchStamped" => out
                .wrench
                .entry(topic)
                .or_default()
                .push((t, WrenchStamped::from_cdr(&m.data).unwrap())),
            "std_msgs/msg/Float64MultiArray" => out
                .arrays
                .entry(topic)
                .or_default()
                .push((t, Float64MultiArray::from_cdr(&m.data).unwrap())),
            "geometry_msgs/msg/PointStamped" => out
                .points
                .push((t, PointStamped::from_cdr(&m.data).unwrap())),
            "std_msgs/msg/String" => out
                .strings
                .entry(topic)
                .or_default()
                .push((t, StringMessage::from_cdr(&m.data).unwrap().data)),
            other => panic!("unexpected schema {other}"),
        }
    }
    assert_eq!(summary.stats.unwrap().message_count, count);
    out
}

fn check_module_in_rust(path: &Path) {
    let d = read_back(path, "clip-on-10mm");
    let psc1 = &d.wrench["/fbgforge/psc1/wrench"];
    let psc2 = &d.wrench["/fbgforge/psc2/wrench"];
    assert_eq!((psc1.len(), psc2.len()), (10, 9));
    for (k, (t, w)) in psc1.iter().enumerate() {
        assert_eq!(*t, T0_NS + k as u64 * MS);
        assert_eq!(w.header.stamp.to_ns(), Some(*t));
        assert_eq!(w.header.frame_id, "fbgforge_psc1");
        assert_eq!(w.wrench.force.z, 0.5 * k as f64);
        assert_eq!((w.wrench.force.x, w.wrench.force.y), (0.0, 0.0));
        assert_eq!(w.wrench.torque, Default::default());
    }
    assert!(psc2
        .iter()
        .all(|(t, w)| w.wrench.force.z == 5.0 && *t != T0_NS + 4 * MS));
    let peaks = &d.arrays["/fbgforge/peaks"];
    assert_eq!(peaks.len(), 10);
    assert_eq!(peaks[7].1.layout.dim[0].label, "gratings");
    assert!(peaks[7].1.data[3].is_nan());
    assert_eq!(peaks[6].1.data[3], module_peak(3, 6).unwrap());
    let flags = &d.strings["/fbgforge/flags"];
    assert_eq!(flags.len(), 10);
    assert_eq!(flags[5].1, "ceiling");
    assert_eq!(flags[4].1, "");
    let tare = &d.strings["/fbgforge/tare"];
    assert_eq!(
        tare,
        &vec![
            (T0_NS, "waiting".to_string()),
            (T0_NS + 3 * MS, "resting".to_string())
        ]
    );
}

fn check_array_in_rust(path: &Path) {
    let d = read_back(path, "tactile-array-60x80");
    let cells = &d.arrays["/fbgforge/cells"];
    assert_eq!(cells.len(), 6);
    for (k, (_, a)) in cells.iter().enumerate() {
        let dim = &a.layout.dim;
        assert_eq!(
            (dim.len(), dim[0].label.as_str(), dim[0].size, dim[0].stride),
            (1, "cells", 8, 8)
        );
        assert_eq!(a.data, array_loads(k as u64));
    }
    assert_eq!(d.points.len(), 3);
    for (t, p) in &d.points {
        assert!((T0_NS + 2 * MS..=T0_NS + 4 * MS).contains(t));
        assert_eq!([p.point.x, p.point.y, p.point.z], CENTRE_B_M);
        assert_eq!(p.header.frame_id, "fbgforge_array");
    }
    assert_eq!(d.arrays["/fbgforge/peaks"].len(), 6);
    assert_eq!(d.strings["/fbgforge/flags"][3].1, "inconsistent");
    assert_eq!(d.strings["/fbgforge/tare"].len(), 2);
}

fn python() -> Option<PathBuf> {
    let py = std::env::var_os("FBGFORGE_PYTHON").filter(|p| !p.is_empty());
    if py.is_none() {
        let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false");
        assert!(
            !ci,
            "CI must decode the MCAP files with the Python readers: set FBGFORGE_PYTHON to a \
             python with the PyPI packages mcap and mcap-ros2-support"
        );
        eprintln!(
            "\n*** mcap_roundtrip: SKIPPED the Python readers (set FBGFORGE_PYTHON to a python \
             with `mcap` and `mcap-ros2-support`); the files were checked in Rust only ***\n"
        );
    }
    py.map(PathBuf::from)
}

/// `tests/read_mcap.py FILE` → its JSON, after the checks every file shares: no decoding
/// error, every message decoded and re-encoded to the same bytes.
fn read_with_python(py: &Path, file: &Path) -> Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/read_mcap.py");
    let out = Command::new(py).arg(&script).arg(file).output().unwrap();
    assert!(
        out.status.success(),
        "read_mcap.py: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["errors"], Value::Array(vec![]), "every message decodes");
    let n = v["statistics"]["message_count"].as_u64().unwrap();
    assert_eq!(v["messages"].as_array().unwrap().len() as u64, n);
    assert_eq!(v["profile"], "ros2");
    assert!(v["schemas"]
        .as_array()
        .unwrap()
        .iter()
        .all(|s| s["encoding"] == "ros2msg"));
    let re = &v["reencoded"];
    if re["available"] == true {
        assert_eq!(
            re["identical"].as_u64(),
            Some(n),
            "re-encoded by mcap-ros2-support: {re}"
        );
    }
    v
}

fn python_messages<'a>(v: &'a Value, topic: &str) -> Vec<&'a Value> {
    v["messages"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["topic"] == topic)
        .collect()
}

fn check_module_in_python(v: &Value) {
    let counts = &v["statistics"]["channel_message_counts"];
    let want = serde_json::json!({
        "/fbgforge/psc1/wrench": 10, "/fbgforge/psc2/wrench": 9,
        "/fbgforge/peaks": 10, "/fbgforge/flags": 10, "/fbgforge/tare": 2
    });
    assert_eq!(counts, &want);
    let psc1 = python_messages(v, "/fbgforge/psc1/wrench");
    let z: Vec<f64> = psc1
        .iter()
        .map(|m| m["msg"]["wrench"]["force"]["z"].as_f64().unwrap())
        .collect();
    assert_eq!(z, (0..10).map(|k| 0.5 * k as f64).collect::<Vec<_>>());
    let first = &psc1[0]["msg"];
    assert_eq!(first["header"]["frame_id"], "fbgforge_psc1");
    assert_eq!(first["header"]["stamp"]["sec"], 1_700_000_000);
    assert_eq!(first["header"]["stamp"]["nanosec"], 0);
    assert_eq!(psc1[3]["msg"]["header"]["stamp"]["nanosec"], 3_000_000);
    assert_eq!(psc1[3]["log_time"].as_u64(), Some(T0_NS + 3 * MS));
    let psc2 = python_messages(v, "/fbgforge/psc2/wrench");
    assert!(psc2.iter().all(|m| m["msg"]["wrench"]["force"]["z"] == 5.0));
    let peaks = python_messages(v, "/fbgforge/peaks");
    assert_eq!(peaks[7]["msg"]["layout"]["dim"][0]["label"], "gratings");
    assert_eq!(peaks[7]["msg"]["data"][3], "nan");
    assert_eq!(peaks[7]["msg"]["data"][0].as_f64(), module_peak(0, 7));
    let flags = python_messages(v, "/fbgforge/flags");
    assert_eq!(flags[5]["msg"]["data"], "ceiling");
    let tare: Vec<_> = python_messages(v, "/fbgforge/tare")
        .iter()
        .map(|m| m["msg"]["data"].clone())
        .collect();
    assert_eq!(tare, vec!["waiting", "resting"]);
    let peaks_channel = v["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["topic"] == "/fbgforge/peaks")
        .unwrap();
    assert_eq!(peaks_channel["metadata"]["unit"], "nm");
    assert_eq!(peaks_channel["schema"], "std_msgs/msg/Float64MultiArray");
    let labels: Vec<String> =
        serde_json::from_str(peaks_channel["metadata"]["labels"].as_str().unwrap()).unwrap();
    assert_eq!(labels, GRATINGS_MODULE);
}

fn check_array_in_python(v: &Value) {
    let counts = &v["statistics"]["channel_message_counts"];
    let want = serde_json::json!({
        "/fbgforge/cells": 6, "/fbgforge/contact": 3,
        "/fbgforge/peaks": 6, "/fbgforge/flags": 6, "/fbgforge/tare": 2
    });
    assert_eq!(counts, &want);
    let cells = python_messages(v, "/fbgforge/cells");
    let dim = &cells[3]["msg"]["layout"]["dim"];
    assert_eq!(
        dim,
        &serde_json::json!([{"label": "cells", "size": 8, "stride": 8}])
    );
    let loads: Vec<f64> = cells[3]["msg"]["data"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(loads, array_loads(3));
    let (arg_max, _) =
        loads
            .iter()
            .enumerate()
            .fold((0, f64::MIN), |a, (i, &x)| if x > a.1 { (i, x) } else { a });
    assert_eq!(CELLS[arg_max], "B");
    let contact = python_messages(v, "/fbgforge/contact");
    let p = &contact[0]["msg"]["point"];
    assert_eq!(
        [
            p["x"].as_f64().unwrap(),
            p["y"].as_f64().unwrap(),
            p["z"].as_f64().unwrap()
        ],
        CENTRE_B_M
    );
    assert_eq!(contact[0]["msg"]["header"]["frame_id"], "fbgforge_array");
    assert_eq!(contact[0]["log_time"].as_u64(), Some(T0_NS + 2 * MS));
    let peaks = python_messages(v, "/fbgforge/peaks");
    assert_eq!(
        peaks[0]["msg"]["data"],
        serde_json::json!([1540.0, 1541.0, 1542.0, 1543.0, 1544.0, 1545.0])
    );
    assert_eq!(v["metadata"]["fbgforge"]["kind"], "array");
}

#[test]
fn module_and_array_runs_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let module = dir.path().join("module.mcap");
    let array = dir.path().join("array.mcap");
    record_module(&module);
    record_array(&array);
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 2, "no .partial left after finish: {left:?}");
    check_module_in_rust(&module);
    check_array_in_rust(&array);
    if let Some(py) = python() {
        check_module_in_python(&read_with_python(&py, &module));
        check_array_in_python(&read_with_python(&py, &array));
    }
}

#[test]
fn a_recorder_dropped_without_finish_leaves_only_a_partial_file() {
    let dir = tempfile::tempdir().unwrap();
    // Into a folder that does not exist yet: made, as for every output.
    let path = dir.path().join("runs/today/run.mcap");
    let setup = RecorderSetup {
        design_name: "d".into(),
        sensor: SensorLayout::Module {
            core_labels: labels(&["c"]),
        },
        grating_labels: labels(&["g"]),
    };
    let mut rec = McapRecorder::create(&path, setup).unwrap();
    let partial = rec.partial_path().to_owned();
    assert_eq!(partial, dir.path().join("runs/today/run.mcap.partial"));
    rec.record_module(&ModuleReading {
        frame_time_ns: T0_NS,
        core_forces_n: &[Some(1.0)],
        peaks_nm: &[Some(1550.0)],
        flags: &[],
        tare: &TareState::Nominal,
    })
    .unwrap();
    drop(rec);
    assert!(!path.exists());
    // What was recorded is there, and readable.
    let bytes = std::fs::read(&partial).unwrap();
    let n = mcap::MessageStream::new(&bytes)
        .unwrap()
        .collect::<Result<Vec<_>, _>>()
        .unwrap()
        .len();
    assert_eq!(n, 4);
}

#[test]
fn bad_readings_and_setups_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let setup = |sensor| RecorderSetup {
        design_name: "d".into(),
        sensor,
        grating_labels: labels(&["g1", "g2"]),
    };
    let twice = McapRecorder::create(
        dir.path().join("a.mcap"),
        setup(SensorLayout::Array {
            cell_labels: labels(&["A", "A"]),
        }),
    );
    assert!(matches!(twice, Err(PublishError::Labels(_))), "{twice:?}");
    let clash = McapRecorder::create(
        dir.path().join("b.mcap"),
        setup(SensorLayout::Module {
            core_labels: labels(&["c 1", "c-1"]),
        }),
    );
    assert!(matches!(clash, Err(PublishError::Labels(m)) if m.contains("/fbgforge/c_1/wrench")));

    let mut rec = McapRecorder::create(
        dir.path().join("c.mcap"),
        setup(SensorLayout::Array {
            cell_labels: labels(&["A", "B"]),
        }),
    )
    .unwrap();
    let peaks = [Some(1550.0), Some(1551.0)];
    let good = ArrayReading {
        frame_time_ns: T0_NS,
        cell_loads_n: &[0.0, 1.0],
        contact_centroid_m: None,
        peaks_nm: &peaks,
        flags: &[],
        tare: &TareState::Resting,
    };
    let short = ArrayReading {
        cell_loads_n: &[0.0],
        ..good
    };
    assert!(matches!(
        rec.record_array(&short),
        Err(PublishError::LengthMismatch {
            what: "cell_loads_n",
            expected: 2,
            got: 1
        })
    ));
    let late = ArrayReading {
        frame_time_ns: u64::MAX,
        ..good
    };
    assert!(matches!(
        rec.record_array(&late),
        Err(PublishError::FrameTimeOutOfRange { .. })
    ));
    let module = ModuleReading {
        frame_time_ns: T0_NS,
        core_forces_n: &[],
        peaks_nm: &peaks,
        flags: &[],
        tare: &TareState::Resting,
    };
    assert!(matches!(
        rec.record_module(&module),
        Err(PublishError::WrongKind {
            setup: "array",
            given: "module"
        })
    ));
    // Rejected readings write nothing and do not spoil the recording.
    rec.record_array(&good).unwrap();
    let summary = rec.finish().unwrap();
    assert_eq!(summary.frames, 1);
    assert_eq!(summary.messages_per_topic["/fbgforge/contact"], 0);
}
