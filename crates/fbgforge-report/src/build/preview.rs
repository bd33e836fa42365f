//! Cut-away previews of what `build` makes, as SVG: the assembled module cut by the
//! vertical planes its fibers leave in (a strain fiber's pillar and the reference
//! fiber's exit), and the mold cut through a fiber slit, with the fiber and the
//! silicone level drawn in. Sections of the checked meshes, so the picture is what the
//! STL files hold.

use fbgforge_geometry::assembly::{axial_section, plane_section, FiberTrace};
use fbgforge_geometry::design_profile::{DesignProfile, ModuleDims};
use fbgforge_geometry::registry::first_of_each_kind;
use fbgforge_geometry::{BuiltPart, PartKind};
use std::fmt::Write;

type Seg2 = [(f64, f64); 2];
/// A named, coloured polyline in model coordinates (mm).
type Polyline = (String, &'static str, Vec<(f64, f64)>);

fn colour(kind: PartKind) -> &'static str {
    kind.part().preview_colour()
}

/// One panel: layers of segments in model coordinates (mm), drawn to fit `w`×`h` px.
struct Panel {
    title: String,
    layers: Vec<(String, &'static str, Vec<Seg2>)>,
    polylines: Vec<Polyline>,
    levels: Vec<(String, f64)>,
    /// Model window (x0, x1, y0, y1) to show, mm; everything when None.
    view: Option<(f64, f64, f64, f64)>,
    /// Dimensions drawn on the section: from, to (model mm) and what is measured.
    dims: Vec<Dim>,
}

/// A dimension line between two model points, labelled with its name and length.
#[derive(Debug, Clone)]
struct Dim {
    a: (f64, f64),
    b: (f64, f64),
    name: String,
}

impl Dim {
    fn new(name: &str, a: (f64, f64), b: (f64, f64)) -> Self {
        Dim {
            a,
            b,
            name: name.into(),
        }
    }
    fn length_mm(&self) -> f64 {
        (self.b.0 - self.a.0).hypot(self.b.1 - self.a.1)
    }
}

/// A length as the manifest gives it: up to 4 decimals, trailing zeros dropped
/// (0.075 mm prints `0.075`, not `0.07`; 2 mm prints `2`).
pub(crate) fn mm(v: f64) -> String {
    let t = format!("{v:.4}");
    let t = t.trim_end_matches('0').trim_end_matches('.');
    if t == "-0" {
        "0".into()
    } else {
        t.into()
    }
}

/// A round length for a scale bar near a fifth of `span_mm`: 1, 2 or 5 × 10ⁿ mm.
pub(crate) fn scale_bar_mm(span_mm: f64) -> f64 {
    let target = (span_mm / 5.0).max(1e-6);
    let decade = 10f64.powf(target.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|k| k * decade)
        .find(|&v| v <= target)
        .unwrap_or(decade)
}

impl Panel {
    fn bounds(&self) -> (f64, f64, f64, f64) {
        if let Some(v) = self.view {
            return v;
        }
        let pts = self
            .layers
            .iter()
            .flat_map(|l| l.2.iter().flat_map(|s| [s[0], s[1]]))
            .chain(self.polylines.iter().flat_map(|l| l.2.iter().copied()));
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (x, y) in pts {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        (x0, x1, y0, y1)
    }
}

/// Text boxes already placed in a panel (px: left, top, right, bottom), so that no
/// label is drawn over another: a label that would overlap one is moved up a line
/// until it overlaps none.
#[derive(Default)]
struct Labels {
    boxes: Vec<[f64; 4]>,
}

impl Labels {
    /// Font size of labels, px, and the width of a character as a share of it (a
    /// generous bound for sans-serif digits and lower case).
    const SIZE: f64 = 12.0;
    const CHAR: f64 = 0.62;

