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

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn predict_study_quick_times_every_shipped_module() {
    let dir = tempfile::tempdir().unwrap();
    let designs: Vec<PathBuf> = ["clip-on-10mm.toml", "clip-on-34mm.toml"]
        .iter()
        .map(|n| root().join("designs").join(n))
        .collect();
    let a = fbgforge_studies::predict::BenchPredictArgs {
        designs,
        iterations: 2_000,
        out: dir.path().to_path_buf(),
        quick: true,
    };
    fbgforge_studies::predict::run(&a).unwrap();
    let rows = read_json(&dir.path().join("predict.json"));
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for r in rows {
        // One closed-form K is far cheaper than a whole prediction of the design.
        let k_ns = r["closed_form_ns_per_k"].as_f64().unwrap();
        let full_us = r["full_predict_us"].as_f64().unwrap();
        assert!(k_ns > 0.0 && k_ns * 1e-3 < full_us, "{r}");
    }
}

#[test]
fn verify_study_quick_recovers_k_of_its_synthetic_log() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::verify::BenchVerifyArgs {
        out: dir.path().to_path_buf(),
        minutes: 60.0,
        rate_hz: 1000.0,
        keep: false,
        quick: true,
    };
    fbgforge_studies::verify::run(&a).unwrap();
    let csv = std::fs::read_to_string(dir.path().join("bench_verify.csv")).unwrap();
    let total = csv.lines().find(|l| l.starts_with("end to end")).unwrap();
    // "... worst K error 0.123 %": the pipeline recovers the log's K within 1 %.
    let pct: f64 = total
        .split("worst K error ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(pct < 1.0, "{total}");
    assert!(
        !dir.path().join("bench-peaks.txt").exists(),
        "logs removed without --keep"
    );
    // The protocol table: every protocol detected, K within 1 %, Δt_max within 0.05 s
    // of the synthetic truth, Q in the ratio of K within 5 %.
    let csv = std::fs::read_to_string(dir.path().join("protocols.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 12, "{csv}");
    for r in &rows {
        assert!(r[0].starts_with(r[3]), "{r:?}");
        let num = |i: usize| r[i].parse::<f64>().unwrap();
        assert!(
            num(4) < 1.0 && num(6) < 0.05 && (num(8) - 1.0).abs() < 0.05,
            "{r:?}"
        );
    }
}

#[test]
fn optimize_study_quick_never_ends_below_its_start() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::optimize::BenchOptimizeArgs {
        threads: 2,
        out_dir: dir.path().to_path_buf(),
        quick: true,
    };
    fbgforge_studies::optimize::run(&a).unwrap();
    let rows = read_json(&dir.path().join("optimize.json"));
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 1, "quick: the 34 mm module with Nelder–Mead");
    let r = &rows[0];
    assert!(r["objective"].as_f64().unwrap() >= r["start_objective"].as_f64().unwrap());
}

#[test]
fn reconstruct_study_quick_recovers_every_single_load() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::reconstruct::BenchOptions {
        out: dir.path().to_path_buf(),
        design: None,
        seed: 1,
        repeats: 20,
        quick: true,
        part: fbgforge_studies::reconstruct::Part::All,
        budget_us: None,
    };
    fbgforge_studies::reconstruct::run(&a).unwrap();
    let runs = read_json(&dir.path().join("protocol.json"));
    let wsupport = runs
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["method"].as_str().unwrap().starts_with("wsupport"))
        .unwrap();
    let single = wsupport["by_load_count"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["n_loads"] == 1)
        .unwrap();
    // The paper's Table 3: every single load is recovered (RR 100 %).
    assert_eq!(single["rr_pct"].as_f64().unwrap(), 100.0, "{single}");
    assert!(dir.path().join("speed_accuracy.svg").exists());
    // The scaling part writes its test and validation frames for the peers
    // (studies/peers/scaling_vs_peers.py tunes on the latter): same matrix, two frames
    // per load count in a quick run, each truth with as many loads as it says.
    let frames = dir.path().join("scaling-frames").join("n8");
    let read = |p: PathBuf| std::fs::read_to_string(&p).unwrap();
    assert_eq!(
        read(frames.join("A.csv")),
        read(frames.join("val").join("A.csv"))
    );
    for d in [frames.clone(), frames.join("val")] {
        let truth = read(d.join("truth.csv"));
        let loads = read(d.join("loads_per_frame.csv"));
        let rows: Vec<&str> = truth.lines().skip(1).collect();
        let counts: Vec<usize> = loads.lines().skip(1).map(|l| l.parse().unwrap()).collect();
        assert_eq!(rows.len(), 8, "{}", d.display());
        assert_eq!(read(d.join("shifts.csv")).lines().count(), 9);
        for (row, k) in rows.iter().zip(&counts) {
            let loaded = row
                .split(',')
                .filter(|v| v.parse::<f64>().unwrap() > 0.0)
                .count();
            assert_eq!(loaded, *k, "{row}");
        }
    }
}

