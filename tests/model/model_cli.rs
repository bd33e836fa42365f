//! Command-line tests of `fbgforge predict` and `fbgforge sweep`: output that parses
//! and matches the library, files written where asked, clear errors on bad input.

use crate::common;
use std::path::Path;
use std::process::Output;

use crate::common::bin;

use common::shipped_path as design;

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn predict_json_matches_the_library() {
    let path = design("clip-on-34mm.toml");
    let o = run(&[
        "predict",
        path.to_str().unwrap(),
        "--force-n",
        "12.5",
        "--fidelity",
        "closed-form",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let preds = v["predictions"].as_array().unwrap();
    let lib = fbgforge::model::predict(&fbgforge::design::load(&path).unwrap(), 12.5).unwrap();
    assert_eq!(preds.len(), lib.len());
    for (j, l) in preds.iter().zip(&lib) {
        assert_eq!(j["grating"], l.grating.as_str());
        assert!(
            (j["sensitivity_pm_per_n"].as_f64().unwrap() - l.sensitivity_pm_per_n).abs() < 1e-9
        );
        assert!((j["shift_pm"].as_f64().unwrap() - 12.5 * l.sensitivity_pm_per_n).abs() < 1e-6);
    }
}

#[test]
fn predict_table_names_every_configuration() {
    let o = run(&[
        "predict",
        design("clip-on-16mm.toml").to_str().unwrap(),
        "--fidelity",
        "closed-form",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    for word in [
        "lambda_11",
        "lambda_22",
        "blue",
        "green",
        "light_green",
        "pm/N",
        "closed-form",
    ] {
        assert!(out.contains(word), "missing {word} in\n{out}");
    }
}

#[test]
fn sweep_writes_chart_and_csv_with_one_row_per_point() {
    let dir = tempfile::tempdir().unwrap();
    let (svg, csv) = (dir.path().join("e2.svg"), dir.path().join("e2.csv"));
    let o = run(&[
        "sweep",
        design("clip-on-34mm.toml").to_str().unwrap(),
        "--param",
        "cap_modulus_mpa",
        "--from",
        "1",
        "--to",
        "50",
        "--steps",
        "5",
        "--case",
        "II",
        "--plot",
        svg.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
    let text = std::fs::read_to_string(&csv).unwrap();
    // 4 gratings × 5 values in Case II, plus the header.
    assert_eq!(text.lines().count(), 1 + 4 * 5);
    assert!(text.lines().skip(1).all(|l| l.contains(",II,")));
}

#[test]
fn sweep_and_predict_reject_bad_input_clearly() {
    let d = design("clip-on-34mm.toml");
    let d = d.to_str().unwrap();
    let o = run(&["sweep", d, "--param", "e7_mpa", "--from", "1", "--to", "2"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("unknown sweep parameter `e7_mpa`") && stderr(&o).contains("es_mpa"),
        "{}",
        stderr(&o)
    );
    let o = run(&["sweep", d, "--param", "e1_mpa", "--from", "5", "--to", "1"]);
    assert!(
        o.status.code() == Some(1) && stderr(&o).contains("reversed"),
        "{}",
        stderr(&o)
    );
    let o = run(&["sweep", d, "--param", "es_mpa", "--from", "0", "--to", "10"]);
    assert!(
        o.status.code() == Some(1) && stderr(&o).contains("modulus"),
        "{}",
        stderr(&o)
    );

    // A design without inserts: Case I requests fail, predict gives Case II only.
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(design("clip-on-34mm.toml")).unwrap();
    let cut = text.find("[[module.inserts]]").unwrap();
    let rest = &text[cut..];
    let gratings = rest.find("[[module.gratings]]").unwrap();
    let no_inserts = format!("{}{}", &text[..cut], &rest[gratings..]);
    let path = dir.path().join("no-inserts.toml");
    std::fs::write(&path, no_inserts).unwrap();
    let p = path.to_str().unwrap();
    let o = run(&[
        "sweep", p, "--param", "e1_mpa", "--from", "1", "--to", "2", "--case", "I",
    ]);
    assert!(
        o.status.code() == Some(1) && stderr(&o).contains("needs a solid insert"),
        "{}",
        stderr(&o)
    );
    let o = run(&["predict", p, "--case", "I"]);
    assert!(
        o.status.code() == Some(1) && stderr(&o).contains("needs a solid insert"),
        "{}",
        stderr(&o)
    );
    let o = run(&["predict", p, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["predictions"]
        .as_array()
        .unwrap()
        .iter()
        .all(|p| p["case"] == "II"));

    // Zero modulus in the spec is caught by the spec's validation, naming the field.
    let zero = text.replace("youngs_modulus_mpa = 44.0", "youngs_modulus_mpa = 0.0");
    let path = dir.path().join("zero.toml");
    std::fs::write(&path, zero).unwrap();
    let o = run(&["predict", path.to_str().unwrap()]);
    assert!(
        o.status.code() == Some(1) && stderr(&o).contains("youngs_modulus_mpa"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn sweep_with_the_fe_model_says_so_and_writes_its_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("fe.csv");
    let svg = dir.path().join("fe.svg");
    let path = design("clip-on-34mm.toml");
    let args = |fidelity: &str, csv: &Path| {
        run(&[
            "sweep",
            path.to_str().unwrap(),
            "--param",
            "e2_mpa",
            "--from",
            "20",
            "--to",
            "44",
            "--steps",
            "2",
            "--case",
            "II",
            "--fidelity",
            fidelity,
            "--csv",
            csv.to_str().unwrap(),
            "--plot",
            svg.to_str().unwrap(),
        ])
    };
    let o = args("fem", &csv);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("model: finite elements"));
    let cf_csv = dir.path().join("cf.csv");
    let o = args("closed-form", &cf_csv);
    assert!(o.status.success(), "{}", stderr(&o));
    let k = |p: &Path| -> Vec<f64> {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
            .collect()
    };
    let (fe, cf) = (k(&csv), k(&cf_csv));
    assert_eq!(fe.len(), 8, "2 steps × 4 gratings");
    for (a, b) in fe.iter().zip(&cf) {
        assert!(
            a != b && ((a - b) / a).abs() < 0.08,
            "FE {a} vs closed form {b}"
        );
    }
}

#[test]
fn output_to_a_closed_pipe_ends_quietly_instead_of_panicking() {
    // `fbgforge predict … | head -1`: the reader goes away before the table is written.
    let path = design("clip-on-34mm.toml");
    let mut child = bin()
        .args(["predict", path.to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("binary runs");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("the process ends");
    let err = stderr(&out);
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.status.success() || err.is_empty(), "{err}");
}

#[test]
fn predict_mesh_level_is_fixed_when_given_and_refused_outside_1_to_4() {
    let path = design("clip-on-16mm.toml");
    let p = path.to_str().unwrap();
    // The help says what level 1 is extrapolated with and what the default does.
    let help = run(&["predict", "--help"]);
    let text = String::from_utf8_lossy(&help.stdout);
    assert!(
        text.contains("level 1 is extrapolated from level 0"),
        "{text}"
    );
    assert!(text.contains("cheapest"), "{text}");
    for bad in ["0", "5"] {
        let o = run(&["predict", p, "--mesh-level", bad]);
        assert!(!o.status.success());
        assert!(stderr(&o).contains("--mesh-level"), "{}", stderr(&o));
    }
    let o = run(&["predict", p, "--case", "i", "--mesh-level", "2", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for r in v["predictions"].as_array().unwrap() {
        assert_eq!(r["mesh_level"], 2, "{r}");
    }
    assert_eq!(v["starting_mesh_level"], 2, "{v}");
    assert_eq!(v["mesh_levels_used"], serde_json::json!([2]), "{v}");
}

#[test]
fn a_modulus_sweep_without_a_range_spans_the_material_library() {
    use fbgforge::optimize::materials::{MaterialLibrary, MaterialRole};
    let d = design("clip-on-34mm.toml");
    let process = fbgforge::design::load(&d).unwrap().printer.process;
    let dir = tempfile::tempdir().unwrap();
    let lib = MaterialLibrary::shipped();
    for (param, role) in [
        ("es_mpa", MaterialRole::Insert),
        ("e1_mpa", MaterialRole::Core),
        ("e2_mpa", MaterialRole::Cap),
    ] {
        let (lo, hi) = lib.modulus_range(role, process).unwrap();
        // The library offers more than one material for each part: a real range.
        assert!(hi > lo, "{param}: {lo}..{hi}");
        let csv = dir.path().join(format!("{param}.csv"));
        let o = run(&[
            "sweep",
            d.to_str().unwrap(),
            "--param",
            param,
            "--steps",
            "4",
            "--fidelity",
            "closed-form",
            "--plot",
            dir.path().join("s.svg").to_str().unwrap(),
            "--csv",
            csv.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{param}: {}", stderr(&o));
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            stdout.contains(&format!("over {lo}..{hi} (4 ")),
            "{param}: {stdout}"
        );
        let values: Vec<f64> = std::fs::read_to_string(&csv)
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
            .collect();
        let min = values.iter().cloned().fold(f64::INFINITY, f64::min);
        let max = values.iter().cloned().fold(0.0, f64::max);
        assert!(
            (min - lo).abs() < 1e-9 * lo && (max - hi).abs() < 1e-9 * hi,
            "{param}: {min}..{max}"
        );
    }
    // A length has no library range: still asked for.
    let o = run(&["sweep", d.to_str().unwrap(), "--param", "cap_wall_mm"]);
    assert!(
        o.status.code() == Some(1) && stderr(&o).contains("--from and --to are required"),
        "{}",
        stderr(&o)
    );
}
