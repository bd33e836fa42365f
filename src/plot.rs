//! SVG charts for results people would rather look at than read.
//!
//! One small chart type covers most plots fbgforge makes: named series of (x, y)
//! points drawn as lines, markers or both, optionally with a shaded band, on linear
//! or log10 axes; [`HeatMaps`] draws values over a plane (a sensitivity map). Charts are
//! rendered to a string with plotters' SVG backend and written atomically; the same
//! numbers always go to a JSON or CSV beside the chart.

use crate::output::write_atomic;
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;

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
    /// Legend label.
    pub name: String,
    /// Data points (x, y).
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub mark: Mark,
    /// A range around the series, (x, low, high), drawn as a shaded band in the
    /// series' colour (e.g. a prediction's band between bounding model readings).
    pub band: Option<Vec<(f64, f64, f64)>>,
}

impl Series {
    /// A series from a name, points and a mark.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, mark: Mark) -> Self {
        Series {
            name: name.into(),
            points,
            mark,
            band: None,
        }
    }

    /// The same series with a shaded band (x, low, high).
    pub fn with_band(mut self, band: Vec<(f64, f64, f64)>) -> Self {
        self.band = Some(band);
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
    /// Plot x as log10.
    pub x_log: bool,
    /// Plot y as log10.
    pub y_log: bool,
    /// Series.
    pub series: Vec<Series>,
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

    /// Render to an SVG string.
    pub fn to_svg(&self) -> Result<String> {
        let tx = |v: f64| if self.x_log { v.log10() } else { v };
        let ty = |v: f64| if self.y_log { v.log10() } else { v };
        let data: Vec<Vec<(f64, f64)>> = self
            .series
            .iter()
            .map(|s| {
                s.points
                    .iter()
                    .map(|&(x, y)| (tx(x), ty(y)))
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .collect()
            })
            .collect();
        // Each band as a closed outline: the low edge forward, the high edge back.
        let bands: Vec<Vec<(f64, f64)>> = self
            .series
            .iter()
            .map(|s| {
                let Some(b) = &s.band else {
                    return Vec::new();
                };
                let ok = |&(x, y): &(f64, f64)| x.is_finite() && y.is_finite();
                let low = b.iter().map(|&(x, lo, _)| (tx(x), ty(lo))).filter(ok);
                let high: Vec<(f64, f64)> = b
                    .iter()
                    .map(|&(x, _, hi)| (tx(x), ty(hi)))
                    .filter(ok)
                    .collect();
                low.chain(high.into_iter().rev()).collect()
            })
            .collect();
        let all: Vec<&(f64, f64)> = data.iter().chain(&bands).flatten().collect();
        if all.is_empty() {
            return Err(anyhow!(
                "chart `{}` has no finite points to draw",
                self.title
            ));
        }
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &&(x, y) in &all {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        let pad = |a: f64, b: f64| {
            let d = if (b - a).abs() < 1e-12 {
                a.abs().max(1.0) * 0.05
            } else {
                (b - a) * 0.05
            };
            (a - d, b + d)
        };
        let (x0, x1) = pad(x0, x1);
        let (y0, y1) = pad(y0, y1);
        let x_label = if self.x_log {
            format!("log10 {}", self.x_label)
        } else {
            self.x_label.clone()
        };
        let y_label = if self.y_log {
            format!("log10 {}", self.y_label)
        } else {
            self.y_label.clone()
        };

        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (900, 600)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| anyhow!("plot: {e}"))?;
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, ("sans-serif", 22))
                .margin(15)
                .x_label_area_size(45)
                .y_label_area_size(70)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| anyhow!("plot: {e}"))?;
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .draw()
                .map_err(|e| anyhow!("plot: {e}"))?;
            for (i, band) in bands.iter().enumerate() {
                if band.len() >= 3 {
                    let shade = Palette99::pick(i).mix(0.18);
                    chart
                        .draw_series(std::iter::once(Polygon::new(band.clone(), shade.filled())))
                        .map_err(|e| anyhow!("plot: {e}"))?;
                }
            }
            for (i, (s, pts)) in self.series.iter().zip(&data).enumerate() {
                let color = Palette99::pick(i).to_rgba();
                let style = ShapeStyle::from(&color).stroke_width(2);
                if matches!(s.mark, Mark::Line | Mark::LinePoints) {
                    chart
                        .draw_series(LineSeries::new(pts.iter().copied(), style))
                        .map_err(|e| anyhow!("plot: {e}"))?
                        .label(s.name.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
                }
                if matches!(s.mark, Mark::Points | Mark::LinePoints) {
                    let ann = chart
                        .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                        .map_err(|e| anyhow!("plot: {e}"))?;
                    if s.mark == Mark::Points {
                        ann.label(s.name.clone())
                            .legend(move |(x, y)| Circle::new((x + 10, y), 3, color.filled()));
                    }
                }
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| anyhow!("plot: {e}"))?;
            root.present().map_err(|e| anyhow!("plot: {e}"))?;
        }
        Ok(svg)
    }

    /// Render and write atomically to `path`.
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        let svg = self.to_svg()?;
        write_atomic(path, svg.as_bytes())
    }
}

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