#[test]
fn reconstruct_fault_study_quick_flags_what_it_misses_and_names_the_dead_grating() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::reconstruct::BenchOptions {
        out: dir.path().to_path_buf(),
        design: None,
        seed: 1,
        repeats: 1,
        quick: true,
        part: fbgforge_studies::reconstruct::Part::Faults,
        budget_us: None,
    };
    fbgforge_studies::reconstruct::run(&a).unwrap();
    let rows = read_json(&dir.path().join("faults.json"));
    let rows = rows.as_array().unwrap();
    // 2 arrays × 6 scenarios × (default, 6 methods, bnb with common mode).
    assert_eq!(rows.len(), 2 * 6 * 8);
    let row = |array: &str, scenario: &str, method: &str| {
        rows.iter()
            .find(|r| r["array"] == array && r["scenario"] == scenario && r["method"] == method)
            .unwrap_or_else(|| panic!("{array} {scenario} {method}"))
    };
    let f = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap();
    for array in ["6x8 paper", "10x20 grid"] {
        // The dead grating is named in its stream, and no grating in a clean one.
        for scenario in ["dead", "all"] {
            let r = row(array, scenario, "bnb");
            assert_eq!(r["dead_named"], r["streams"], "{r}");
        }
        assert_eq!(row(array, "clean", "bnb")["false_suspects"], 0);
        // Issue 35: the stream diagnosis fits the common offset by itself, so bnb
        // without --common-mode recovers what bnb with it does on the offset stream.
        let (cm, plain) = (row(array, "offset", "bnb +cm"), row(array, "offset", "bnb"));
        assert!(
            f(plain, "rr_pct") >= f(cm, "rr_pct") - 5.0,
            "{cm} against {plain}"
        );
        // With every fault, most missed frames carry a flag; few clean ones do.
        let all = row(array, "all", "bnb");
        assert!(f(all, "flag_recall_pct") >= 50.0, "{all}");
        let clean = row(array, "clean", "bnb");
        assert!(
            clean["false_flag_pct"].as_f64().unwrap_or(0.0) <= 30.0,
            "{clean}"
        );
    }
    assert!(dir.path().join("faults.csv").exists());
    assert!(dir.path().join("faults-10x20.svg").exists());
}

#[test]
fn reconstruct_flag_study_quick_flags_alike_names_faults_and_refuses_absurd_frames() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::reconstruct::BenchOptions {
        out: dir.path().to_path_buf(),
        design: None,
        seed: 1,
        repeats: 1,
        quick: true,
        part: fbgforge_studies::reconstruct::Part::Flags,
        budget_us: None,
    };
    fbgforge_studies::reconstruct::run(&a).unwrap();
    let rows = read_json(&dir.path().join("flags.json"));
    let rows = rows.as_array().unwrap();
    let row = |array: &str, fault: &str, method: &str| {
        rows.iter()
            .find(|r| r["array"] == array && r["fault"] == fault && r["method"] == method)
            .unwrap_or_else(|| panic!("{array} {fault} {method}"))
    };
    let f = |r: &serde_json::Value, k: &str| r[k].as_f64().unwrap_or(0.0);
    let flag = |r: &serde_json::Value, word: &str| {
        r["flag_pct"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p[0] == word)
            .map_or(0.0, |p| p[1].as_f64().unwrap())
    };
    for array in ["6x8 paper", "10x20 hex"] {
        // The same objective gives the same loads and, the rivals being computed,
        // the same flags: `support` and `bnb` agree on every fault.
        for fault in ["clean", "dead", "drift", "offset", "absurd"] {
            let (s, b) = (row(array, fault, "support"), row(array, fault, "bnb"));
            assert_eq!(s["rr_pct"], b["rr_pct"], "{array} {fault}");
            assert_eq!(s["false_flag_pct"], b["false_flag_pct"], "{array} {fault}");
            assert_eq!(s["recall_pct"], b["recall_pct"], "{array} {fault}");
        }
        // A clean stream: no suspect, no offset; a dead grating and an offset found.
        let clean = row(array, "clean", "bnb");
        assert_eq!(
            (
                clean["wrong_suspects"].as_u64(),
                clean["common_mode_streams"].as_u64()
            ),
            (Some(0), Some(0))
        );
        assert_eq!(row(array, "dead", "bnb")["diagnosis_right"], 1);
        assert_eq!(row(array, "offset", "bnb")["common_mode_streams"], 1);
        // Absurd frames (3 % of the stream) are unusable for every method, and
        // flagged: never trusted zero loads.
        for method in ["bnb", "support", "lasso", "omp", "nnls"] {
            let r = row(array, "absurd", method);
            assert!(flag(r, "unusable") >= 1.0, "{r}");
            assert!(f(r, "recall_pct") > 0.0, "{r}");
        }
    }
    // The 10 × 20 drift stream names its drifting grating and nothing else: the
    // strongest trend is corrected first and its neighbours, into whose
    // leave-one-out fits it leaked, tested again (one was named with it before).
    let drift = row("10x20 hex", "drift", "bnb");
    assert_eq!(
        (
            drift["diagnosis_right"].as_u64(),
            drift["wrong_suspects"].as_u64()
        ),
        (Some(1), Some(0)),
        "{drift}"
    );
    // False flags on right answers (no load off by more than 25 g, no loaded cell
    // missed or added) within the test's 5 % size on clean streams.
    for array in ["6x8 paper", "10x20 hex"] {
        let clean = row(array, "clean", "bnb");
        assert!(f(clean, "false_flag_right_pct") <= 5.0, "{clean}");
    }
    // Every wrong answer of a clean stream is held against its truth and falls in
    // exactly one class; an exhaustive search (`support`, certified) is never beaten
    // on its own objective, so none of its wrong answers is missed by the search.
    for array in ["6x8 paper", "10x20 hex"] {
        for method in ["default → support", "support", "bnb"] {
            let Some(r) = rows
                .iter()
                .find(|r| r["array"] == array && r["fault"] == "clean" && r["method"] == method)
            else {
                continue;
            };
            let c = &r["wrong_classes"];
            let n = |k: &str| c[k].as_u64().unwrap();
            assert_eq!(n("classified"), r["wrong"].as_u64().unwrap(), "{r}");
            assert_eq!(
                n("search_failure") + n("within_chance") + n("answer_better"),
                n("classified"),
                "{r}"
            );
        }
        for fault in ["clean", "dead", "drift", "offset", "absurd"] {
            let s = row(array, fault, "support");
            assert_eq!(s["wrong_classes"]["search_missed"], 0, "{s}");
        }
    }
    assert!(dir.path().join("flags-roc.csv").exists());
    assert!(dir.path().join("flags-roc-10x20-clean.svg").exists());
    // The margin ROC of a "rival within the noise" flag: per array and data, a
    // larger margin flags a superset, so both rates never fall; at M = 0 on clean
    // streams (a rival the methods' own objective prefers) within the 5 % size.
    let csv = std::fs::read_to_string(dir.path().join("flags-margin.csv")).unwrap();
    let pts: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    let fields = fbgforge_studies::reconstruct_flags::RIVAL_MARGINS.len();
    assert_eq!(pts.len(), 2 * 2 * fields);
    for curve in pts.chunks(fields) {
        let v = |r: &Vec<String>, k: usize| r[k].parse::<f64>().unwrap();
        for w in curve.windows(2) {
            assert!(
                v(&w[1], 5) >= v(&w[0], 5) && v(&w[1], 6) >= v(&w[0], 6),
                "{w:?}"
            );
        }
        if curve[0][1] == "clean" {
            assert!(v(&curve[0], 5) <= 5.0, "{:?}", curve[0]);
        }
    }
}

