//! Export of checked parts: binary STL, STEP, the 3MF plate and assembled module, the
//! dimensioned previews, and the manifest that lists them.
//!
//! Everything is rendered to memory first; [`write_all`] writes the files through
//! [`crate::output`] (temporary file + rename) only after every part has been rendered,
//! so a failure leaves no half-written or partial set of files.

use super::design_profile::DesignProfile;
use super::step_text::{iso8601_now, step_string, STEP_SCHEMA};
use super::{BuiltPart, PartKind};
use anyhow::{Context, Result};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use truck_modeling::Solid;
use truck_stepio::out;

/// Binary STL of a mesh (f32 coordinates, mm).
pub(crate) fn stl_bytes(part: &BuiltPart) -> Result<Vec<u8>> {
    let m = &part.mesh;
    let tris: Vec<stl_io::Triangle> = m
        .triangles
        .iter()
        .map(|t| stl_io::Triangle {
            normal: stl_io::Normal::new(m.normal(t).map(|x| x as f32)),
            vertices: t.map(|i| {
                let p = m.positions[i as usize];
                stl_io::Vertex::new([p[0] as f32, p[1] as f32, p[2] as f32])
            }),
        })
        .collect();
    let mut buf = Vec::with_capacity(84 + 50 * tris.len());
    stl_io::write_stl(&mut buf, tris.iter()).context("encoding STL")?;
    Ok(buf)
}

/// STEP (AP214 B-rep) text of a part's solid.
///
/// truck-stepio 0.3 writes a header other CAD reads badly: the schema `ISO-10303-042`
/// (a part number, not a schema name) and the author and organisation of FILE_NAME as
/// nested lists `(('')),`, which OpenCASCADE counts as two unresolved references. The
/// header is therefore written here; the data section is truck's.
pub(crate) fn step_text(part: &BuiltPart, design_name: &str) -> String {
    step_text_of(&[&part.solid], &part.name, design_name)
}

/// STEP text of solids in one file (a part's: one MANIFOLD_SOLID_BREP), its PRODUCT
/// and header named `name`. The assembled module is written by
/// [`crate::step_assembly`].
pub(crate) fn step_text_of(solids: &[&Solid], name: &str, design_name: &str) -> String {
    let compressed: Vec<_> = solids.iter().map(|s| s.compress()).collect();
    let text = out::CompleteStepDisplay::new(
        compressed.iter().collect::<out::StepModels<_, _, _>>(),
        out::StepHeaderDescriptor::default(),
    )
    .to_string();
    let data = text.find("DATA;").map_or(text.as_str(), |i| &text[i..]);
    // truck names no product; CAD shows the PRODUCT's name as the body's.
    let data = data.replacen(
        "PRODUCT('','','',",
        &format!("PRODUCT('{n}','{n}','',", n = step_string(name)),
        1,
    );
    format!(
        "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('fbgforge part {part} of design {design}'), '2;1');\nFILE_NAME('{design}-{part}.step', '{stamp}', ('fbgforge'), (''), 'truck-stepio 0.3', 'fbgforge {version}', '');\nFILE_SCHEMA(('{STEP_SCHEMA}'));\nENDSEC;\n{data}",
        part = step_string(name),
        design = step_string(design_name),
        stamp = iso8601_now(),
        version = env!("CARGO_PKG_VERSION"),
    )
}

/// One part in the manifest.
#[derive(Debug, Clone, Serialize)]
pub struct ManifestPart {
    /// Part name.
    pub name: String,
    /// Part kind.
    pub kind: PartKind,
    /// STL file name (relative to the manifest).
    pub stl: String,
    /// STEP file name (relative to the manifest).
    pub step: String,
    /// Triangles in the STL.
    pub triangles: usize,
    /// Chord tolerance of this part's mesh, mm (finer than requested when the volume
    /// bound needed it).
    pub mesh_tolerance_mm: f64,
    /// Volume enclosed by the mesh, mm³.
    pub mesh_volume_mm3: f64,
    /// Volume in closed form from the spec, mm³.
    pub exact_volume_mm3: f64,
    /// (mesh − exact) / exact, percent.
    pub volume_error_percent: f64,
    /// Bounding box minimum corner (x, y, z), mm.
    pub bbox_min_mm: [f64; 3],
    /// Bounding box maximum corner (x, y, z), mm.
    pub bbox_max_mm: [f64; 3],
    /// Materials this part is printed in (one file, one print per material).
    pub materials: Vec<String>,
}

