//! Export of checked parts: binary STL, STEP, and the manifest that lists them.
//!
//! Everything is rendered to memory first; [`write_all`] writes the files through
//! [`crate::output`] (temporary file + rename) only after every part has been rendered,
//! so a failure leaves no half-written or partial set of files.

use super::design_profile::DesignProfile;
use super::{BuiltPart, PartKind};
use anyhow::{Context, Result};
use serde::Serialize;
use std::path::{Path, PathBuf};
use truck_stepio::out;

/// Binary STL of a mesh (f32 coordinates, mm).
pub fn stl_bytes(part: &BuiltPart) -> Result<Vec<u8>> {
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

/// The STEP schema the files declare: AP214 (automotive design), which the data
/// section's APPLICATION_PROTOCOL_DEFINITION ('automotive_design', 2000) already names.
pub const STEP_SCHEMA: &str = "AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }";

/// STEP (AP214 B-rep) text of a part's solid.
///
/// truck-stepio 0.3 writes a header other CAD reads badly: the schema `ISO-10303-042`
/// (a part number, not a schema name) and the author and organisation of FILE_NAME as
/// nested lists `(('')),`, which OpenCASCADE counts as two unresolved references. The
/// header is therefore written here; the data section is truck's.
pub fn step_text(part: &BuiltPart, design_name: &str) -> String {
    let compressed = part.solid.compress();
    let text = out::CompleteStepDisplay::new(
        out::StepModel::from(&compressed),
        out::StepHeaderDescriptor::default(),
    )
    .to_string();
    let data = text.find("DATA;").map_or(text.as_str(), |i| &text[i..]);
    format!(
        "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('fbgforge part {part} of design {design}'), '2;1');\nFILE_NAME('{design}-{part}.step', '{stamp}', ('fbgforge'), (''), 'truck-stepio 0.3', 'fbgforge {version}', '');\nFILE_SCHEMA(('{STEP_SCHEMA}'));\nENDSEC;\n{data}",
        part = step_string(&part.name),
        design = step_string(design_name),
        stamp = iso8601_now(),
        version = env!("CARGO_PKG_VERSION"),
    )
}

/// A STEP string literal's content: apostrophes doubled, only printable ASCII kept.
fn step_string(s: &str) -> String {
    s.chars()
        .filter(|c| c.is_ascii() && !c.is_ascii_control())
        .collect::<String>()
        .replace('\'', "''")
}

/// The current UTC time as ISO 8601 (`YYYY-MM-DDThh:mm:ss`), as FILE_NAME expects.
fn iso8601_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64);
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
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
    /// Height of the fibers' axes (the sheet's mid-thickness), mm.
    pub fiber_axis_z_mm: f64,
    /// Height of the slit bottoms, where each coated fiber rests, mm.
    pub slit_bottom_z_mm: f64,
    /// Width of the fiber's seat in the slit, mm.
    pub slit_width_mm: f64,
    /// Width of the plug pocket above the seat (None without plugs), mm.
    pub pocket_width_mm: Option<f64>,
    /// Plugs to print (one per slit), 0 without plugs.
    pub plugs_to_print: usize,
    /// How the slits are closed under the silicone level.
    pub sealing: String,
}

fn mold_report(profile: &DesignProfile) -> Option<MoldReport> {
    let a = profile.array.as_ref()?;
    let (l, pocket) = (&a.layout, a.pocket);
    let slits = 2 * a.spec.fiber_x_mm.len();
    Some(MoldReport {
        silicone_level_mm: l.silicone_level_z_mm,
        fiber_axis_z_mm: l.fiber_z_mm,
        slit_bottom_z_mm: l.slit_bottom_z_mm,
        slit_width_mm: a.spec.mold.slit_width_mm,
        pocket_width_mm: pocket.map(|q| q.width_mm),
        plugs_to_print: if pocket.is_some() { slits } else { 0 },
        sealing: if pocket.is_some() {
            format!(
                "lay each fiber in its seat, push a printed plug (mold-plug.stl) into each of the {slits} pockets down onto the fiber, then pour"
            )
        } else {
            "the slits are open above each fiber below the silicone level: close them from outside (putty or tape) before pouring, or set array.mold.plugs = true".into()
        },
    })
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
    /// Every fiber's way out, traced through the assembled parts (module designs
    /// built whole).
    pub fibers: Option<Vec<super::assembly::FiberTrace>>,
    /// The mold's levels and slits (array designs).
    pub mold: Option<MoldReport>,
    /// Cut-away previews written beside the parts.
    pub previews: Vec<String>,
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

/// Render all parts in memory; `fibers` are the traced fiber paths when the whole
/// module was built.
pub fn render(
    profile: &DesignProfile,
    parts: &[BuiltPart],
    tolerance_mm: f64,
    fibers: Option<&[super::assembly::FiberTrace]>,
) -> Result<Rendered> {
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
    let mut previews = Vec::new();
    if let Some(svg) = fibers.and_then(|f| super::preview::module_svg(profile, parts, f)) {
        previews.push("preview-module.svg".to_string());
        files.push(("preview-module.svg".into(), svg.into_bytes()));
    }
    if let Some(svg) = super::preview::mold_svg(profile, parts) {
        previews.push("preview-mold.svg".to_string());
        files.push(("preview-mold.svg".into(), svg.into_bytes()));
    }
    let snap = profile
        .module
        .as_ref()
        .and_then(|m| crate::profile::snap_report(design, &m.profile, &m.parts));
    let manifest = Manifest {
        design: design.name.clone(),
        tolerance_mm,
        parts: listed,
        clearances: clearances(profile),
        snap,
        fibers: fibers.map(<[_]>::to_vec),
        mold: mold_report(profile),
        previews,
    };
    Ok(Rendered { files, manifest })
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