#[test]
fn reconstruct_budget_study_quick_compares_the_default_with_certified_bnb_per_load_count() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::reconstruct::BenchOptions {
        out: dir.path().to_path_buf(),
        design: None,
        seed: 1,
        repeats: 1,
        quick: true,
        part: fbgforge_studies::reconstruct::Part::Budget,
        budget_us: None,
    };
    fbgforge_studies::reconstruct::run(&a).unwrap();
    let rows = read_json(&dir.path().join("budget.json"));
    let rows = rows.as_array().unwrap();
    // Certified bnb and the default at three budgets, each at 1–4 loads.
    assert_eq!(rows.len(), 16);
    for r in rows.iter().filter(|r| r["entry"] == "certified bnb") {
        // Run to the end, every answer is the certified optimum.
        assert_eq!(r["certified"], r["frames"], "{r}");
    }
    for r in rows {
        assert!(
            r["mean_us"].as_f64().unwrap() > 0.0 && r["estimated_us"].as_f64().unwrap() > 0.0,
            "{r}"
        );
        assert!(
            (0.0..=100.0).contains(&r["rr_pct"].as_f64().unwrap()),
            "{r}"
        );
    }
    assert!(rows.iter().any(|r| r["entry"]
        .as_str()
        .unwrap()
        .starts_with("default 100 µs → ")));
}

#[test]
fn fem_study_quick_converges_under_refinement() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::fem::FemStudyArgs {
        out: dir.path().to_path_buf(),
        quick: true,
    };
    fbgforge_studies::fem::run(&a).unwrap();
    let csv = std::fs::read_to_string(dir.path().join("fem_convergence.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (cfg, k) = (col("configuration"), col("sensitivity_pm_per_n"));
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    // Case II: successive refinements change K less and less.
    let k2: Vec<f64> = rows
        .iter()
        .filter(|r| r[cfg].contains("Case II"))
        .map(|r| r[k].parse().unwrap())
        .collect();
    assert!(k2.len() >= 3, "{csv}");
    let d: Vec<f64> = k2.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    assert!(d.windows(2).all(|w| w[1] < w[0]), "{k2:?}");
}

#[test]
fn contact_study_quick_meets_hertz_and_finds_the_knee() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::fem_contact::ContactStudyArgs {
        out: dir.path().to_path_buf(),
        quick: true,
    };
    fbgforge_studies::fem_contact::run(&a).unwrap();
    let rows = |name: &str| -> Vec<Vec<String>> {
        std::fs::read_to_string(dir.path().join(name))
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(str::to_owned).collect())
            .collect()
    };
    // Hertz: within 3 % at 8 elements across the contact radius.
    let hertz = rows("contact_hertz.csv");
    let err: f64 = hertz.last().unwrap()[3].parse().unwrap();
    assert!(err.abs() < 3.0, "Hertz error {err} %");
    // The dome clearance closes below 2 N for both inserts, and the touching pairs are
    // all on the domes.
    for k in rows("contact_knee.csv") {
        let knee: f64 = k[2].parse().unwrap();
        assert!(knee > 0.05 && knee < 2.0, "{k:?}");
    }
    assert!(rows("contact_curve.csv").iter().all(|r| r[5] == "0"));
    // The default radius (1.72 mm) meets the statements; the window file has a row
    // for it.
    let w = rows("contact_window.csv");
    let r = w.iter().find(|r| r[0] == "1.72").unwrap();
    assert_eq!((r[7].as_str(), r[8].as_str()), ("true", "true"));
}

