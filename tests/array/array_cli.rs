//! End-to-end tests of `fbgforge reconstruct`: known loads from fixture files, and a
//! clear `error: …` with exit code 1 on bad input.

use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fixture(name: &str) -> PathBuf {
    root().join("fixtures/array").join(name)
}

fn fbgforge(args: &[&str]) -> std::process::Output {
    crate::common::bin()
        .args(args)
        .current_dir(root())
        .output()
        .expect("the binary runs")
}

#[test]
fn reconstruct_writes_the_known_loads_and_a_json_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("loads.csv");
    let m = fixture("paper-model-matrix.csv");
    let s = fixture("paper-model-shifts.csv");
    let o = fbgforge(&[
        "reconstruct",
        "--matrix",
        m.to_str().unwrap(),
        "--shifts",
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
        // A budget no method misses: the choice is then the most accurate method,
        // whatever the machine's load.
        "--budget-us",
        "1e9",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(summary["method"], "wsupport");
    assert_eq!(summary["choice"]["candidates"][0]["status"], "picked");
    assert!(summary["choice"]["reason"]
        .as_str()
        .unwrap()
        .starts_with("wsupport is the most accurate method within"));
    assert!(summary["setup_ms"].as_f64().unwrap() > 0.0);
    assert!(summary["time_per_frame_us"].as_f64().unwrap() > 0.0);
    assert_eq!(summary["max_loads"], 4);
    assert_eq!(summary["frames"], 4);
    assert_eq!(summary["not_converged"], 0);
    // Noise-free frames of known loads: all trusted and certified, no grating
    // suspect, the flags counted in the summary.
    assert_eq!(summary["flags"]["trusted"], 4, "{summary}");
    // `wsupport` certifies a frame unless its heuristic skipped a bounded solve.
    assert!(summary["certified"].as_u64().unwrap() <= 4);
    assert_eq!(summary["suspect_gratings"], serde_json::json!([]));
    assert_eq!(
        summary["min_load_g"], 25.0,
        "the paper's rated range by default"
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "time_s,A,B,C,D,E,F,G,H,residual_pm,flags"
    );
    // Noise-free frames of known loads: every one trusted (empty flags).
    let rows: Vec<Vec<f64>> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 11, "{l}");
            assert_eq!(f[10], "", "{l}");
            f[..10].iter().map(|v| v.parse().unwrap()).collect()
        })
        .collect();
    let want = [
        [0.0, 0.0, 100.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.001, 200.0, 0.0, 0.0, 0.0, 0.0, 0.0, 50.0, 0.0],
        [0.002, 0.0, 0.0, 100.0, 0.0, 50.0, 0.0, 0.0, 200.0],
        [0.003, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ];
    for (r, w) in rows.iter().zip(want) {
        for (a, b) in r.iter().zip(w) {
            assert!((a - b).abs() < 0.01, "{r:?} vs {w:?}");
        }
    }
}

#[test]
fn reconstruct_from_a_design_uses_the_model_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("loads.csv");
    let s = fixture("paper-model-shifts.csv");
    // The fixture's shifts come from the paper kernel: the design names that model
    // (the default would be the sheet model, docs/array.md §12).
    let design = dir.path().join("kernel-array.toml");
    let text = std::fs::read_to_string(root().join("designs/tactile-array-60x80.toml"))
        .unwrap()
        .replacen("[array]\n", "[array]\nmodel = \"kernel\"\n", 1);
    assert!(text.contains("model = \"kernel\""));
    std::fs::write(&design, text).unwrap();
    let o = fbgforge(&[
        "reconstruct",
        "--design",
        design.to_str().unwrap(),
        "--shifts",
        s.to_str().unwrap(),
        "--method",
        "omp",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    // Frame 0 is 100 g on B; then its residual and (empty) flags.
    let row: Vec<f64> = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .take(10)
        .map(|v| v.parse().unwrap())
        .collect();
    assert!((row[2] - 100.0).abs() < 0.01, "{row:?}");
}

fn expect_error(args: &[&str], needles: &[&str]) {
    let o = fbgforge(args);
    assert_eq!(o.status.code(), Some(1), "{args:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.starts_with("error: "), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in: {err}");
    }
}

