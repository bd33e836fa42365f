//! The tare at rest, as a user meets it: `live` started while the demo stream of
//! `synth-stream` is under load waits for the script's rest, tares there and then reads
//! the script (array: the right cells; module: the scripted force); a re-tare asked on
//! the control input is taken on the next window at rest, and the record marks the tare
//! and every re-tare. The record read back by `live` and `reconstruct` is
//! `live_record.rs`.

use serde_json::Value;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Child, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

use crate::common;

/// `synth-stream` of `design` with its demo script, on the instrument's clock (frames
/// pass while nobody reads, as with the real one); returns the child and its address.
fn demo_stream(design: &Path, duration_s: &str) -> (Child, String) {
    let mut stream = common::bin();
    stream
        .args(["synth-stream", design.to_str().unwrap(), "--port", "0"])
        .args([
            "--duration-s",
            duration_s,
            "--seed",
            "5",
            "--noise",
            "paper",
        ])
        .stderr(Stdio::null());
    common::spawn_stream(stream)
}

/// The demo script's value at frame `serial` (1 kHz): `rest_s` of rest, then each step
/// of `steps` for 0.5 s, repeated.
fn demo_truth(serial: u64, rest_s: f64, steps: &[Vec<f64>]) -> Vec<f64> {
    let period = rest_s + 0.5 * steps.len() as f64;
    let t = (serial as f64 / 1000.0) % period;
    if t < rest_s {
        return vec![0.0; steps[0].len()];
    }
    let k = (((t - rest_s) / 0.5) as usize).min(steps.len() - 1);
    steps[k].clone()
}

/// Start `live --jsonl --record` on the demo stream `delay` after it started serving.
fn live_after(design: &Path, from: &str, record: &Path, delay: Duration) -> Vec<Value> {
    std::thread::sleep(delay);
    let o = common::bin()
        .args(["live", design.to_str().unwrap(), "--from", from, "--jsonl"])
        .args(["--give-up-s", "1", "--record"])
        .arg(record)
        .stdin(Stdio::null())
        .output()
        .expect("live runs");
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// The instrument's counter of the record's first row (`# serial N`).
fn first_serial(record: &Path) -> u64 {
    let text = std::fs::read_to_string(record).unwrap();
    text.lines()
        .find_map(|l| l.strip_prefix("# serial "))
        .and_then(|n| n.trim().parse().ok())
        .expect("a `# serial` line")
}

fn of_type<'a>(lines: &'a [Value], t: &str) -> Vec<&'a Value> {
    lines.iter().filter(|v| v["type"] == t).collect()
}

/// What every start under load must show: it began in a load step, waited (naming
/// moving gratings), tared on a window that lies in the script's rest, lost no frame.
/// Returns the first serial.
fn check_start_under_load(lines: &[Value], record: &Path, rest_s: f64, steps: &[Vec<f64>]) -> u64 {
    let s0 = first_serial(record);
    assert!(
        demo_truth(s0, rest_s, steps).iter().any(|&v| v != 0.0),
        "live started at serial {s0}, in the rest: the test must start it under load"
    );
    let tares = of_type(lines, "tare");
    let waiting = tares
        .iter()
        .find(|t| t["state"] == "waiting")
        .expect("waited");
    assert!(
        !waiting["moving"].as_array().unwrap().is_empty(),
        "{waiting}"
    );
    assert!(waiting["message"].as_str().unwrap().contains("moving: "));
    let rested: Vec<&&Value> = tares.iter().filter(|t| t["state"] == "resting").collect();
    assert_eq!(rested.len(), 1, "one tare: {tares:?}");
    let w = rested[0]["window_frames"].as_array().unwrap();
    for f in [w[0].as_u64().unwrap(), w[1].as_u64().unwrap()] {
        // Row n of the record is frame n, serial s0 + n − 1 (no frame lost: below).
        let serial = s0 + f - 1;
        assert!(
            demo_truth(serial, rest_s, steps).iter().all(|&v| v == 0.0),
            "tare window frame {f} (serial {serial}) is not in the script's rest"
        );
    }
    let summary = *of_type(lines, "summary").last().unwrap();
    assert_eq!(summary["dropped"]["total"], 0, "{summary}");
    assert_eq!(summary["tare"], "resting", "{summary}");
    s0
}

