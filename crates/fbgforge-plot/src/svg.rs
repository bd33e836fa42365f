//! The small pieces every SVG picture of fbgforge shares: text escaping, numbers
//! written compactly, the colour palette and dash patterns, a text-width estimate, and
//! the legend box drawn beside (never over) a picture.
//!
//! Pictures are written as SVG text directly: each element carries a `class` (and the
//! data elements a `data-series` and `data-role`), so a report's CSS can style them and
//! a test can find the model's line or the legend by name.

use std::fmt::Write as _;

/// Text escaped for an SVG or HTML text node or a double-quoted attribute.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// A pixel coordinate: one decimal is finer than any screen needs.
pub fn px(v: f64) -> String {
    let r = (v * 10.0).round() / 10.0;
    if r == r.trunc() {
        format!("{}", r as i64)
    } else {
        format!("{r:.1}")
    }
}

/// Colours of the series, in order (Tableau 10, its yellow darkened to read on white).
pub const PALETTE: [&str; 10] = [
    "#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f", "#c9a227", "#b07aa1", "#ff9da7",
    "#9c755f", "#7f7f7f",
];

/// The colour of palette entry `i` (wrapping).
pub fn color(i: usize) -> &'static str {
    PALETTE[i % PALETTE.len()]
}

/// How a line is stroked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Stroke {
    /// Continuous.
    #[default]
    Solid,
    /// Long dashes.
    Dashed,
    /// Dots.
    Dotted,
    /// Dash and dot.
    DashDot,
}

impl Stroke {
    /// Every stroke, in the order series cycle through them.
    pub const ALL: [Stroke; 4] = [
        Stroke::Solid,
        Stroke::Dashed,
        Stroke::Dotted,
        Stroke::DashDot,
    ];

    /// The `stroke-dasharray` attribute (empty for a solid line).
    pub fn dasharray(self) -> &'static str {
        match self {
            Stroke::Solid => "",
            Stroke::Dashed => r#" stroke-dasharray="7 4""#,
            Stroke::Dotted => r#" stroke-dasharray="2 3""#,
            Stroke::DashDot => r#" stroke-dasharray="8 3 2 3""#,
        }
    }
}

/// Font size of tick labels and legend text, px.
pub const FONT_PX: f64 = 12.0;

/// A generous estimate of the width of `text` at `font_px` in a sans-serif font: the
/// layout reserves this much, so a legend never runs into the plot.
pub(crate) fn text_width_px(text: &str, font_px: f64) -> f64 {
    text.chars()
        .map(|c| {
            // DejaVu Sans, the widest of the usual fallbacks: digits 0.64 em.
            let em = if c.is_ascii_uppercase() || "mwMW@%".contains(c) {
                0.8
            } else if "il.,:;'|!()[] ".contains(c) {
                0.36
            } else {
                0.65
            };
            em * font_px
        })
        .sum()
}

/// `text` broken into lines of at most `max_chars` characters at spaces (a word longer
/// than that stays whole).
pub fn wrap(text: &str, max_chars: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        let len = line.chars().count();
        if len > 0 && len + 1 + word.chars().count() > max_chars {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() || lines.is_empty() {
        lines.push(line);
    }
    lines
}

/// A rectangle in pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Left edge.
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width.
    pub width: f64,
    /// Height.
    pub height: f64,
}

impl Rect {
    /// Whether the two rectangles share any area.
    pub fn overlaps(&self, o: &Rect) -> bool {
        self.x < o.x + o.width
            && o.x < self.x + self.width
            && self.y < o.y + o.height
            && o.y < self.y + self.height
    }
}

/// What a legend entry's swatch shows.
#[derive(Debug, Clone, PartialEq)]
pub enum Swatch {
    /// A line in a colour and stroke, over a light band when `band` is set.
    Line {
        /// Colour.
        color: String,
        /// Dash pattern.
        stroke: Stroke,
        /// Width, px.
        width: f64,
        /// Fill opacity of a band behind the line, if any.
        band: Option<f64>,
    },
    /// A marker.
    Point {
        /// Colour.
        color: String,
    },
    /// A filled area.
    Area {
        /// Colour.
        color: String,
        /// Fill opacity.
        opacity: f64,
        /// Drawn with an outline of the stroke.
        outline: Option<Stroke>,
    },
}

/// One legend row: a swatch and its label.
#[derive(Debug, Clone, PartialEq)]
pub struct LegendEntry {
    /// Swatch.
    pub swatch: Swatch,
    /// Label (wrapped to the legend's width).
    pub label: String,
}

/// Longest legend line, characters, before wrapping.
const LEGEND_WRAP_CHARS: usize = 42;
const LEGEND_LINE_PX: f64 = 15.0;
const LEGEND_GAP_PX: f64 = 5.0;
const LEGEND_PAD_PX: f64 = 8.0;
const SWATCH_PX: f64 = 26.0;

/// The legend's wrapped lines and its size (width, height) in pixels.
pub fn legend_size(entries: &[LegendEntry]) -> (Vec<Vec<String>>, f64, f64) {
    let lines: Vec<Vec<String>> = entries
        .iter()
        .map(|e| wrap(&e.label, LEGEND_WRAP_CHARS))
        .collect();
    let text_w = lines
        .iter()
        .flatten()
        .map(|l| text_width_px(l, FONT_PX))
        .fold(0.0, f64::max);
    let rows: usize = lines.iter().map(Vec::len).sum();
    let width = 2.0 * LEGEND_PAD_PX + SWATCH_PX + 6.0 + text_w;
    let height = 2.0 * LEGEND_PAD_PX
        + rows as f64 * LEGEND_LINE_PX
        + entries.len().saturating_sub(1) as f64 * LEGEND_GAP_PX;
    (lines, width, height)
}

