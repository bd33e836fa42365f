//! How `live` ends, as documented in `live --help`: a replayed file loses no frame; a
//! signal (SIGTERM, SIGHUP, SIGINT) or a closed output ends it with its summary
//! (on standard error when standard output is gone) and status 0; a source path that
//! does not exist is an error naming it (1), one deleted while followed is a lost
//! source naming it (3); a malformed frame is counted once.

use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::process::{Child, ChildStdin, Stdio};
use std::time::{Duration, Instant};

use crate::common;

fn array() -> String {
    common::shipped_path("tactile-array-60x80.toml")
        .to_str()
        .unwrap()
        .to_string()
}

/// One frame of the array's peaks, nm: its nominal wavelengths plus `pm`.
fn peaks_line(pm: f64) -> String {
    let d = common::shipped("tactile-array-60x80.toml");
    let w: Vec<String> = d
        .array
        .unwrap()
        .gratings
        .iter()
        .map(|g| format!("{}", g.bragg_wavelength_nm + pm * 1e-3))
        .collect();
    w.join(" ") + "\n"
}

fn summary_of(text: &str) -> Value {
    text.lines()
        .filter_map(|l| serde_json::from_str::<Value>(l).ok())
        .rfind(|v| v["type"] == "summary")
        .unwrap_or_else(|| panic!("no summary in {text}"))
}