#[test]
fn fe_speed_study_quick_reuses_every_structure_across_a_modulus_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::fe_speed::FeSpeedArgs {
        design: root().join("designs/clip-on-34mm.toml"),
        runs: 1,
        out: dir.path().to_path_buf(),
        quick: true,
    };
    fbgforge_studies::fe_speed::run(&a).unwrap();
    let doc = read_json(&dir.path().join("fe_speed.json"));
    let rows = doc["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    let (predict, closed, sweep) = (&rows[0], &rows[1], &rows[2]);
    // The closed-form fast path builds no FE structure at all.
    assert_eq!(closed["structures_built"].as_u64(), Some(0), "{closed}");
    assert_eq!(closed["structures_reused"].as_u64(), Some(0), "{closed}");
    // A sweep over E1 keeps every mesh: it builds the structures of one step (those of
    // a Case I predict) and re-uses them at every further step.
    let built = sweep["structures_built"].as_u64().unwrap();
    assert!(built > 0, "{sweep}");
    assert!(
        built <= predict["structures_built"].as_u64().unwrap(),
        "{predict} {sweep}"
    );
    assert!(
        sweep["structures_reused"].as_u64().unwrap() >= 2 * built,
        "{sweep}"
    );
}

#[test]
fn sheet_study_quick_compares_with_the_paper_and_times_the_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::sheet::SheetStudyArgs {
        design: root().join("designs/tactile-array-60x80.toml"),
        part: None,
        repeats: 1,
        out: dir.path().to_path_buf(),
        quick: true,
    };
    fbgforge_studies::sheet::run(&a).unwrap();
    let p = read_json(&dir.path().join("paper.json"));
    // The mirror-averaged shape within 25 % of Table 1 after one common scale.
    assert!(p["sheet"]["worst_shape_error_pct"].as_f64().unwrap() <= 25.0);
    let s = read_json(&dir.path().join("speed.json"));
    let rows = s["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    // Finer resolutions agree better with the finest (their cost is the study's table,
    // not a timed test).
    let e = |i: usize| rows[i]["max_error_vs_finest_pct"].as_f64().unwrap();
    assert!(e(2) < e(0), "refinement 2 is closer to the finest than 0.5");
    assert!(std::fs::read_to_string(dir.path().join("speed.svg"))
        .unwrap()
        .contains("<svg"));
    let trends = std::fs::read_to_string(dir.path().join("trends.csv")).unwrap();
    assert_eq!(trends.lines().count(), 3);
}

#[test]
fn live_starts_study_quick_reads_only_after_a_tare_window_and_its_oracle_is_right() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::live_starts::LiveStartsArgs {
        array: root().join("designs/tactile-array-60x80.toml"),
        module: root().join("designs/clip-on-34mm.toml"),
        scenarios: 4,
        seed: 1,
        out: dir.path().to_path_buf(),
        quick: true,
    };
    fbgforge_studies::live_starts::run(&a).unwrap();
    let csv = std::fs::read_to_string(dir.path().join("scenarios.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    // 2 designs × 4 scenarios × 3 policies.
    assert_eq!(rows.len(), 24);
    for r in &rows {
        let first: Option<f64> = r[12].parse().ok();
        match r[8].as_str() {
            // The truth the generator used is the truth the study compares with: a
            // tare on the true zero shows no confidently wrong load.
            "oracle" => assert_eq!(r[11], "0", "{r:?}"),
            // No reading before a whole tare window (1 s) has passed.
            "at_rest" => assert!(first.is_none_or(|t| t >= 1.0 - 1e-9), "{r:?}"),
            // The old tare reads from frame 51.
            "first_50" => assert!(first.is_some_and(|t| (t - 0.050).abs() < 1e-9), "{r:?}"),
            p => panic!("policy {p}"),
        }
    }
    let s = read_json(&dir.path().join("summary.json"));
    assert_eq!(s["totals"].as_array().unwrap().len(), 6);
}

#[test]
fn model_error_study_quick_finds_every_nominal_inside_and_every_written_grating_in_margin() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::model_error::ModelErrorArgs {
        designs: 3,
        optimise: 1,
        seed: 38,
        out: dir.path().to_path_buf(),
        quick: true,
    };
    let r = fbgforge_studies::model_error::run(&a).unwrap();
    assert_eq!(r.designs, 3);
    assert!(r.rows >= 3 * 4, "{r:?}");
    // Every nominal inside its widened readings and its design interval.
    assert_eq!(r.rows_outside_widened_band, 0, "{r:?}");
    assert_eq!(r.rows_outside_design_interval, 0, "{r:?}");
    // The policy picked a mesh stating at most 15 % on every row, and every row
    // (FE readings on each of them) names its level.
    assert_eq!(r.rows_over_max_error, 0, "{r:?}");
    assert_eq!(r.rows_over_max_error_unflagged, 0, "{r:?}");
    assert_eq!(r.rows_outside_unflagged, 0, "{r:?}");
    assert_eq!(r.rows_by_mesh_level.iter().sum::<usize>(), r.rows, "{r:?}");
    assert_eq!(r.rows_by_mesh_level[0], 0, "{r:?}");
    // Each drawn design is written beside its rows.
    for k in 0..r.designs {
        assert!(dir.path().join(format!("designs/design-{k}.toml")).exists());
    }
    // What optimize wrote keeps the 5 % margin at the far end of its interval.
    assert_eq!(r.optimised, 1);
    if r.optimise_failed == 0 {
        assert!(r.written_gratings > 0, "{r:?}");
        assert_eq!(r.written_at_or_over_limit, 0, "{r:?}");
        assert_eq!(r.written_under_margin, 0, "{r:?}");
        assert!(r.smallest_written_margin_percent >= 5.0 - 1e-6, "{r:?}");
        assert_eq!(r.written_wavelength_window_over, 0, "{r:?}");
        assert_eq!(r.written_snap_over, 0, "{r:?}");
    }
    let json = read_json(&dir.path().join("model_error.json"));
    assert_eq!(json["rows"].as_u64().unwrap() as usize, r.rows);
    let csv = std::fs::read_to_string(dir.path().join("model_error.csv")).unwrap();
    assert_eq!(csv.lines().count(), r.rows + 1);
}

