//! The reports of `optimize` and `place`: `report.html` self-contained and rendered
//! in headless Chromium, every convergence line visible, the placed layout drawn on
//! the sheet where the design puts it, and the printed tables within 80 columns.

use crate::chromium::{self, attr, elements};
use crate::common::shipped_path as shipped;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

use crate::common::bin;

fn run_ok(c: &mut Command) -> String {
    let out = c.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn assert_fits_80(text: &str) {
    assert!(!text.is_empty());
    for line in text.lines() {
        assert!(
            line.chars().count() <= 80,
            "{} columns: {line}",
            line.chars().count()
        );
    }
}

/// The `<circle>` inside each group tagged `data-role="run-end"`, in order.
fn run_ends(svg: &str) -> Vec<(f64, f64)> {
    svg.split(r#"data-role="run-end""#)
        .skip(1)
        .map(|chunk| {
            let c = elements(chunk, "<circle")[0];
            (
                attr(c, "cx").unwrap().parse().unwrap(),
                attr(c, "cy").unwrap().parse().unwrap(),
            )
        })
        .collect()
}

/// A report that loads nothing, with its verdict and its charts, renders in Chromium.
fn check_html(report: &Path, charts: usize, test: &str) {
    let html = std::fs::read_to_string(report.join("report.html")).unwrap();
    assert_eq!(chromium::external_references(&html), Vec::<&str>::new());
    assert!(html.contains(r#"id="verdict""#));
    assert!(
        html.matches("<svg class=\"fbg-").count() >= charts,
        "{test}: fewer than {charts} inline pictures"
    );
    let Some(browser) = chromium::browser_or_skip(test) else {
        return;
    };
    // Tall enough for the whole page: the charts come after the tables.
    let page = chromium::render(&browser, &report.join("report.html"), 1280, 4000);
    assert!(page.ink_share() > 0.03, "{test}: ink {}", page.ink_share());
    assert!(page.dom.contains(r#"id="verdict""#) && page.dom.contains("<svg"));
    assert!(
        page.count_color("#4e79a7", 30) > 100,
        "{test}: the first series colour is not on screen"
    );
}

#[test]
fn optimize_report_shows_every_convergence_line_and_its_table_fits_80_columns() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("opt.toml");
    let report = dir.path().join("rep");
    let stdout = run_ok(
        bin()
            .args(["optimize", shipped("clip-on-34mm.toml").to_str().unwrap()])
            .args(["--starts", "1", "--cores", "core_rubber_case_i"])
            .args(["--inserts", "insert_blue,none", "--out"])
            .arg(&out)
            .arg("--report-dir")
            .arg(&report),
    );
    assert_fits_80(&stdout);
    assert!(stdout.contains("best: ") && stdout.contains("choice"));
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(report.join("summary.json")).unwrap())
            .unwrap();
    let win = &summary["choices"][summary["best_choice"].as_u64().unwrap() as usize];
    let runs = win["runs"].as_array().unwrap();
    assert!(runs.len() >= 3, "two Nelder–Mead starts and a swarm");
    let svg = std::fs::read_to_string(report.join("convergence.svg")).unwrap();
    let lines = elements(&svg, r#"<polyline class="line""#)
        .into_iter()
        .filter(|l| attr(l, "data-role") == Some("run"))
        .count();
    // One line per run that iterated (a Nelder–Mead start on a flat infeasible stretch
    // can stop at iteration 0 with no history to draw).
    let runs: Vec<Value> = runs
        .iter()
        .filter(|r| !r["history"].as_array().unwrap().is_empty())
        .cloned()
        .collect();
    assert!(
        runs.len() >= 2,
        "at least a Nelder–Mead run and the swarm iterate"
    );
    assert_eq!(lines, runs.len(), "one line per run that iterated");
    // Runs that end at different costs end at different heights, however close the
    // costs (on a linear axis of the cost, runs ending within 1e-5 of each other drew
    // over one another).
    let ends = run_ends(&svg);
    assert_eq!(ends.len(), runs.len());
    let last = |r: &Value| {
        r["history"]
            .as_array()
            .unwrap()
            .last()
            .unwrap()
            .as_f64()
            .unwrap()
    };
    for i in 0..runs.len() {
        for j in i + 1..runs.len() {
            let (a, b) = (last(&runs[i]), last(&runs[j]));
            if (a - b).abs() > 1e-12 * a.abs().max(1.0) {
                assert!(
                    (ends[i].1 - ends[j].1).abs() >= 2.0,
                    "runs {i} and {j} end at costs {a} and {b} but at {:?} and {:?}",
                    ends[i],
                    ends[j]
                );
            }
        }
    }
    check_html(&report, 2, "optimize report.html");
}

#[test]
fn place_report_draws_the_chosen_layout_where_the_design_puts_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("placed.toml");
    let report = dir.path().join("rep");
    let start_path = shipped("tactile-array-60x80.toml");
    let stdout = run_ok(
        bin()
            .args(["place", start_path.to_str().unwrap()])
            .args(["--max-iters", "4", "--agreement-samples", "0", "--out"])
            .arg(&out)
            .arg("--report-dir")
            .arg(&report),
    );
    assert_fits_80(&stdout);
    let start = fbgforge::design::load(&start_path).unwrap().array.unwrap();
    let placed = fbgforge::design::load(&out).unwrap().array.unwrap();
    let svg = std::fs::read_to_string(report.join("layout.svg")).unwrap();
    let sheet = elements(&svg, r#"<rect class="sheet""#)[0];
    let (sx0, sy0, sw, sh) = chromium::rect(sheet);
    let scale: f64 = attr(sheet, "data-px-per-mm").unwrap().parse().unwrap();
    assert!(
        (sw - placed.size_x_mm * scale).abs() < 0.2 && (sh - placed.size_y_mm * scale).abs() < 0.2
    );
    assert_eq!(
        elements(&svg, r#"<rect class="cell""#).len(),
        (placed.cells_x * placed.cells_y) as usize
    );
    assert_eq!(
        elements(&svg, r#"<line class="fiber chosen""#).len(),
        placed.fiber_x_mm.len()
    );
    for (layout, array) in [("chosen", &placed), ("start", &start)] {
        let rects = elements(&svg, &format!(r#"<rect class="grating {layout}""#));
        assert_eq!(rects.len(), array.gratings.len());
        for g in &array.gratings {
            let r = rects
                .iter()
                .find(|r| attr(r, "data-grating") == Some(g.name.as_str()))
                .unwrap_or_else(|| panic!("{layout} {} not drawn", g.name));
            let x_mm = array.fiber_x_mm[g.fiber as usize];
            let y: f64 = attr(r, "data-y-mm").unwrap().parse().unwrap();
            assert!(
                (y - g.y_mm).abs() < 1e-9,
                "{layout} {}: {y} vs {}",
                g.name,
                g.y_mm
            );
            // Drawn to scale: the rectangle's centre is the grating's centre.
            let (x, top, w, h) = chromium::rect(r);
            let cx = sx0 + (x_mm + placed.size_x_mm / 2.0) * scale;
            let cy = sy0 + (placed.size_y_mm / 2.0 - g.y_mm) * scale;
            assert!(
                (x + w / 2.0 - cx).abs() < 0.2,
                "{}: x {} vs {cx}",
                g.name,
                x + w / 2.0
            );
            assert!(
                (top + h / 2.0 - cy).abs() < 0.2,
                "{}: y {} vs {cy}",
                g.name,
                top + h / 2.0
            );
            assert!((h - g.length_mm * scale).abs() < 0.2 || h == 3.0);
        }
    }
    // The legend is beside the sheet.
    let legend = chromium::rect(elements(&svg, r#"<rect class="legend-box""#)[0]);
    assert!(legend.0 >= sx0 + sw);
    let csv = std::fs::read_to_string(report.join("layout.csv")).unwrap();
    assert_eq!(csv.lines().count(), placed.gratings.len() + 1);
    check_html(&report, 2, "place report.html");
    let html = std::fs::read_to_string(report.join("report.html")).unwrap();
    assert!(html.contains(r#"<svg class="fbg-layout""#));
}