/// `live --from - --jsonl` with standard input left open (the run goes on until it is
/// stopped); returns once all three frames written were read back, so a signal sent
/// next cannot race a frame still in the pipe.
fn live_on_open_stdin() -> (Child, BufReader<std::process::ChildStdout>, ChildStdin) {
    let mut child = common::bin()
        .args(["live", &array(), "--from", "-", "--jsonl", "--no-tare"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin
        .write_all(peaks_line(0.0).repeat(3).as_bytes())
        .unwrap();
    stdin.flush().unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    let mut frames = 0;
    while frames < 3 && out.read_line(&mut line).unwrap() > 0 {
        if line.contains("\"type\":\"frame\"") {
            frames += 1;
        }
        line.clear();
    }
    (child, out, stdin)
}

fn wait_at_most(child: &mut Child, s: u64) -> std::process::ExitStatus {
    let t0 = Instant::now();
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            return st;
        }
        assert!(t0.elapsed() < Duration::from_secs(s), "live did not end");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_signal_ends_the_run_with_its_summary_and_status_0() {
    for (name, sig) in [
        ("SIGTERM", libc::SIGTERM),
        ("SIGHUP", libc::SIGHUP),
        ("SIGINT", libc::SIGINT),
    ] {
        let (mut child, mut out, _stdin) = live_on_open_stdin();
        // SAFETY: a signal to our own child, by its id.
        assert_eq!(unsafe { libc::kill(child.id() as i32, sig) }, 0);
        let status = wait_at_most(&mut child, 20);
        let mut rest = String::new();
        out.read_to_string(&mut rest).unwrap();
        assert_eq!(status.code(), Some(0), "{name}: {status}");
        let s = summary_of(&rest);
        assert!(
            s["ended"].as_str().unwrap().contains("signal"),
            "{name}: {s}"
        );
        assert_eq!(s["frames_out"], 3, "{name}: {s}");
    }
}

#[test]
fn a_closed_output_ends_the_run_with_its_summary_on_standard_error() {
    let (mut child, out, mut stdin) = live_on_open_stdin();
    // The reader of the output ends (as `| head -1` does), then more frames come.
    drop(out);
    for _ in 0..50 {
        if stdin
            .write_all(peaks_line(0.0).repeat(100).as_bytes())
            .is_err()
        {
            break;
        }
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let status = wait_at_most(&mut child, 20);
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    // Not SIGPIPE's 141: a documented end, its summary for a person on stderr.
    assert_eq!(status.code(), Some(0), "{status}: {err}");
    assert!(err.contains("frames in"), "{err}");
    assert!(err.contains("output closed"), "{err}");
}

#[test]
fn a_missing_or_deleted_source_file_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-log.csv");
    let o = common::bin()
        .args([
            "live",
            &array(),
            "--from",
            missing.to_str().unwrap(),
            "--jsonl",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("no-such-log.csv") && err.contains("does not exist"),
        "{err}"
    );
    assert!(o.stdout.is_empty());

    // Followed, then deleted: the source is lost (3), and the summary names the file.
    let log = dir.path().join("growing.csv");
    let mut text = String::from("time_s,fbg1,fbg2,fbg3,fbg4,fbg5,fbg6\n");
    for k in 0..3 {
        text.push_str(&format!("{k},{}", peaks_line(0.0).replace(' ', ",")));
    }
    std::fs::write(&log, text).unwrap();
    let mut child = common::bin()
        .args(["live", &array(), "--from", log.to_str().unwrap(), "--jsonl"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(500));
    std::fs::remove_file(&log).unwrap();
    let status = wait_at_most(&mut child, 20);
    let mut out = String::new();
    child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut out)
        .unwrap();
    assert_eq!(status.code(), Some(3), "{out}");
    let s = summary_of(&out);
    assert_eq!(s["source_lost"], true);
    let ended = s["ended"].as_str().unwrap();
    assert!(
        ended.contains("growing.csv") && ended.contains("deleted"),
        "{ended}"
    );
}

#[test]
fn a_replayed_file_loses_no_frame_and_a_malformed_one_is_counted_once() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("replay.csv");
    // 20 000 frames, far more than the queue holds (8192), one of them malformed.
    let mut text = String::from("time_s,fbg1,fbg2,fbg3,fbg4,fbg5,fbg6\n");
    for k in 0..20_000 {
        if k == 7_000 {
            text.push_str("7.0,1520.8,oops,1526.7,1530.6,1534.1,1537.7\n");
            continue;
        }
        let w = peaks_line(if k % 1000 < 500 { 0.0 } else { 20.0 });
        text.push_str(&format!("{},{}", k as f64 * 1e-3, w.replace(' ', ",")));
    }
    std::fs::write(&log, &text).unwrap();
    for _ in 0..2 {
        let o = common::bin()
            .args(["live", &array(), "--from", log.to_str().unwrap(), "--jsonl"])
            .args(["--from-start", "--idle-exit-s", "0.3", "--no-tare"])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(0));
        let out = String::from_utf8_lossy(&o.stdout);
        let s = summary_of(&out);
        // Every frame, every run: 19 999 read, 1 bad, none dropped.
        assert_eq!(s["frames_out"], 19_999, "{s}");
        assert_eq!(s["bad_frames"], 1, "{s}");
        assert_eq!(s["dropped"]["total"], 0, "counted once, as bad: {s}");
        let frames = out
            .lines()
            .filter(|l| l.contains("\"type\":\"frame\""))
            .count();
        assert_eq!(frames, 19_999);
    }
    // --realtime: read at the pace it comes through a queue of 16; whatever finds the
    // queue full is dropped, and every frame is still accounted for, once.
    let o = common::bin()
        .args(["live", &array(), "--from", log.to_str().unwrap(), "--jsonl"])
        .args([
            "--from-start",
            "--idle-exit-s",
            "0.3",
            "--no-tare",
            "--realtime",
        ])
        .args(["--queue", "16"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0));
    let s = summary_of(&String::from_utf8_lossy(&o.stdout));
    let (read, bad) = (
        s["frames_out"].as_u64().unwrap(),
        s["bad_frames"].as_u64().unwrap(),
    );
    let dropped = s["dropped"]["queue_overflow"].as_u64().unwrap();
    assert_eq!(read + bad + dropped, 20_000, "{s}");
    assert_eq!(s["dropped"]["total"], dropped, "{s}");
}
