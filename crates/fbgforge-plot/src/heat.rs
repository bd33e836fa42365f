//! Heat maps: values over a plane (each grating's sensitivity over a sheet), panels side
//! by side, each on a diverging scale (blue below zero, white at zero, red above)
//! normalised to its own largest |value|, with points and polylines on top. Written as
//! SVG text like every chart ([`super::svg`]), its elements tagged for tests and reports.

use super::axis::Axis;
use super::svg::{escape, open, px, FONT_PX};
use crate::output::write_atomic;
use anyhow::{anyhow, Result};
use std::fmt::Write as _;
use std::path::Path;

/// One panel of a [`HeatMaps`] figure: a value per grid cell, with marks on top.
#[derive(Debug, Clone)]
pub struct HeatPanel {
    /// Panel title.
    pub title: String,
    /// Cell-centre x values of the grid, increasing, evenly spaced.
    pub x: Vec<f64>,
    /// Cell-centre y values of the grid, increasing, evenly spaced.
    pub y: Vec<f64>,
    /// Values, `values[j][i]` at (x[i], y[j]).
    pub values: Vec<Vec<f64>>,
    /// Points to mark (drawn as black dots).
    pub points: Vec<(f64, f64)>,
    /// Lines to draw (thin grey), each a polyline.
    pub lines: Vec<Vec<(f64, f64)>>,
}

/// A figure of heat maps side by side (e.g. each grating's sensitivity over a sheet),
/// each on a diverging scale (blue below zero, white at zero, red above) normalised to
/// its own largest |value|.
#[derive(Debug, Clone)]
pub struct HeatMaps {
    /// Title above every panel.
    pub title: String,
    /// Axis labels, with units.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// The panels, laid out in rows of up to three.
    pub panels: Vec<HeatPanel>,
}

/// Diverging colour of t in [−1, 1], as `#rrggbb`.
fn diverging(t: f64) -> String {
    let t = if t.is_finite() {
        t.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let (end, f) = if t >= 0.0 {
        ((178.0, 24.0, 43.0), t)
    } else {
        ((33.0, 102.0, 172.0), -t)
    };
    let mix = |a: f64, b: f64| (a + (b - a) * f).round() as u8;
    format!(
        "#{:02x}{:02x}{:02x}",
        mix(255.0, end.0),
        mix(255.0, end.1),
        mix(255.0, end.2)
    )
}

/// Size of one panel and its margins, px.
const PANEL_W: f64 = 420.0;
const PANEL_H: f64 = 360.0;
const TITLE_H: f64 = 40.0;
const LEFT: f64 = 56.0;
const RIGHT: f64 = 12.0;
const CAPTION: f64 = 28.0;
const BELOW: f64 = 44.0;

impl HeatMaps {
    /// Render to an SVG string (with the namespace a file needs).
    pub(crate) fn to_svg(&self) -> Result<String> {
        if self.panels.is_empty() {
            return Err(anyhow!("heat maps `{}` have no panel", self.title));
        }
        let cols = self.panels.len().min(3);
        let rows = self.panels.len().div_ceil(cols);
        let (w, h) = (PANEL_W * cols as f64, PANEL_H * rows as f64 + TITLE_H);
        let mut s = String::new();
        open(&mut s, "heat-maps", w, h, true);
        let _ = writeln!(
            s,
            r#"<text class="title" x="{}" y="26" font-size="20" text-anchor="middle">{}</text>"#,
            px(w / 2.0),
            escape(&self.title)
        );
        for (k, p) in self.panels.iter().enumerate() {
            let (ox, oy) = (
                PANEL_W * (k % cols) as f64,
                TITLE_H + PANEL_H * (k / cols) as f64,
            );
            self.panel(&mut s, p, ox, oy);
        }
        s.push_str("</svg>\n");
        Ok(s)
    }

    /// One panel with its top-left corner at (ox, oy).
    fn panel(&self, s: &mut String, p: &HeatPanel, ox: f64, oy: f64) {
        let Some(f) = PanelFrame::of(p, ox, oy) else {
            return;
        };
        let _ = writeln!(
            s,
            r#"<g class="panel" data-series="{}" data-peak="{}">"#,
            escape(&p.title),
            f.peak
        );
        let _ = writeln!(
            s,
            r#"<text class="panel-title" x="{}" y="{}" font-size="15" text-anchor="middle">{}</text>"#,
            px(ox + PANEL_W / 2.0),
            px(oy + 18.0),
            escape(&p.title)
        );
        f.cells(s, p);
        f.marks(s, p);
        f.ticks(s);
        let _ = writeln!(
            s,
            r#"<text class="x-label" x="{}" y="{}" font-size="{FONT_PX}" text-anchor="middle">{}</text>"#,
            px(f.left + f.pw / 2.0),
            px(f.top + f.ph + 34.0),
            escape(&self.x_label)
        );
        let (lx, ly) = (ox + 14.0, f.top + f.ph / 2.0);
        let _ = writeln!(
            s,
            r#"<text class="y-label" x="{}" y="{}" font-size="{FONT_PX}" text-anchor="middle" transform="rotate(-90 {} {})">{}</text>"#,
            px(lx),
            px(ly),
            px(lx),
            px(ly),
            escape(&self.y_label)
        );
        s.push_str("</g>\n");
    }

    /// Render and write atomically to `path`.
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        let svg = self.to_svg()?;
        write_atomic(path, svg.as_bytes())
    }
}

