//! The `synth-log`, `verify` and `calibrate-array` commands end to end.

use std::path::Path;

use crate::common::bin;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn synth_log_then_verify_writes_json_and_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let design = root().join("designs/clip-on-34mm.toml");
    let out = bin()
        .args([
            "synth-log",
            design.to_str().unwrap(),
            "--format",
            "imon",
            "--core",
            "psc2",
            "--k-pm-per-n",
            "-20",
            "--temperature-ramp-k-per-s",
            "0.05",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = dir.path().join("report");
    let out = bin()
        .args([
            "verify",
            design.to_str().unwrap(),
            "--core",
            "psc2",
            "--case",
            "II",
            "--json",
            "--log",
        ])
        .arg(dir.path().join("log.txt"))
        .arg("--force")
        .arg(dir.path().join("force.csv"))
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    // 0 = pass or not judged, 2 = fail; both wrote the report.
    let code = out.status.code().unwrap();
    assert!(
        code == 0 || code == 2,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("truth.json")).unwrap())
            .unwrap();
    let g = &v["measurement"]["gratings"][0];
    assert_eq!(g["grating"], "lambda_21");
    let k = g["sensitivity_pm_per_n"].as_f64().unwrap();
    assert!((k + 20.0).abs() < 0.2, "{k}");
    assert!(g["sls_time_constant_s"].as_f64().unwrap() > 0.0);
    let off = v["measurement"]["clock_offset_s"].as_f64().unwrap();
    assert!(
        (off - truth["clock_offset_s"].as_f64().unwrap()).abs() <= 0.05,
        "{off}"
    );
    for f in [
        "report.md",
        "report.json",
        "shift_vs_force.svg",
        "force_vs_time.svg",
        "shift_vs_time.svg",
        "lag_per_pulse.svg",
        "timeseries.csv",
        "pulses.csv",
    ] {
        assert!(report.join(f).is_file(), "{f} missing");
    }
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(md.contains("lambda_21") && md.contains("![shift against force](shift_vs_force.svg)"));
}