/// Diverging colour of t in [−1, 1].
fn diverging(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let mix = |a: (f64, f64, f64), b: (f64, f64, f64), f: f64| {
        RGBColor(
            (a.0 + (b.0 - a.0) * f).round() as u8,
            (a.1 + (b.1 - a.1) * f).round() as u8,
            (a.2 + (b.2 - a.2) * f).round() as u8,
        )
    };
    let white = (255.0, 255.0, 255.0);
    if t >= 0.0 {
        mix(white, (178.0, 24.0, 43.0), t)
    } else {
        mix(white, (33.0, 102.0, 172.0), -t)
    }
}

impl HeatMaps {
    /// Render to an SVG string.
    pub fn to_svg(&self) -> Result<String> {
        if self.panels.is_empty() {
            return Err(anyhow!("heat maps `{}` have no panel", self.title));
        }
        let cols = self.panels.len().min(3);
        let rows = self.panels.len().div_ceil(cols);
        let (pw, ph) = (420u32, 360u32);
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (pw * cols as u32, ph * rows as u32 + 40))
                .into_drawing_area();
            root.fill(&WHITE).map_err(|e| anyhow!("plot: {e}"))?;
            let root = root
                .titled(&self.title, ("sans-serif", 20))
                .map_err(|e| anyhow!("plot: {e}"))?;
            let areas = root.split_evenly((rows, cols));
            for (p, area) in self.panels.iter().zip(areas.iter()) {
                let step = |v: &[f64]| {
                    if v.len() >= 2 {
                        (v[v.len() - 1] - v[0]) / (v.len() - 1) as f64
                    } else {
                        1.0
                    }
                };
                let (dx, dy) = (step(&p.x), step(&p.y));
                let (Some(&x0), Some(&x1), Some(&y0), Some(&y1)) =
                    (p.x.first(), p.x.last(), p.y.first(), p.y.last())
                else {
                    continue;
                };
                let (x0, x1, y0, y1) = (x0 - dx / 2.0, x1 + dx / 2.0, y0 - dy / 2.0, y1 + dy / 2.0);
                let peak = p
                    .values
                    .iter()
                    .flatten()
                    .filter(|v| v.is_finite())
                    .fold(0.0f64, |m, v| m.max(v.abs()));
                let mut chart = ChartBuilder::on(area)
                    .caption(&p.title, ("sans-serif", 15))
                    .margin(8)
                    .x_label_area_size(32)
                    .y_label_area_size(40)
                    .build_cartesian_2d(x0..x1, y0..y1)
                    .map_err(|e| anyhow!("plot: {e}"))?;
                chart
                    .configure_mesh()
                    .disable_mesh()
                    .x_desc(self.x_label.as_str())
                    .y_desc(self.y_label.as_str())
                    .x_labels(5)
                    .y_labels(5)
                    .draw()
                    .map_err(|e| anyhow!("plot: {e}"))?;
                let cells =
                    p.y.iter().enumerate().flat_map(|(j, &y)| {
                        p.x.iter().enumerate().map(move |(i, &x)| (i, j, x, y))
                    });
                chart
                    .draw_series(cells.map(|(i, j, x, y)| {
                        let v = p.values.get(j).and_then(|r| r.get(i)).copied();
                        let t = match v {
                            Some(v) if peak > 0.0 => v / peak,
                            _ => 0.0,
                        };
                        Rectangle::new(
                            [(x - dx / 2.0, y - dy / 2.0), (x + dx / 2.0, y + dy / 2.0)],
                            diverging(t).filled(),
                        )
                    }))
                    .map_err(|e| anyhow!("plot: {e}"))?;
                for l in &p.lines {
                    chart
                        .draw_series(std::iter::once(PathElement::new(
                            l.clone(),
                            RGBColor(120, 120, 120).stroke_width(1),
                        )))
                        .map_err(|e| anyhow!("plot: {e}"))?;
                }
                chart
                    .draw_series(p.points.iter().map(|&q| Circle::new(q, 4, BLACK.filled())))
                    .map_err(|e| anyhow!("plot: {e}"))?;
            }
            root.present().map_err(|e| anyhow!("plot: {e}"))?;
        }
        Ok(svg)
    }

    /// Render and write atomically to `path`.
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        let svg = self.to_svg()?;
        write_atomic(path, svg.as_bytes())
    }
}
