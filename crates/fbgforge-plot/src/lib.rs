//! SVG charts for results people would rather look at than read.
//!
//! One small chart type covers most plots fbgforge makes ([`heat`] draws values over a
//! plane): named series of (x, y)
//! points drawn as lines, markers or both, optionally with a shaded band, on linear
//! or log10 axes (ticks labelled with the values, decades with minor lines). The
//! legend sits to the right of the plot area, never over the data; bands get lighter
//! and outlined as they multiply, so overlapping ones stay apart. Every element is
//! tagged (`class`, and on data `data-series` / `data-role`), so a report can inline
//! the same chart ([`Chart::to_svg_inline`]) and a test can find, say, the model's K
//! line by its role. Charts are written atomically; the same numbers always go to a
//! JSON or CSV beside the chart.

// Sibling crates under the names the modules used inside one crate.
#[allow(unused_imports)]
use fbgforge_core::output;

pub mod axis;
pub mod heat;
pub mod html;
pub mod svg;

use crate::output::write_atomic;
use anyhow::{anyhow, Result};
use axis::Axis;
pub use heat::{HeatMaps, HeatPanel};
use std::fmt::Write as _;
use std::path::Path;
pub use svg::Stroke;
use svg::{color, escape, px, LegendEntry, Rect, Swatch, FONT_PX};

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// Connected line.
    Line,
    /// Markers only.
    Points,
    /// Line with markers.
    LinePoints,
}

/// One named series.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label (an empty name keeps the series out of the legend).
    pub name: String,
    /// Data points (x, y).
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub mark: Mark,
    /// A range around the series, (x, low, high), drawn as a shaded band in the
    /// series' colour (e.g. a prediction's band between bounding model readings).
    pub band: Option<Vec<(f64, f64, f64)>>,
    /// Palette index of the colour; the series' position when `None`. Related series
    /// (a grating's points, fit and model line) share one.
    pub color: Option<usize>,
    /// Dash pattern of the line.
    pub stroke: Stroke,
    /// What the series is, as a word a test or a style sheet can find
    /// (`data-role`, e.g. `model-k`).
    pub role: Option<String>,
}

impl Series {
    /// A series from a name, points and a mark.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, mark: Mark) -> Self {
        Series {
            name: name.into(),
            points,
            mark,
            band: None,
            color: None,
            stroke: Stroke::Solid,
            role: None,
        }
    }

    /// The same series with a shaded band (x, low, high).
    pub fn with_band(mut self, band: Vec<(f64, f64, f64)>) -> Self {
        self.band = Some(band);
        self
    }

    /// The same series in palette colour `i`.
    pub fn with_color(mut self, i: usize) -> Self {
        self.color = Some(i);
        self
    }

    /// The same series with a dash pattern.
    pub fn with_stroke(mut self, s: Stroke) -> Self {
        self.stroke = s;
        self
    }

    /// The same series tagged with a role (`data-role` in the SVG).
    pub fn with_role(mut self, role: impl Into<String>) -> Self {
        self.role = Some(role.into());
        self
    }
}

/// A chart: title, axis labels, log flags and series.
#[derive(Debug, Clone)]
pub struct Chart {
    /// Title at the top.
    pub title: String,
    /// x-axis label, with unit.
    pub x_label: String,
    /// y-axis label, with unit.
    pub y_label: String,
    /// Plot x on a log10 axis (values ≤ 0 are not drawn).
    pub x_log: bool,
    /// Plot y on a log10 axis (values ≤ 0 are not drawn).
    pub y_log: bool,
    /// Series.
    pub series: Vec<Series>,
}

/// Size of the plot area, px; the margins and the legend come around it.
const PLOT_W: f64 = 620.0;
const PLOT_H: f64 = 400.0;
const TOP: f64 = 44.0;
const BOTTOM: f64 = 56.0;
const LEGEND_GAP: f64 = 22.0;
const MARGIN: f64 = 12.0;

/// Where the parts of a rendered chart are, px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    /// The whole picture.
    pub size: (f64, f64),
    /// The plot area (axes inside, data inside).
    pub plot: Rect,
    /// The legend box, when there is one.
    pub legend: Option<Rect>,
}

/// Fill opacity of each band when `n` bands share a chart: light enough that a few
/// overlapping ones stay apart (outlines tell them apart beyond two).
pub(crate) fn band_opacity(n: usize) -> f64 {
    match n {
        0..=1 => 0.2,
        2 => 0.15,
        n => (0.3 / n as f64).max(0.05),
    }
}