/// Fit clearances of the module assembly.
#[derive(Debug, Clone, Serialize)]
pub struct Clearances {
    /// Radial gap between the cap's inner wall and the core's pillar faces, mm.
    pub cap_core_radial_mm: f64,
    /// Radial gap between the core's inner wall and an insert, mm.
    pub core_insert_radial_mm: f64,
    /// Gap between each side of a cap alignment pillar and its groove, mm.
    pub alignment_pillar_side_mm: f64,
    /// Gap between a cap alignment pillar's inner face and the groove bottom, mm.
    pub alignment_pillar_groove_bottom_mm: f64,
    /// Gap between the cap's inner dome and the core's outer dome (concentric spheres:
    /// the pillar height plus the radial clearance, since the pillars stop at the
    /// dome), mm.
    pub dome_gap_mm: f64,
}

/// What a lab needs to cast the array: levels and slit sizes of the mold.
#[derive(Debug, Clone, Serialize)]
pub struct MoldReport {
    /// Silicone level: pour to this height above the mold's underside (the sheet's top;
    /// the wall top when the walls are as high as the sheet is thick), mm.
    pub silicone_level_mm: f64,
    /// The sheet's mid-thickness, where the fibers belong, mm.
    pub mid_sheet_z_mm: f64,
    /// Height of the fibers' axes as printed: the seat plus the fiber's radius, mm.
    pub fiber_axis_z_mm: f64,
    /// Printed axis less the mid-thickness: the seat is put on a layer boundary, so at
    /// most half a layer, mm.
    pub fiber_axis_offset_mm: f64,
    /// Layer height the seat and the pocket's ledge are placed for (the first layer
    /// as high), mm; slice with it.
    pub layer_height_mm: f64,
    /// Height of the slit bottoms, where each coated fiber rests (a layer boundary), mm.
    pub slit_bottom_z_mm: f64,
    /// Width of the fiber's seat in the slit, mm.
    pub slit_width_mm: f64,
    /// Width of the plug pocket above the seat (None without plugs), mm.
    pub pocket_width_mm: Option<f64>,
    /// Height of the pocket's ledge (the layer boundary at or above the fiber's top),
    /// where the plug rests, mm (None without plugs).
    pub pocket_bottom_z_mm: Option<f64>,
    /// Clearance between a plug and its pocket, each side, mm (0: press fit).
    pub plug_fit_mm: Option<f64>,
    /// Plugs to print (one per slit), 0 without plugs.
    pub plugs_to_print: usize,
    /// Open cross-section left through the wall below the silicone level at each slit
    /// once the fiber (and the plug) are in: the seat less the fiber, mm².
    pub open_area_per_slit_mm2: f64,
    /// How the slits are closed under the silicone level.
    pub sealing: String,
}