/// Draw the legend with its top-left corner at (x, y); returns its box. The caller
/// places it beside the picture, so it never covers data.
pub fn draw_legend(out: &mut String, entries: &[LegendEntry], x: f64, y: f64) -> Rect {
    let (lines, width, height) = legend_size(entries);
    let _ = writeln!(
        out,
        r##"<g class="legend"><rect class="legend-box" x="{}" y="{}" width="{}" height="{}" fill="#ffffff" stroke="#bbbbbb"/>"##,
        px(x),
        px(y),
        px(width),
        px(height)
    );
    let mut top = y + LEGEND_PAD_PX;
    for (e, lines) in entries.iter().zip(&lines) {
        let mid = top + LEGEND_LINE_PX / 2.0;
        let (x0, x1) = (x + LEGEND_PAD_PX, x + LEGEND_PAD_PX + SWATCH_PX);
        match &e.swatch {
            Swatch::Line {
                color,
                stroke,
                width,
                band,
            } => {
                if let Some(op) = band {
                    let _ = writeln!(
                        out,
                        r#"<rect x="{}" y="{}" width="{}" height="10" fill="{color}" fill-opacity="{op:.3}"/>"#,
                        px(x0),
                        px(mid - 5.0),
                        px(SWATCH_PX)
                    );
                }
                let _ = writeln!(
                    out,
                    r#"<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="{color}" stroke-width="{width}"{}/>"#,
                    px(x0),
                    px(mid),
                    px(x1),
                    px(mid),
                    stroke.dasharray()
                );
            }
            Swatch::Point { color } => {
                let _ = writeln!(
                    out,
                    r#"<circle cx="{}" cy="{}" r="3" fill="{color}"/>"#,
                    px((x0 + x1) / 2.0),
                    px(mid)
                );
            }
            Swatch::Area {
                color,
                opacity,
                outline,
            } => {
                let edge = match outline {
                    Some(s) => format!(r#" stroke="{color}" stroke-width="1"{}"#, s.dasharray()),
                    None => String::new(),
                };
                let _ = writeln!(
                    out,
                    r#"<rect x="{}" y="{}" width="{}" height="10" fill="{color}" fill-opacity="{opacity:.3}"{edge}/>"#,
                    px(x0),
                    px(mid - 5.0),
                    px(SWATCH_PX)
                );
            }
        }
        let _ = write!(
            out,
            r#"<text class="legend-label" x="{}" y="{}" font-size="{FONT_PX}">"#,
            px(x1 + 6.0),
            px(mid + 4.0)
        );
        for (k, l) in lines.iter().enumerate() {
            if k == 0 {
                let _ = write!(out, "{}", escape(l));
            } else {
                let _ = write!(
                    out,
                    r#"<tspan x="{}" dy="{LEGEND_LINE_PX}">{}</tspan>"#,
                    px(x1 + 6.0),
                    escape(l)
                );
            }
        }
        let _ = writeln!(out, "</text>");
        top += lines.len() as f64 * LEGEND_LINE_PX + LEGEND_GAP_PX;
    }
    let _ = writeln!(out, "</g>");
    Rect {
        x,
        y,
        width,
        height,
    }
}

/// The opening tag of a picture: `standalone` adds the SVG namespace a file needs (an
/// SVG inlined in HTML needs none, so a report carries no URL at all).
pub fn open(out: &mut String, class: &str, width: f64, height: f64, standalone: bool) {
    let ns = if standalone {
        r#" xmlns="http://www.w3.org/2000/svg""#
    } else {
        ""
    };
    let _ = writeln!(
        out,
        r#"<svg{ns} class="{class}" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="DejaVu Sans, Arial, Helvetica, sans-serif">"#,
        w = px(width),
        h = px(height)
    );
    let _ = writeln!(
        out,
        r##"<rect class="background" x="0" y="0" width="{}" height="{}" fill="#ffffff"/>"##,
        px(width),
        px(height)
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped_for_nodes_and_attributes() {
        assert_eq!(
            escape(r#"a<b & "c" 'd'>"#),
            "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;"
        );
    }

    #[test]
    fn labels_wrap_at_spaces_and_keep_long_words() {
        assert_eq!(wrap("aa bb cc", 5), vec!["aa bb", "cc"]);
        assert_eq!(wrap("abcdefgh ij", 4), vec!["abcdefgh", "ij"]);
        assert_eq!(wrap("", 4), vec![""]);
    }

    #[test]
    fn rectangles_overlap_only_when_they_share_area() {
        let a = Rect {
            x: 0.0,
            y: 0.0,
            width: 10.0,
            height: 10.0,
        };
        let touching = Rect { x: 10.0, ..a };
        let inside = Rect {
            x: 5.0,
            y: 5.0,
            width: 1.0,
            height: 1.0,
        };
        assert!(!a.overlaps(&touching));
        assert!(a.overlaps(&inside) && inside.overlaps(&a));
    }
}
