//! Export of checked parts: binary STL, STEP, and the manifest that lists them.
//!
//! Everything is rendered to memory first; [`write_all`] writes the files through
//! [`crate::output`] (temporary file + rename) only after every part has been rendered,
//! so a failure leaves no half-written or partial set of files.

use super::{BuiltPart, PartKind};
use crate::profile::ModuleProfile;
use crate::spec::Design;
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

/// STEP (AP203 B-rep) text of a part's solid.
pub fn step_text(part: &BuiltPart, design_name: &str) -> String {
    let compressed = part.solid.compress();
    out::CompleteStepDisplay::new(
        out::StepModel::from(&compressed),
        out::StepHeaderDescriptor {
            file_name: format!("{}-{}.step", design_name, part.name),
            organization_system: "fbgforge".to_owned(),
            ..Default::default()
        },
    )
    .to_string()
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
}

fn clearances(design: &Design) -> Option<Clearances> {
    let m = design.module.as_ref()?;
    let p = ModuleProfile::from_module(m);
    Some(Clearances {
        cap_core_radial_mm: p.cap_inner_radius_mm - p.pillar_outer_radius_mm,
        core_insert_radial_mm: p.core_inner_radius_mm - p.insert_radius_mm,
        alignment_pillar_side_mm: (m.pillars.groove_width_mm - p.cap_pillar_width_mm) / 2.0,
        alignment_pillar_groove_bottom_mm: p.cap_pillar_inner_radius_mm - p.groove_bottom_radius_mm,
        dome_gap_mm: p.cap_dome_inner_sphere_radius_mm - p.core_dome_outer_sphere_radius_mm,
    })
}

fn materials(design: &Design, part: &BuiltPart) -> Vec<String> {
    let Some(m) = &design.module else {
        return design.array.iter().map(|a| a.material.clone()).collect();
    };
    match part.kind {
        PartKind::Cap => vec![m.cap_material.clone()],
        PartKind::Core => m
            .cores
            .iter()
            .map(|c| format!("{} ({})", c.material, c.name))
            .collect(),
        PartKind::Insert => m
            .inserts
            .iter()
            .filter(|i| format!("insert-{}", i.name) == part.name)
            .map(|i| i.material.clone())
            .collect(),
        PartKind::Mold => Vec::new(),
    }
}

/// Everything to write for a design: (file name, bytes) plus the manifest.
pub struct Rendered {
    /// Files other than the manifest.
    pub files: Vec<(String, Vec<u8>)>,
    /// The manifest.
    pub manifest: Manifest,
}

/// Render all parts in memory.
pub fn render(design: &Design, parts: &[BuiltPart], tolerance_mm: f64) -> Result<Rendered> {
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
            materials: materials(design, p),
        });
    }
    let manifest = Manifest {
        design: design.name.clone(),
        tolerance_mm,
        parts: listed,
        clearances: clearances(design),
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