fn mold_report(profile: &DesignProfile) -> Option<MoldReport> {
    let a = profile.array.as_ref()?;
    let (l, pocket) = (&a.layout, a.pocket);
    let slits = 2 * a.spec.fiber_x_mm.len();
    let design = profile.design;
    let rf = design.fiber_routing.coated_diameter_mm / 2.0;
    let mid = a.spec.mold.base_thickness_mm + a.spec.thickness_mm / 2.0;
    let axis = l.slit_bottom_z_mm + rf;
    let seat_top = pocket.map_or(l.silicone_level_z_mm, |q| {
        q.bottom_z_mm.min(l.silicone_level_z_mm)
    });
    let open = a.spec.mold.slit_width_mm * (seat_top - l.slit_bottom_z_mm)
        - std::f64::consts::PI * rf * rf;
    Some(MoldReport {
        silicone_level_mm: l.silicone_level_z_mm,
        mid_sheet_z_mm: mid,
        fiber_axis_z_mm: axis,
        fiber_axis_offset_mm: axis - mid,
        layer_height_mm: design.printer.layer_height_mm(),
        slit_bottom_z_mm: l.slit_bottom_z_mm,
        slit_width_mm: a.spec.mold.slit_width_mm,
        pocket_width_mm: pocket.map(|q| q.width_mm),
        pocket_bottom_z_mm: pocket.map(|q| q.bottom_z_mm),
        plug_fit_mm: pocket.map(|_| super::mold_plug::PLUG_FIT_MM),
        plugs_to_print: if pocket.is_some() { slits } else { 0 },
        open_area_per_slit_mm2: open,
        sealing: if pocket.is_some() {
            format!(
                "lay each fiber in its seat, press a printed plug (mold-plug.stl, a press fit: sand it if it does not go in, never leave it loose) into each of the {slits} pockets down onto its ledge, then pour; below the silicone level only the seat beside and over the fiber stays open ({open:.3} mm² per slit): dab silicone on it from outside if the first pour seeps"
            )
        } else {
            "the slits are open above each fiber below the silicone level: close them from outside (putty or tape) before pouring, or set array.mold.plugs = true".into()
        },
    })
}

/// A material of the design as the manifest and the 3MF files name it.
#[derive(Debug, Clone, Serialize)]
pub struct ManifestMaterial {
    /// Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// The vendor's name of the material, when the design states it.
    pub vendor_name: Option<String>,
    /// Shore hardness, when the design states it.
    pub shore_hardness: Option<String>,
    /// Display colour in the 3MF files (`#RRGGBB`): the stated one or the palette's.
    pub display_colour: String,
    /// Where the numbers come from.
    pub note: Option<String>,
}

/// Colours for materials that state none, in the order of the material table.
const PALETTE: [&str; 10] = [
    "#1F77B4", "#2CA02C", "#9467BD", "#D62728", "#FF7F0E", "#8C564B", "#E377C2", "#7F7F7F",
    "#BCBD22", "#17BECF",
];

/// Every material of the design with its display colour.
pub(crate) fn manifest_materials(
    design: &crate::spec::Design,
) -> BTreeMap<String, ManifestMaterial> {
    design
        .materials
        .iter()
        .enumerate()
        .map(|(i, (k, m))| {
            (
                k.clone(),
                ManifestMaterial {
                    youngs_modulus_mpa: m.youngs_modulus_mpa,
                    vendor_name: m.vendor_name.clone(),
                    shore_hardness: m.shore_hardness.clone(),
                    display_colour: m
                        .display_colour
                        .clone()
                        .unwrap_or_else(|| PALETTE[i % PALETTE.len()].into())
                        .to_uppercase(),
                    note: m.note.clone(),
                },
            )
        })
        .collect()
}

/// The 3MF and assembly files of a build.
#[derive(Debug, Clone, Serialize)]
pub struct Packages {
    /// Every printed piece on one plate, each in its material: one 3MF object per
    /// piece (a part printed in two materials is two objects).
    pub plate_3mf: String,
    /// The module assembled, parts in place (when cap, core and inserts were built).
    pub assembled_3mf: Option<String>,
    /// The same as one STEP file, a solid per part.
    pub assembled_step: Option<String>,
    /// The pieces in the assembled files.
    pub assembled_pieces: Vec<String>,
}

