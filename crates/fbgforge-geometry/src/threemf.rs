//! 3MF packages (3D Manufacturing Format, core specification 1.x): a ZIP holding the
//! content types, the package relationship and one model file, in millimetres, with
//! one `<object>` per printed piece and the pieces' materials as `<basematerials>`
//! (name and display colour) referenced by `pid`/`pindex`. PrusaSlicer and GrabCAD
//! Print read it, so a multi-material print takes its materials from the file rather
//! than from `manifest.json` by hand. PrusaSlicer keeps the object names but not the
//! `<basematerials>`, so each package also carries PrusaSlicer's per-object
//! configuration ([`SLICER_CONFIG_PATH`]): every object on the extruder of its material
//! (material k of the list on extruder k + 1).
//!
//! The XML is written with `quick-xml` and packed with `zip` (deflate); [`read`] reads
//! a package back (the tests use it to check what was written).

use super::mesh::TriMesh;
use anyhow::{bail, Context, Result};
use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;
use std::io::{Cursor, Read, Write};

/// The 3MF core namespace.
pub(crate) const CORE_NS: &str = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02";
/// Path of the model part in the package.
pub(crate) const MODEL_PATH: &str = "3D/3dmodel.model";

/// A material of the package: its name and display colour (`#RRGGBB`).
#[derive(Debug, Clone, PartialEq)]
pub struct BaseMaterial {
    /// Name shown by the printer's software.
    pub name: String,
    /// Display colour, `#RRGGBB`.
    pub colour: String,
}

/// One object of the package: a mesh, its material and where it stands on the plate.
#[derive(Debug, Clone)]
pub struct Object<'a> {
    /// Object name.
    pub name: String,
    /// Its mesh (mm).
    pub mesh: &'a TriMesh,
    /// Index of its material in the package's material list.
    pub material: usize,
    /// Translation applied by its build item, mm.
    pub offset_mm: [f64; 3],
}

fn xml_err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("writing 3MF XML: {e}")
}

/// The model file's XML.
pub(crate) fn model_xml(
    title: &str,
    materials: &[BaseMaterial],
    objects: &[Object],
) -> Result<String> {
    let mut w = Writer::new(Vec::new());
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))
        .map_err(xml_err)?;
    let model = BytesStart::new("model").with_attributes([
        ("unit", "millimeter"),
        ("xml:lang", "en-US"),
        ("xmlns", CORE_NS),
    ]);
    w.write_event(Event::Start(model)).map_err(xml_err)?;
    let meta = BytesStart::new("metadata").with_attributes([("name", "Title")]);
    w.write_event(Event::Start(meta)).map_err(xml_err)?;
    w.write_event(Event::Text(quick_xml::events::BytesText::new(title)))
        .map_err(xml_err)?;
    w.write_event(Event::End(BytesEnd::new("metadata")))
        .map_err(xml_err)?;
    w.write_event(Event::Start(BytesStart::new("resources")))
        .map_err(xml_err)?;
    // Resource ids: 1 for the materials, 2.. for the objects.
    w.write_event(Event::Start(
        BytesStart::new("basematerials").with_attributes([("id", "1")]),
    ))
    .map_err(xml_err)?;
    for m in materials {
        w.write_event(Event::Empty(BytesStart::new("base").with_attributes([
            ("name", m.name.as_str()),
            ("displaycolor", m.colour.as_str()),
        ])))
        .map_err(xml_err)?;
    }
    w.write_event(Event::End(BytesEnd::new("basematerials")))
        .map_err(xml_err)?;
    for (k, o) in objects.iter().enumerate() {
        let id = (k + 2).to_string();
        let pindex = o.material.to_string();
        w.write_event(Event::Start(BytesStart::new("object").with_attributes([
            ("id", id.as_str()),
            ("type", "model"),
            ("name", o.name.as_str()),
            ("pid", "1"),
            ("pindex", pindex.as_str()),
        ])))
        .map_err(xml_err)?;
        w.write_event(Event::Start(BytesStart::new("mesh")))
            .map_err(xml_err)?;
        w.write_event(Event::Start(BytesStart::new("vertices")))
            .map_err(xml_err)?;
        for p in &o.mesh.positions {
            let [x, y, z] = p.map(|c| format!("{c:.6}"));
            w.write_event(Event::Empty(BytesStart::new("vertex").with_attributes([
                ("x", x.as_str()),
                ("y", y.as_str()),
                ("z", z.as_str()),
            ])))
            .map_err(xml_err)?;
        }
        w.write_event(Event::End(BytesEnd::new("vertices")))
            .map_err(xml_err)?;
        w.write_event(Event::Start(BytesStart::new("triangles")))
            .map_err(xml_err)?;
        for t in &o.mesh.triangles {
            let [a, b, c] = t.map(|i| i.to_string());
            w.write_event(Event::Empty(BytesStart::new("triangle").with_attributes([
                ("v1", a.as_str()),
                ("v2", b.as_str()),
                ("v3", c.as_str()),
            ])))
            .map_err(xml_err)?;
        }
        w.write_event(Event::End(BytesEnd::new("triangles")))
            .map_err(xml_err)?;
        w.write_event(Event::End(BytesEnd::new("mesh")))
            .map_err(xml_err)?;
        w.write_event(Event::End(BytesEnd::new("object")))
            .map_err(xml_err)?;
    }
    w.write_event(Event::End(BytesEnd::new("resources")))
        .map_err(xml_err)?;
    w.write_event(Event::Start(BytesStart::new("build")))
        .map_err(xml_err)?;
    for (k, o) in objects.iter().enumerate() {
        let id = (k + 2).to_string();
        let [x, y, z] = o.offset_mm.map(|c| format!("{c:.6}"));
        let transform = format!("1 0 0 0 1 0 0 0 1 {x} {y} {z}");
        w.write_event(Event::Empty(BytesStart::new("item").with_attributes([
            ("objectid", id.as_str()),
            ("transform", transform.as_str()),
        ])))
        .map_err(xml_err)?;
    }
    w.write_event(Event::End(BytesEnd::new("build")))
        .map_err(xml_err)?;
    w.write_event(Event::End(BytesEnd::new("model")))
        .map_err(xml_err)?;
    String::from_utf8(w.into_inner()).context("3MF model is UTF-8")
}