#[test]
fn spectra_study_quick_counts_few_confidently_wrong_peaks() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::spectra::SpectraStudyArgs {
        scenarios: 0,
        seed: 36,
        out: dir.path().to_path_buf(),
        quick: true,
    };
    let lines = fbgforge_studies::spectra::run_study(&a).unwrap();
    let all = lines.iter().find(|l| l.group == "all").unwrap();
    assert_eq!(all.scenarios, 300);
    // Nearly every scenario yields a peak in its grating's window.
    assert!(all.found >= 285, "{all:?}");
    // The full study (4000 scenarios, seed 36) measured 0.9 % confidently wrong
    // (0.6–1.2 %); 300 scenarios may hold a few more by chance, never a tenth.
    assert!(all.confidently_wrong_fraction < 0.05, "{all:?}");
    // Well-sampled lone Gaussians: the case the finder is built for.
    let clean = lines
        .iter()
        .find(|l| l.group == "gaussian, alone, unsaturated")
        .unwrap();
    assert!(clean.confidently_wrong <= 1, "{clean:?}");
    let csv = std::fs::read_to_string(dir.path().join("spectra-scenarios.csv")).unwrap();
    assert_eq!(csv.lines().count(), 301);
}

#[test]
fn spectrum_forward_study_quick_agrees_with_the_dense_scan() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::spectrum_forward::SpectrumForwardArgs {
        scenarios: 0,
        seed: 36,
        out: dir.path().to_path_buf(),
        quick: true,
    };
    let (rows, s) = fbgforge_studies::spectrum_forward::run_study(&a).unwrap();
    assert_eq!(s.scenarios, 8);
    // The draws stay inside the spec's ranges: predict answers every one.
    assert_eq!(s.refused, 0, "{rows:?}");
    // No missed warning and no force off on the quick draws (the full study states
    // its rate with its interval in docs/spectra.md §8).
    assert_eq!(s.confidently_wrong, 0, "{rows:?}");
    let csv = std::fs::read_to_string(dir.path().join("spectrum-forward-scenarios.csv")).unwrap();
    assert_eq!(csv.lines().count(), 9);
}

/// Run the verdict study (`only`: one class) and read its rows: (class, clock,
/// given verdict, reason code, outcome).
fn verdict_rows(
    dir: &Path,
    scenarios: usize,
    first_seed: u64,
    only: Option<&str>,
    quick: bool,
) -> (serde_json::Value, Vec<[String; 5]>) {
    let a = fbgforge_studies::verdicts::VerdictStudyArgs {
        out: dir.to_path_buf(),
        scenarios,
        first_seed,
        only: only.map(String::from),
        keep: false,
        quick,
    };
    fbgforge_studies::verdicts::run(&a).unwrap();
    let csv = std::fs::read_to_string(dir.join("verdicts.csv")).unwrap();
    let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let (c, k, g, r, o) = (
        col("class"),
        col("clock"),
        col("given"),
        col("code"),
        col("outcome"),
    );
    let rows = csv
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            [f[c], f[k], f[g], f[r], f[o]].map(String::from)
        })
        .collect();
    (read_json(&dir.join("verdicts.json")), rows)
}