/// `manifest.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Manifest {
    /// Design name.
    pub design: String,
    /// Meshing tolerance requested, mm.
    pub tolerance_mm: f64,
    /// Parts written.
    pub parts: Vec<ManifestPart>,
    /// Assembly clearances (module designs only).
    pub clearances: Option<Clearances>,
    /// The snap-fit, sized (module designs with `[module.snap]`).
    pub snap: Option<crate::profile::SnapReport>,
    /// How the cap is held on the core (module designs): the snap with its retention
    /// force and free travel, or nothing, with the warning.
    pub retention: Option<crate::profile::Retention>,
    /// Every fiber's way out, traced through the assembled parts (module designs
    /// built whole).
    pub fibers: Option<Vec<super::assembly::FiberTrace>>,
    /// The mold's levels and slits (array designs).
    pub mold: Option<MoldReport>,
    /// Cut-away previews written beside the parts.
    pub previews: Vec<String>,
    /// The 3MF files and the assembled module.
    pub packages: Packages,
    /// The design's materials: names, hardness and display colours.
    pub materials: BTreeMap<String, ManifestMaterial>,
    /// Every designed gap between mating parts, on exact dimensions, with the gap
    /// the written meshes keep (module designs).
    pub fits: Option<Vec<super::fits::FitGap>>,
    /// Every designed gap the meshes must keep (the fits but press fits, and the fiber
    /// passages around a revolved wall): designed and meshed, and the surface
    /// tolerance that keeps it.
    pub meshed_gaps: Vec<super::gaps::MeshedGap>,
    /// The passages to clear after printing and how.
    pub print_notes: Vec<super::print_notes::PrintNote>,
}

fn clearances(profile: &DesignProfile) -> Option<Clearances> {
    let m = profile.module.as_ref()?;
    let p = &m.profile;
    Some(Clearances {
        cap_core_radial_mm: p.cap_inner_radius_mm - p.pillar_outer_radius_mm,
        core_insert_radial_mm: p.core_inner_radius_mm - p.insert_radius_mm,
        alignment_pillar_side_mm: (m.spec.pillars.groove_width_mm - p.cap_pillar_width_mm) / 2.0,
        alignment_pillar_groove_bottom_mm: p.cap_pillar_inner_radius_mm - p.groove_bottom_radius_mm,
        dome_gap_mm: p.cap_dome_inner_sphere_radius_mm - p.core_dome_outer_sphere_radius_mm,
    })
}

/// Everything to write for a design: (file name, bytes) plus the manifest.
pub struct Rendered {
    /// Files other than the manifest.
    pub files: Vec<(String, Vec<u8>)>,
    /// The manifest.
    pub manifest: Manifest,
}

/// What a build checked, for [`render`].
#[derive(Debug, Clone, Copy)]
pub struct Checked<'a> {
    /// Every part built, meshed and checked.
    pub parts: &'a [BuiltPart],
    /// The requested meshing tolerance, mm.
    pub tolerance_mm: f64,
    /// The traced fiber paths, when the whole module was built.
    pub fibers: Option<&'a [super::assembly::FiberTrace]>,
    /// Every designed gap measured on the meshes.
    pub gaps: &'a [super::gaps::MeshedGap],
}

/// Render all parts in memory with `drawings`, the caller's pictures of the parts (file
/// name, bytes: the previews), listed in the manifest.
pub fn render(
    profile: &DesignProfile,
    checked: &Checked,
    drawings: Vec<(String, Vec<u8>)>,
) -> Result<Rendered> {
    let (parts, tolerance_mm, fibers) = (checked.parts, checked.tolerance_mm, checked.fibers);
    let design = profile.design;
    let mut files = Vec::new();
    let mut listed = Vec::new();
    for p in parts {
        let stl = format!("{}.stl", p.name);
        let step = format!("{}.step", p.name);
        files.push((stl.clone(), stl_bytes(p)?));
        files.push((step.clone(), step_text(p, &design.name).into_bytes()));
        let (lo, hi) = p.mesh.bbox_mm();
        listed.push(ManifestPart {
            name: p.name.clone(),
            kind: p.kind,
            stl,
            step,
            triangles: p.mesh.triangles.len(),
            mesh_tolerance_mm: p.mesh_tolerance_mm,
            mesh_volume_mm3: p.mesh_volume_mm3,
            exact_volume_mm3: p.exact_volume_mm3,
            volume_error_percent: p.volume_error() * 100.0,
            bbox_min_mm: lo,
            bbox_max_mm: hi,
            materials: p.kind.part().materials(design, &p.name),
        });
    }
    let previews: Vec<String> = drawings.iter().map(|(name, _)| name.clone()).collect();
    files.extend(drawings);
    let snap = profile
        .module
        .as_ref()
        .and_then(|m| crate::profile::snap_report(design, &m.profile, &m.parts));
    let retention = profile
        .module
        .as_ref()
        .and_then(|m| crate::profile::retention(design, &m.profile, &m.parts));
    let materials = manifest_materials(design);
    let packages = render_packages(profile, parts, &materials, fibers.is_some(), &mut files)?;
    let manifest = Manifest {
        design: design.name.clone(),
        tolerance_mm,
        parts: listed,
        clearances: clearances(profile),
        snap,
        retention,
        fibers: fibers.map(<[_]>::to_vec),
        mold: mold_report(profile),
        previews,
        packages,
        materials,
        fits: profile.module.as_ref().map(|m| {
            let mut fits = super::fits::module_fits(m);
            for f in &mut fits {
                if let Some(g) = checked.gaps.iter().find(|g| g.what == f.what) {
                    f.meshed_gap_mm = Some(g.meshed_gap_mm);
                    f.surface_tolerance_mm = Some(g.surface_tolerance_mm);
                }
            }
            fits
        }),
        meshed_gaps: checked.gaps.to_vec(),
        print_notes: super::print_notes::print_notes(profile),
    };
    Ok(Rendered { files, manifest })
}

