//! `fbgforge calibrate-array` on files (issue 34): the log in every format gives the
//! true matrix; `--json` prints `gratings`, `cells`, `matrix_pm_per_g`, `faults` and
//! `metrology`; the scatter is written beside the matrix in the form `reconstruct
//! --matrix-sd` reads; a faulty run exits 3 and writes no matrix at `--out`.

use crate::calibrate_runs::{cell_by_cell, design, lab, truth};
use crate::common;
use fbgforge::array::calibrate::{self, CalibrateRequest, Loading};
use fbgforge::logs::LogFormat;
use fbgforge::synth::array_log::{self, ArrayRunSettings};
use fbgforge::synth::module_log::{self as synth, LogStyle, SynthConfig};
use std::path::{Path, PathBuf};

/// Write a run's log (`format`) and its schedule into `dir`.
fn write_run(
    dir: &Path,
    format: LogFormat,
    events: &[Loading],
    schedule: &[Loading],
    s: &ArrayRunSettings,
) -> (PathBuf, PathBuf) {
    let log = array_log::synth_array_run(&design(), &truth(), events, s).unwrap();
    let path = dir.join(format!("cal.{}", synth::extension(format)));
    let cfg = SynthConfig {
        sample_rate_hz: s.sample_rate_hz,
        ..Default::default()
    };
    synth::write_log(&path, format, &log, &cfg, &LogStyle::default()).unwrap();
    let sched = dir.join("schedule.csv");
    let mut text =
        String::from("# times in s from the log's first row\nstart_s,end_s,cell,load_g\n");
    for l in schedule {
        text.push_str(&format!(
            "{},{},{},{}\n",
            l.start_s,
            l.end_s,
            fbgforge::profile::cell_label(l.cell),
            l.load_g
        ));
    }
    std::fs::write(&sched, text).unwrap();
    (path, sched)
}

#[test]
fn every_log_format_gives_the_true_matrix_and_its_scatter_file() {
    let (a, ev) = (truth(), cell_by_cell());
    let dir = tempfile::tempdir().unwrap();
    for format in LogFormat::ALL {
        let (log, schedule) = write_run(dir.path(), format, &ev, &ev, &lab());
        let out = dir.path().join(format!("A-{format:?}.csv"));
        let req = CalibrateRequest {
            log,
            schedule,
            out: Some(out.clone()),
            ..Default::default()
        };
        let o = calibrate::run(&design(), &req, &mut ()).unwrap();
        assert!(
            o.calibration.faults.is_empty(),
            "{format:?}: {:#?}",
            o.calibration.faults
        );
        let m = fbgforge::array::io::read_matrix(&out).unwrap();
        let sd = fbgforge::array::io::read_matrix(&out.with_extension("sd.csv")).unwrap();
        assert_eq!(
            (m.gratings.clone(), m.cells.clone()),
            (a.gratings.clone(), a.cells.clone())
        );
        assert_eq!(sd.sensitivity_pm_per_g.shape(), (6, 8));
        for g in 0..6 {
            for c in 0..8 {
                let (v, t) = (
                    m.sensitivity_pm_per_g[(g, c)],
                    a.sensitivity_pm_per_g[(g, c)],
                );
                assert!(
                    (v - t).abs() < 0.002,
                    "{format:?} fbg{} {c}: {v} vs {t}",
                    g + 1
                );
                assert!(sd.sensitivity_pm_per_g[(g, c)] > 0.0);
            }
        }
    }
}

#[test]
fn json_names_the_matrix_faults_and_metrology_and_a_fault_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let stair = array_log::staircase(2, 25.0, 250.0, 5.0, 3, 10.0);
    let mut ev = cell_by_cell();
    let t_end = stair.last().unwrap().end_s + 10.0;
    for l in &mut ev {
        l.start_s += t_end;
        l.end_s += t_end;
    }
    let all: Vec<Loading> = stair.into_iter().chain(ev).collect();
    let s = ArrayRunSettings {
        sample_rate_hz: 3.0,
        noise_pm: 0.5,
        ..Default::default()
    };
    let (log, sched) = write_run(dir.path(), LogFormat::Csv, &all, &all, &s);
    let out = dir.path().join("A.csv");
    let design = common::shipped_path("tactile-array-60x80.toml");
    let args = |out: &Path, log: &Path| {
        let mut c = common::bin();
        c.arg("calibrate-array")
            .arg(&design)
            .arg("--log")
            .arg(log)
            .arg("--schedule")
            .arg(&sched)
            .arg("--out")
            .arg(out)
            .arg("--json");
        c.output().unwrap()
    };
    let o = args(&out, &log);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["gratings"].as_array().unwrap().len(), 6);
    assert_eq!(v["cells"][7], "H");
    assert_eq!(v["matrix_pm_per_g"].as_array().unwrap().len(), 6);
    assert_eq!(v["matrix_pm_per_g"][0].as_array().unwrap().len(), 8);
    assert_eq!(v["faults"], serde_json::json!([]));
    let met = v["metrology"].as_array().unwrap();
    assert_eq!(met.len(), 6, "one per grating on the staircase's cell C");
    for m in met {
        assert_eq!(m["cell"], "C");
        for key in [
            "grating",
            "sensitivity_pm_per_g",
            "sensitivity_sem_pm_per_g",
            "r",
            "resolution_g",
            "linearity_percent_span",
            "hysteresis_percent_span",
        ] {
            assert!(!m[key].is_null(), "{key}: {m}");
        }
        assert_eq!(m["cycles"], 3);
    }
    assert!(out.exists() && out.with_extension("sd.csv").exists());
    // The same run with fbg2 and fbg3 exchanged: swapped_gratings, exit 3, no matrix.
    let sub = dir.path().join("swapped");
    std::fs::create_dir(&sub).unwrap();
    let (log2, _) = write_run(
        &sub,
        LogFormat::Csv,
        &all,
        &all,
        &ArrayRunSettings {
            swapped: Some((1, 2)),
            ..s
        },
    );
    let out2 = sub.join("A.csv");
    let o = args(&out2, &log2);
    assert_eq!(
        o.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let f = v["faults"].as_array().unwrap();
    assert!(
        f.iter().any(|f| f["kind"] == "swapped_gratings"
            && f["gratings"] == serde_json::json!(["fbg2", "fbg3"])),
        "{f:?}"
    );
    for f in f {
        assert!(f["cells"].is_array() && f["reason"].is_string());
    }
    assert!(!out2.exists() && out2.with_extension("faulty.csv").exists());
}