/// Where a panel's plot area sits and how the plane maps onto it (the plane keeps its
/// aspect ratio inside the panel).
struct PanelFrame {
    /// The plane's extent, cell edges included: x from, x to, y from, y to.
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    /// Cell size along x and y.
    dx: f64,
    dy: f64,
    /// Largest |value|, the colour scale's end.
    peak: f64,
    /// px per unit of the plane.
    scale: f64,
    /// The plot area: left, top, width, height, px.
    left: f64,
    top: f64,
    pw: f64,
    ph: f64,
}

impl PanelFrame {
    /// The frame of panel `p` with its top-left corner at (ox, oy); `None` for a panel
    /// with no grid.
    fn of(p: &HeatPanel, ox: f64, oy: f64) -> Option<Self> {
        let step = |v: &[f64]| {
            if v.len() >= 2 {
                (v[v.len() - 1] - v[0]) / (v.len() - 1) as f64
            } else {
                1.0
            }
        };
        let (dx, dy) = (step(&p.x), step(&p.y));
        let (x0, x1, y0, y1) = (*p.x.first()?, *p.x.last()?, *p.y.first()?, *p.y.last()?);
        let (x0, x1, y0, y1) = (x0 - dx / 2.0, x1 + dx / 2.0, y0 - dy / 2.0, y1 + dy / 2.0);
        let peak = p
            .values
            .iter()
            .flatten()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let (aw, ah) = (PANEL_W - LEFT - RIGHT, PANEL_H - CAPTION - BELOW);
        let scale = (aw / (x1 - x0)).min(ah / (y1 - y0));
        let (pw, ph) = ((x1 - x0) * scale, (y1 - y0) * scale);
        Some(PanelFrame {
            x0,
            x1,
            y0,
            y1,
            dx,
            dy,
            peak,
            scale,
            left: ox + LEFT + (aw - pw) / 2.0,
            top: oy + CAPTION + (ah - ph) / 2.0,
            pw,
            ph,
        })
    }

    fn sx(&self, x: f64) -> f64 {
        self.left + (x - self.x0) * self.scale
    }

    fn sy(&self, y: f64) -> f64 {
        self.top + self.ph - (y - self.y0) * self.scale
    }

    /// The cells, coloured by value over the peak.
    fn cells(&self, s: &mut String, p: &HeatPanel) {
        let (dx, dy) = (self.dx, self.dy);
        for (j, &y) in p.y.iter().enumerate() {
            for (i, &x) in p.x.iter().enumerate() {
                let v = p.values.get(j).and_then(|r| r.get(i)).copied();
                let t = match v {
                    Some(v) if self.peak > 0.0 => v / self.peak,
                    _ => 0.0,
                };
                // Cells overlap by a hair so no seam shows between them.
                let _ = writeln!(
                    s,
                    r#"<rect class="cell" x="{}" y="{}" width="{}" height="{}" fill="{}"/>"#,
                    px(self.sx(x - dx / 2.0)),
                    px(self.sy(y + dy / 2.0)),
                    px(dx * self.scale + 0.3),
                    px(dy * self.scale + 0.3),
                    diverging(t)
                );
            }
        }
    }

