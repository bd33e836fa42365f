//! Array calibration: a synthetic calibration run recovers the sensing matrix it was
//! made from; bad schedules are named.

use crate::common;
use fbgforge::array::calibrate::{self, Loading};
use fbgforge::logs::{self, LogFormat, ReadOptions};
use fbgforge::synth::module_log::{self as synth, LogStyle, SynthConfig};
use std::path::Path;

fn design() -> fbgforge::spec::Design {
    common::shipped("tactile-array-60x80.toml")
}

/// 200 g on each of the 8 cells in turn, then 100 g on each again.
fn schedule() -> Vec<Loading> {
    let mut s = Vec::new();
    for (rep, load) in [(0, 200.0), (1, 100.0)] {
        for cell in 0..8 {
            let start = 10.0 + (rep * 8 + cell) as f64 * 20.0;
            s.push(Loading {
                start_s: start,
                end_s: start + 10.0,
                cell,
                load_g: load,
            });
        }
    }
    s
}

#[test]
fn calibration_recovers_the_power_law_matrix_in_every_format() {
    let d = design();
    let truth = calibrate::power_law_matrix(&d).unwrap();
    // The kernel reproduces reference §2's centre-load sensitivities only loosely, but
    // its nearest-cell values must be of the paper's order (0.1–0.4 pm/g).
    let max = truth
        .sensitivity_pm_per_g
        .iter()
        .fold(0.0f64, |a, &b| a.max(b));
    assert!(max > 0.1 && max < 0.5, "{max}");
    let sched = schedule();
    let log =
        fbgforge::synth::array_log::synth_calibration_log(&d, &truth, &sched, 10.0, 0.2, 0.01, 3)
            .unwrap();
    let cfg = SynthConfig {
        sample_rate_hz: 10.0,
        ..Default::default()
    };
    let dir = tempfile::tempdir().unwrap();
    for format in LogFormat::ALL {
        let path = dir.path().join(format!("cal.{}", synth::extension(format)));
        synth::write_log(&path, format, &log, &cfg, &LogStyle::default()).unwrap();
        let pl = logs::read_peak_log(&path, &ReadOptions::default()).unwrap();
        let m = calibrate::calibrate(&d, &pl, &sched, None).unwrap();
        assert_eq!(m.cells, vec!["A", "B", "C", "D", "E", "F", "G", "H"]);
        assert_eq!(
            m.gratings,
            vec!["fbg1", "fbg2", "fbg3", "fbg4", "fbg5", "fbg6"]
        );
        let (mm, tm) = (&m.sensitivity_pm_per_g, &truth.sensitivity_pm_per_g);
        for (g, (row, trow)) in mm.row_iter().zip(tm.row_iter()).enumerate() {
            for (c, (v, t)) in row.iter().zip(trow.iter()).enumerate() {
                // 0.2 pm noise averaged over ~75 samples per loading, two loadings:
                // ≤ 0.005 pm/g absolute, or 2 % of the larger entries.
                assert!(
                    (v - t).abs() <= 0.005f64.max(0.02 * t),
                    "{format:?} fbg{} cell {c}: {v} vs {t}",
                    g + 1
                );
            }
        }
        // The CSV the reconstruction reads.
        let out = dir.path().join("A.csv");
        fbgforge::array::io::write_matrix_with_comments(&out, &m, &["test".into()]).unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("# test"));
        assert_eq!(lines.next(), Some("grating,A,B,C,D,E,F,G,H"));
        let first: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(first.len(), 9);
        assert_eq!(first[0], "fbg1");
        assert!((first[1].parse::<f64>().unwrap() - m.sensitivity_pm_per_g[(0, 0)]).abs() < 1e-6);
    }
}

#[test]
fn schedule_errors_name_the_line_and_the_cells() {
    let p = Path::new("sched.csv");
    let e = calibrate::parse_schedule("start_s,end_s,cell,load_g\n0,10,Z,200\n", p, 8)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sched.csv:2") && e.contains("unknown cell `Z`") && e.contains("A, B"),
        "{e}"
    );
    let e = calibrate::parse_schedule("start,end\n", p, 8)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sched.csv:1") && e.contains("start_s,end_s,cell,load_g"),
        "{e}"
    );
    let e = calibrate::parse_schedule("start_s,end_s,cell,load_g\n5,4,A,200\n", p, 8)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not after"), "{e}");
    let e = calibrate::parse_schedule(
        "# c\nstart_s,end_s,cell,load_g\n0,10,A,200\n5,15,B,200\n",
        p,
        8,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("overlap"), "{e}");
    let ok =
        calibrate::parse_schedule("start_s,end_s,cell,load_g\n20,30,b,100\n0,10,A,200\n", p, 8)
            .unwrap();
    assert_eq!(
        ok[0],
        Loading {
            start_s: 0.0,
            end_s: 10.0,
            cell: 0,
            load_g: 200.0
        }
    );
    assert_eq!(ok[1].cell, 1);
    // A cell the schedule never loads is an error at calibration time.
    let d = design();
    let truth = calibrate::power_law_matrix(&d).unwrap();
    let sched: Vec<Loading> = schedule().into_iter().filter(|l| l.cell != 5).collect();
    let log =
        fbgforge::synth::array_log::synth_calibration_log(&d, &truth, &sched, 5.0, 0.1, 0.0, 1)
            .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cal.csv");
    synth::write_log(
        &path,
        LogFormat::Csv,
        &log,
        &SynthConfig::default(),
        &LogStyle::default(),
    )
    .unwrap();
    let pl = logs::read_peak_log(&path, &ReadOptions::default()).unwrap();
    let e = calibrate::calibrate(&d, &pl, &sched, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("cell F"), "{e}");
}