#[test]
fn verify_errors_exit_1_with_a_message() {
    let design = root().join("designs/clip-on-34mm.toml");
    let out = bin()
        .args(["verify", design.to_str().unwrap(), "--log"])
        .arg(root().join("fixtures/logs/metadata_only.txt"))
        .arg("--force")
        .arg(root().join("fixtures/logs/force_stand.csv"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("error: ") && err.contains("metadata_only.txt"),
        "{err}"
    );
    let out = bin()
        .args([
            "verify",
            design.to_str().unwrap(),
            "--insert",
            "purple",
            "--log",
            "x",
            "--force",
            "y",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no insert named `purple`"));
}

#[test]
fn calibrate_array_from_a_synthetic_run() {
    let dir = tempfile::tempdir().unwrap();
    let design = root().join("designs/tactile-array-60x80.toml");
    let sched = dir.path().join("schedule.csv");
    let mut text = String::from("# 200 g on each cell in turn\nstart_s,end_s,cell,load_g\n");
    for (k, c) in ["A", "B", "C", "D", "E", "F", "G", "H"].iter().enumerate() {
        text += &format!("{},{},{c},200\n", 10 + 20 * k, 20 + 20 * k);
    }
    std::fs::write(&sched, text).unwrap();
    let out = bin()
        .args([
            "synth-log",
            design.to_str().unwrap(),
            "--format",
            "enlight-sensors",
            "--rate-hz",
            "10",
            "--noise-pm",
            "0.1",
            "--schedule",
        ])
        .arg(&sched)
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let matrix = dir.path().join("A.csv");
    let out = bin()
        .args(["calibrate-array", design.to_str().unwrap(), "--log"])
        .arg(dir.path().join("log.txt"))
        .arg("--schedule")
        .arg(&sched)
        .arg("--out")
        .arg(&matrix)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read = |p: &Path| -> Vec<Vec<f64>> {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#') && !l.starts_with("grating"))
            .map(|l| l.split(',').skip(1).map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    let (got, want) = (read(&matrix), read(&dir.path().join("matrix_truth.csv")));
    assert_eq!(got.len(), 6);
    for (r, w) in got.iter().zip(&want) {
        for (a, b) in r.iter().zip(w) {
            assert!((a - b).abs() < 0.005f64.max(0.02 * b), "{a} vs {b}");
        }
    }
    // The sheet's unknowns fitted to the measured matrix (`--fit-modulus` is the old
    // name of `--fit-sheet`): each parameter has a value only where identifiable.
    let out = bin()
        .args(["calibrate-array", design.to_str().unwrap(), "--log"])
        .arg(dir.path().join("log.txt"))
        .arg("--schedule")
        .arg(&sched)
        .arg("--out")
        .arg(&matrix)
        .arg("--fit-modulus")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("sheet fit: ") && stdout.contains("youngs_modulus_mpa"),
        "{stdout}"
    );
    let fit: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(matrix.with_extension("sheet-fit.json")).unwrap(),
    )
    .unwrap();
    let params = fit["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 3, "{fit}");
    for p in params {
        assert_eq!(
            p["value"].is_null(),
            !p["identifiable"].as_bool().unwrap(),
            "{p}"
        );
    }
}

/// A newcomer's first `synth-log --from-model` + `verify` PASSes, on every shipped
/// module, core, log format and with a temperature ramp: the log follows the design's
/// own prediction (Case II, as `verify` judges by default), its pulses are scaled so
/// that every shift stays in its window, and the fitted K is the model's within 1 %.
/// Any other verdict on such a log would be confidently wrong (a FAIL of a part that
/// is exactly its model), so every scenario is counted and none may miss.
#[test]
fn a_log_that_follows_the_model_passes_verify() {
    let mut misses = Vec::new();
    let mut runs = 0;
    for (design, core, format, ramp, seed) in [
        ("clip-on-34mm", "psc1", "enlight-peaks", "0", "1"),
        ("clip-on-34mm", "psc2", "imon", "0.05", "2"),
        ("clip-on-22mm", "psc1", "csv", "0", "3"),
        ("clip-on-16mm", "psc2", "enlight-peaks", "0.1", "4"),
        ("clip-on-10mm", "psc1", "enlight-sensors", "0", "5"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let path = root().join(format!("designs/{design}.toml"));
        let out = bin()
            .args([
                "synth-log",
                path.to_str().unwrap(),
                "--from-model",
                "--core",
                core,
            ])
            .args([
                "--format",
                format,
                "--temperature-ramp-k-per-s",
                ramp,
                "--seed",
                seed,
                "--out",
            ])
            .arg(dir.path())
            .output()
            .unwrap();
        let said = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(said.starts_with("K from the model (Case II): "), "{said}");
        let log = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.file_stem().is_some_and(|s| s == "log"))
            .unwrap();
        let v = bin()
            .args([
                "verify",
                path.to_str().unwrap(),
                "--core",
                core,
                "--json",
                "--log",
            ])
            .arg(&log)
            .arg("--force")
            .arg(dir.path().join("force.csv"))
            .output()
            .unwrap();
        runs += 1;
        let doc: serde_json::Value = serde_json::from_slice(&v.stdout)
            .unwrap_or_else(|_| panic!("{design}: {}", String::from_utf8_lossy(&v.stderr)));
        let verdict = &doc["verdict"];
        let close = verdict["gratings"].as_array().unwrap().iter().all(|g| {
            let m = g["measured_sensitivity_pm_per_n"].as_f64().unwrap();
            let p = g["predicted_sensitivity_pm_per_n"].as_f64().unwrap();
            (m - p).abs() <= 0.01 * p.abs()
        });
        if verdict["overall"] != "pass" || v.status.code() != Some(0) || !close {
            misses.push(format!("{design} {core} {format} ramp {ramp}: {verdict}"));
        }
    }
    assert!(
        misses.is_empty(),
        "{} of {runs} runs did not PASS: {misses:#?}",
        misses.len()
    );
}

/// The plain `verify` of the README's first example prints PASS.
#[test]
fn the_first_verify_prints_pass() {
    let dir = tempfile::tempdir().unwrap();
    let design = root().join("designs/clip-on-34mm.toml");
    let out = bin()
        .args([
            "synth-log",
            design.to_str().unwrap(),
            "--from-model",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = bin()
        .args(["verify", design.to_str().unwrap(), "--log"])
        .arg(dir.path().join("log.txt"))
        .arg("--force")
        .arg(dir.path().join("force.csv"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&v.stdout);
    assert_eq!(v.status.code(), Some(0), "{text}");
    assert!(text.lines().any(|l| l == "verdict: PASS"), "{text}");
}

/// `synth-log` of an array names the flag that writes an array's log; `--from-model`
/// names the inserts when given a wrong one and refuses to mix with `--k-pm-per-n`.
#[test]
fn synth_log_errors_name_the_way_out() {
    let run = |args: &[&str]| {
        let out = bin().arg("synth-log").args(args).output().unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let array = root().join("designs/tactile-array-60x80.toml");
    let e = run(&[array.to_str().unwrap(), "--out", "/nonexistent/x"]);
    assert!(e.contains("--schedule") && e.contains("flat array"), "{e}");
    let module = root().join("designs/clip-on-34mm.toml");
    let e = run(&[
        module.to_str().unwrap(),
        "--from-model",
        "--insert",
        "insert_blue",
        "--out",
        "/nonexistent/x",
    ]);
    assert!(
        e.contains("no insert named `insert_blue`") && e.contains("blue, green, light_green"),
        "{e}"
    );
    let e = run(&[
        module.to_str().unwrap(),
        "--from-model",
        "--k-pm-per-n",
        "12",
    ]);
    assert!(
        e.contains("--k-pm-per-n") && e.contains("--from-model"),
        "{e}"
    );
}
