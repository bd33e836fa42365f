//! SVG charts for results people would rather look at than read.
//!
//! One small chart type covers every plot fbgforge makes: named series of (x, y)
//! points drawn as lines, markers or both, optionally with a shaded band, on linear
//! or log10 axes. Charts are
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
