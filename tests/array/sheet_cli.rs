//! `fbgforge predict` on an array design (issue 27): the matrix and the response to one
//! load as JSON, naming the model; the sensitivity map; `--model kernel` (the sheet's
//! unknowns fitted to a measured matrix: `calibrate_fit.rs`).

use crate::common;
use fbgforge::array::kernel::{model_matrix, ArrayModelKind, DistanceKernel};
use fbgforge::array::sheet::fit::compare_with_paper;
use fbgforge::array::sheet::SheetModel;
use std::path::Path;

fn fbgforge(args: &[&str]) -> std::process::Output {
    crate::common::bin()
        .args(args)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")))
        .output()
        .expect("the binary runs")
}

fn json(o: &std::process::Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
}

#[test]
fn predict_gives_the_array_matrix_and_one_loads_response_as_json() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().to_str().unwrap();
    let design = "designs/tactile-array-60x80.toml";
    let j = json(&fbgforge(&["predict", design, "--json", "--map-dir", map]));
    assert_eq!(j["model"], "sheet");
    let gratings = j["gratings"].as_array().unwrap();
    let cells = j["cells"].as_array().unwrap();
    assert_eq!((gratings.len(), cells.len()), (6, 8));
    let rows = j["sensitivity_pm_per_g"].as_array().unwrap();
    assert_eq!(rows.len(), 6);
    // The same numbers as the library's one entry point.
    let d = common::shipped("tactile-array-60x80.toml");
    let lib = model_matrix(&d, None).unwrap();
    assert_eq!(lib.model, ArrayModelKind::Sheet);
    for (i, r) in rows.iter().enumerate() {
        let r = r.as_array().unwrap();
        assert_eq!(r.len(), 8);
        for (c, v) in r.iter().enumerate() {
            let want = lib.matrix.sensitivity_pm_per_g[(i, c)];
            assert!((v.as_f64().unwrap() - want).abs() <= 1e-9 * want.abs().max(1e-6));
        }
    }
    // The map: an SVG and a CSV of the same numbers, one panel/column per grating.
    let svg = std::fs::read_to_string(j["map"]["svg"].as_str().unwrap()).unwrap();
    assert!(svg.contains("<svg"));
    let csv = std::fs::read_to_string(j["map"]["csv"].as_str().unwrap()).unwrap();
    let head = csv.lines().next().unwrap();
    for g in gratings {
        assert!(head.contains(g.as_str().unwrap()), "{head}");
    }
    // One load at the centre: Table 1's situation, so the answer is the comparison's.
    let j = json(&fbgforge(&[
        "predict",
        design,
        "--load-at-mm",
        "0,0",
        "--json",
        "--map-dir",
        map,
    ]));
    assert_eq!(j["load_at_mm"], serde_json::json!([0.0, 0.0]));
    assert_eq!(j["gratings"].as_array().unwrap().len(), 6);
    let c = compare_with_paper(&SheetModel::from_design(&d).unwrap(), &d).unwrap();
    for (v, r) in j["sensitivity_pm_per_g"]
        .as_array()
        .unwrap()
        .iter()
        .zip(&c.table1)
    {
        let v = v.as_f64().unwrap();
        assert!(
            (v - r.model_pm_per_g).abs() < 1e-6 * r.model_pm_per_g,
            "{v} vs {r:?}"
        );
    }
    // The empirical kernel on request: its own numbers and its name.
    let j = json(&fbgforge(&[
        "predict",
        design,
        "--load-at-mm",
        "0,0",
        "--json",
        "--model",
        "kernel",
        "--map-dir",
        map,
    ]));
    assert_eq!(j["model"], "kernel");
    let k = DistanceKernel::paper();
    for (v, r) in j["sensitivity_pm_per_g"]
        .as_array()
        .unwrap()
        .iter()
        .zip(&c.table1)
    {
        let want = k.sensitivity_pm_per_g(r.distance_mm);
        assert!(
            (v.as_f64().unwrap() - want).abs() < 1e-3 * want,
            "{v} vs {want}"
        );
    }
    // A load off the sheet is refused with a reason, not answered.
    let o = fbgforge(&[
        "predict",
        design,
        "--load-at-mm",
        "200,0",
        "--json",
        "--map-dir",
        map,
    ]);
    assert!(!o.status.success());
    assert!(!String::from_utf8_lossy(&o.stderr).is_empty());
}
