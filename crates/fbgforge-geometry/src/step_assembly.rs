//! The assembled module as a STEP (AP214) assembly, as CAD programs read one: a root
//! PRODUCT (the module) and, under it, one named PRODUCT per part, each placed by a
//! NEXT_ASSEMBLY_USAGE_OCCURRENCE with its CONTEXT_DEPENDENT_SHAPE_REPRESENTATION and
//! ITEM_DEFINED_TRANSFORMATION, and coloured by a STYLED_ITEM whose COLOUR_RGB is the
//! display colour of the part's material.
//!
//! The entity layout is OpenCASCADE's own for an XDE assembly (what CadQuery writes).
//! Each part's B-rep comes from truck-stepio (one solid per call); its entities are
//! renumbered into the file, its APPLICATION_CONTEXT is the root's, and its PRODUCT is
//! named. The parts are built in the module's frame, so every placement is the
//! identity, written out in full so that a CAD program can move a part.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use truck_modeling::Solid;
use truck_stepio::out;

/// One part of the assembly: its name (the manifest's), its solid, in place, and its
/// colour (sRGB, 0–1) with the name of the material it comes from.
pub struct AssemblyPart<'a> {
    /// The part's name, as the manifest lists it.
    pub name: &'a str,
    /// The part's exact solid, in the module's frame.
    pub solid: &'a Solid,
    /// Display colour, each channel 0–1.
    pub colour_rgb: [f64; 3],
    /// The material the colour belongs to.
    pub material: &'a str,
}

/// `#RRGGBB` as sRGB channels 0–1 (grey when the text is not a colour).
pub fn hex_colour(hex: &str) -> [f64; 3] {
    let h = hex.trim_start_matches('#');
    let ch = |i: usize| {
        h.get(i..i + 2)
            .and_then(|s| u8::from_str_radix(s, 16).ok())
            .map_or(0.75, |v| f64::from(v) / 255.0)
    };
    [ch(0), ch(2), ch(4)]
}

/// One entity of a STEP data section: its number and the text after `#N = `.
struct Entity {
    id: usize,
    body: String,
}

/// The entities of truck's data section (between `DATA;` and `ENDSEC;`), an entity
/// being every line up to the one that ends in `;`.
fn entities(text: &str) -> Vec<Entity> {
    let data = text.split_once("DATA;").map_or("", |(_, d)| d);
    let data = data.split_once("ENDSEC;").map_or(data, |(d, _)| d);
    let mut out = Vec::new();
    let mut cur = String::new();
    for line in data.lines() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(line);
        if cur.ends_with(';') {
            if let Some((id, body)) = cur
                .strip_prefix('#')
                .and_then(|r| r.split_once('='))
                .and_then(|(n, b)| Some((n.trim().parse().ok()?, b.trim())))
            {
                out.push(Entity {
                    id,
                    body: body.trim_end_matches(';').to_string(),
                });
            }
            cur.clear();
        }
    }
    out
}

/// `body` with every reference `#n` replaced by `map(n)`.
fn renumber(body: &str, map: impl Fn(usize) -> usize) -> String {
    let mut out = String::with_capacity(body.len());
    let mut chars = body.char_indices().peekable();
    let mut in_string = false;
    while let Some((_, c)) = chars.next() {
        if c == '\'' {
            in_string = !in_string;
        }
        if c == '#' && !in_string {
            let mut n = String::new();
            while let Some(&(_, d)) = chars.peek() {
                if !d.is_ascii_digit() {
                    break;
                }
                n.push(d);
                chars.next();
            }
            match n.parse() {
                Ok(v) => {
                    let _ = write!(out, "#{}", map(v));
                }
                Err(_) => out.push('#'),
            }
        } else {
            out.push(c);
        }
    }
    out
}

/// The entity type of a body (`PRODUCT`, `MANIFOLD_SOLID_BREP`…; empty for a complex
/// entity).
fn kind(body: &str) -> &str {
    body.split('(').next().unwrap_or("").trim()
}

/// Writes numbered entities.
struct Writer {
    next: usize,
    text: String,
}

impl Writer {
    /// Append `body` as the next entity; returns its number.
    fn add(&mut self, body: &str) -> usize {
        let id = self.next;
        self.next += 1;
        let _ = writeln!(self.text, "#{id} = {body};");
        id
    }

    /// An identity AXIS2_PLACEMENT_3D (origin, z up, x along x).
    fn identity_axis(&mut self) -> usize {
        let o = self.add("CARTESIAN_POINT('', (0.0, 0.0, 0.0))");
        let z = self.add("DIRECTION('', (0.0, 0.0, 1.0))");
        let x = self.add("DIRECTION('', (1.0, 0.0, 0.0))");
        self.add(&format!("AXIS2_PLACEMENT_3D('', #{o}, #{z}, #{x})"))
    }

