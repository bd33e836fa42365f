//! `verify --report DIR` writes `report.html`: self-contained, the verdict and its
//! reasons, the model's K and band on the shift–force chart; rendered in headless
//! Chromium (not blank, the verdict and the chart in the DOM).

use crate::chromium::{self, attr, elements, pixel_to_data, points};
use serde_json::Value;
use std::path::{Path, PathBuf};

use crate::common::bin;

fn design() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("designs/clip-on-34mm.toml")
}

/// Synthesise logs with the core's first grating at `k` pm/N (pulses of 2–8 N) and
/// verify them (Case II, core psc2) with `tolerance`; returns the report folder and
/// report.json.
fn verify_report(dir: &Path, k: f64, tolerance: f64) -> (PathBuf, Value) {
    let d = design();
    // Pulses up to 8 N keep a shift of 170 pm/N inside the gratings' windows.
    let out = bin()
        .args(["synth-log", d.to_str().unwrap(), "--format", "imon"])
        .args(["--core", "psc2", "--k-pm-per-n", &k.to_string()])
        .args(["--pulses-n", "2,4,6,8", "--out"])
        .arg(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = dir.join("report");
    let out = bin()
        .args([
            "verify",
            d.to_str().unwrap(),
            "--core",
            "psc2",
            "--case",
            "II",
        ])
        .args(["--k-tolerance", &tolerance.to_string(), "--log"])
        .arg(dir.join("log.txt"))
        .arg("--force")
        .arg(dir.join("force.csv"))
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    let code = out.status.code().unwrap();
    assert!(
        code == 0 || code == 2,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(report.join("report.json")).unwrap())
            .unwrap();
    (report, json)
}

fn word(status: &str) -> &'static str {
    match status {
        "pass" => "PASS",
        "fail" => "FAIL",
        "in_band" => "IN BAND",
        "not_judged" => "NOT JUDGED",
        "no_response" => "NO RESPONSE",
        other => panic!("unknown status {other}"),
    }
}

/// The slope (pm/N) of a two-point line drawn in a chart, in data units.
fn slope(svg: &str, line: &str) -> f64 {
    let to_data = pixel_to_data(svg);
    let p = points(line);
    let (a, b) = (to_data(p[0]), to_data(*p.last().unwrap()));
    (b.1 - a.1) / (b.0 - a.0)
}