#[test]
fn verdict_study_quick_gives_no_confidently_wrong_verdict() {
    // 60 scenarios drawn from the study's own space (its own forward model, not the
    // project's synthetic generator), each verified with the clock offset given and
    // estimated: not one definite verdict against the truth or refusal naming a fault
    // that is not there, and at least 90 % of the runs whose truth the data decide get
    // the right definite verdict.
    let dir = tempfile::tempdir().unwrap();
    let (s, rows) = verdict_rows(dir.path(), 0, 1, None, true);
    assert_eq!(s["runs"].as_u64(), Some(120), "{s}");
    assert_eq!(s["confidently_wrong"].as_u64(), Some(0), "{s}");
    assert_eq!(s["errors"].as_u64(), Some(0), "{s}");
    assert!(s["definite_rate"].as_f64().unwrap() >= 0.9, "{s}");
    assert!(s["definite_truth"].as_u64().unwrap() >= 40, "{s}");
    assert_eq!(rows.len(), 120);
    let md = std::fs::read_to_string(dir.path().join("verdict_confusion.md")).unwrap();
    assert!(md.contains("| expected \\ given |"), "{md}");
}

/// Each class of the issue, drawn on its own over `n` seeds: no confidently wrong
/// verdict, and every refusal names one of `codes` (the rival the class is about).
fn class_holds(class: &str, n: usize, codes: &[&str], definite: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let (s, rows) = verdict_rows(dir.path(), n, 1000, Some(class), false);
    assert_eq!(
        s["confidently_wrong"].as_u64(),
        Some(0),
        "{class}: {s} {rows:?}"
    );
    assert_eq!(rows.len(), 2 * n);
    for r in &rows {
        assert_eq!(r[0], class);
        let ok = if r[4] == "Right" {
            definite.contains(&r[2].as_str())
        } else {
            codes.contains(&r[3].as_str())
        };
        assert!(ok, "{class}: {r:?}");
    }
}

#[test]
fn a_short_recording_is_never_aligned_to_the_wrong_press() {
    // Issue #33, class 1: the interrogator or the force stand stopped early; an
    // estimated offset with too few presses or a rival offset is NOT JUDGED
    // (alignment), a given one is judged. Seed 1000 (a staircase at 250 Hz whose
    // wavelength log starts 283 s into the force log, beyond the ±60 s search) was NO
    // RESPONSE at a wrong offset: the shift's presses where the force rests now make it
    // NOT JUDGED, naming the offset at which the presses line up.
    class_holds(
        "wavelength-cut",
        4,
        &["alignment", "unexplained"],
        &["PASS", "FAIL"],
    );
    class_holds(
        "force-cut",
        4,
        &["alignment", "unexplained"],
        &["PASS", "FAIL"],
    );
}

#[test]
fn a_loose_bond_never_passes() {
    // Class 2: friction in the bond (12-40 % of span of loop): FAIL (bonding or off
    // the model), or not judged for its precision, never PASS.
    class_holds(
        "loose-bond",
        4,
        &["precision", "alignment", "instrument"],
        &["FAIL"],
    );
}

#[test]
fn temperature_without_a_reference_is_no_response_on_an_unloaded_sensor() {
    // Class 3: an unloaded sensor with a temperature swing and no reference: NO
    // RESPONSE (or NOT JUDGED for the alignment), never FAIL.
    class_holds(
        "unloaded-with-temperature",
        4,
        &["no_response", "alignment"],
        &[],
    );
}

#[test]
fn a_saturated_or_stuck_interrogator_is_not_judged() {
    // Class 4: peaks pinned at a ceiling or frozen: NOT JUDGED (instrument).
    class_holds(
        "wavelength-saturation",
        4,
        &["instrument", "alignment", "unexplained"],
        &[],
    );
    class_holds(
        "stuck-peaks",
        3,
        &["instrument", "alignment", "unexplained"],
        &[],
    );
}

#[test]
fn clock_jumps_and_whole_second_pauses_are_seen() {
    // Classes 5 and 6: a wall clock stepped back or forward mid-log, and whole-second
    // timestamps with pauses: judged right when the rows still line up, else NOT
    // JUDGED naming the clock, never a silent drop of presses.
    class_holds(
        "clock-jump",
        4,
        &["clock", "alignment", "unexplained"],
        &["PASS", "FAIL"],
    );
    class_holds(
        "whole-second-pauses",
        4,
        &["precision", "alignment", "clock"],
        &["PASS", "FAIL"],
    );
}

#[test]
fn force_units_in_a_column_or_the_header_are_read() {
    // Class 7: a Mark-10 style units column, named units, and unnamed kgf/lbf (K off
    // by the unit's factor: NOT JUDGED naming the unit).
    class_holds("units-column", 3, &["alignment"], &["PASS", "FAIL"]);
    class_holds("units-unnamed", 3, &["units", "alignment"], &[]);
}

#[test]
fn calibrate_study_quick_counts_every_scenario_and_a_clean_run_is_never_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let a = fbgforge_studies::calibrate::CalibrateStudyArgs {
        design: root().join("designs/tactile-array-60x80.toml"),
        out: dir.path().to_path_buf(),
        runs: 3,
        seed: 1,
        quick: true,
    };
    fbgforge_studies::calibrate::run(&a).unwrap();
    let counts: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("calibrate-study.json")).unwrap(),
    )
    .unwrap();
    let counts = counts.as_array().unwrap();
    assert_eq!(counts.len(), fbgforge_studies::calibrate::SCENARIOS.len());
    for c in counts {
        assert_eq!(c["runs"], 3, "{c}");
        // No scenario may hand out a wrong matrix as usable.
        assert_eq!(c["confidently_wrong"], 0, "{c}");
    }
    let rows = std::fs::read_to_string(dir.path().join("calibrate-study.csv")).unwrap();
    assert_eq!(rows.lines().count(), 1 + 3 * counts.len());
}

