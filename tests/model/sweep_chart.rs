//! `sweep`'s spacing and chart: log steps on a log axis over a wide range (asked with
//! `--log`, automatic beyond 20×, refused with `--linear`), one colour per
//! configuration, the legend beside the plot.

use crate::common::shipped_path as shipped;
use std::collections::BTreeSet;
use std::path::Path;

/// Sweep e1_mpa of the 34 mm design with the closed form; returns (stdout, swept
/// values in CSV order without repeats, the SVG).
fn sweep(dir: &Path, from: f64, to: f64, extra: &[&str]) -> (String, Vec<f64>, String) {
    let (svg, csv) = (dir.join("s.svg"), dir.join("s.csv"));
    let out = crate::common::bin()
        .args(["sweep", shipped("clip-on-34mm.toml").to_str().unwrap()])
        .args(["--param", "e1_mpa", "--from", &from.to_string()])
        .args(["--to", &to.to_string(), "--steps", "5"])
        .args(["--fidelity", "closed-form", "--plot"])
        .arg(&svg)
        .arg("--csv")
        .arg(&csv)
        .args(extra)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut values: Vec<f64> = Vec::new();
    for line in text.lines().skip(1) {
        let v: f64 = line.split(',').nth(1).unwrap().parse().unwrap();
        if !values.contains(&v) {
            values.push(v);
        }
    }
    (
        String::from_utf8(out.stdout).unwrap(),
        values,
        std::fs::read_to_string(&svg).unwrap(),
    )
}

fn attr<'a>(el: &'a str, name: &str) -> &'a str {
    let key = format!(" {name}=\"");
    let start = el.find(&key).unwrap_or_else(|| panic!("no {name} in {el}")) + key.len();
    &el[start..start + el[start..].find('"').unwrap()]
}

fn element<'a>(svg: &'a str, open: &str) -> &'a str {
    let i = svg.find(open).unwrap_or_else(|| panic!("no {open}"));
    &svg[i..i + svg[i..].find('>').unwrap()]
}

fn rect(el: &str) -> (f64, f64, f64, f64) {
    let f = |n: &str| attr(el, n).parse::<f64>().unwrap();
    (f("x"), f("y"), f("width"), f("height"))
}

fn is_geometric(v: &[f64]) -> bool {
    v.windows(3)
        .all(|w| ((w[1] / w[0]) / (w[2] / w[1]) - 1.0).abs() < 1e-9)
}

fn is_arithmetic(v: &[f64]) -> bool {
    v.windows(3)
        .all(|w| ((w[1] - w[0]) / (w[2] - w[1]) - 1.0).abs() < 1e-9)
}

