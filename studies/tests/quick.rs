//! Every study's `--quick` form runs under `cargo test` and writes outputs whose
//! numbers are checked, so the studies cannot rot.

use std::path::{Path, PathBuf};

/// The repository root, where the shipped designs live.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn build_study_quick_writes_a_sweep_with_shrinking_volume_error() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::build::BuildStudyArgs {
        design: root().join("designs/clip-on-34mm.toml"),
        array: root().join("designs/tactile-array-60x80.toml"),
        out: dir.path().to_path_buf(),
        repeats: 1,
        quick: true,
    };
    fbgforge_studies::build::run(&a).unwrap();
    let csv = std::fs::read_to_string(dir.path().join("tolerance-sweep.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    // Per part: the finer tolerance has more triangles and no larger volume error.
    for part in ["cap", "core"] {
        let r: Vec<&Vec<String>> = rows.iter().filter(|r| r[0] == part).collect();
        assert_eq!(r.len(), 2, "{part}: two tolerances");
        let tri = |i: usize| r[i][2].parse::<usize>().unwrap();
        let err = |i: usize| r[i][4].parse::<f64>().unwrap().abs();
        assert!(tri(1) > tri(0), "{part}: finer mesh, more triangles");
        assert!(err(1) <= err(0), "{part}: finer mesh, smaller volume error");
        assert!(err(1) < 0.5, "{part}: default tolerance within 0.5 %");
    }
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("timings.json")).unwrap())
            .unwrap();
    assert!(t["module_and_mold_ms"].as_f64().unwrap() > 0.0);
    assert_eq!(t["family_diameters_mm"].as_array().unwrap().len(), 13);
}