#[test]
fn bad_input_exits_with_a_clear_error() {
    let m = fixture("paper-model-matrix.csv");
    let s = fixture("paper-model-shifts.csv");
    let (m, s) = (m.to_str().unwrap(), s.to_str().unwrap());
    let out = tempfile::tempdir().unwrap();
    let o = out.path().join("x.csv");
    let o = o.to_str().unwrap();
    expect_error(
        &[
            "reconstruct",
            "--matrix",
            m,
            "--shifts",
            s,
            "--method",
            "simplex",
            "--out",
            o,
        ],
        &["unknown method `simplex`", "support"],
    );
    expect_error(
        &[
            "reconstruct",
            "--matrix",
            m,
            "--shifts",
            s,
            "--ulimit-g",
            "-5",
            "--out",
            o,
        ],
        &["ulimit", "-5"],
    );
    // The load range's lower end: negative, NaN, or not below ulimit.
    for (value, needle) in [("-1", "-1"), ("NaN", "NaN"), ("250", "ulimit")] {
        expect_error(
            &[
                "reconstruct",
                "--matrix",
                m,
                "--shifts",
                s,
                "--min-load-g",
                value,
                "--out",
                o,
            ],
            &["--min-load-g", "min_load", needle],
        );
    }
    // The method choice's options.
    for (args, needles) in [
        (vec!["--penalty", "2"], vec!["--penalty", "--method"]),
        (vec!["--budget-us", "0"], vec!["--budget-us", "positive"]),
        (vec!["--max-loads", "0"], vec!["--max-loads", "at least 1"]),
        (
            vec!["--resolution-pm", "0"],
            vec!["--resolution-pm", "positive"],
        ),
        (
            vec!["--resolution-pm", "nan"],
            vec!["--resolution-pm", "positive"],
        ),
    ] {
        let mut all = vec!["reconstruct", "--matrix", m, "--shifts", s, "--out", o];
        all.extend(args);
        expect_error(&all, &needles);
    }
    let missing = fixture("bad-shifts-missing-fbg6.csv");
    expect_error(
        &[
            "reconstruct",
            "--matrix",
            m,
            "--shifts",
            missing.to_str().unwrap(),
            "--out",
            o,
        ],
        &["fbg6"],
    );
    let empty = fixture("empty.csv");
    expect_error(
        &[
            "reconstruct",
            "--matrix",
            empty.to_str().unwrap(),
            "--shifts",
            s,
            "--out",
            o,
        ],
        &["empty.csv", "empty"],
    );
    let nan = fixture("bad-matrix-nan.csv");
    expect_error(
        &[
            "reconstruct",
            "--matrix",
            nan.to_str().unwrap(),
            "--shifts",
            s,
            "--out",
            o,
        ],
        &["bad-matrix-nan.csv:3"],
    );
    assert!(
        !out.path().join("x.csv").exists(),
        "no output file on error"
    );
}

#[test]
fn shifts_without_a_time_column_give_a_frame_column() {
    // Same frames as the fixture minus its time_s column: the output's first column is
    // then `frame`, the 0-based row index.
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(fixture("paper-model-shifts.csv")).unwrap();
    let no_time: String = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split_once(',').unwrap().1.to_string() + "\n")
        .collect();
    let shifts = dir.path().join("no-time.csv");
    std::fs::write(&shifts, no_time).unwrap();
    let out = dir.path().join("loads.csv");
    let o = fbgforge(&[
        "reconstruct",
        "--matrix",
        fixture("paper-model-matrix.csv").to_str().unwrap(),
        "--shifts",
        shifts.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "frame,A,B,C,D,E,F,G,H,residual_pm,flags");
    let frames: Vec<&str> = lines[1..]
        .iter()
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(frames, ["0", "1", "2", "3"]);
    // Frame 0 is B = 100 g.
    let b: f64 = lines[1].split(',').nth(2).unwrap().parse().unwrap();
    assert!((b - 100.0).abs() < 0.01, "{b}");
}

