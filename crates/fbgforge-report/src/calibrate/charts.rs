//! A calibration's charts, each beside a CSV of the same numbers: the additivity tests
//! as stacked bars (each cell's load alone, stacked, against a square at the loads
//! together: the array paper's Figs. 6–8), and each staircase's calibration curves with
//! their calibration lines.

use crate::array::calibrate::additivity::AdditivityTest;
use crate::array::calibrate::metrology::Branch;
use crate::array::calibrate::Calibration;
use crate::output::write_atomic;
use crate::plot::axis::Axis;
use crate::plot::svg::{color, escape, open, px};
use crate::plot::{Chart, Mark, Series};
use anyhow::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The additivity CSV: one row per test and grating, every cell's single response in
/// its own column (empty for cells not in the test).
pub fn additivity_csv(c: &Calibration) -> String {
    let mut s = String::from("test,loads,grating,sum_pm,simultaneous_pm,error_percent,significant");
    for cell in &c.cells {
        let _ = write!(s, ",{cell}_pm");
    }
    s.push('\n');
    for (k, t) in c.additivity.iter().enumerate() {
        let loads: Vec<String> = t
            .cells
            .iter()
            .zip(&t.loads_g)
            .map(|(c, l)| format!("{c}{l}"))
            .collect();
        for g in &t.gratings {
            let _ = write!(
                s,
                "{},{},{},{:.4},{:.4},{:.2},{}",
                k + 1,
                loads.join("+"),
                g.grating,
                g.sum_pm,
                g.simultaneous_pm,
                g.error_percent,
                g.significant
            );
            for cell in &c.cells {
                match t.cells.iter().position(|x| x == cell) {
                    Some(i) => write!(s, ",{:.4}", g.individual_pm[i]),
                    None => write!(s, ","),
                }
                .ok();
            }
            s.push('\n');
        }
    }
    s
}

const PANEL_W: f64 = 560.0;
const PANEL_H: f64 = 240.0;
const LEFT: f64 = 64.0;
const RIGHT: f64 = 150.0;
const TOP: f64 = 34.0;
const BOTTOM: f64 = 40.0;