#[test]
fn a_start_under_load_waits_for_rest_and_then_reads_the_demo_script() {
    let dir = tempfile::tempdir().unwrap();
    let array = common::shipped_path("tactile-array-60x80.toml");
    let module = common::shipped_path("clip-on-34mm.toml");
    // The demo scripts (`synth::stream::default_script`): 1.5 s of rest, then 0.5 s
    // steps. Array: 100 g on each cell in turn, then 50 g on B with 200 g on G (6 s a
    // pass); module: 2, 5, 10, 5 N, then 5 N with +2 K (4 s a pass).
    let rest_s = fbgforge::synth::stream::DEMO_REST_S;
    let mut array_steps: Vec<Vec<f64>> = (0..8)
        .map(|k| (0..8).map(|j| if j == k { 100.0 } else { 0.0 }).collect())
        .collect();
    array_steps.push(vec![0.0, 50.0, 0.0, 0.0, 0.0, 0.0, 200.0, 0.0]);
    let module_steps: Vec<Vec<f64>> = [2.0, 5.0, 10.0, 5.0, 5.0]
        .iter()
        .map(|&f| vec![f])
        .collect();
    // Started 2 s in: the array is in its second load step (B), the module in its
    // second (5 N): the starts. Both run at once (12.5 s and 8.5 s).
    let (mut sa, from_a) = demo_stream(&array, "12.5");
    let (mut sm, from_m) = demo_stream(&module, "8.5");
    let rec_a = dir.path().join("array.csv");
    let rec_m = dir.path().join("module.csv");
    let (a2, ra2, m2, rm2) = (array.clone(), rec_a.clone(), module.clone(), rec_m.clone());
    let ta = std::thread::spawn(move || live_after(&a2, &from_a, &ra2, Duration::from_secs(2)));
    let tm = std::thread::spawn(move || live_after(&m2, &from_m, &rm2, Duration::from_secs(2)));
    let (la, lm) = (ta.join().unwrap(), tm.join().unwrap());
    sa.wait().unwrap();
    sm.wait().unwrap();

    check_start_under_load(&la, &rec_a, rest_s, &array_steps);
    let frames = of_type(&la, "frame");
    assert!(
        frames.len() > 3000,
        "the second pass is read: {}",
        frames.len()
    );
    let mut loaded = 0;
    for f in &frames {
        let truth = demo_truth(f["serial"].as_u64().unwrap(), rest_s, &array_steps);
        let est: Vec<f64> = f["loads_g"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let err = est
            .iter()
            .zip(&truth)
            .map(|(e, t)| (e - t).abs())
            .fold(0.0, f64::max);
        // Before: 100 g on A read as 19 g on C, every loaded frame flagged. The paper's
        // noise gives up to ~20 g on one cell; 40 g apart is a wrong answer, allowed
        // only where the frame says so (a rival explains it as well: `ambiguous`, or
        // the readings do not fit: `inconsistent`); the flagged share is bounded below.
        let flags = f["flags"].as_array().unwrap();
        let owned = flags
            .iter()
            .any(|x| x == "ambiguous" || x == "inconsistent");
        assert!(err < 40.0 || owned, "frame {f}: truth {truth:?}");
        loaded += usize::from(truth.iter().any(|&v| v > 0.0));
    }
    assert!(loaded > 2000, "{loaded} loaded frames read");
    let flagged = frames
        .iter()
        .filter(|f| !f["flags"].as_array().unwrap().is_empty())
        .count();
    // Before: 100 % of the loaded frames flagged. Since issue 35 the flags rest on a
    // χ² test of stated size α = 0.05 (docs/array.md §11.1): on frames the model
    // explains, at most that share is flagged `inconsistent` by chance (measured here
    // 2.2 %: the stream's noise is under the resolution the test assumes).
    assert!(
        flagged * 20 < frames.len(),
        "{flagged} of {} flagged",
        frames.len()
    );

    check_start_under_load(&lm, &rec_m, rest_s, &module_steps);
    let frames = of_type(&lm, "frame");
    assert!(frames.len() > 2000, "{}", frames.len());
    for f in &frames {
        let truth = demo_truth(f["serial"].as_u64().unwrap(), rest_s, &module_steps)[0];
        for force in f["forces_n"].as_array().unwrap() {
            // Before: +3.48 N where the script holds 5 N. 0.5 pm of noise on
            // |K| ≈ 170 pm/N is a few mN; 0.05 N is > 8 σ.
            let force = force.as_f64().unwrap();
            assert!(
                (force - truth).abs() < 0.05,
                "{force} N, truth {truth} N: {f}"
            );
        }
    }
}

/// Read `live --jsonl` lines from a child as they come.
fn lines_of(child: &mut Child) -> Receiver<Value> {
    let out = BufReader::new(child.stdout.take().unwrap());
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for l in out.lines() {
            let Ok(l) = l else { return };
            let v: Value = serde_json::from_str(&l).unwrap_or_else(|e| panic!("{e}: {l}"));
            if tx.send(v).is_err() {
                return;
            }
        }
    });
    rx
}

/// Wait (at most 20 s) for a line that `want` accepts; the lines before it are kept.
fn wait_for(rx: &Receiver<Value>, seen: &mut Vec<Value>, want: impl Fn(&Value) -> bool) -> Value {
    let t0 = Instant::now();
    loop {
        let left = Duration::from_secs(20).saturating_sub(t0.elapsed());
        let v = rx
            .recv_timeout(left)
            .unwrap_or_else(|e| panic!("{e}: no such line after {seen:?}"));
        seen.push(v.clone());
        if want(&v) {
            return v;
        }
    }
}