#[test]
fn a_wavelength_log_cut_beyond_the_search_names_the_offset_its_presses_point_to() {
    // Issue #33, class 1, seed 1000: the wavelength log starts some 283 s into the
    // force log, beyond the ±60 s the offset is searched in. Estimated, the force lands
    // on rest and the grating reads silent; the shift's presses where the force rests
    // make the verdict NOT JUDGED (alignment), not NO RESPONSE, and the offset at which
    // the force log's presses start on them is the true one (within a second).
    use fbgforge_studies::verdicts::space::Class;
    let dir = tempfile::tempdir().unwrap();
    let (_, files) =
        fbgforge_studies::verdicts::write_one(dir.path(), 1000, Some(Class::WavelengthCut))
            .unwrap();
    let mut req = fbgforge::verify::VerifyRequest::new(files.design, files.log, files.force);
    req.case = Some(fbgforge::model::LoadCase::II);
    req.analysis.core = Some("psc2".into());
    let out = fbgforge::verify::run(&req).unwrap();
    let v = serde_json::to_value(&out.report).unwrap();
    assert_eq!(v["verdict"]["overall"], "not_judged", "{}", v["verdict"]);
    assert_eq!(v["verdict"]["reason_code"], "alignment", "{}", v["verdict"]);
    let reason = v["verdict"]["reason"].as_str().unwrap();
    assert!(reason.contains("at rest or has no samples"), "{reason}");
    let m = &v["measurement"]["alignment"]["press_match"];
    let found = m["clock_offset_s"].as_f64().unwrap();
    assert!(
        found > 100.0 && (found - files.offset_s).abs() < 1.0,
        "{m} vs {}",
        files.offset_s
    );
    assert!(m["presses"].as_u64().unwrap() >= 3, "{m}");
}

#[test]
fn an_hour_s_clock_jump_judges_the_rows_under_the_force_log_not_an_error() {
    // Seed 2042 (wider draw): the wavelength log's clock runs back by an hour after
    // its first presses, so its longest stretch on one clock lies an hour before the
    // force log. Analysing the longest stretch ended in an error naming both files
    // (exit 1). Now the stretch under the force log is analysed: with the offset given
    // its presses are judged (PASS, the truth: K within 0.1 % of the part's); with the
    // offset estimated the presses outside the rows analysed make it NOT JUDGED with
    // reason_code `clock`, the jump named. Never an error.
    let dir = tempfile::tempdir().unwrap();
    let (s, rows) = verdict_rows(dir.path(), 1, 2042, None, false);
    assert_eq!(s["errors"].as_u64(), Some(0), "{rows:?}");
    assert_eq!(s["confidently_wrong"].as_u64(), Some(0), "{rows:?}");
    assert_eq!(rows.len(), 2);
    for r in &rows {
        assert_eq!(r[0], "clock-jump", "{r:?}");
        match r[1].as_str() {
            "given" => assert_eq!((r[2].as_str(), r[4].as_str()), ("PASS", "Right"), "{r:?}"),
            _ => assert_eq!(
                (r[2].as_str(), r[3].as_str()),
                ("NOT JUDGED", "clock"),
                "{r:?}"
            ),
        }
    }
}

#[test]
fn silence_from_a_noisy_k_or_untrusted_readings_is_not_no_response() {
    // The wider draw (seeds 2000-2399) found three runs confidently wrong: seed 2117
    // (stuck peaks at 1 kHz: a frozen grating called dead, FAIL), 2143 (a saturated
    // force under a preloaded sine) and 2223 (a loose bond), both NO RESPONSE with the
    // offset given while the force explained 0.72 and 0.94 of the shift and K was 1.5
    // and 1.1 × the model's, only too noisy (2-6 effective samples) to tell from zero.
    // Each is now NOT JUDGED (instrument, precision), never a false fault.
    for seed in [2117, 2143, 2223] {
        let dir = tempfile::tempdir().unwrap();
        let (s, rows) = verdict_rows(dir.path(), 1, seed, None, false);
        assert_eq!(
            s["confidently_wrong"].as_u64(),
            Some(0),
            "seed {seed}: {rows:?}"
        );
        for r in &rows {
            assert!(
                r[2] != "NO RESPONSE" && r[2] != "FAIL",
                "seed {seed}: {r:?}"
            );
        }
    }
}