/// One test's panel at vertical offset `y0`.
fn additivity_panel(out: &mut String, t: &AdditivityTest, y0: f64) {
    let mut values = vec![0.0];
    for g in &t.gratings {
        let pos: f64 = g.individual_pm.iter().filter(|v| **v > 0.0).sum();
        let neg: f64 = g.individual_pm.iter().filter(|v| **v < 0.0).sum();
        values.extend([pos, neg, g.simultaneous_pm]);
    }
    let axis = Axis::fit(values, false).expect("finite values");
    let y_of = |v: f64| y0 + TOP + PANEL_H * (1.0 - axis.fraction(v).unwrap_or(0.0));
    let title: Vec<String> = t
        .cells
        .iter()
        .zip(&t.loads_g)
        .map(|(c, l)| format!("{l} g on {c}"))
        .collect();
    let _ = writeln!(
        out,
        r#"<g class="additivity-test"><text x="{}" y="{}" font-size="14" font-weight="bold">{}</text>"#,
        px(LEFT),
        px(y0 + 20.0),
        escape(&format!(
            "Additivity: {} (bars alone, stacked; squares together)",
            title.join(" + ")
        ))
    );
    for tick in axis.ticks().iter().filter(|t| t.major) {
        let y = y_of(tick.value);
        let _ = writeln!(
            out,
            r##"<line x1="{}" x2="{}" y1="{y}" y2="{y}" stroke="#dddddd"/><text x="{}" y="{}" font-size="11" text-anchor="end">{}</text>"##,
            px(LEFT),
            px(LEFT + PANEL_W),
            px(LEFT - 6.0),
            px(y + 4.0),
            escape(&tick.label),
            y = px(y)
        );
    }
    let slot = PANEL_W / t.gratings.len().max(1) as f64;
    for (i, g) in t.gratings.iter().enumerate() {
        let x = LEFT + slot * (i as f64 + 0.2);
        let w = slot * 0.6;
        let (mut up, mut down) = (0.0, 0.0);
        for (k, &v) in g.individual_pm.iter().enumerate() {
            let (a, b) = if v >= 0.0 {
                up += v;
                (up - v, up)
            } else {
                down += v;
                (down - v, down)
            };
            let (ya, yb) = (y_of(a), y_of(b));
            let _ = writeln!(
                out,
                r#"<rect class="bar" data-cell="{}" data-grating="{}" x="{}" y="{}" width="{}" height="{}" fill="{}"/>"#,
                escape(&t.cells[k]),
                escape(&g.grating),
                px(x),
                px(ya.min(yb)),
                px(w),
                px((ya - yb).abs()),
                color(k)
            );
        }
        let ys = y_of(g.simultaneous_pm);
        let _ = writeln!(
            out,
            r##"<rect class="together" data-grating="{}" x="{}" y="{}" width="10" height="10" fill="#000000"/><text x="{}" y="{}" font-size="11" text-anchor="middle">{}</text>"##,
            escape(&g.grating),
            px(x + w / 2.0 - 5.0),
            px(ys - 5.0),
            px(x + w / 2.0),
            px(y0 + TOP + PANEL_H + 16.0),
            escape(&g.grating)
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{}" y="{}" font-size="11" transform="rotate(-90 {} {})" text-anchor="middle">shift, pm</text>"#,
        px(14.0),
        px(y0 + TOP + PANEL_H / 2.0),
        px(14.0),
        px(y0 + TOP + PANEL_H / 2.0)
    );
    for (k, cell) in t.cells.iter().enumerate() {
        let y = y0 + TOP + 18.0 * k as f64;
        let _ = writeln!(
            out,
            r#"<rect x="{}" y="{}" width="14" height="12" fill="{}"/><text x="{}" y="{}" font-size="12">{} alone</text>"#,
            px(LEFT + PANEL_W + 16.0),
            px(y),
            color(k),
            px(LEFT + PANEL_W + 36.0),
            px(y + 11.0),
            escape(cell)
        );
    }
    let y = y0 + TOP + 18.0 * t.cells.len() as f64;
    let _ = writeln!(
        out,
        r##"<rect x="{}" y="{}" width="10" height="10" fill="#000000"/><text x="{}" y="{}" font-size="12">together</text></g>"##,
        px(LEFT + PANEL_W + 18.0),
        px(y + 1.0),
        px(LEFT + PANEL_W + 36.0),
        px(y + 11.0)
    );
}

/// The additivity tests as stacked bars, one panel per test.
pub fn additivity_svg(c: &Calibration) -> String {
    let panel = TOP + PANEL_H + BOTTOM;
    let (w, h) = (
        LEFT + PANEL_W + RIGHT,
        panel * c.additivity.len().max(1) as f64,
    );
    let mut out = String::new();
    open(&mut out, "additivity", w, h, true);
    for (k, t) in c.additivity.iter().enumerate() {
        additivity_panel(&mut out, t, panel * k as f64);
    }
    out.push_str("</svg>\n");
    out
}

/// The calibration curves as CSV: every curve point with its calibration line.
pub fn metrology_csv(c: &Calibration) -> String {
    let mut s = String::from("cell,grating,load_g,branch,shift_pm,line_pm,deviation_pm\n");
    for m in &c.metrology {
        for p in &m.curve {
            let branch = match p.branch {
                Branch::Up => "up",
                Branch::Top => "top",
                Branch::Down => "down",
            };
            let _ = writeln!(
                s,
                "{},{},{},{branch},{:.4},{:.4},{:.4}",
                m.cell,
                m.grating,
                p.load_g,
                p.shift_pm,
                p.shift_pm - p.deviation_pm,
                p.deviation_pm
            );
        }
    }
    s
}

/// One staircase cell's calibration curves (points) and lines.
pub fn metrology_chart(c: &Calibration, cell: &str) -> Chart {
    let mut chart = Chart::new(
        format!("Staircase on cell {cell}: calibration curves (mean over cycles) and lines"),
        "mass on the cell, g",
        "shift, pm",
    );
    for (k, m) in c.metrology.iter().filter(|m| m.cell == cell).enumerate() {
        let pts: Vec<(f64, f64)> = m.curve.iter().map(|p| (p.load_g, p.shift_pm)).collect();
        let line: Vec<(f64, f64)> = m
            .measuring_interval_g
            .iter()
            .map(|&l| (l, m.intercept_pm + m.sensitivity_pm_per_g * l))
            .collect();
        chart = chart
            .with(
                Series::new(m.grating.clone(), pts, Mark::Points)
                    .with_color(k)
                    .with_role("curve"),
            )
            .with(
                Series::new("", line, Mark::Line)
                    .with_color(k)
                    .with_role("calibration-line"),
            );
    }
    chart
}

/// Write the charts and their CSVs beside `stem` (the matrix path): `.additivity.csv`
/// and `.svg` when the run has additivity tests, `.metrology.csv` and one
/// `.metrology-<cell>.svg` per staircase cell when it has staircases.
pub fn write_charts(c: &Calibration, stem: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    if !c.additivity.is_empty() {
        for (ext, text) in [
            ("additivity.csv", additivity_csv(c)),
            ("additivity.svg", additivity_svg(c)),
        ] {
            let p = stem.with_extension(ext);
            write_atomic(&p, text.as_bytes())?;
            written.push(p);
        }
    }
    if !c.metrology.is_empty() {
        let p = stem.with_extension("metrology.csv");
        write_atomic(&p, metrology_csv(c).as_bytes())?;
        written.push(p);
        let mut cells: Vec<&str> = c.metrology.iter().map(|m| m.cell.as_str()).collect();
        cells.dedup();
        for cell in cells {
            let p = stem.with_extension(format!("metrology-{cell}.svg"));
            metrology_chart(c, cell).write_svg(&p)?;
            written.push(p);
        }
    }
    Ok(written)
}