const CONTENT_TYPES: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types"><Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/><Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>
"#;

const RELS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>
"#;

/// Path of PrusaSlicer's per-object configuration in a package: PrusaSlicer (and the
/// slicers derived from it) read each object's `extruder` from it on import, so each
/// piece comes in on the extruder (filament) of its material.
pub(crate) const SLICER_CONFIG_PATH: &str = "Metadata/Slic3r_PE_model.config";

/// PrusaSlicer's per-object configuration for `objects` (resource ids 2.., as
/// [`model_xml`] numbers them): each object's name and its extruder, its material's
/// index + 1, over one volume of all its triangles.
pub(crate) fn slicer_config_xml(objects: &[Object]) -> Result<String> {
    let mut w = Writer::new_with_indent(Vec::new(), b' ', 1);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))
        .map_err(xml_err)?;
    w.write_event(Event::Start(BytesStart::new("config")))
        .map_err(xml_err)?;
    for (k, o) in objects.iter().enumerate() {
        let id = (k + 2).to_string();
        let extruder = (o.material + 1).to_string();
        let last = o.mesh.triangles.len().saturating_sub(1).to_string();
        w.write_event(Event::Start(
            BytesStart::new("object")
                .with_attributes([("id", id.as_str()), ("instances_count", "1")]),
        ))
        .map_err(xml_err)?;
        for (key, value) in [("name", o.name.as_str()), ("extruder", extruder.as_str())] {
            w.write_event(Event::Empty(BytesStart::new("metadata").with_attributes([
                ("type", "object"),
                ("key", key),
                ("value", value),
            ])))
            .map_err(xml_err)?;
        }
        w.write_event(Event::Start(
            BytesStart::new("volume")
                .with_attributes([("firstid", "0"), ("lastid", last.as_str())]),
        ))
        .map_err(xml_err)?;
        w.write_event(Event::Empty(BytesStart::new("metadata").with_attributes([
            ("type", "volume"),
            ("key", "name"),
            ("value", o.name.as_str()),
        ])))
        .map_err(xml_err)?;
        w.write_event(Event::End(BytesEnd::new("volume")))
            .map_err(xml_err)?;
        w.write_event(Event::End(BytesEnd::new("object")))
            .map_err(xml_err)?;
    }
    w.write_event(Event::End(BytesEnd::new("config")))
        .map_err(xml_err)?;
    String::from_utf8(w.into_inner()).context("slicer config is UTF-8")
}