#[test]
fn a_control_line_re_tares_on_the_next_rest_and_the_record_marks_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = common::shipped("tactile-array-60x80.toml");
    let nominal: Vec<f64> = d
        .array
        .as_ref()
        .unwrap()
        .gratings
        .iter()
        .map(|g| g.bragg_wavelength_nm)
        .collect();
    let frame = |offset_pm: f64| -> String {
        let w: Vec<String> = nominal
            .iter()
            .map(|l| format!("{}", l + offset_pm * 1e-3))
            .collect();
        w.join(" ") + "\n"
    };
    let control = dir.path().join("control.txt");
    std::fs::write(&control, "").unwrap();
    let record = dir.path().join("rec.csv");
    let path = common::shipped_path("tactile-array-60x80.toml");
    let mut child = common::bin()
        .args(["live", path.to_str().unwrap(), "--from", "-", "--jsonl"])
        .args(["--tare-frames", "10", "--tare-s", "0", "--control"])
        .arg(&control)
        .arg("--record")
        .arg(&record)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let rx = lines_of(&mut child);
    let mut seen = Vec::new();
    let is_tare = |state: &'static str, origin: &'static str| {
        move |v: &Value| v["type"] == "tare" && v["state"] == state && v["origin"] == origin
    };
    // At rest on the nominal wavelengths: tared on frames 1–10.
    stdin.write_all(frame(0.0).repeat(10).as_bytes()).unwrap();
    stdin.flush().unwrap();
    let t = wait_for(&rx, &mut seen, is_tare("resting", "start"));
    for (b, n) in t["baseline_nm"].as_array().unwrap().iter().zip(&nominal) {
        assert!((b.as_f64().unwrap() - n).abs() < 1e-9, "{t}");
    }
    // Every grating 30 pm up (the sensor warmed): frames 11–13 read as shifts of 30 pm.
    stdin.write_all(frame(30.0).repeat(3).as_bytes()).unwrap();
    stdin.flush().unwrap();
    let f = wait_for(&rx, &mut seen, |v| v["type"] == "frame");
    for s in f["shifts_pm"].as_array().unwrap() {
        assert!((s.as_f64().unwrap() - 30.0).abs() < 1e-6, "{f}");
    }
    // A bad control line is named; `tare` starts a new tare at once.
    std::fs::OpenOptions::new()
        .append(true)
        .open(&control)
        .unwrap()
        .write_all(b"zero\ntare\n")
        .unwrap();
    let e = wait_for(&rx, &mut seen, |v| {
        v["type"] == "event" && v["event"] == "control"
    });
    assert!(e["message"].as_str().unwrap().contains("`zero`"), "{e}");
    wait_for(&rx, &mut seen, is_tare("waiting", "control"));
    // The new window: frames 14–23, then 24–25 are read.
    stdin.write_all(frame(30.0).repeat(10).as_bytes()).unwrap();
    stdin.flush().unwrap();
    let t = wait_for(&rx, &mut seen, is_tare("resting", "control"));
    for (b, n) in t["baseline_nm"].as_array().unwrap().iter().zip(&nominal) {
        assert!((b.as_f64().unwrap() - n - 0.030).abs() < 1e-9, "{t}");
    }
    stdin.write_all(frame(30.0).repeat(2).as_bytes()).unwrap();
    drop(stdin);
    let rest: Vec<Value> = rx.iter().collect();
    seen.extend(rest);
    assert_eq!(child.wait().unwrap().code(), Some(0));
    // The frames after the re-tare read no shift and no load.
    let frames = of_type(&seen, "frame");
    let after = &frames[frames.len() - 2..];
    for f in after {
        for s in f["shifts_pm"].as_array().unwrap() {
            assert!(s.as_f64().unwrap().abs() < 1e-6, "{f}");
        }
        assert!(
            f["loads_g"].as_array().unwrap().iter().all(|v| v == 0.0),
            "{f}"
        );
    }
    let summary = *of_type(&seen, "summary").last().unwrap();
    assert_eq!(summary["tare_requests"], 1, "{summary}");
    // 10 + 10 frames taken into the tares, 3 + 2 read.
    assert_eq!(summary["frames_in"], 25, "{summary}");
    assert_eq!(summary["frames_out"], 5, "{summary}");
    assert_eq!(summary["tare_frames"], 20, "{summary}");
    // The record marks the tare and the re-tare, each with its baseline.
    let text = std::fs::read_to_string(&record).unwrap();
    let marks: Vec<&str> = text.lines().filter(|l| l.starts_with("# tare ")).collect();
    assert!(
        marks
            .iter()
            .any(|l| l.starts_with("# tare resting (start) at frame 10")),
        "{marks:?}"
    );
    assert!(
        marks
            .iter()
            .any(|l| l.starts_with("# tare waiting (control) at frame 13")),
        "{marks:?}"
    );
    assert!(
        marks
            .iter()
            .any(|l| l.starts_with("# tare resting (control) at frame 23")),
        "{marks:?}"
    );
    let rows = text.lines().filter(|l| !l.starts_with('#')).count();
    assert_eq!(rows, 1 + 25, "a header and every frame: {text}");
}
