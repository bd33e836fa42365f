//! How a live run ends and what its clock says: a lost instrument ("gave up
//! reconnecting") exits with its own status, apart from a clean end (a finite stream
//! that says it ended, a file read to its end); the frames' age is measured only where
//! the stream's clock is this machine's wall clock, so replaying an old log never
//! reports an age of days. The other ends (replay without drops, signals, a closed
//! pipe, a missing or deleted file, a malformed frame counted once) are in
//! `live_stop.rs`.

use serde_json::Value;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Output, Stdio};
use std::time::{SystemTime, UNIX_EPOCH};

use crate::common;

/// `live --jsonl` to its end. These logs are at rest from their first row: a tare
/// window of their first frames (no minimum time) unless the test says otherwise.
fn live(args: &[&str]) -> Output {
    let mut c = crate::common::bin();
    c.current_dir(env!("CARGO_MANIFEST_DIR"))
        .arg("live")
        .args(args)
        .arg("--jsonl");
    if !args.contains(&"--tare-s") {
        c.args(["--tare-s", "0"]);
    }
    c.stdin(Stdio::null()).output().expect("live runs")
}

fn lines(o: &Output) -> Vec<Value> {
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

fn summary(o: &Output) -> Value {
    lines(o)
        .into_iter()
        .rfind(|v| v["type"] == "summary")
        .expect("a summary line")
}

/// The exit status `fbgforge live` gives a lost source (documented in `--help`).
const LOST: i32 = 3;

#[test]
fn a_lost_instrument_exits_with_its_own_status_a_finite_stream_with_0() {
    let array = common::shipped_path("tactile-array-60x80.toml");
    let a = array.to_str().unwrap();
    let start_server = |duration: &str| {
        let mut stream = crate::common::bin();
        stream
            .args(["synth-stream", a, "--port", "0", "--duration-s", duration])
            .args(["--frame-clock", "client", "--json"]);
        crate::common::spawn_stream(stream)
    };
    // A finite stream that ends by its own duration and says so: a normal end, 0,
    // every one of its 1000 frames read or taken into the tare.
    let (mut server, from) = start_server("1");
    let o = live(&[
        a,
        "--from",
        &from,
        "--give-up-s",
        "0.5",
        "--tare-frames",
        "10",
    ]);
    server.wait().unwrap();
    let s = summary(&o);
    assert_eq!(o.status.code(), Some(0), "{s}");
    assert_eq!(s["source_lost"], false);
    assert!(
        s["ended"].as_str().unwrap().contains("end of stream"),
        "{s}"
    );
    assert_eq!(s["frames_in"], 1000, "{s}");
    assert_eq!(s["reconnects"], 0, "{s}");
    // The instrument killed mid-stream (no end said): reconnecting is given up after
    // --give-up-s, status 3.
    let (mut server, from) = start_server("60");
    let mut c = crate::common::bin();
    c.current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["live", a, "--from", &from, "--jsonl", "--give-up-s", "0.5"])
        .args(["--tare-frames", "10", "--tare-s", "0"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = c.spawn().unwrap();
    // Once it reads frames, kill the instrument.
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut text = String::new();
    let mut line = String::new();
    while out.read_line(&mut line).unwrap() > 0 {
        text.push_str(&line);
        let frame = line.contains("\"type\":\"frame\"");
        line.clear();
        if frame {
            break;
        }
    }
    server.kill().unwrap();
    server.wait().unwrap();
    std::io::Read::read_to_string(&mut out, &mut text).unwrap();
    let status = child.wait().unwrap();
    let s: Value = text
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .rfind(|v| v["type"] == "summary")
        .unwrap();
    assert_eq!(status.code(), Some(LOST), "{s}");
    assert_eq!(s["source_lost"], true);
    assert!(
        s["ended"]
            .as_str()
            .unwrap()
            .contains("gave up reconnecting"),
        "{s}"
    );
    assert!(s["frames_out"].as_u64().unwrap() > 0, "{s}");
    // Nothing listening at all: lost before the first frame, the same status.
    let closed = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let dead = format!("tcp://127.0.0.1:{}", closed.local_addr().unwrap().port());
    drop(closed);
    let o = live(&[a, "--from", &dead, "--give-up-s", "0.2"]);
    assert_eq!(o.status.code(), Some(LOST));
    assert!(summary(&o)["ended"]
        .as_str()
        .unwrap()
        .contains("gave up connecting"));
    // Standard input read to its end: a clean end, status 0.
    let mut c = crate::common::bin()
        .args(["live", a, "--from", "-", "--jsonl", "--no-tare"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    c.stdin
        .take()
        .unwrap()
        .write_all(b"1520.0 1525.0 1530.0 1535.0 1540.0 1545.0\n")
        .unwrap();
    let o = c.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(summary(&o)["source_lost"], false);
    // --help says so.
    let help = crate::common::bin()
        .args(["live", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout).replace('\n', " ");
    assert!(help.contains("Exit status: 0 when"), "{help}");
    assert!(help.contains("3 when the source was lost"), "{help}");
}

/// An ENLIGHT row of the array at its nominal wavelengths, stamped `epoch_s` (UTC).
fn enlight_row(nominal: &[f64], epoch_s: f64) -> String {
    let days = (epoch_s / 86400.0).floor();
    let (y, m, d) = civil_from_days(days as i64);
    let sod = epoch_s - days * 86400.0;
    let (h, mi, s) = (
        (sod / 3600.0).floor(),
        ((sod % 3600.0) / 60.0).floor(),
        sod % 60.0,
    );
    let peaks: Vec<String> = nominal.iter().map(|l| format!("{l:.5}")).collect();
    format!(
        "{d:02}/{m:02}/{y} {h:02}:{mi:02}:{s:09.6}\t{}\t0\t0\t0\t{}\n",
        nominal.len(),
        peaks.join("\t")
    )
}

/// Days since 1970 to (year, month, day), proleptic Gregorian.
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

fn write_log(path: &Path, rows: &[String]) {
    let head = "Date:\t20/03/2025\nHW Acquisition Rate: 1000 Hz\nTimestamp Format: Full\n\nTimestamp\t# CH 1\t# CH 2\t# CH 3\t# CH 4\n";
    std::fs::write(path, format!("{head}{}", rows.concat())).unwrap();
}

#[test]
fn the_clock_age_is_measured_only_where_the_stream_clock_is_the_wall_clock() {
    let d = common::shipped("tactile-array-60x80.toml");
    let nominal: Vec<f64> = d
        .array
        .as_ref()
        .unwrap()
        .gratings
        .iter()
        .map(|g| g.bragg_wavelength_nm)
        .collect();
    let design = common::shipped_path("tactile-array-60x80.toml");
    let a = design.to_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let old = dir.path().join("old.txt");
    // A log recorded on 2025-03-20, replayed: its clock is not this machine's.
    let t0 = 1_742_479_426.0;
    let rows: Vec<String> = (0..30)
        .map(|k| enlight_row(&nominal, t0 + 0.01 * k as f64))
        .collect();
    write_log(&old, &rows);
    let o = live(&[
        a,
        "--from",
        old.to_str().unwrap(),
        "--from-start",
        "--idle-exit-s",
        "0.3",
        "--tare-frames",
        "10",
    ]);
    assert_eq!(o.status.code(), Some(0));
    let s = summary(&o);
    assert_eq!(s["frames_out"], 20, "{s}");
    assert_eq!(s["age"]["count"], 0, "{s}");
    let frames: Vec<Value> = lines(&o)
        .into_iter()
        .filter(|v| v["type"] == "frame")
        .collect();
    assert!(frames.iter().all(|f| f.get("age_us").is_none()));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!stderr.contains("age ("), "{stderr}");
    assert!(!stderr.contains("days"), "{stderr}");

    // The same rows stamped now and appended while the run follows the file: the
    // stream's clock is the wall clock, and the age is measured (and small).
    let live_log = dir.path().join("live.txt");
    write_log(&live_log, &[]);
    let path = live_log.clone();
    let nominal_w = nominal.clone();
    let writer = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(300));
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .unwrap();
        for _ in 0..30 {
            let now = SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .unwrap()
                .as_secs_f64();
            f.write_all(enlight_row(&nominal_w, now).as_bytes())
                .unwrap();
            f.flush().unwrap();
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    });
    let o = live(&[
        a,
        "--from",
        live_log.to_str().unwrap(),
        "--frames",
        "20",
        "--idle-exit-s",
        "30",
        "--tare-frames",
        "10",
    ]);
    writer.join().unwrap();
    let s = summary(&o);
    assert_eq!(s["frames_out"], 20, "{s}");
    assert_eq!(s["age"]["count"], 20, "{s}");
    assert!(s["age"]["max_us"].as_f64().unwrap() < 60e6, "{s}");

    // Replayed with --from-start once written: those rows are the file's past, not
    // the stream, whatever their stamps say.
    let o = live(&[
        a,
        "--from",
        live_log.to_str().unwrap(),
        "--from-start",
        "--idle-exit-s",
        "0.3",
        "--tare-frames",
        "10",
    ]);
    let s = summary(&o);
    assert_eq!(s["frames_out"], 20, "{s}");
    assert_eq!(s["age"]["count"], 0, "{s}");
}

#[test]
fn a_stream_clock_far_from_this_machine_s_is_named_once_and_not_aged() {
    // A log appended live but stamped in 2025 (another clock): an event says so.
    let d = common::shipped("tactile-array-60x80.toml");
    let nominal: Vec<f64> = d
        .array
        .as_ref()
        .unwrap()
        .gratings
        .iter()
        .map(|g| g.bragg_wavelength_nm)
        .collect();
    let design = common::shipped_path("tactile-array-60x80.toml");
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("skewed.txt");
    write_log(&log, &[]);
    let path = log.clone();
    let writer = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(300));
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .unwrap();
        // Rows keep coming for 4 s: a run that starts late still sees 25 new ones.
        for k in 0..400 {
            f.write_all(enlight_row(&nominal, 1_742_479_426.0 + 0.01 * k as f64).as_bytes())
                .unwrap();
            f.flush().unwrap();
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
    });
    let o = live(&[
        design.to_str().unwrap(),
        "--from",
        log.to_str().unwrap(),
        "--frames",
        "15",
        "--idle-exit-s",
        "30",
        "--tare-frames",
        "10",
    ]);
    writer.join().unwrap();
    let all = lines(&o);
    let clock: Vec<&Value> = all
        .iter()
        .filter(|v| v["type"] == "event" && v["event"] == "clock")
        .collect();
    assert_eq!(clock.len(), 1, "{all:?}");
    let m = clock[0]["message"].as_str().unwrap();
    assert!(m.contains("days behind this machine's clock"), "{m}");
    assert_eq!(summary(&o)["age"]["count"], 0);
}