/// The 3MF package (ZIP bytes) of a model file.
pub fn package(model: &str) -> Result<Vec<u8>> {
    package_with(model, &[])
}

/// The 3MF package of a model file and `extra` files (path in the package, text).
pub fn package_with(model: &str, extra: &[(&str, &str)]) -> Result<Vec<u8>> {
    let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
    // Deflate's fastest level: the default (6) took a fifth of a module's build
    // (perf, 34 mm module) for files a few per cent smaller.
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .compression_level(Some(1));
    for (path, text) in [
        ("[Content_Types].xml", CONTENT_TYPES),
        ("_rels/.rels", RELS),
        (MODEL_PATH, model),
    ]
    .into_iter()
    .chain(extra.iter().copied())
    {
        zip.start_file(path, opts)
            .with_context(|| format!("3MF: adding {path}"))?;
        zip.write_all(text.as_bytes())
            .with_context(|| format!("3MF: writing {path}"))?;
    }
    Ok(zip
        .finish()
        .context("3MF: closing the package")?
        .into_inner())
}

/// What a 3MF model file holds, as read back.
#[derive(Debug, Clone, Default)]
pub struct ReadModel {
    /// The model's `unit`.
    pub unit: String,
    /// The base materials, in order.
    pub materials: Vec<BaseMaterial>,
    /// The objects: name, material index (`pindex`), vertices, triangles.
    pub objects: Vec<ReadObject>,
    /// The build items' translations, by object (in object order), mm.
    pub offsets_mm: Vec<[f64; 3]>,
}

/// One object read back.
#[derive(Debug, Clone, Default)]
pub struct ReadObject {
    /// Name.
    pub name: String,
    /// `pindex`: its material.
    pub material: usize,
    /// Vertices, mm.
    pub vertices: Vec<[f64; 3]>,
    /// Triangles (vertex indices).
    pub triangles: Vec<[usize; 3]>,
}

impl ReadObject {
    /// Signed volume enclosed by the triangles, mm³.
    pub fn volume_mm3(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i]);
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                    + a[2] * (b[0] * c[1] - b[1] * c[0]))
                    / 6.0
            })
            .sum()
    }
}

/// Read a 3MF package's model back (its content types and relationship must be there).
pub fn read(bytes: &[u8]) -> Result<ReadModel> {
    let mut zip = zip::ZipArchive::new(Cursor::new(bytes)).context("3MF: not a ZIP package")?;
    for must in ["[Content_Types].xml", "_rels/.rels"] {
        zip.by_name(must)
            .with_context(|| format!("3MF: the package has no {must}"))?;
    }
    let mut xml = String::new();
    zip.by_name(MODEL_PATH)
        .with_context(|| format!("3MF: the package has no {MODEL_PATH}"))?
        .read_to_string(&mut xml)
        .context("3MF: reading the model")?;
    parse_model(&xml)
}

