//! `live --record FILE`: the raw peaks of a run, read back exactly. Replayed with
//! `live --from FILE --from-start` and the same settings, the record gives the same
//! tare (the same frames, the same baseline) and the same readings, bit for bit; its
//! shifts file given to `reconstruct --shifts` gives the loads `live` showed.

use serde_json::Value;
use std::path::Path;
use std::process::Stdio;

use crate::common;

fn jsonl(out: &[u8]) -> Vec<Value> {
    String::from_utf8_lossy(out)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

fn of_type<'a>(lines: &'a [Value], t: &str) -> Vec<&'a Value> {
    lines.iter().filter(|v| v["type"] == t).collect()
}

fn live(args: &[&str]) -> Vec<Value> {
    let o = common::bin()
        .arg("live")
        .args(args)
        .args(["--jsonl", "--tare-s", "0.2"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    jsonl(&o.stdout)
}

/// A script under load at the start (the tare waits for its rest), then loads.
const SCRIPT: &str = "hold_s,A,B,C,D,E,F,G,H
0.3,0,0,100,0,0,0,0,0
0.5,0,0,0,0,0,0,0,0
0.4,0,150,0,0,0,0,0,0
0.4,80,0,0,0,0,200,0,0
";

#[test]
fn the_record_replays_to_the_same_tare_and_readings_and_reconstructs_the_same_loads() {
    let dir = tempfile::tempdir().unwrap();
    let design = common::shipped_path("tactile-array-60x80.toml");
    let d = design.to_str().unwrap();
    let script = dir.path().join("script.csv");
    std::fs::write(&script, SCRIPT).unwrap();
    let mut stream = common::bin();
    stream
        .args(["synth-stream", d, "--port", "0", "--frame-clock", "client"])
        .args(["--duration-s", "1.6", "--noise", "paper", "--seed", "3"])
        .arg("--script")
        .arg(&script);
    let (mut server, from) = common::spawn_stream(stream);
    // Into a folder that does not exist yet: `live` makes it, as every output does.
    let record = dir.path().join("runs/today/run.csv");
    let rec = record.to_str().unwrap();
    let ran = live(&[d, "--from", &from, "--give-up-s", "1", "--record", rec]);
    server.wait().unwrap();
    assert!(!Path::new(&format!("{rec}.partial")).exists());

    // Replayed: the same tare changes at the same frames, the same readings.
    let replayed = live(&[d, "--from", rec, "--from-start", "--idle-exit-s", "0.3"]);
    let tares = |l: &[Value]| -> Vec<(Value, Value, Value)> {
        of_type(l, "tare")
            .iter()
            .map(|t| {
                (
                    t["state"].clone(),
                    t["frame"].clone(),
                    t["baseline_nm"].clone(),
                )
            })
            .collect()
    };
    let t = tares(&ran);
    assert!(t.len() >= 2, "waited under load, then tared: {t:?}");
    assert_eq!(t[0].0, "waiting");
    assert_eq!(t.last().unwrap().0, "resting");
    assert_eq!(t, tares(&replayed));
    let (a, b) = (of_type(&ran, "frame"), of_type(&replayed, "frame"));
    assert!(a.len() > 500, "{}", a.len());
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        for key in ["frame", "peaks_nm", "shifts_pm", "loads_g", "flags"] {
            assert_eq!(x[key], y[key], "{key}: {x} against {y}");
        }
    }
    let summary = |l: &[Value]| (*of_type(l, "summary").last().unwrap()).clone();
    assert_eq!(summary(&ran)["frames_in"], summary(&replayed)["frames_in"]);
    assert_eq!(summary(&replayed)["dropped"]["total"], 0);

    // The shifts file: `reconstruct` with the method live used, and every grating kept
    // (live reads one frame at a time and cannot judge a grating's scatter over a run,
    // which `reconstruct` does by default), gives the same loads (to the 0.001 g its
    // CSV prints).
    let out = dir.path().join("loads.csv");
    let shifts = dir.path().join("runs/today/run.shifts.csv");
    let method = of_type(&ran, "start")[0]["method"]
        .as_str()
        .expect("live names its method")
        .to_owned();
    let o = common::bin()
        .args([
            "reconstruct",
            "--design",
            d,
            "--method",
            &method,
            "--keep-all-gratings",
        ])
        .arg("--shifts")
        .arg(&shifts)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| {
            l.split(',')
                .skip(1)
                .take(8)
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), a.len());
    for (f, row) in a.iter().zip(&rows) {
        for (l, r) in f["loads_g"].as_array().unwrap().iter().zip(row) {
            assert!(
                (l.as_f64().unwrap() - r).abs() <= 0.0005 + 1e-9,
                "{f} against {row:?}"
            );
        }
    }
}