    /// The panel's lines and points, then the plot area's frame.
    fn marks(&self, s: &mut String, p: &HeatPanel) {
        for l in &p.lines {
            let pts: Vec<String> = l
                .iter()
                .map(|&(x, y)| format!("{},{}", px(self.sx(x)), px(self.sy(y))))
                .collect();
            let _ = writeln!(
                s,
                r##"<polyline class="line" points="{}" fill="none" stroke="#787878" stroke-width="1"/>"##,
                pts.join(" ")
            );
        }
        for &(x, y) in &p.points {
            let _ = writeln!(
                s,
                r##"<circle class="point" cx="{}" cy="{}" r="4" fill="#000000"/>"##,
                px(self.sx(x)),
                px(self.sy(y))
            );
        }
        let _ = writeln!(
            s,
            r##"<rect class="frame" x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#000000"/>"##,
            px(self.left),
            px(self.top),
            px(self.pw),
            px(self.ph)
        );
    }

    /// Major ticks with their labels along the bottom and the left edge.
    fn ticks(&self, s: &mut String) {
        let (left, top, ph) = (self.left, self.top, self.ph);
        let axis = |lo: f64, hi: f64| Axis { log: false, lo, hi };
        for t in axis(self.x0, self.x1).ticks().iter().filter(|t| t.major) {
            let x = self.sx(t.value);
            let _ = writeln!(
                s,
                r##"<line class="tick" x1="{x}" y1="{b}" x2="{x}" y2="{b2}" stroke="#000000"/><text class="tick-label" x="{x}" y="{ty}" font-size="{FONT_PX}" text-anchor="middle">{}</text>"##,
                escape(&t.label),
                x = px(x),
                b = px(top + ph),
                b2 = px(top + ph + 4.0),
                ty = px(top + ph + 16.0)
            );
        }
        for t in axis(self.y0, self.y1).ticks().iter().filter(|t| t.major) {
            let y = self.sy(t.value);
            let _ = writeln!(
                s,
                r##"<line class="tick" x1="{l2}" y1="{y}" x2="{l}" y2="{y}" stroke="#000000"/><text class="tick-label" x="{tx}" y="{ty}" font-size="{FONT_PX}" text-anchor="end">{}</text>"##,
                escape(&t.label),
                y = px(y),
                l = px(left),
                l2 = px(left - 4.0),
                tx = px(left - 6.0),
                ty = px(y + 4.0)
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scale_is_white_at_zero_and_saturates_at_the_ends() {
        assert_eq!(diverging(0.0), "#ffffff");
        assert_eq!(diverging(1.0), "#b2182b");
        assert_eq!(diverging(-1.0), "#2166ac");
        assert_eq!(diverging(7.0), diverging(1.0));
        assert_eq!(diverging(f64::NAN), "#ffffff");
    }

    #[test]
    fn each_cell_is_drawn_with_its_value_on_its_panels_own_scale() {
        let panel = |title: &str, k: f64| HeatPanel {
            title: title.into(),
            x: vec![0.0, 1.0],
            y: vec![0.0, 1.0, 2.0],
            values: vec![vec![k, 0.0], vec![0.0, -k], vec![0.5 * k, 0.0]],
            points: vec![(0.5, 1.0)],
            lines: vec![vec![(0.0, 0.0), (1.0, 2.0)]],
        };
        let m = HeatMaps {
            title: "t".into(),
            x_label: "x (mm)".into(),
            y_label: "y (mm)".into(),
            panels: vec![panel("a", 1.0), panel("b", 100.0)],
        };
        let svg = m.to_svg().unwrap();
        assert_eq!(svg.matches(r#"class="cell""#).count(), 12);
        // Both panels reach full red and full blue: each is normalised to its own peak.
        assert_eq!(svg.matches("#b2182b").count(), 2);
        assert_eq!(svg.matches("#2166ac").count(), 2);
        assert_eq!(svg.matches(r#"class="point""#).count(), 2);
        assert!(svg.contains(r#"data-peak="100""#));
        let empty = HeatMaps {
            panels: vec![],
            ..m
        };
        assert!(empty.to_svg().is_err());
    }
}