fn parse_model(xml: &str) -> Result<ReadModel> {
    let mut r = quick_xml::Reader::from_str(xml);
    let mut out = ReadModel::default();
    let mut ids: Vec<String> = Vec::new();
    loop {
        let ev = r.read_event().context("3MF: reading the model's XML")?;
        let e = match &ev {
            Event::Start(e) | Event::Empty(e) => e,
            Event::Eof => break,
            _ => continue,
        };
        let attr = |k: &str| -> Option<String> {
            e.attributes()
                .flatten()
                .find(|a| a.key.as_ref() == k.as_bytes())
                .and_then(|a| a.unescape_value().ok().map(|v| v.into_owned()))
        };
        let num = |k: &str| -> Result<f64> {
            attr(k)
                .with_context(|| format!("3MF: missing {k}"))?
                .parse()
                .with_context(|| format!("3MF: {k} is not a number"))
        };
        match e.name().as_ref() {
            b"model" => out.unit = attr("unit").unwrap_or_default(),
            b"base" => out.materials.push(BaseMaterial {
                name: attr("name").unwrap_or_default(),
                colour: attr("displaycolor").unwrap_or_default(),
            }),
            b"object" => {
                ids.push(attr("id").unwrap_or_default());
                out.objects.push(ReadObject {
                    name: attr("name").unwrap_or_default(),
                    material: attr("pindex").and_then(|v| v.parse().ok()).unwrap_or(0),
                    ..ReadObject::default()
                });
            }
            b"vertex" => {
                let o = out
                    .objects
                    .last_mut()
                    .context("3MF: vertex outside an object")?;
                o.vertices.push([num("x")?, num("y")?, num("z")?]);
            }
            b"triangle" => {
                let o = out
                    .objects
                    .last_mut()
                    .context("3MF: triangle outside an object")?;
                let v = |k: &str| -> Result<usize> {
                    attr(k)
                        .with_context(|| format!("3MF: missing {k}"))?
                        .parse()
                        .with_context(|| format!("3MF: {k} is not an index"))
                };
                o.triangles.push([v("v1")?, v("v2")?, v("v3")?]);
            }
            b"item" => {
                let t: Vec<f64> = attr("transform")
                    .unwrap_or_else(|| "1 0 0 0 1 0 0 0 1 0 0 0".into())
                    .split_whitespace()
                    .map(|x| x.parse().unwrap_or(f64::NAN))
                    .collect();
                if t.len() != 12 {
                    bail!("3MF: a transform of {} numbers", t.len());
                }
                out.offsets_mm.push([t[9], t[10], t[11]]);
            }
            _ => {}
        }
    }
    Ok(out)
}

/// Lay pieces of the given footprints (x, y sizes, mm) out on a plate in rows no wider
/// than `row_mm`, `gap_mm` apart: the lower-left corner of each, mm.
pub(crate) fn lay_out(footprints: &[(f64, f64)], row_mm: f64, gap_mm: f64) -> Vec<(f64, f64)> {
    let (mut x, mut y, mut row_h) = (0.0, 0.0, 0.0f64);
    footprints
        .iter()
        .map(|&(w, h)| {
            if x > 0.0 && x + w > row_mm {
                x = 0.0;
                y += row_h + gap_mm;
                row_h = 0.0;
            }
            let at = (x, y);
            x += w + gap_mm;
            row_h = row_h.max(h);
            at
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_package_reads_back_what_was_written() {
        // A unit tetrahedron: volume 1/6.
        let mesh = TriMesh {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        };
        let mats = vec![
            BaseMaterial {
                name: "PLA <white> & \"more\"".into(),
                colour: "#FFFFFF".into(),
            },
            BaseMaterial {
                name: "TPU".into(),
                colour: "#1F4FD8".into(),
            },
        ];
        let objs = vec![Object {
            name: "tet".into(),
            mesh: &mesh,
            material: 1,
            offset_mm: [10.0, 20.0, 0.0],
        }];
        let bytes = package(&model_xml("t", &mats, &objs).unwrap()).unwrap();
        let m = read(&bytes).unwrap();
        assert_eq!(m.unit, "millimeter");
        assert_eq!(m.materials, mats);
        assert_eq!(m.objects.len(), 1);
        assert_eq!(m.objects[0].material, 1);
        assert_eq!(m.objects[0].triangles, mesh.triangles.map_to_usize());
        assert!((m.objects[0].volume_mm3() - 1.0 / 6.0).abs() < 1e-12);
        assert_eq!(m.offsets_mm, vec![[10.0, 20.0, 0.0]]);
    }

    trait ToUsize {
        fn map_to_usize(&self) -> Vec<[usize; 3]>;
    }
    impl ToUsize for Vec<[u32; 3]> {
        fn map_to_usize(&self) -> Vec<[usize; 3]> {
            self.iter().map(|t| t.map(|i| i as usize)).collect()
        }
    }

    #[test]
    fn the_plate_layout_keeps_pieces_apart_and_rows_short() {
        let at = lay_out(&[(30.0, 30.0), (30.0, 10.0), (50.0, 20.0)], 70.0, 5.0);
        assert_eq!(at, vec![(0.0, 0.0), (35.0, 0.0), (0.0, 35.0)]);
    }
}
