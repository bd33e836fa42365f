//! The picture of a placement: the array's sheet to scale, its cells (labelled as the
//! reconstruction names them), the fibers, and each grating where the start layout
//! had it (grey outline) and where the chosen layout puts it (filled), joined by a
//! thin line; a legend beside the sheet and millimetre ticks on both edges.
//!
//! Every grating's rectangle carries its name, layout and centre in mm
//! (`data-grating`, `data-layout`, `data-x-mm`, `data-y-mm`), so a reader of the SVG
//! can check the picture against the design.

use crate::plot::axis::Axis;
use crate::plot::svg::{self, color, escape, px, LegendEntry, Rect, Stroke, Swatch, FONT_PX};
use crate::profile::{cell_label, ArrayLayout};
use crate::spec::TactileArray;
use std::fmt::Write as _;

/// Width the sheet is drawn at, px (its height follows to scale, within limits).
const SHEET_W_PX: f64 = 600.0;
const SHEET_MAX_H_PX: f64 = 560.0;
const LEFT: f64 = 64.0;
const TOP: f64 = 44.0;
const BOTTOM: f64 = 52.0;

/// Palette entry of the chosen gratings.
const CHOSEN: usize = 0;
const START_GREY: &str = "#8a8a8a";

/// One grating's centre (x, y), mm, in each layout.
fn centres(a: &TactileArray) -> Vec<(f64, f64)> {
    a.gratings
        .iter()
        .map(|g| {
            (
                a.fiber_x_mm
                    .get(g.fiber as usize)
                    .copied()
                    .unwrap_or(f64::NAN),
                g.y_mm,
            )
        })
        .collect()
}

/// The sheet drawn to scale: where it sits, px, and how millimetres map onto it.
struct Frame {
    sheet: Rect,
    scale: f64,
    size_mm: (f64, f64),
}

impl Frame {
    fn of(chosen: &TactileArray) -> Self {
        let (sx, sy) = (chosen.size_x_mm, chosen.size_y_mm);
        let scale = (SHEET_W_PX / sx).min(SHEET_MAX_H_PX / sy);
        Frame {
            sheet: Rect {
                x: LEFT,
                y: TOP,
                width: sx * scale,
                height: sy * scale,
            },
            scale,
            size_mm: (sx, sy),
        }
    }

    /// mm (origin at the sheet's centre, +y up) to px.
    fn at(&self, x: f64, y: f64) -> (f64, f64) {
        let (sx, sy) = self.size_mm;
        (
            self.sheet.x + (x + sx / 2.0) * self.scale,
            self.sheet.y + (sy / 2.0 - y) * self.scale,
        )
    }
}

/// The legend's rows (the start's fibers only when they moved).
fn legend_entries(chosen: &TactileArray, moved_fibers: bool) -> Vec<LegendEntry> {
    let (sx, sy) = (chosen.size_x_mm, chosen.size_y_mm);
    let mut entries = vec![
        LegendEntry {
            swatch: Swatch::Area {
                color: color(CHOSEN).into(),
                opacity: 0.85,
                outline: None,
            },
            label: "grating, chosen layout".into(),
        },
        LegendEntry {
            swatch: Swatch::Area {
                color: START_GREY.into(),
                opacity: 0.0,
                outline: Some(Stroke::Dashed),
            },
            label: "grating, start layout".into(),
        },
        LegendEntry {
            swatch: Swatch::Line {
                color: "#333333".into(),
                stroke: Stroke::Solid,
                width: 1.5,
                band: None,
            },
            label: "fiber (mold slit)".into(),
        },
        LegendEntry {
            swatch: Swatch::Area {
                color: "#f3f3f3".into(),
                opacity: 1.0,
                outline: Some(Stroke::Solid),
            },
            label: format!(
                "cell ({:.1} × {:.1} mm), labelled as reconstructed",
                sx / chosen.cells_x.max(1) as f64,
                sy / chosen.cells_y.max(1) as f64
            ),
        },
    ];
    if moved_fibers {
        entries.insert(
            3,
            LegendEntry {
                swatch: Swatch::Line {
                    color: START_GREY.into(),
                    stroke: Stroke::Dashed,
                    width: 1.5,
                    band: None,
                },
                label: "fiber, start layout".into(),
            },
        );
    }
    entries
}