    /// A 3D representation context in millimetres, radians and steradians.
    fn context(&mut self) -> usize {
        let mm = self.add("( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) )");
        let rad = self.add("( NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.) )");
        let sr = self.add("( NAMED_UNIT(*) SI_UNIT($,.STERADIAN.) SOLID_ANGLE_UNIT() )");
        let unc = self.add(&format!(
            "UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.0E-6), #{mm}, 'distance_accuracy_value', 'confusion accuracy')"
        ));
        self.add(&format!(
            "( GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#{unc})) GLOBAL_UNIT_ASSIGNED_CONTEXT((#{mm}, #{rad}, #{sr})) REPRESENTATION_CONTEXT('Context #1', '3D Context with UNIT and UNCERTAINTY') )"
        ))
    }
}

/// What the root product left for its parts.
struct Root {
    app_context: usize,
    definition: usize,
    representation: usize,
}

/// Where a part's copied entities landed.
struct PartIds {
    product: usize,
    definition: usize,
    representation: usize,
    context: usize,
    solid: usize,
}

/// Copy truck's entities of one solid into `w`: the application context becomes the
/// root's, the protocol definition is the root's, the PRODUCT is named `name`, and the
/// B-rep representation also holds `origin` (the axis a placement maps from).
fn copy_part(w: &mut Writer, solid: &Solid, name: &str, root: &Root, origin: usize) -> PartIds {
    let compressed = [solid.compress()];
    let text = out::CompleteStepDisplay::new(
        compressed.iter().collect::<out::StepModels<_, _, _>>(),
        out::StepHeaderDescriptor::default(),
    )
    .to_string();
    let ents = entities(&text);
    let dropped: Vec<usize> = ents
        .iter()
        .filter(|e| {
            matches!(
                kind(&e.body),
                "APPLICATION_CONTEXT" | "APPLICATION_PROTOCOL_DEFINITION"
            )
        })
        .map(|e| e.id)
        .collect();
    let app = ents
        .iter()
        .find(|e| kind(&e.body) == "APPLICATION_CONTEXT")
        .map(|e| e.id);
    let mut map = BTreeMap::new();
    for e in ents.iter().filter(|e| !dropped.contains(&e.id)) {
        map.insert(e.id, w.next + map.len());
    }
    let lookup = |n: usize| {
        if Some(n) == app {
            root.app_context
        } else {
            map.get(&n).copied().unwrap_or(n)
        }
    };
    let (mut ids, n) = (
        PartIds {
            product: 0,
            definition: 0,
            representation: 0,
            context: 0,
            solid: 0,
        },
        super::step_text::step_string(name),
    );
    for e in ents.iter().filter(|e| !dropped.contains(&e.id)) {
        let mut body = renumber(&e.body, lookup);
        let id = map[&e.id];
        match kind(&body) {
            "PRODUCT" => {
                ids.product = id;
                body = body.replacen("PRODUCT('','',", &format!("PRODUCT('{n}','{n}',"), 1);
            }
            "PRODUCT_DEFINITION" => ids.definition = id,
            "MANIFOLD_SOLID_BREP" => ids.solid = id,
            "ADVANCED_BREP_SHAPE_REPRESENTATION" => {
                ids.representation = id;
                body = body.replacen("('', (", &format!("('{n}', (#{origin}, "), 1);
                ids.context = body
                    .rsplit('#')
                    .next()
                    .and_then(|t| t.trim_end_matches(')').trim().parse().ok())
                    .unwrap_or(0);
            }
            _ => {}
        }
        let got = w.add(&body);
        debug_assert_eq!(got, id);
    }
    ids
}