impl Chart {
    /// A linear chart with no series yet.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Chart {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_log: false,
            y_log: false,
            series: Vec::new(),
        }
    }

    /// Add a series (builder style).
    pub fn with(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }

    /// Render to a standalone SVG document (for a `.svg` file).
    pub(crate) fn to_svg(&self) -> Result<String> {
        Ok(self.render(true)?.0)
    }

    /// Render to an `<svg>` element for inlining in HTML (no namespace URL).
    pub(crate) fn to_svg_inline(&self) -> Result<String> {
        Ok(self.render(false)?.0)
    }

    /// Render and write atomically to `path`.
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        let svg = self.to_svg()?;
        write_atomic(path, svg.as_bytes())
    }

    fn color_of(&self, i: usize) -> &'static str {
        color(self.series[i].color.unwrap_or(i))
    }

    /// The legend rows: one per named series.
    fn legend_entries(&self, band_op: f64) -> Vec<LegendEntry> {
        self.series
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.name.is_empty())
            .map(|(i, s)| {
                let c = self.color_of(i).to_string();
                let swatch = match s.mark {
                    // A band on its own (no line): its shade with its outline.
                    _ if s.points.is_empty() && s.band.is_some() => Swatch::Area {
                        color: c,
                        opacity: band_op,
                        outline: Some(s.stroke),
                    },
                    Mark::Points => Swatch::Point { color: c },
                    Mark::Line | Mark::LinePoints => Swatch::Line {
                        color: c,
                        stroke: s.stroke,
                        width: 2.0,
                        band: s.band.as_ref().map(|_| band_op),
                    },
                };
                LegendEntry {
                    swatch,
                    label: s.name.clone(),
                }
            })
            .collect()
    }

    /// Render to SVG text and the layout of its parts.
    pub fn render(&self, standalone: bool) -> Result<(String, Layout)> {
        let xs = self.series.iter().flat_map(|s| {
            s.points
                .iter()
                .map(|p| p.0)
                .chain(s.band.iter().flatten().map(|b| b.0))
        });
        let ys = self.series.iter().flat_map(|s| {
            s.points
                .iter()
                .map(|p| p.1)
                .chain(s.band.iter().flatten().flat_map(|b| [b.1, b.2].into_iter()))
        });
        let no_points = || {
            anyhow!(
                "chart `{}` has no finite points to draw{}",
                self.title,
                if self.x_log || self.y_log {
                    " (a log axis shows only values above 0)"
                } else {
                    ""
                }
            )
        };
        let xa = Axis::fit(xs, self.x_log).ok_or_else(no_points)?;
        let ya = Axis::fit(ys, self.y_log).ok_or_else(no_points)?;
        let (xt, yt) = (xa.ticks(), ya.ticks());
        let bands = self.series.iter().filter(|s| s.band.is_some()).count();
        let band_op = band_opacity(bands);
        let entries = self.legend_entries(band_op);
        let (_, legend_w, legend_h) = svg::legend_size(&entries);
        let widest_y = yt
            .iter()
            .map(|t| svg::text_width_px(&t.label, FONT_PX))
            .fold(0.0, f64::max);
        let left = 34.0 + widest_y + 10.0;
        let plot = Rect {
            x: left,
            y: TOP,
            width: PLOT_W,
            height: PLOT_H,
        };
        let legend_at = (plot.x + plot.width + LEGEND_GAP, TOP);
        let width = if entries.is_empty() {
            plot.x + plot.width + MARGIN + 10.0
        } else {
            legend_at.0 + legend_w + MARGIN
        };
        let height = (TOP + PLOT_H + BOTTOM).max(TOP + legend_h + MARGIN);
        let map = |x: f64, y: f64| -> Option<(f64, f64)> {
            let fx = xa.fraction(x)?;
            let fy = ya.fraction(y)?;
            Some((plot.x + fx * plot.width, plot.y + (1.0 - fy) * plot.height))
        };

        let mut s = String::new();
        svg::open(&mut s, "fbg-chart", width, height, standalone);
        let _ = writeln!(s, "<title>{}</title>", escape(&self.title));
        let _ = writeln!(
            s,
            r#"<text class="chart-title" x="{}" y="26" text-anchor="middle" font-size="17">{}</text>"#,
            px(plot.x + plot.width / 2.0),
            escape(&self.title)
        );
        // The plot area carries its axes' ranges, so a reader of the SVG (a test) can
        // map a pixel back to data.
        let _ = writeln!(
            s,
            r##"<rect class="plot-area" x="{}" y="{}" width="{}" height="{}" fill="#ffffff" stroke="#444444" data-x-scale="{}" data-x-lo="{}" data-x-hi="{}" data-y-scale="{}" data-y-lo="{}" data-y-hi="{}"/>"##,
            px(plot.x),
            px(plot.y),
            px(plot.width),
            px(plot.height),
            if xa.log { "log" } else { "linear" },
            xa.lo,
            xa.hi,
            if ya.log { "log" } else { "linear" },
            ya.lo,
            ya.hi
        );
        self.draw_grid(&mut s, &plot, (&xa, &xt), (&ya, &yt));
        self.draw_data(&mut s, &map, band_op, bands > 2);
        let legend = (!entries.is_empty())
            .then(|| svg::draw_legend(&mut s, &entries, legend_at.0, legend_at.1));
        let _ = writeln!(s, "</svg>");
        Ok((
            s,
            Layout {
                size: (width, height),
                plot,
                legend,
            },
        ))
    }

    /// Grid lines, ticks, tick labels and axis labels.
    fn draw_grid(
        &self,
        s: &mut String,
        plot: &Rect,
        (xa, xt): (&Axis, &[axis::Tick]),
        (ya, yt): (&Axis, &[axis::Tick]),
    ) {
        let bottom = plot.y + plot.height;
        let _ = writeln!(
            s,
            r#"<g class="axis x-axis" data-scale="{}">"#,
            if xa.log { "log" } else { "linear" }
        );
        for t in xt {
            let Some(f) = xa.fraction(t.value) else {
                continue;
            };
            let x = plot.x + f * plot.width;
            let (class, stroke) = if t.major {
                ("grid", "#dddddd")
            } else {
                ("grid minor", "#efefef")
            };
            let _ = writeln!(
                s,
                r#"<line class="{class}" x1="{x}" y1="{}" x2="{x}" y2="{}" stroke="{stroke}"/>"#,
                px(plot.y),
                px(bottom),
                x = px(x)
            );
            if t.major {
                let _ = writeln!(
                    s,
                    r##"<line x1="{x}" y1="{}" x2="{x}" y2="{}" stroke="#444444"/><text class="tick-label" x="{x}" y="{}" text-anchor="middle" font-size="{FONT_PX}" data-value="{}">{}</text>"##,
                    px(bottom),
                    px(bottom + 5.0),
                    px(bottom + 19.0),
                    t.value,
                    escape(&t.label),
                    x = px(x)
                );
            }
        }
        let _ = writeln!(
            s,
            r#"<text class="axis-label" x="{}" y="{}" text-anchor="middle" font-size="13">{}</text></g>"#,
            px(plot.x + plot.width / 2.0),
            px(bottom + 42.0),
            escape(&self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<g class="axis y-axis" data-scale="{}">"#,
            if ya.log { "log" } else { "linear" }
        );
        for t in yt {
            let Some(f) = ya.fraction(t.value) else {
                continue;
            };
            let y = plot.y + (1.0 - f) * plot.height;
            let (class, stroke) = if t.major {
                ("grid", "#dddddd")
            } else {
                ("grid minor", "#efefef")
            };
            let _ = writeln!(
                s,
                r#"<line class="{class}" x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="{stroke}"/>"#,
                px(plot.x),
                px(plot.x + plot.width),
                y = px(y)
            );
            if t.major {
                let _ = writeln!(
                    s,
                    r##"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="#444444"/><text class="tick-label" x="{}" y="{}" text-anchor="end" font-size="{FONT_PX}" data-value="{}">{}</text>"##,
                    px(plot.x - 5.0),
                    px(plot.x),
                    px(plot.x - 8.0),
                    px(y + 4.0),
                    t.value,
                    escape(&t.label),
                    y = px(y)
                );
            }
        }
        let cy = plot.y + plot.height / 2.0;
        let _ = writeln!(
            s,
            r#"<text class="axis-label" x="16" y="{}" text-anchor="middle" font-size="13" transform="rotate(-90 16 {})">{}</text></g>"#,
            px(cy),
            px(cy),
            escape(&self.y_label)
        );
    }

    /// Bands first (under every line), then lines, then markers.
    fn draw_data(
        &self,
        s: &mut String,
        map: &dyn Fn(f64, f64) -> Option<(f64, f64)>,
        band_op: f64,
        outline: bool,
    ) {
        let tag = |i: usize| {
            let ser = &self.series[i];
            format!(
                r#"data-series="{}"{}"#,
                escape(&ser.name),
                ser.role
                    .as_ref()
                    .map(|r| format!(r#" data-role="{}""#, escape(r)))
                    .unwrap_or_default()
            )
        };
        for (i, ser) in self.series.iter().enumerate() {
            let Some(b) = &ser.band else { continue };
            let low: Vec<(f64, f64)> = b.iter().filter_map(|&(x, lo, _)| map(x, lo)).collect();
            let high: Vec<(f64, f64)> = b.iter().filter_map(|&(x, _, hi)| map(x, hi)).collect();
            if low.len() < 2 || high.len() < 2 {
                continue;
            }
            let pts: Vec<String> = low
                .iter()
                .chain(high.iter().rev())
                .map(|&(x, y)| format!("{},{}", px(x), px(y)))
                .collect();
            let c = self.color_of(i);
            // A band without a line of its own is always outlined, in its dash.
            let edge = if ser.points.is_empty() {
                format!(
                    r#" stroke="{c}" stroke-opacity="0.8" stroke-width="1"{}"#,
                    ser.stroke.dasharray()
                )
            } else if outline {
                format!(r#" stroke="{c}" stroke-opacity="0.7" stroke-width="0.8""#)
            } else {
                String::new()
            };
            let _ = writeln!(
                s,
                r#"<polygon class="band" {} points="{}" fill="{c}" fill-opacity="{band_op:.3}"{edge}/>"#,
                tag(i),
                pts.join(" ")
            );
        }
        for (i, ser) in self.series.iter().enumerate() {
            if !matches!(ser.mark, Mark::Line | Mark::LinePoints) {
                continue;
            }
            let c = self.color_of(i);
            // A point that cannot be drawn breaks the line rather than being bridged.
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for &(x, y) in &ser.points {
                match map(x, y) {
                    Some(p) => runs.last_mut().expect("one run").push(p),
                    None => runs.push(Vec::new()),
                }
            }
            for run in runs.iter().filter(|r| !r.is_empty()) {
                let pts: Vec<String> = run
                    .iter()
                    .map(|&(x, y)| format!("{},{}", px(x), px(y)))
                    .collect();
                let _ = writeln!(
                    s,
                    r#"<polyline class="line" {} points="{}" fill="none" stroke="{c}" stroke-width="2" stroke-linejoin="round"{}/>"#,
                    tag(i),
                    pts.join(" "),
                    ser.stroke.dasharray()
                );
            }
        }
        for (i, ser) in self.series.iter().enumerate() {
            if !matches!(ser.mark, Mark::Points | Mark::LinePoints) {
                continue;
            }
            let c = self.color_of(i);
            let r = if ser.mark == Mark::Points { 2.5 } else { 3.0 };
            let _ = writeln!(s, r#"<g class="points" {} fill="{c}">"#, tag(i));
            for p in ser.points.iter().filter_map(|&(x, y)| map(x, y)) {
                let _ = writeln!(s, r#"<circle cx="{}" cy="{}" r="{r}"/>"#, px(p.0), px(p.1));
            }
            let _ = writeln!(s, "</g>");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn twelve_banded_series() -> Chart {
        let mut c = Chart::new("bands", "E (MPa)", "shift (pm)");
        c.x_log = true;
        for k in 0..12 {
            let pts: Vec<(f64, f64)> = [10.0, 100.0, 2000.0]
                .iter()
                .map(|&x| (x, (k as f64 + 1.0) * 1000.0 / x))
                .collect();
            let band = pts.iter().map(|&(x, y)| (x, 0.9 * y, 1.1 * y)).collect();
            c = c.with(
                Series::new(
                    format!("lambda_{k} · Case I · light_green insert"),
                    pts,
                    Mark::Line,
                )
                .with_band(band),
            );
        }
        c
    }

    #[test]
    fn the_legend_sits_beside_the_plot_area_never_over_it() {
        let (svg, layout) = twelve_banded_series().render(true).unwrap();
        let legend = layout.legend.expect("named series have a legend");
        assert!(
            !legend.overlaps(&layout.plot),
            "{legend:?} {:?}",
            layout.plot
        );
        assert!(legend.x >= layout.plot.x + layout.plot.width);
        // The picture is large enough to hold it.
        assert!(legend.x + legend.width <= layout.size.0);
        assert!(legend.y + legend.height <= layout.size.1);
        // And the SVG says so: the legend box's rectangle is where the layout puts it.
        assert!(svg.contains(&format!(
            r#"<rect class="legend-box" x="{}" y="{}""#,
            px(legend.x),
            px(legend.y)
        )));
    }

    #[test]
    fn many_bands_are_light_and_outlined() {
        let (svg, _) = twelve_banded_series().render(true).unwrap();
        assert_eq!(svg.matches(r#"<polygon class="band""#).count(), 12);
        let op = band_opacity(12);
        assert!(op <= 0.05 + 1e-12);
        // Twelve overlapping bands at that opacity stay below 50 % cover.
        assert!(1.0 - (1.0 - op).powi(12) < 0.5);
        assert!(svg.contains(r#"stroke-opacity="0.7""#));
        // One band alone is shaded darker and has no outline.
        let one = Chart::new("t", "x", "y").with(
            Series::new("a", vec![(0.0, 0.0), (1.0, 1.0)], Mark::Line)
                .with_band(vec![(0.0, -1.0, 1.0), (1.0, 0.0, 2.0)]),
        );
        let svg = one.to_svg().unwrap();
        assert!(svg.contains(r#"fill-opacity="0.200""#) && !svg.contains("stroke-opacity"));
    }

    #[test]
    fn points_map_to_the_plot_area_by_the_axes_it_declares() {
        let c = Chart::new("t", "x", "y").with(
            Series::new("line", vec![(1.0, 2.0), (3.0, 6.0)], Mark::Line).with_role("model-k"),
        );
        let (svg, layout) = c.render(false).unwrap();
        assert!(!svg.contains("http"), "an inline chart names no URL");
        let line = svg
            .lines()
            .find(|l| l.contains(r#"data-role="model-k""#))
            .expect("the tagged line");
        assert!(line.starts_with(r#"<polyline class="line""#));
        let pts: Vec<(f64, f64)> = attr(line, "points")
            .split(' ')
            .map(|p| {
                let (a, b) = p.split_once(',').unwrap();
                (a.parse().unwrap(), b.parse().unwrap())
            })
            .collect();
        let area = svg.lines().find(|l| l.contains("plot-area")).unwrap();
        let (x0, x1): (f64, f64) = (
            attr(area, "data-x-lo").parse().unwrap(),
            attr(area, "data-x-hi").parse().unwrap(),
        );
        let (y0, y1): (f64, f64) = (
            attr(area, "data-y-lo").parse().unwrap(),
            attr(area, "data-y-hi").parse().unwrap(),
        );
        let p = layout.plot;
        let data = |(u, v): (f64, f64)| {
            (
                x0 + (u - p.x) / p.width * (x1 - x0),
                y0 + (p.y + p.height - v) / p.height * (y1 - y0),
            )
        };
        let (a, b) = (data(pts[0]), data(pts[1]));
        assert!(
            (a.0 - 1.0).abs() < 0.01 && (a.1 - 2.0).abs() < 0.01,
            "{a:?}"
        );
        assert!(((b.1 - a.1) / (b.0 - a.0) - 2.0).abs() < 0.01);
    }

    #[test]
    fn a_value_that_cannot_be_drawn_breaks_the_line_and_empty_charts_are_errors() {
        let mut c = Chart::new("t", "x", "y").with(Series::new(
            "s",
            vec![(1.0, 1.0), (2.0, 2.0), (3.0, -1.0), (4.0, 4.0), (5.0, 5.0)],
            Mark::Line,
        ));
        c.y_log = true;
        let svg = c.to_svg().unwrap();
        assert_eq!(svg.matches(r#"<polyline class="line""#).count(), 2);
        let empty =
            Chart::new("nothing", "x", "y").with(Series::new("s", vec![(1.0, -1.0)], Mark::Points));
        let mut log = empty.clone();
        log.y_log = true;
        let e = log.to_svg().unwrap_err().to_string();
        assert!(e.contains("nothing") && e.contains("log axis"), "{e}");
    }

    /// The value of attribute `name` in one SVG element's text.
    fn attr<'a>(el: &'a str, name: &str) -> &'a str {
        let key = format!(" {name}=\"");
        let start = el.find(&key).unwrap_or_else(|| panic!("no {name} in {el}")) + key.len();
        let len = el[start..].find('"').unwrap();
        &el[start..start + len]
    }
}