#[test]
fn the_interrogator_resolution_sets_the_l0_penalty() {
    // λ = 16 σ²: the paper's 4 at its 0.5 pm, 1 at 0.25 pm; for a named method and for
    // the default choice alike; an explicit --penalty wins.
    let m = fixture("paper-model-matrix.csv");
    let s = fixture("paper-model-shifts.csv");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("loads.csv");
    let penalty = |extra: &[&str]| -> (String, f64) {
        let mut args = vec![
            "reconstruct",
            "--matrix",
            m.to_str().unwrap(),
            "--shifts",
            s.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--json",
        ];
        args.extend(extra);
        let o = fbgforge(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (
            v["method"].as_str().unwrap().to_string(),
            v["penalty"].as_f64().unwrap(),
        )
    };
    assert_eq!(penalty(&["--method", "bnb"]).1, 4.0);
    assert_eq!(
        penalty(&["--method", "bnb", "--resolution-pm", "0.25"]).1,
        1.0
    );
    assert_eq!(
        penalty(&["--method", "support", "--resolution-pm", "1"]).1,
        16.0
    );
    assert_eq!(
        penalty(&[
            "--method",
            "bnb",
            "--resolution-pm",
            "0.25",
            "--penalty",
            "2.5"
        ])
        .1,
        2.5
    );
    // Methods without an ℓ0 penalty keep their own.
    let (_, omp) = penalty(&["--method", "omp", "--resolution-pm", "0.25"]);
    let (_, omp_default) = penalty(&["--method", "omp"]);
    assert_eq!(omp, omp_default);
    // The default choice: when it picks an ℓ0 method, with the resolution's penalty.
    let (method, p) = penalty(&["--resolution-pm", "0.25", "--budget-us", "100000"]);
    if method == "support" || method == "bnb" {
        assert_eq!(p, 1.0, "{method}");
    }
}

/// Loads CSV (`time_s,<cells…>` and trust columns) as rows of numbers: (time, loads).
fn loads_rows(path: &Path, cells: usize) -> Vec<(f64, Vec<f64>)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f64> = l
                .split(',')
                .take(1 + cells)
                .map(|v| v.parse().unwrap())
                .collect();
            (f[0], f[1..].to_vec())
        })
        .collect()
}

#[test]
fn a_wavelength_log_reconstructs_as_its_shifts_do() {
    // Stated tolerance: loads from --log and from the shifts CSV agree within 0.5 g.
    const TOLERANCE_G: f64 = 0.5;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("schedule.csv"),
        "start_s,end_s,cell,load_g\n3,5,B,100\n6,8,D,150\n9,11,A,80\n",
    )
    .unwrap();
    let syn = d.join("syn");
    let o = fbgforge(&[
        "synth-log",
        "tactile-array-60x80",
        "--schedule",
        d.join("schedule.csv").to_str().unwrap(),
        "--format",
        "csv",
        "--out",
        syn.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The shifts by hand: the mean of the first 50 rows (2.5 s at rest) as the tare.
    let log = std::fs::read_to_string(syn.join("log.csv")).unwrap();
    let mut lines = log.lines();
    let header = lines.next().unwrap();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let n = header.split(',').count();
    let tare: Vec<f64> = (1..n)
        .map(|g| rows[..50].iter().map(|r| r[g]).sum::<f64>() / 50.0)
        .collect();
    let mut shifts = format!("{header}\n");
    for r in &rows[50..] {
        let s: Vec<String> = (1..n)
            .map(|g| format!("{:.6}", (r[g] - tare[g - 1]) * 1e3))
            .collect();
        shifts.push_str(&format!("{},{}\n", r[0], s.join(",")));
    }
    std::fs::write(d.join("shifts.csv"), shifts).unwrap();
    let run = |input: &str, path: &Path, out: &Path| {
        let o = fbgforge(&[
            "reconstruct",
            "tactile-array-60x80",
            input,
            path.to_str().unwrap(),
            "--method",
            "support",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8(o.stdout).unwrap()
    };
    let stdout = run("--log", &syn.join("log.csv"), &d.join("via-log.csv"));
    let flat = stdout.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        flat.contains("tare on the first 50 frames at rest; 370 frames read, 0 skipped"),
        "{stdout}"
    );
    assert!(
        d.join("log-shifts.csv").exists(),
        "the shifts beside the loads"
    );
    run("--shifts", &d.join("shifts.csv"), &d.join("via-shifts.csv"));
    let (a, b) = (
        loads_rows(&d.join("via-log.csv"), 8),
        loads_rows(&d.join("via-shifts.csv"), 8),
    );
    assert_eq!(a.len(), 370);
    assert_eq!(a.len(), b.len());
    let mut worst = 0.0f64;
    for ((ta, la), (tb, lb)) in a.iter().zip(&b) {
        assert!((ta - tb).abs() < 1e-9);
        for (x, y) in la.iter().zip(lb) {
            worst = worst.max((x - y).abs());
        }
    }
    assert!(worst <= TOLERANCE_G, "loads differ by up to {worst} g");
    // The loads are there: the 150 g on D is read near 150 g in both.
    let peak_d = a.iter().map(|(_, l)| l[3]).fold(0.0, f64::max);
    assert!(peak_d > 50.0, "D peaks at {peak_d} g");
}