/// The STEP text of the assembled module: the root `name` over `parts`.
///
/// ```
/// use fbgforge_geometry::step_assembly::{assembly_step_text, hex_colour, AssemblyPart};
/// use truck_modeling::{builder, Point3, Vector3};
/// let v = builder::vertex(Point3::new(0.0, 0.0, 0.0));
/// let e = builder::tsweep(&v, Vector3::unit_x());
/// let f = builder::tsweep(&e, Vector3::unit_y());
/// let cube = builder::tsweep(&f, Vector3::unit_z());
/// let parts = [AssemblyPart {
///     name: "cap",
///     solid: &cube,
///     colour_rgb: hex_colour("#FF0000"),
///     material: "red",
/// }];
/// let text = assembly_step_text(&parts, "module-assembled", "demo");
/// assert_eq!(text.matches("NEXT_ASSEMBLY_USAGE_OCCURRENCE").count(), 1);
/// assert!(text.contains("PRODUCT('cap','cap'"));
/// assert!(text.contains("COLOUR_RGB('red', 1.000000, 0.000000, 0.000000)"));
/// ```
pub fn assembly_step_text(parts: &[AssemblyPart], name: &str, design_name: &str) -> String {
    let mut w = Writer {
        next: 1,
        text: String::new(),
    };
    let n = super::step_text::step_string(name);
    let app = w.add("APPLICATION_CONTEXT('core data for automotive mechanical design processes')");
    w.add(&format!(
        "APPLICATION_PROTOCOL_DEFINITION('international standard', 'automotive_design', 2000, #{app})"
    ));
    let pc = w.add(&format!("PRODUCT_CONTEXT('', #{app}, 'mechanical')"));
    let product = w.add(&format!("PRODUCT('{n}', '{n}', '', (#{pc}))"));
    w.add(&format!(
        "PRODUCT_RELATED_PRODUCT_CATEGORY('part', $, (#{product}))"
    ));
    let pdf = w.add(&format!("PRODUCT_DEFINITION_FORMATION('', '', #{product})"));
    let pdc = w.add(&format!(
        "PRODUCT_DEFINITION_CONTEXT('part definition', #{app}, 'design')"
    ));
    let pd = w.add(&format!("PRODUCT_DEFINITION('design', '', #{pdf}, #{pdc})"));
    let pds = w.add(&format!("PRODUCT_DEFINITION_SHAPE('', '', #{pd})"));
    let ctx = w.context();
    let origin = w.identity_axis();
    let placements: Vec<usize> = parts.iter().map(|_| w.identity_axis()).collect();
    let items: Vec<String> = std::iter::once(origin)
        .chain(placements.iter().copied())
        .map(|i| format!("#{i}"))
        .collect();
    let sr = w.add(&format!(
        "SHAPE_REPRESENTATION('{n}', ({}), #{ctx})",
        items.join(", ")
    ));
    w.add(&format!("SHAPE_DEFINITION_REPRESENTATION(#{pds}, #{sr})"));
    let root = Root {
        app_context: app,
        definition: pd,
        representation: sr,
    };
    for (k, (part, &placement)) in parts.iter().zip(&placements).enumerate() {
        place_part(&mut w, part, &root, placement, k + 1);
    }
    format!(
        "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('fbgforge assembly {n} of design {design}'), '2;1');\nFILE_NAME('{design}-{n}.step', '{stamp}', ('fbgforge'), (''), 'truck-stepio 0.3', 'fbgforge {version}', '');\nFILE_SCHEMA(('{schema}'));\nENDSEC;\nDATA;\n{data}ENDSEC;\nEND-ISO-10303-21;\n",
        design = super::step_text::step_string(design_name),
        stamp = super::step_text::iso8601_now(),
        version = env!("CARGO_PKG_VERSION"),
        schema = super::step_text::STEP_SCHEMA,
        data = w.text,
    )
}

/// One part under the root: its entities, the usage occurrence that places it at
/// `placement` of the root's representation, and its colour.
fn place_part(w: &mut Writer, part: &AssemblyPart, root: &Root, placement: usize, k: usize) {
    let origin = w.identity_axis();
    let ids = copy_part(w, part.solid, part.name, root, origin);
    let n = super::step_text::step_string(part.name);
    w.add(&format!(
        "PRODUCT_RELATED_PRODUCT_CATEGORY('part', $, (#{}))",
        ids.product
    ));
    let idt = w.add(&format!(
        "ITEM_DEFINED_TRANSFORMATION('', '', #{origin}, #{placement})"
    ));
    let rel = w.add(&format!(
        "( REPRESENTATION_RELATIONSHIP('', '', #{}, #{}) REPRESENTATION_RELATIONSHIP_WITH_TRANSFORMATION(#{idt}) SHAPE_REPRESENTATION_RELATIONSHIP() )",
        ids.representation, root.representation
    ));
    let nauo = w.add(&format!(
        "NEXT_ASSEMBLY_USAGE_OCCURRENCE('{k}', '{n}', '', #{}, #{}, $)",
        root.definition, ids.definition
    ));
    let pds = w.add(&format!(
        "PRODUCT_DEFINITION_SHAPE('Placement', 'Placement of an item', #{nauo})"
    ));
    w.add(&format!(
        "CONTEXT_DEPENDENT_SHAPE_REPRESENTATION(#{rel}, #{pds})"
    ));
    let [r, g, b] = part.colour_rgb;
    let colour = w.add(&format!(
        "COLOUR_RGB('{}', {r:.6}, {g:.6}, {b:.6})",
        super::step_text::step_string(part.material)
    ));
    let fasc = w.add(&format!("FILL_AREA_STYLE_COLOUR('', #{colour})"));
    let fas = w.add(&format!("FILL_AREA_STYLE('', (#{fasc}))"));
    let fill = w.add(&format!("SURFACE_STYLE_FILL_AREA(#{fas})"));
    let side = w.add(&format!("SURFACE_SIDE_STYLE('', (#{fill}))"));
    let usage = w.add(&format!("SURFACE_STYLE_USAGE(.BOTH., #{side})"));
    let psa = w.add(&format!("PRESENTATION_STYLE_ASSIGNMENT((#{usage}))"));
    let styled = w.add(&format!("STYLED_ITEM('color', (#{psa}), #{})", ids.solid));
    w.add(&format!(
        "MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION('', (#{styled}), #{})",
        ids.context
    ));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_are_renumbered_outside_strings_only() {
        assert_eq!(
            renumber("FOO('#1 a', #2, (#10, #3))", |n| n + 100),
            "FOO('#1 a', #102, (#110, #103))"
        );
    }

    #[test]
    fn hex_colours_read_as_channels() {
        assert_eq!(hex_colour("#FF0080"), [1.0, 0.0, 128.0 / 255.0]);
        assert_eq!(hex_colour("blue"), [0.75, 0.75, 0.75]);
    }
}