/// A piece of a built part for a 3MF file: its label, material key and mesh.
fn pieces<'a>(
    design: &crate::spec::Design,
    parts: impl IntoIterator<Item = &'a BuiltPart>,
) -> Vec<(String, Option<String>, &'a BuiltPart)> {
    parts
        .into_iter()
        .flat_map(|p| {
            p.kind
                .part()
                .prints(design, &p.name)
                .into_iter()
                .map(move |pr| (pr.label, pr.material, p))
        })
        .collect()
}

/// The 3MF package of `pieces`, each placed by `offset`: the materials they use as
/// `<basematerials>` in order of first use (named by key and vendor name).
fn package_3mf(
    title: &str,
    pieces: &[(String, Option<String>, &BuiltPart)],
    materials: &BTreeMap<String, ManifestMaterial>,
    offset: impl Fn(usize, &BuiltPart) -> [f64; 3],
) -> Result<Vec<u8>> {
    let mut used: Vec<Option<String>> = Vec::new();
    let mut objects = Vec::new();
    for (k, (label, mat, part)) in pieces.iter().enumerate() {
        let idx = used.iter().position(|u| u == mat).unwrap_or_else(|| {
            used.push(mat.clone());
            used.len() - 1
        });
        objects.push(super::threemf::Object {
            name: label.clone(),
            mesh: &part.mesh,
            material: idx,
            offset_mm: offset(k, part),
        });
    }
    let base: Vec<super::threemf::BaseMaterial> = used
        .iter()
        .map(
            |u| match u.as_ref().and_then(|k| materials.get(k).map(|m| (k, m))) {
                Some((k, m)) => super::threemf::BaseMaterial {
                    name: match &m.vendor_name {
                        Some(v) => format!("{k} ({v})"),
                        None => k.clone(),
                    },
                    colour: m.display_colour.clone(),
                },
                None => super::threemf::BaseMaterial {
                    name: "not stated".into(),
                    colour: "#BFBFBF".into(),
                },
            },
        )
        .collect();
    let model = super::threemf::model_xml(title, &base, &objects)?;
    let slicer = super::threemf::slicer_config_xml(&objects)?;
    super::threemf::package_with(&model, &[(super::threemf::SLICER_CONFIG_PATH, &slicer)])
}

/// Plate width the 3MF plate lays pieces out in, mm (a 250 × 210 mm bed with margins).
const PLATE_ROW_MM: f64 = 200.0;
/// Gap between pieces on the plate, mm.
const PLATE_GAP_MM: f64 = 5.0;