    /// Place `text` (font size `size`) with its baseline start at (x, y) or above;
    /// returns the `<text>` element.
    fn place(&mut self, x: f64, y: f64, size: f64, text: &str, attrs: &str) -> String {
        let w = Self::CHAR * size * text.chars().count() as f64;
        let mut y = y;
        let overlaps = |y: f64, b: &[f64; 4]| {
            x < b[2] && b[0] < x + w && y - size < b[3] && b[1] < y + 0.25 * size
        };
        while self.boxes.iter().any(|b| overlaps(y, b)) {
            y -= size + 1.0;
        }
        let b = [x, y - size, x + w, y + 0.25 * size];
        self.boxes.push(b);
        format!(
            r#"<text class="label" data-box="{:.2} {:.2} {:.2} {:.2}" x="{x:.2}" y="{y:.2}" font-size="{size}" {attrs}>{text}</text>"#,
            b[0], b[1], b[2], b[3]
        )
    }
}

/// Where panel `i` sits in the picture and how its model millimetres map to px.
struct PanelFrame {
    /// Panel index (panels stand side by side).
    i: usize,
    /// Panel width, the panels' common height and the padding, px.
    w: f64,
    h: f64,
    pad: f64,
    /// px per mm.
    scale: f64,
    /// The panel's model window: x from, x to, y from (mm).
    x0: f64,
    x1: f64,
    y0: f64,
}

impl PanelFrame {
    /// Left edge of the drawing, px.
    fn ox(&self) -> f64 {
        self.i as f64 * self.w
            + self.pad
            + 0.5 * (self.w - 2.0 * self.pad - self.scale * (self.x1 - self.x0))
    }
    fn tx(&self, x: f64) -> f64 {
        self.ox() + (x - self.x0) * self.scale
    }
    fn ty(&self, y: f64) -> f64 {
        self.h - self.pad - (y - self.y0) * self.scale
    }
}

fn draw(panels: &[Panel], caption: &str) -> String {
    let (w, max_h, pad) = (520.0, 560.0, 40.0);
    let scales: Vec<f64> = panels
        .iter()
        .map(|p| {
            let (x0, x1, y0, y1) = p.bounds();
            ((w - 2.0 * pad) / (x1 - x0)).min((max_h - 2.0 * pad) / (y1 - y0))
        })
        .collect();
    let h = panels
        .iter()
        .zip(&scales)
        .map(|(p, sc)| {
            let (_, _, y0, y1) = p.bounds();
            (y1 - y0) * sc + 2.0 * pad
        })
        .fold(120.0, f64::max);
    let lines: Vec<&str> = caption.split("; ").collect();
    let legend = 14.0 * panels.iter().map(|p| p.layers.len()).max().unwrap_or(1) as f64 + 16.0;
    let total_h = h + legend + 20.0 + 16.0 * lines.len() as f64;
    let total_w = w * panels.len() as f64;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{total_w}" height="{total_h}" viewBox="0 0 {total_w} {total_h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    for (i, p) in panels.iter().enumerate() {
        let (x0, x1, y0, y1) = p.bounds();
        // Each panel at its own aspect: as high as its drawing at its scale.
        let own_h = ((y1 - y0) * scales[i] + 2.0 * pad).max(120.0);
        let f = PanelFrame {
            i,
            w,
            h: own_h,
            pad,
            scale: scales[i],
            x0,
            x1,
            y0,
        };
        let mut labels = Labels::default();
        let _ = writeln!(
            s,
            r#"<clipPath id="c{i}"><rect x="{}" y="{}" width="{}" height="{}"/></clipPath><g clip-path="url(#c{i})">"#,
            i as f64 * w + pad - 2.0,
            pad - 2.0,
            w - 2.0 * pad + 4.0,
            own_h - 2.0 * pad + 4.0
        );
        draw_sections(&mut s, p, &f, &mut labels);
        draw_dims(&mut s, p, &f, &mut labels);
        s.push_str("</g>\n");
        draw_labels(&mut s, p, &f);
    }
    for (k, l) in lines.iter().enumerate() {
        let _ = writeln!(
            s,
            r#"<text x="10" y="{}">{l}</text>"#,
            h + legend + 24.0 + 16.0 * k as f64
        );
    }
    s.push_str("</svg>\n");
    s
}

/// A panel's levels, section layers and polylines.
fn draw_sections(s: &mut String, p: &Panel, f: &PanelFrame, labels: &mut Labels) {
    let (x0, x1) = (f.x0, f.x1);
    for (name, y) in &p.levels {
        let _ = writeln!(
            s,
            r##"<line x1="{}" y1="{:.2}" x2="{}" y2="{:.2}" stroke="#17becf" stroke-dasharray="6 3"/>{}"##,
            f.tx(x0),
            f.ty(*y),
            f.tx(x1),
            f.ty(*y),
            labels.place(
                f.tx(x0),
                f.ty(*y) - 3.0,
                Labels::SIZE,
                name,
                r##"fill="#17becf""##
            )
        );
    }
    for (name, col, segs) in &p.layers {
        let mut d = String::new();
        for sg in segs {
            let _ = write!(
                d,
                "M{:.2} {:.2}L{:.2} {:.2}",
                f.tx(sg[0].0),
                f.ty(sg[0].1),
                f.tx(sg[1].0),
                f.ty(sg[1].1)
            );
        }
        let _ = writeln!(
            s,
            r#"<path d="{d}" stroke="{col}" stroke-width="1.2" fill="none"><title>{name}</title></path>"#
        );
    }
    for (_, col, line) in &p.polylines {
        let d: String = line
            .iter()
            .enumerate()
            .map(|(j, &(x, y))| {
                format!(
                    "{}{:.2} {:.2}",
                    if j == 0 { "M" } else { "L" },
                    f.tx(x),
                    f.ty(y)
                )
            })
            .collect();
        let _ = writeln!(
            s,
            r#"<path d="{d}" stroke="{col}" stroke-width="1.6" fill="none"/>"#
        );
    }
}

/// A panel's dimension lines: ticks across the line at both ends, the label beside its
/// middle.
fn draw_dims(s: &mut String, p: &Panel, f: &PanelFrame, labels: &mut Labels) {
    for d in &p.dims {
        let (x0, y0, x1, y1) = (f.tx(d.a.0), f.ty(d.a.1), f.tx(d.b.0), f.ty(d.b.1));
        let len = d.length_mm();
        let (dx, dy) = (x1 - x0, y1 - y0);
        let l = dx.hypot(dy).max(1e-9);
        let (nx, ny) = (-dy / l * 4.0, dx / l * 4.0);
        let _ = writeln!(
            s,
            r##"<g class="dim" data-name="{name}" data-mm="{len:.4}" data-x0="{x0:.3}" data-y0="{y0:.3}" data-x1="{x1:.3}" data-y1="{y1:.3}"><path d="M{x0:.2} {y0:.2}L{x1:.2} {y1:.2}M{:.2} {:.2}L{:.2} {:.2}M{:.2} {:.2}L{:.2} {:.2}" stroke="#000" stroke-width="0.8" fill="none"/>{}</g>"##,
            x0 - nx,
            y0 - ny,
            x0 + nx,
            y0 + ny,
            x1 - nx,
            y1 - ny,
            x1 + nx,
            y1 + ny,
            labels.place(
                x1.max(x0) + 6.0,
                0.5 * (y0 + y1) + 3.0,
                10.0,
                &format!("{} {}", d.name, mm(len)),
                ""
            ),
            name = d.name,
        );
    }
}

/// A panel's scale bar (under its lower-left corner), title and legend.
fn draw_labels(s: &mut String, p: &Panel, f: &PanelFrame) {
    let (i, w, h, pad, scale) = (f.i, f.w, f.h, f.pad, f.scale);
    let bar = scale_bar_mm(f.x1 - f.x0);
    let (bx, by) = (i as f64 * w + pad, h - pad + 16.0);
    let _ = writeln!(
        s,
        r##"<g class="scale-bar" data-mm="{bar}" data-px="{:.4}"><path d="M{bx:.2} {by:.2}h{:.4}M{bx:.2} {:.2}v8M{:.2} {:.2}v8" stroke="#000" stroke-width="2" fill="none"/><text x="{:.2}" y="{:.2}">{bar} mm</text></g>"##,
        bar * scale,
        bar * scale,
        by - 4.0,
        bx + bar * scale,
        by - 4.0,
        bx + bar * scale + 6.0,
        by + 4.0
    );
    let _ = writeln!(
        s,
        r#"<text x="{}" y="20" font-weight="bold">{}</text>"#,
        i as f64 * w + pad,
        p.title
    );
    for (k, (name, col, _)) in p.layers.iter().enumerate() {
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" fill="{col}">{name}</text>"#,
            i as f64 * w + pad,
            h + 10.0 + 14.0 * k as f64
        );
    }
    for (k, (name, col, _)) in p.polylines.iter().enumerate() {
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" fill="{col}">{name}</text>"#,
            i as f64 * w + w / 2.0,
            h + 10.0 + 14.0 * k as f64
        );
    }
}

/// The assembled module cut by the plane of pillar 0's fiber and by the plane of the
/// reference fiber's exit, with every fiber in that plane drawn in red.
pub(crate) fn module_svg(
    profile: &DesignProfile,
    parts: &[BuiltPart],
    fibers: &[FiberTrace],
) -> Option<String> {
    let design = profile.design;
    let m = profile.module.as_ref()?;
    let (p, pp) = (&m.profile, &m.parts);
    // Parts of one kind share a solid: one section each.
    let shown: Vec<&BuiltPart> = first_of_each_kind(parts, |b| b.kind)
        .into_iter()
        .filter(|b| b.kind.part().in_module())
        .collect();
    let planes = [
        ("pillar 0 (strain fiber)", *p.pillar_angles_rad.first()?),
        ("reference fiber exit", pp.reference_exit_angle_rad),
    ];
    let panels = planes
        .iter()
        .map(|&(title, theta)| {
            let layers = shown
                .iter()
                .map(|b| {
                    (
                        b.name.clone(),
                        colour(b.kind),
                        axial_section(&b.mesh, theta),
                    )
                })
                .collect();
            let (c, s) = (theta.cos(), theta.sin());
            let polylines = fibers
                .iter()
                .filter(|f| (f.exit_angle_deg.to_radians() - theta).sin().abs() < 1e-6)
                .map(|f| {
                    let line = f
                        .points
                        .iter()
                        .map(|q| (q[0] * c + q[1] * s, q[2]))
                        .collect();
                    (format!("fiber {}", f.grating), "#d62728", line)
                })
                .collect();
            let mut levels = vec![
                ("plate".into(), 0.0),
                (
                    format!("bend start {}", mm(pp.bend_start_z_mm)),
                    pp.bend_start_z_mm,
                ),
            ];
            let in_plane = |g: &crate::profile::GratingPlacement| {
                g.radius_mm == 0.0
                    || (g.angle_rad - theta).sin().abs() < 1e-6 && (g.angle_rad - theta).cos() > 0.0
            };
            let mut dims = module_dims(m, shown.iter().any(|b| b.kind == PartKind::Insert));
            for g in crate::profile::module_gratings(m.spec, p)
                .iter()
                .filter(|g| in_plane(g))
            {
                let s = g.radius_mm + 0.6 * pp.channel_width_mm;
                dims.push(Dim::new(&g.name, (s, g.z_start_mm), (s, g.z_end_mm)));
                levels.push((
                    format!("{} from {}", g.name, mm(g.z_start_mm)),
                    g.z_start_mm,
                ));
            }
            Panel {
                title: format!("{} cut at {:.1}°: {title}", design.name, theta.to_degrees()),
                layers,
                polylines,
                levels,
                view: None,
                dims,
            }
        })
        .collect::<Vec<_>>();
    let mut caption = format!(
        "Cut-away of the assembled module; fibers bend at {} mm radius and leave at {} mm above the plate.",
        mm(pp.bend_radius_mm),
        mm(pp.exit_height_mm)
    );
    if !shown.iter().any(|b| b.kind == PartKind::Insert) {
        for f in fibers {
            let free = unsupported_length_mm(m, f);
            if free > 0.0 {
                let _ = write!(
                    caption,
                    "; UNSUPPORTED: fiber {} hangs free for {} mm in the core's cavity (no insert holds it)",
                    f.grating,
                    mm(free)
                );
            }
        }
    }
    Some(draw(&panels, &caption))
}

/// The module's walls and clearances as dimension lines in a section plane (s, z):
/// on the +s side, below the pillars for the core and above them for the cap.
fn module_dims(m: &ModuleDims, with_insert: bool) -> Vec<Dim> {
    let (p, pp) = (&m.profile, &m.parts);
    let z_low = 0.5 * (pp.cap_slot_top_mm.max(pp.core_slot_top_mm) + pp.pillar_bottom_mm);
    let z_up = 0.5 * (pp.pillar_bottom_mm + p.pillar_top_mm);
    let mut dims = vec![
        Dim::new(
            "cap wall",
            (p.cap_inner_radius_mm, z_up),
            (p.cap_outer_radius_mm, z_up),
        ),
        Dim::new(
            "cap/core clearance",
            (p.pillar_outer_radius_mm, z_up + 2.0),
            (p.cap_inner_radius_mm, z_up + 2.0),
        ),
        Dim::new(
            "core wall",
            (p.core_inner_radius_mm, z_low),
            (p.core_outer_radius_mm, z_low),
        ),
    ];
    // Nothing is drawn that is not built: the clearance to an insert only with one.
    if with_insert {
        dims.push(Dim::new(
            "core/insert clearance",
            (p.insert_radius_mm, z_low - 2.0),
            (p.core_inner_radius_mm, z_low - 2.0),
        ));
    }
    dims
}

/// Length of the fibers' paths through the core's empty cavity (inside its inner
/// wall and under its inner dome, above the plate), mm: where nothing holds a fiber
/// when the module has no insert.
pub(crate) fn unsupported_length_mm(m: &ModuleDims, fiber: &FiberTrace) -> f64 {
    let p = &m.profile;
    let free = |q: [f64; 3]| {
        let r = q[0].hypot(q[1]);
        r < p.core_inner_radius_mm
            && (q[2] <= p.core_inner_junction_z_mm
                || r.hypot(q[2] - p.dome_center_z_mm) < p.core_dome_inner_sphere_radius_mm)
            && q[2] > 0.0
    };
    // The trace starts at the grating; a fiber that starts on the axis came down it
    // from the top hole, through the cavity up to its inner dome.
    let mut total = match fiber.points.first() {
        Some(q) if q[0].hypot(q[1]) < 1e-9 => {
            (p.dome_center_z_mm + p.core_dome_inner_sphere_radius_mm - q[2]).max(0.0)
        }
        _ => 0.0,
    };
    // Each segment of the path cut into 0.01 mm steps, a step counted when its middle
    // is free (a segment may run from a wall's passage into the cavity).
    for w in fiber.points.windows(2) {
        let d = [w[1][0] - w[0][0], w[1][1] - w[0][1], w[1][2] - w[0][2]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let n = (len / 0.01).ceil().max(1.0) as usize;
        let step = len / n as f64;
        total += step
            * (0..n)
                .filter(|&k| {
                    let t = (k as f64 + 0.5) / n as f64;
                    free([w[0][0] + t * d[0], w[0][1] + t * d[1], w[0][2] + t * d[2]])
                })
                .count() as f64;
    }
    total
}

/// The mold (and its plugs in place) cut through the first fiber's slits, with the
/// fiber and the silicone level.
pub(crate) fn mold_svg(profile: &DesignProfile, parts: &[BuiltPart]) -> Option<String> {
    let design = profile.design;
    let a = profile.array.as_ref()?;
    let mold = parts.iter().find(|b| b.kind == PartKind::Mold)?;
    let l = &a.layout;
    let x = *l.slit_x_mm.first()?;
    let mut layers = vec![(
        "mold".to_string(),
        colour(PartKind::Mold),
        plane_section(&mold.mesh, [1.0, 0.0, 0.0], x, |q| (q[1], q[2])),
    )];
    if let (Some(plug), Some(pocket)) = (
        parts.iter().find(|b| b.kind == PartKind::MoldPlug),
        a.pocket,
    ) {
        // The plug in place: its corner at the pocket's −x, inner-wall end, bottom.
        let (iy, hy) = (a.spec.mold.internal_y_mm / 2.0, l.mold_outer_mm.1 / 2.0);
        let fit = fbgforge_geometry::mold_plug::PLUG_FIT_MM;
        let x0 = x - pocket.width_mm / 2.0 + fit;
        for y0 in [iy, -hy] {
            let segs = plane_section(&plug.mesh, [1.0, 0.0, 0.0], x - x0, |q| {
                (q[1] + y0, q[2] + pocket.bottom_z_mm)
            });
            layers.push(("plug in place".into(), colour(PartKind::MoldPlug), segs));
        }
    }
    let hy = l.mold_outer_mm.1 / 2.0;
    // The fiber's axis as printed (the seat plus the fiber's radius), as the manifest
    // states it, not the mid-sheet height it is placed for.
    let axis = l.slit_bottom_z_mm + design.fiber_routing.coated_diameter_mm / 2.0;
    let fiber = vec![(-hy - 3.0, axis), (hy + 3.0, axis)];
    let iy = a.spec.mold.internal_y_mm / 2.0;
    let top = l.mold_outer_mm.2;
    let wall_z = 0.5 * (l.cavity_floor_z_mm + top);
    let whole = Panel {
        title: format!("{} mold cut at x = {x} mm (fiber 0)", design.name),
        layers: layers.clone(),
        polylines: vec![("fiber axis".into(), "#d62728", fiber.clone())],
        levels: vec![("silicone level".into(), l.silicone_level_z_mm)],
        view: None,
        dims: vec![
            Dim::new("wall", (-hy, wall_z), (-iy, wall_z)),
            Dim::new("base", (0.0, 0.0), (0.0, l.cavity_floor_z_mm)),
            Dim::new(
                "sheet",
                (-iy / 2.0, l.cavity_floor_z_mm),
                (-iy / 2.0, l.silicone_level_z_mm),
            ),
        ],
    };
    let detail = Panel {
        title: "detail: the +y wall's slit".into(),
        layers,
        polylines: vec![("fiber axis".into(), "#d62728", fiber)],
        levels: vec![
            ("silicone level".into(), l.silicone_level_z_mm),
            (format!("fiber axis {}", mm(axis)), axis),
        ],
        view: Some((iy - 2.0, hy + 1.0, -0.5, top + 1.0)),
        dims: vec![
            Dim::new(
                "fiber seat",
                (iy - 1.0, 0.0),
                (iy - 1.0, l.slit_bottom_z_mm),
            ),
            Dim::new(
                "wall",
                (iy, l.cavity_floor_z_mm - 0.3),
                (hy, l.cavity_floor_z_mm - 0.3),
            ),
        ],
    };
    Some(draw(
        &[whole, detail],
        &format!(
            "Fill silicone to {} mm above the mold's underside; the fiber axis lies at {} mm, the slit bottoms at {} mm.",
            mm(l.silicone_level_z_mm),
            mm(axis),
            mm(l.slit_bottom_z_mm)
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::mm;

    #[test]
    fn lengths_print_at_the_manifest_precision() {
        assert_eq!(mm(0.075), "0.075");
        assert_eq!(mm(4.525), "4.525");
        assert_eq!(mm(2.0), "2");
        assert_eq!(mm(0.1 + 0.2), "0.3");
        assert_eq!(mm(1.23456), "1.2346");
        assert_eq!(mm(-0.00001), "0");
    }
}
