//! The `optimize` and `place` commands end to end: files written and loadable, and
//! bad input reported as `error: ...` with exit status 1.

use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fbgforge"))
}

fn shipped(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("designs")
        .join(name)
}

fn fails_with(args: &[&str], needle: &str) {
    let out = bin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
    assert!(
        err.starts_with("error: ") && err.contains(needle),
        "{args:?}: {err}"
    );
}

#[test]
fn optimize_writes_a_loadable_design_a_summary_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("opt.toml");
    let status = bin()
        .args([
            "optimize",
            shipped("clip-on-34mm.toml").to_str().unwrap(),
            "--starts",
            "0",
            "--cores",
        ])
        .arg("core_rubber_case_i")
        .args([
            "--inserts",
            "insert_blue,none",
            "--out",
            out.to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let summary: serde_json::Value = serde_json::from_slice(&status.stdout).unwrap();
    assert_eq!(summary["choices"].as_array().unwrap().len(), 2);
    let d = fbgforge::spec::load(&out).unwrap();
    assert_eq!(d.name, "clip-on-34mm-optimised");
    let report = dir.path().join("opt-report");
    for f in [
        "summary.json",
        "convergence.svg",
        "convergence.csv",
        "landscape.svg",
        "landscape.csv",
    ] {
        let p = report.join(f);
        assert!(
            p.metadata().map(|m| m.len() > 0).unwrap_or(false),
            "{} missing",
            p.display()
        );
    }
}

#[test]
fn place_writes_a_loadable_design() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("placed.toml");
    let status = bin()
        .args([
            "place",
            shipped("tactile-array-60x80.toml").to_str().unwrap(),
        ])
        .args([
            "--objective",
            "coherence",
            "--max-iters",
            "10",
            "--agreement-samples",
            "0",
        ])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let d = fbgforge::spec::load(&out).unwrap();
    assert!(d.array.is_some());
    assert!(dir.path().join("placed-report/convergence.svg").exists());
}

#[test]
fn bad_input_is_an_error_naming_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let d34 = shipped("clip-on-34mm.toml");
    let d34 = d34.to_str().unwrap();
    let out = dir.path().join("x.toml");
    let out = out.to_str().unwrap();
    fails_with(
        &[
            "optimize",
            d34,
            "--vary",
            "outer_diameter_mm,wall",
            "--out",
            out,
        ],
        "unknown variable `wall`",
    );
    fails_with(
        &["optimize", d34, "--bounds", "cap_wall_mm=2:1", "--out", out],
        "contradictory bounds for `cap_wall_mm`",
    );
    fails_with(
        &["optimize", d34, "--objective", "speed", "--out", out],
        "unknown objective `speed`",
    );
    fails_with(
        &["optimize", d34, "--max-force-n", "0", "--out", out],
        "--max-force-n",
    );
    fails_with(
        &[
            "optimize",
            d34,
            "--max-strain-microstrain",
            "1",
            "--starts",
            "0",
            "--out",
            out,
        ],
        "infeasible: constraint `grating_strain` cannot be met",
    );
    let empty = dir.path().join("empty.toml");
    std::fs::write(&empty, "# nothing\n").unwrap();
    fails_with(
        &[
            "optimize",
            d34,
            "--materials",
            empty.to_str().unwrap(),
            "--out",
            out,
        ],
        "material table is empty",
    );
    let bad_json = dir.path().join("v.json");
    std::fs::write(&bad_json, "{\"gratings\": [{\"k\": 1}]}").unwrap();
    fails_with(
        &[
            "optimize",
            d34,
            "--measured",
            bad_json.to_str().unwrap(),
            "--out",
            out,
        ],
        "no measured lag",
    );
    fails_with(&["place", d34, "--out", out], "no [array] section");
    let arr = shipped("tactile-array-60x80.toml");
    fails_with(
        &[
            "place",
            arr.to_str().unwrap(),
            "--method",
            "magic",
            "--out",
            out,
        ],
        "magic",
    );
    // Nothing was written for the failed runs.
    assert!(!Path::new(out).exists());
}