#[test]
fn a_wide_sweep_is_spaced_in_log_on_a_log_axis_with_the_legend_outside() {
    let dir = tempfile::tempdir().unwrap();
    let (stdout, values, svg) = sweep(dir.path(), 10.0, 2000.0, &[]);
    assert!(stdout.contains("5 log steps"), "{stdout}");
    assert_eq!(values.len(), 5);
    assert!((values[0] - 10.0).abs() < 1e-12 && (values[4] - 2000.0).abs() < 1e-9);
    assert!(is_geometric(&values), "{values:?}");
    let axis = element(&svg, r#"<g class="axis x-axis""#);
    assert_eq!(attr(axis, "data-scale"), "log");
    // Decades labelled with their values, equally spaced along the axis.
    let x_axis = &svg
        [svg.find(r#"class="axis x-axis""#).unwrap()..svg.find(r#"class="axis y-axis""#).unwrap()];
    let mut decades = Vec::new();
    for label in ["10", "100", "1000"] {
        let tag = format!(">{label}</text>");
        let end = x_axis
            .find(&tag)
            .unwrap_or_else(|| panic!("no tick {label}"));
        let start = x_axis[..end].rfind("<text").unwrap();
        decades.push(attr(&x_axis[start..end], "x").parse::<f64>().unwrap());
    }
    assert!(((decades[1] - decades[0]) - (decades[2] - decades[1])).abs() < 0.2);
    // The legend is beside the plot area.
    let plot = rect(element(&svg, r#"<rect class="plot-area""#));
    let legend = rect(element(&svg, r#"<rect class="legend-box""#));
    assert!(
        legend.0 >= plot.0 + plot.2,
        "legend {legend:?} over {plot:?}"
    );
    // One colour per configuration (case and insert), not per series.
    let csv = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
    let configs: BTreeSet<(String, String)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[3].to_string(), f[4].to_string())
        })
        .collect();
    let colours: BTreeSet<&str> = svg
        .match_indices(r#"<polyline class="line""#)
        .map(|(i, _)| attr(&svg[i..i + svg[i..].find('>').unwrap()], "stroke"))
        .collect();
    assert!(configs.len() > 1);
    assert_eq!(colours.len(), configs.len(), "{colours:?} for {configs:?}");
}

#[test]
fn linear_and_log_spacing_can_be_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let (stdout, values, svg) = sweep(dir.path(), 10.0, 2000.0, &["--linear"]);
    assert!(stdout.contains("5 linear steps"));
    assert!(is_arithmetic(&values), "{values:?}");
    assert_eq!(
        attr(element(&svg, r#"<g class="axis x-axis""#), "data-scale"),
        "linear"
    );
    // 10× is not wide: linear by default, log when asked.
    let (_, values, _) = sweep(dir.path(), 100.0, 1000.0, &[]);
    assert!(is_arithmetic(&values), "{values:?}");
    let (_, values, svg) = sweep(dir.path(), 100.0, 1000.0, &["--log"]);
    assert!(is_geometric(&values), "{values:?}");
    assert_eq!(
        attr(element(&svg, r#"<g class="axis x-axis""#), "data-scale"),
        "log"
    );
}

/// (number of shift lines, their distinct stroke colours) of a sweep chart.
fn shift_legend(svg: &str) -> (usize, BTreeSet<String>) {
    let lines = svg.matches(r#"<polyline class="line""#).count();
    let colours = svg
        .match_indices(r#"<polyline class="line""#)
        .map(|(i, _)| attr(&svg[i..i + svg[i..].find('>').unwrap()], "stroke").to_string())
        .collect();
    (lines, colours)
}

#[test]
fn coinciding_configurations_are_drawn_once_and_named_together() {
    let dir = tempfile::tempdir().unwrap();
    // Distinct curves: the shipped design's e2 sweep draws every configuration.
    let run = |design: &Path, svg: &Path| {
        let out = crate::common::bin()
            .arg("sweep")
            .arg(design)
            .args([
                "--param", "e2_mpa", "--from", "20", "--to", "80", "--steps", "4",
            ])
            .args(["--fidelity", "closed-form", "--csv"])
            .arg(dir.path().join("s.csv"))
            .arg("--plot")
            .arg(svg)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        std::fs::read_to_string(svg).unwrap()
    };
    let shipped_design = shipped("clip-on-34mm.toml");
    let svg = run(&shipped_design, &dir.path().join("a.svg"));
    let (lines, colours) = shift_legend(&svg);
    // Case II and three inserts, four strain gratings each.
    assert_eq!((lines, colours.len()), (16, 4), "{colours:?}");
    assert!(!svg.contains(" = "), "nothing merged");
    // A fourth insert of the green insert's material: the same curves, drawn once.
    let text = std::fs::read_to_string(&shipped_design).unwrap();
    let twin = text.replacen(
        "[[module.inserts]]\nname = \"green\"",
        "[[module.inserts]]\nname = \"green_twin\"\nmaterial = \"insert_green\"\n\n\
         [[module.inserts]]\nname = \"green\"",
        1,
    );
    assert_ne!(twin, text);
    let path = dir.path().join("twin.toml");
    std::fs::write(&path, twin).unwrap();
    let svg = run(&path, &dir.path().join("b.svg"));
    let csv = std::fs::read_to_string(dir.path().join("s.csv")).unwrap();
    assert!(
        csv.contains(",green_twin,"),
        "the CSV keeps every configuration"
    );
    let (lines, colours) = shift_legend(&svg);
    assert_eq!((lines, colours.len()), (16, 4), "{colours:?}");
    assert!(
        svg.contains("Case I · green_twin = Case I · green"),
        "the legend names both"
    );
}