/// The cells, labelled as the reconstruction names them, and the sheet's outline.
fn draw_cells(s: &mut String, f: &Frame, chosen: &TactileArray) {
    let cells = ArrayLayout::from_array(chosen);
    let (cw, ch) = cells.cell_size_mm;
    let scale = f.scale;
    let _ = writeln!(s, r#"<g class="cells">"#);
    for (k, &(cx, cy)) in cells.cell_centers_mm.iter().enumerate() {
        let (x0, y0) = f.at(cx - cw / 2.0, cy + ch / 2.0);
        let _ = writeln!(
            s,
            r##"<rect class="cell" x="{}" y="{}" width="{}" height="{}" fill="#f3f3f3" stroke="#c8c8c8"/><text class="cell-label" x="{}" y="{}" text-anchor="middle" font-size="{FONT_PX}" fill="#9a9a9a">{}</text>"##,
            px(x0),
            px(y0),
            px(cw * scale),
            px(ch * scale),
            px(x0 + cw * scale / 2.0),
            px(y0 + ch * scale / 2.0 + 4.0),
            escape(&cell_label(k))
        );
    }
    let _ = writeln!(s, "</g>");
    let (sx, sy) = f.size_mm;
    let sheet = &f.sheet;
    let _ = writeln!(
        s,
        r##"<rect class="sheet" x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#333333" stroke-width="1.5" data-size-x-mm="{sx}" data-size-y-mm="{sy}" data-px-per-mm="{scale}"/>"##,
        px(sheet.x),
        px(sheet.y),
        px(sheet.width),
        px(sheet.height)
    );
}

/// The fibers: the start's dashed where they moved, the chosen solid.
fn draw_fibers(s: &mut String, f: &Frame, start: &TactileArray, chosen: &TactileArray) {
    let fiber = |s: &mut String, x: f64, class: &str, stroke: &str, dash: Stroke| {
        let (u, _) = f.at(x, 0.0);
        let _ = writeln!(
            s,
            r#"<line class="{class}" x1="{u}" y1="{}" x2="{u}" y2="{}" stroke="{stroke}" stroke-width="1.5"{} data-x-mm="{x}"/>"#,
            px(f.sheet.y),
            px(f.sheet.y + f.sheet.height),
            dash.dasharray(),
            u = px(u)
        );
    };
    if start.fiber_x_mm != chosen.fiber_x_mm {
        for &x in &start.fiber_x_mm {
            fiber(s, x, "fiber start", START_GREY, Stroke::Dashed);
        }
    }
    for &x in &chosen.fiber_x_mm {
        fiber(s, x, "fiber chosen", "#333333", Stroke::Solid);
    }
}

/// The gratings: start outlines, the moves, chosen fills with their names.
fn draw_gratings(s: &mut String, f: &Frame, start: &TactileArray, chosen: &TactileArray) {
    let (from, to) = (centres(start), centres(chosen));
    let bar_w = (2.2 * f.scale).clamp(6.0, 12.0);
    let grating = |s: &mut String, name: &str, (x, y): (f64, f64), len: f64, chosen: bool| {
        let (u, v) = f.at(x, y + len / 2.0);
        let style = if chosen {
            format!(r#"fill="{}" fill-opacity="0.85""#, color(CHOSEN))
        } else {
            format!(
                r#"fill="none" stroke="{START_GREY}" stroke-width="1.5" stroke-dasharray="4 2""#
            )
        };
        let _ = writeln!(
            s,
            r#"<rect class="grating {}" x="{}" y="{}" width="{}" height="{}" {style} data-grating="{}" data-layout="{}" data-x-mm="{x}" data-y-mm="{y}"/>"#,
            if chosen { "chosen" } else { "start" },
            px(u - bar_w / 2.0),
            px(v),
            px(bar_w),
            px((len * f.scale).max(3.0)),
            escape(name),
            if chosen { "chosen" } else { "start" }
        );
    };
    for (i, g) in start.gratings.iter().enumerate() {
        grating(s, &g.name, from[i], g.length_mm, false);
    }
    for (i, g) in chosen.gratings.iter().enumerate() {
        if let Some(&a) = from.get(i) {
            let (p, q) = (f.at(a.0, a.1), f.at(to[i].0, to[i].1));
            if (p.0 - q.0).hypot(p.1 - q.1) > 1.0 {
                let _ = writeln!(
                    s,
                    r#"<line class="move" x1="{}" y1="{}" x2="{}" y2="{}" stroke="{START_GREY}" stroke-width="1"/>"#,
                    px(p.0),
                    px(p.1),
                    px(q.0),
                    px(q.1)
                );
            }
        }
        grating(s, &g.name, to[i], g.length_mm, true);
        let (u, v) = f.at(to[i].0, to[i].1);
        let _ = writeln!(
            s,
            r#"<text class="grating-label" x="{}" y="{}" font-size="{FONT_PX}" fill="{}">{}</text>"#,
            px(u + bar_w / 2.0 + 3.0),
            px(v + 4.0),
            color(CHOSEN),
            escape(&g.name)
        );
    }
}

/// Millimetre ticks along the bottom and left edges, with the axis labels.
fn draw_ticks(s: &mut String, f: &Frame) {
    let (sx, sy) = f.size_mm;
    let sheet = &f.sheet;
    let xa = Axis {
        log: false,
        lo: -sx / 2.0,
        hi: sx / 2.0,
    };
    let ya = Axis {
        log: false,
        lo: -sy / 2.0,
        hi: sy / 2.0,
    };
    let bottom = sheet.y + sheet.height;
    let _ = writeln!(s, r#"<g class="axis x-axis" data-scale="linear">"#);
    for t in xa.ticks() {
        let (u, _) = f.at(t.value, 0.0);
        let _ = writeln!(
            s,
            r##"<line x1="{u}" y1="{}" x2="{u}" y2="{}" stroke="#444444"/><text class="tick-label" x="{u}" y="{}" text-anchor="middle" font-size="{FONT_PX}">{}</text>"##,
            px(bottom),
            px(bottom + 5.0),
            px(bottom + 19.0),
            escape(&t.label),
            u = px(u)
        );
    }
    let _ = writeln!(
        s,
        r#"<text class="axis-label" x="{}" y="{}" text-anchor="middle" font-size="13">x (mm), fibers run along y</text></g>"#,
        px(sheet.x + sheet.width / 2.0),
        px(bottom + 40.0)
    );
    let _ = writeln!(s, r#"<g class="axis y-axis" data-scale="linear">"#);
    for t in ya.ticks() {
        let (_, v) = f.at(0.0, t.value);
        let _ = writeln!(
            s,
            r##"<line x1="{}" y1="{v}" x2="{}" y2="{v}" stroke="#444444"/><text class="tick-label" x="{}" y="{}" text-anchor="end" font-size="{FONT_PX}">{}</text>"##,
            px(sheet.x - 5.0),
            px(sheet.x),
            px(sheet.x - 8.0),
            px(v + 4.0),
            escape(&t.label),
            v = px(v)
        );
    }
    let cy = sheet.y + sheet.height / 2.0;
    let _ = writeln!(
        s,
        r#"<text class="axis-label" x="16" y="{}" text-anchor="middle" font-size="13" transform="rotate(-90 16 {})">y (mm)</text></g>"#,
        px(cy),
        px(cy)
    );
}

/// The layout picture as SVG (`standalone`: with the namespace a file needs) and where
/// its sheet and legend are, px.
pub(crate) fn layout_svg(
    start: &TactileArray,
    chosen: &TactileArray,
    title: &str,
    standalone: bool,
) -> (String, Rect, Rect) {
    let f = Frame::of(chosen);
    let sheet = f.sheet;
    let entries = legend_entries(chosen, start.fiber_x_mm != chosen.fiber_x_mm);
    let (_, legend_w, legend_h) = svg::legend_size(&entries);
    let legend_x = sheet.x + sheet.width + 28.0;
    let width = legend_x + legend_w + 12.0;
    let height = (sheet.y + sheet.height + BOTTOM).max(TOP + legend_h + 12.0);

    let mut s = String::new();
    svg::open(&mut s, "fbg-layout", width, height, standalone);
    let _ = writeln!(s, "<title>{}</title>", escape(title));
    let _ = writeln!(
        s,
        r#"<text class="chart-title" x="{}" y="26" text-anchor="middle" font-size="17">{}</text>"#,
        px(sheet.x + sheet.width / 2.0),
        escape(title)
    );
    draw_cells(&mut s, &f, chosen);
    draw_fibers(&mut s, &f, start, chosen);
    draw_gratings(&mut s, &f, start, chosen);
    draw_ticks(&mut s, &f);
    let legend = svg::draw_legend(&mut s, &entries, legend_x, TOP);
    let _ = writeln!(s, "</svg>");
    (s, sheet, legend)
}

/// The layouts' numbers as CSV rows: grating, fiber, start x and y, chosen x and y,
/// length (mm).
pub(crate) fn layout_rows(start: &TactileArray, chosen: &TactileArray) -> Vec<Vec<String>> {
    let (from, to) = (centres(start), centres(chosen));
    chosen
        .gratings
        .iter()
        .enumerate()
        .map(|(i, g)| {
            let a = from.get(i).copied().unwrap_or((f64::NAN, f64::NAN));
            vec![
                g.name.clone(),
                g.fiber.to_string(),
                a.0.to_string(),
                a.1.to_string(),
                to[i].0.to_string(),
                to[i].1.to_string(),
                g.length_mm.to_string(),
            ]
        })
        .collect()
}

/// Header of [`layout_rows`].
pub(crate) const LAYOUT_HEADER: [&str; 7] = [
    "grating",
    "fiber",
    "start_x_mm",
    "start_y_mm",
    "x_mm",
    "y_mm",
    "length_mm",
];