/// The shift–force chart draws, per grating, the model's K as a line of that slope,
/// the passing tolerance around it and the contact band, with the legend beside the
/// plot; the HTML holds the same chart and the verdict of report.json.
fn check_report_text(report: &Path, json: &Value) {
    let svg = std::fs::read_to_string(report.join("shift_vs_force.svg")).unwrap();
    let verdicts = json["verdict"]["gratings"].as_array().unwrap();
    assert!(!verdicts.is_empty());
    for v in verdicts {
        let name = v["grating"].as_str().unwrap();
        let k_model = v["predicted_sensitivity_pm_per_n"].as_f64().unwrap();
        let k_fit = v["measured_sensitivity_pm_per_n"].as_f64().unwrap();
        let tol = v["tolerance"].as_f64().unwrap();
        let of = |role: &str, tag: &str| -> Vec<&str> {
            elements(&svg, tag)
                .into_iter()
                .filter(|e| {
                    attr(e, "data-role") == Some(role)
                        && attr(e, "data-series").is_some_and(|s| s.starts_with(name))
                })
                .collect()
        };
        let model = of("model-k", r#"<polyline class="line""#);
        assert_eq!(model.len(), 1, "{name}: one model K line");
        let k_drawn = slope(&svg, model[0]);
        // Pixels are rounded to 0.1: the slope holds to well under 1 %.
        assert!(
            (k_drawn / k_model - 1.0).abs() < 0.01,
            "{name}: model line drawn at {k_drawn} pm/N, the model says {k_model}"
        );
        let fit = of("fit", r#"<polyline class="line""#);
        assert!((slope(&svg, fit[0]) / k_fit - 1.0).abs() < 0.01);
        // The tolerance band: its edges' slopes are K·(1 ± tolerance).
        let band = of("model-k", r#"<polygon class="band""#);
        assert_eq!(band.len(), 1, "{name}: the model's tolerance band");
        let to_data = pixel_to_data(&svg);
        let pts: Vec<(f64, f64)> = points(band[0]).into_iter().map(&to_data).collect();
        // low edge forward (2 points), high edge back (2 points).
        let s_low = (pts[1].1 - pts[0].1) / (pts[1].0 - pts[0].0);
        let s_high = (pts[2].1 - pts[3].1) / (pts[2].0 - pts[3].0);
        let (lo, hi) = (
            (k_model * (1.0 - tol)).min(k_model * (1.0 + tol)),
            (k_model * (1.0 - tol)).max(k_model * (1.0 + tol)),
        );
        assert!((s_low / lo - 1.0).abs() < 0.01, "{s_low} vs {lo}");
        assert!((s_high / hi - 1.0).abs() < 0.01, "{s_high} vs {hi}");
        if v.get("band_pm_per_n").is_some() {
            assert_eq!(of("model-band", r#"<polygon class="band""#).len(), 1);
        }
    }
    // The legend is beside the plot area, not over it.
    let area = chromium::rect(elements(&svg, r#"<rect class="plot-area""#)[0]);
    let legend = chromium::rect(elements(&svg, r#"<rect class="legend-box""#)[0]);
    assert!(
        legend.0 >= area.0 + area.2,
        "legend {legend:?} over plot {area:?}"
    );

    let html = std::fs::read_to_string(report.join("report.html")).unwrap();
    assert_eq!(chromium::external_references(&html), Vec::<&str>::new());
    let overall = word(json["verdict"]["overall"].as_str().unwrap());
    assert!(
        html.contains(r#"id="verdict" class="verdict"#)
            && html.contains(&format!(r#"data-verdict="{overall}""#)),
        "the banner shows {overall}"
    );
    // Each grating's reason names its error against the tolerance.
    for v in verdicts {
        if let Some(e) = v["relative_error"].as_f64() {
            assert!(
                html.contains(&format!("{:.2} % error", 100.0 * e)),
                "{}",
                v["grating"]
            );
        }
    }
    assert!(
        html.contains(r#"data-role="model-k""#),
        "the chart is inline"
    );
}

#[test]
fn verify_report_html_shows_a_failing_k_against_the_model_and_renders() {
    let dir = tempfile::tempdir().unwrap();
    // The model gives about −170 pm/N for psc2 in Case II: −20 fails by far.
    let (report, json) = verify_report(dir.path(), -20.0, 0.08);
    assert_eq!(json["verdict"]["overall"], "fail");
    check_report_text(&report, &json);
    let Some(browser) = chromium::browser_or_skip("verify report.html") else {
        return;
    };
    let page = chromium::render(&browser, &report.join("report.html"), 1280, 2000);
    // Not blank: charts and tables ink a good part of the page.
    assert!(page.ink_share() > 0.03, "ink {}", page.ink_share());
    // The FAIL banner's border and the first grating's colour are on screen.
    assert!(
        page.count_color("#c62828", 40) > 200,
        "no red banner border"
    );
    assert!(
        page.count_color("#4e79a7", 30) > 200,
        "no chart series drawn"
    );
    // The DOM has the verdict and the inline chart with the model's line.
    assert!(page.dom.contains(r#"data-verdict="FAIL""#));
    assert!(page.dom.contains("<svg") && page.dom.contains(r#"class="fbg-chart""#));
    assert!(page.dom.contains(r#"data-role="model-k""#));
}

#[test]
fn verify_report_html_shows_a_pass_in_its_own_colour() {
    let dir = tempfile::tempdir().unwrap();
    // The first grating at the model's K; the second, 15 % lower by the synthesiser's
    // rule, passes at a 20 % tolerance.
    let (report, json) = verify_report(dir.path(), -170.0, 0.2);
    assert_eq!(json["verdict"]["overall"], "pass", "{}", json["verdict"]);
    check_report_text(&report, &json);
    let Some(browser) = chromium::browser_or_skip("verify report.html (pass)") else {
        return;
    };
    let page = chromium::render(&browser, &report.join("report.html"), 1280, 1200);
    assert!(
        page.count_color("#2e7d32", 40) > 200,
        "no green banner border"
    );
    assert_eq!(page.count_color("#c62828", 20), 0, "a red border on a pass");
    assert!(page.dom.contains(r#"data-verdict="PASS""#));
}