/// Render `parts.3mf` (every piece on one plate) and, for a whole module, the
/// assembled module as 3MF and STEP; push them onto `files`.
fn render_packages(
    profile: &DesignProfile,
    parts: &[BuiltPart],
    materials: &BTreeMap<String, ManifestMaterial>,
    whole_module: bool,
    files: &mut Vec<(String, Vec<u8>)>,
) -> Result<Packages> {
    let design = profile.design;
    let plate = pieces(design, parts);
    let feet: Vec<(f64, f64)> = plate
        .iter()
        .map(|(_, _, p)| {
            let (lo, hi) = p.mesh.bbox_mm();
            (hi[0] - lo[0], hi[1] - lo[1])
        })
        .collect();
    let at = super::threemf::lay_out(&feet, PLATE_ROW_MM, PLATE_GAP_MM);
    let bytes = package_3mf(
        &format!("{}: every piece to print", design.name),
        &plate,
        materials,
        |k, p| {
            let (lo, _) = p.mesh.bbox_mm();
            [at[k].0 - lo[0], at[k].1 - lo[1], -lo[2]]
        },
    )?;
    files.push(("parts.3mf".into(), bytes));
    let mut out = Packages {
        plate_3mf: "parts.3mf".into(),
        assembled_3mf: None,
        assembled_step: None,
        assembled_pieces: Vec::new(),
    };
    if whole_module {
        // Cap, the first core and the first insert, in place (the build frame is the
        // assembly).
        let module: Vec<&BuiltPart> = super::registry::first_of_each_kind(parts, |b| b.kind)
            .into_iter()
            .filter(|b| b.kind.part().in_module())
            .collect();
        let mut assembled = Vec::new();
        for p in &module {
            if let Some(first) = pieces(design, [*p]).into_iter().next() {
                assembled.push(first);
            }
        }
        let bytes = package_3mf(
            &format!("{}: the module assembled", design.name),
            &assembled,
            materials,
            |_, _| [0.0; 3],
        )?;
        files.push(("module-assembled.3mf".into(), bytes));
        // One named, coloured product per part (its first material's colour, as in
        // the assembled 3MF), under the module.
        let colours: Vec<(String, [f64; 3])> = module
            .iter()
            .map(|p| {
                let key = p
                    .kind
                    .part()
                    .prints(design, &p.name)
                    .into_iter()
                    .next()
                    .and_then(|pr| pr.material);
                let colour = key
                    .as_ref()
                    .and_then(|k| materials.get(k))
                    .map_or("#BFBFBF", |m| m.display_colour.as_str());
                (
                    key.unwrap_or_else(|| "not stated".into()),
                    super::step_assembly::hex_colour(colour),
                )
            })
            .collect();
        let step_parts: Vec<super::step_assembly::AssemblyPart> = module
            .iter()
            .zip(&colours)
            .map(|(p, (material, rgb))| super::step_assembly::AssemblyPart {
                name: &p.name,
                solid: &p.solid,
                colour_rgb: *rgb,
                material,
            })
            .collect();
        files.push((
            "module-assembled.step".into(),
            super::step_assembly::assembly_step_text(&step_parts, "module-assembled", &design.name)
                .into_bytes(),
        ));
        out.assembled_3mf = Some("module-assembled.3mf".into());
        out.assembled_step = Some("module-assembled.step".into());
        out.assembled_pieces = assembled.into_iter().map(|a| a.0).collect();
    }
    Ok(out)
}

/// Write the rendered files and then the manifest into `dir`; returns the paths.
/// The folder is checked for writability before the first file.
pub fn write_all(dir: &Path, r: &Rendered) -> Result<Vec<PathBuf>> {
    crate::output::ensure_dir(dir)?;
    let probe = tempfile::Builder::new()
        .prefix(".fbgforge-probe-")
        .tempfile_in(dir)
        .with_context(|| format!("cannot write in output folder {}", dir.display()))?;
    drop(probe);
    let mut paths = Vec::new();
    for (name, bytes) in &r.files {
        let path = dir.join(name);
        crate::output::write_atomic(&path, bytes)?;
        paths.push(path);
    }
    let mpath = dir.join("manifest.json");
    crate::output::write_json(&mpath, &r.manifest)?;
    paths.push(mpath);
    Ok(paths)
}