#[test]
fn a_preloaded_sine_s_cycles_count_as_presses_that_pin_the_offset() {
    // The third draw (seeds 3000-3199): five preloaded sines with three or more
    // presses both logs cover (seeds 3050, 3100, 3150, 3158, 3193) were NOT JUDGED
    // with the offset estimated, "only 1 press of the force log lies in the overlap":
    // a preloaded sine never returns to rest, so its whole train is one pulse, and the
    // count was of pulses. A sine's cycles now count each. Seed 3050 (a slightly
    // hysteretic part at 2 Hz, whole-second stamps with pauses) PASSes and seed 3158
    // (a part 32 % off the model at 250 Hz) FAILs, their truths, with either clock.
    for (seed, verdict) in [(3050, "PASS"), (3158, "FAIL")] {
        let dir = tempfile::tempdir().unwrap();
        let (s, rows) = verdict_rows(dir.path(), 1, seed, None, false);
        assert_eq!(
            s["confidently_wrong"].as_u64(),
            Some(0),
            "seed {seed}: {rows:?}"
        );
        assert_eq!(rows.len(), 2);
        for r in &rows {
            assert_eq!(
                (r[2].as_str(), r[4].as_str()),
                (verdict, "Right"),
                "seed {seed}: {r:?}"
            );
        }
    }
}

/// Issue 39's study of print files: the quick draw reaches built designs and
/// refusals of both kinds, its outside checks find what they look for on cases with
/// known answers, and (the finding) no confidently wrong output.
#[test]
fn print_files_study_quick_counts_no_confidently_wrong_build() {
    use fbgforge_studies::print_files as pf;
    // The outside checks on known cases: a tetrahedron is watertight, one face less
    // is not; a point above a triangle is at its height; fields are recognised.
    let tet = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
    assert!(pf::watertight(&tet));
    assert!(!pf::watertight(&tet[..3]));
    // (the overlap depth is the library's point-to-mesh distance, `Solid`)
    let t = fbgforge::geometry::mesh::TriMesh {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 2]],
    };
    let solid = fbgforge::geometry::assembly::Solid::new("t", &t);
    let at = |p| solid.distance_within(p, f64::INFINITY).unwrap();
    assert!((at([0.2, 0.2, 0.3]) - 0.3).abs() < 1e-12);
    assert!((at([2.0, 0.0, 0.0]) - 1.0).abs() < 1e-12);
    assert!(pf::names_field(
        "field `module.pillars.fiber_hole_diameter_mm`: 0.3 mm"
    ));
    assert!(!pf::names_field("mesh check `closed` failed"));
    let dir = tempfile::tempdir().unwrap();
    let a = pf::PrintFilesArgs {
        designs: root().join("designs"),
        scenarios: 12,
        seed: 3900,
        out: dir.path().to_path_buf(),
        quick: true,
    };
    pf::run(&a).unwrap();
    let j = read_json(&dir.path().join("print-files.json"));
    let s = &j["summary"];
    assert_eq!(s["scenarios"], 12);
    assert!(s["built"].as_u64().unwrap() >= 2, "{s}");
    assert!(s["refused_spec"].as_u64().unwrap() >= 1, "{s}");
    assert_eq!(s["confidently_wrong"], 0, "{j}");
}

#[test]
fn a_preloaded_sine_held_at_the_force_ceiling_is_force_untrusted_not_silent() {
    // Seed 5013 (fourth draw, first seed 5000): a good part (K 1.02 × the model's)
    // under a preloaded sine whose force channel saturates at 2.29 N for two thirds of
    // each 12 s cycle, at a 1 Hz interrogator. Two thirds of the samples repeat the
    // ceiling exactly, so the force noise read from second differences was 0 (no
    // clipping could be seen) and the ceiling passed for the rest level: the unclipped
    // dips were taken for negative presses, the force negated, and the sensor read as
    // silent (NO RESPONSE, K -4.6 × the model's) with either clock. The saturated side
    // now names compression and the clipped tops are found: NOT JUDGED, the force
    // untrusted, naming the saturation, with the offset given and estimated.
    let dir = tempfile::tempdir().unwrap();
    let (s, rows) = verdict_rows(dir.path(), 1, 5013, None, false);
    assert_eq!(s["confidently_wrong"].as_u64(), Some(0), "{rows:?}");
    assert_eq!(rows.len(), 2);
    for r in &rows {
        assert_eq!(r[0], "force-saturation", "{r:?}");
        assert_eq!(
            (r[2].as_str(), r[3].as_str(), r[4].as_str()),
            ("NOT JUDGED", "force_untrusted", "Refused"),
            "{r:?}"
        );
    }
    let (_, files) = fbgforge_studies::verdicts::write_one(dir.path(), 5013, None).unwrap();
    let mut req = fbgforge::verify::VerifyRequest::new(files.design, files.log, files.force);
    req.case = Some(fbgforge::model::LoadCase::II);
    req.analysis.core = Some("psc2".into());
    let out = fbgforge::verify::run(&req).unwrap();
    let v = serde_json::to_value(&out.report).unwrap();
    let m = &v["measurement"];
    assert!(
        m["warnings"]["counts"]["force_sign_flipped"].is_null(),
        "{}",
        m["warnings"]
    );
    let top = m["force_trust"]["saturation_n"].as_f64().unwrap();
    assert!((top - 2.2904).abs() < 1e-3, "{}", m["force_trust"]);
    let reason = v["verdict"]["reason"].as_str().unwrap();
    assert!(reason.contains("saturates at 2.2904 N"), "{reason}");
}
