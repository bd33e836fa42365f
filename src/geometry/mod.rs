//! Printable parts of a design: B-rep solids, checked meshes and exact volumes.
//!
//! [`part_names`] lists what a design yields (`cap`, `core`, `insert-<name>` for each
//! insert, `mold` for an array); [`build_solids`] builds their B-rep solids from
//! [`crate::profile`]; [`build_parts`] meshes them at a chord tolerance and runs every
//! mesh check, including agreement of the mesh volume with the closed-form volume.
//! Nothing here writes files: [`export`] turns checked parts into STL, STEP and a
//! manifest, and the CLI writes them only once every part has passed.

pub mod assembly;
pub mod brep;
pub mod export;

pub mod mesh;
pub mod module;
pub mod mold;
pub mod preview;

use crate::profile::{ArrayLayout, ModuleProfile};
use crate::spec::{Design, SpecError};
use anyhow::Context;
use mesh::{MeshError, TriMesh};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use truck_modeling::Solid;

/// Largest allowed relative difference between mesh and exact volume at the printer's
/// default tolerance (0.5 %). A coarser tolerance scales it in proportion, since the
/// chord error of a tessellation grows linearly with the tolerance.
pub const VOLUME_TOLERANCE_AT_DEFAULT: f64 = 0.005;

/// What kind of part; several parts can share one solid (all inserts are alike).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PartKind {
    /// Clip-on cap (CC).
    Cap,
    /// Plug-in sensor core (PSC); every listed core is printed from it.
    Core,
    /// Solid insert (PSC-solid).
    Insert,
    /// Casting mold of the flat array.
    Mold,
    /// Plug that closes a mold slit above its fiber (one file, printed once per slit).
    MoldPlug,
}

/// A part's B-rep with its exact volume.
#[derive(Debug, Clone)]
pub struct PartSolid {
    /// Output name: `cap`, `core`, `insert-<name>`, `mold`.
    pub name: String,
    /// Kind.
    pub kind: PartKind,
    /// Closed, oriented B-rep.
    pub solid: Solid,
    /// Volume in closed form from the spec, mm³.
    pub exact_volume_mm3: f64,
}

/// A part ready to export: solid, checked mesh, volumes.
#[derive(Debug, Clone)]
pub struct BuiltPart {
    /// Output name.
    pub name: String,
    /// Kind.
    pub kind: PartKind,
    /// The B-rep (for STEP).
    pub solid: Solid,
    /// The checked triangle mesh (for STL).
    pub mesh: TriMesh,
    /// Exact volume, mm³.
    pub exact_volume_mm3: f64,
    /// Volume enclosed by the mesh, mm³.
    pub mesh_volume_mm3: f64,
    /// Chord tolerance the mesh was made at (the requested one, or finer if the
    /// volume bound needed it), mm.
    pub mesh_tolerance_mm: f64,
}

impl BuiltPart {
    /// (mesh − exact) / exact.
    pub fn volume_error(&self) -> f64 {
        (self.mesh_volume_mm3 - self.exact_volume_mm3) / self.exact_volume_mm3
    }
}

/// Why a design could not be turned into parts.
#[derive(Debug, thiserror::Error)]
pub enum GeometryError {
    /// A dimension that passes the spec's own ranges but cannot be built.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// A solid could not be assembled.
    #[error(transparent)]
    Brep(#[from] brep::BrepError),
    /// A mesh check failed.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// `--parts` named a part the design does not have.
    #[error("unknown part `{name}`; this design has: {known}")]
    UnknownPart {
        /// Requested name.
        name: String,
        /// Comma-separated list of available parts.
        known: String,
    },
    /// A fiber has no way out of the assembled module.
    #[error(transparent)]
    Route(#[from] assembly::RouteError),
    /// Two assembled parts overlap.
    #[error(transparent)]
    Interference(#[from] assembly::Interference),
    /// A tolerance outside the range truck can mesh with.
    #[error("meshing tolerance {0} mm is out of range; allowed 0.001 to 1 mm")]
    Tolerance(f64),
}

/// Names of the printable parts of a design, in build order.
pub fn part_names(design: &Design) -> Vec<String> {
    let mut names = Vec::new();
    if let Some(m) = &design.module {
        names.push("cap".to_string());
        names.push("core".to_string());
        names.extend(m.inserts.iter().map(|i| format!("insert-{}", i.name)));
    }
    if let Some(a) = &design.array {
        names.push("mold".to_string());
        if a.mold.plugs {
            names.push("mold-plug".to_string());
        }
    }
    names
}

fn check_selection(
    design: &Design,
    selection: Option<&[String]>,
) -> Result<Vec<String>, GeometryError> {
    let all = part_names(design);
    let Some(sel) = selection else { return Ok(all) };
    for s in sel {
        if !all.contains(s) {
            return Err(GeometryError::UnknownPart {
                name: s.clone(),
                known: all.join(", "),
            });
        }
    }
    Ok(all.into_iter().filter(|n| sel.contains(n)).collect())
}

/// Geometric preconditions beyond the spec's ranges: every radius and height in the
/// order the construction needs. The spec's validation should already guarantee these;
/// this keeps the builder from panicking on a design that slips through.
fn check_module_profile(p: &ModuleProfile) -> Result<(), SpecError> {
    let e = |field: &str, msg: String| crate::spec::err(field, msg);
    let radii = [
        (
            "module.cap_wall_mm",
            p.cap_inner_radius_mm,
            p.cap_outer_radius_mm,
        ),
        (
            "module.pillars.groove_depth_mm",
            p.cap_pillar_inner_radius_mm,
            p.cap_inner_radius_mm,
        ),
        (
            "module.pillars.groove_depth_mm",
            p.groove_bottom_radius_mm,
            p.pillar_outer_radius_mm,
        ),
        (
            "module.pillars.height_mm",
            p.core_outer_radius_mm,
            p.groove_bottom_radius_mm,
        ),
        (
            "module.core_wall_mm",
            p.core_inner_radius_mm,
            p.core_outer_radius_mm,
        ),
        (
            "module.core_insert_clearance_mm",
            p.insert_radius_mm,
            p.core_inner_radius_mm,
        ),
        (
            "module.top_hole_diameter_mm",
            p.top_hole_radius_mm,
            p.core_inner_radius_mm,
        ),
        (
            "module.apex_flat_diameter_mm",
            p.apex_flat_radius_mm,
            p.insert_radius_mm,
        ),
    ];
    for (field, lo, hi) in radii {
        // A zero clearance (press fit) is a valid spec: the insert is its own solid, so
        // its radius may equal the core's inner radius.
        let fits = if field == "module.core_insert_clearance_mm" {
            lo <= hi
        } else {
            lo < hi
        };
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && fits) {
            return Err(e(
                field,
                format!("leaves a radius of {lo:.4} mm that must lie between 0 and {hi:.4} mm"),
            ));
        }
    }
    let heights = [
        p.pillar_top_mm,
        p.core_outer_junction_z_mm,
        p.cap_outer_junction_z_mm,
        p.cap_inner_junction_z_mm,
        p.insert_junction_z_mm,
    ];
    if heights.iter().any(|z| !z.is_finite() || *z <= 0.0)
        || p.pillar_top_mm > p.core_outer_junction_z_mm + 1e-9
        || p.pillar_top_mm > p.cap_inner_junction_z_mm + 1e-9
    {
        return Err(e(
            "module.dome_height_mm",
            "the dome leaves no cylindrical section for the pillars; make the module taller or the dome lower".into(),
        ));
    }
    Ok(())
}

fn check_mold(design: &Design) -> Result<(), SpecError> {
    let Some(a) = &design.array else {
        return Ok(());
    };
    let half = a.mold.internal_x_mm / 2.0;
    let sw = crate::spec::mold_slot_width_mm(design, &a.mold) / 2.0;
    for (i, &x) in a.fiber_x_mm.iter().enumerate() {
        if x.abs() + sw >= half - 1e-9 {
            return Err(crate::spec::err(
                &format!("array.fiber_x_mm[{i}]"),
                format!(
                    "{x} mm puts the slit (± {sw} mm) into the mold's corner; allowed within ±{:.3} mm",
                    half - sw
                ),
            ));
        }
    }
    Ok(())
}

/// The plug pocket of the design's mold slits (None without plugs): as wide as a
/// printable plug plus a channel clearance each side, from the coated fiber's top up.
pub fn mold_pocket(design: &Design) -> Option<mold::Pocket> {
    let a = design.array.as_ref()?;
    if !a.mold.plugs {
        return None;
    }
    let layout = ArrayLayout::from_array(a);
    Some(mold::Pocket {
        width_mm: crate::spec::mold_slot_width_mm(design, &a.mold),
        bottom_z_mm: layout.slit_bottom_z_mm + design.fiber_routing.coated_diameter_mm,
    })
}

/// Build the B-rep solids of the selected parts (all when `selection` is None).
/// Parts of one kind share a solid: the inserts differ only in material.
pub fn build_solids(
    design: &Design,
    selection: Option<&[String]>,
) -> Result<Vec<PartSolid>, GeometryError> {
    let names = check_selection(design, selection)?;
    let mut out = Vec::new();
    if let Some(m) = &design.module {
        let p = ModuleProfile::from_module(m);
        check_module_profile(&p)?;
        let pp = crate::profile::PartsProfile::new(
            m,
            &p,
            &design.fiber_routing,
            design.fiber_routing.channel_width_mm(&design.printer),
        );
        if names.iter().any(|n| n == "cap") {
            let s = module::cap::cap(&p, &pp)?;
            out.push(PartSolid {
                name: "cap".into(),
                kind: PartKind::Cap,
                solid: s.solid,
                exact_volume_mm3: s.exact_volume_mm3,
            });
        }
        if names.iter().any(|n| n == "core") {
            let pl = &m.pillars;
            let s = module::core::core(
                &p,
                &pp,
                pl.width_mm,
                pl.fiber_hole_diameter_mm,
                pl.groove_width_mm,
            )?;
            out.push(PartSolid {
                name: "core".into(),
                kind: PartKind::Core,
                solid: s.solid,
                exact_volume_mm3: s.exact_volume_mm3,
            });
        }
        let inserts: Vec<&String> = names.iter().filter(|n| n.starts_with("insert-")).collect();
        if let Some(first) = inserts.first() {
            let s = module::insert::insert(&p, &pp, first)?;
            for n in inserts {
                out.push(PartSolid {
                    name: n.clone(),
                    kind: PartKind::Insert,
                    solid: s.solid.clone(),
                    exact_volume_mm3: s.exact_volume_mm3,
                });
            }
        }
    }
    if let Some(a) = &design.array {
        let layout = ArrayLayout::from_array(a);
        let pocket = mold_pocket(design);
        if names.iter().any(|n| n == "mold") {
            check_mold(design)?;
            let s = mold::mold(&a.mold, &layout, pocket)?;
            out.push(PartSolid {
                name: "mold".into(),
                kind: PartKind::Mold,
                solid: s.solid,
                exact_volume_mm3: s.exact_volume_mm3,
            });
        }
        if let (true, Some(q)) = (names.iter().any(|n| n == "mold-plug"), pocket) {
            let s = mold::plug(
                &a.mold,
                &layout,
                q,
                design.fiber_routing.channel_clearance_mm,
            )?;
            out.push(PartSolid {
                name: "mold-plug".into(),
                kind: PartKind::MoldPlug,
                solid: s.solid,
                exact_volume_mm3: s.exact_volume_mm3,
            });
        }
    }
    Ok(out)
}

/// The volume bound applied at tolerance `tol_mm` for a printer whose default is
/// `default_mm` (see [`VOLUME_TOLERANCE_AT_DEFAULT`]).
pub fn volume_bound(tol_mm: f64, default_mm: f64) -> f64 {
    VOLUME_TOLERANCE_AT_DEFAULT * (tol_mm / default_mm).max(1.0)
}

/// How many times [`mesh_part`] may halve the tolerance to meet the volume bound.
pub const MAX_REFINEMENTS: u32 = 3;

/// Mesh one solid at `tol_mm` and run every check. If the mesh volume misses the
/// exact volume by more than `volume_bound` (small parts: an inscribed polygon of
/// chord error s loses about 4/3 · s/r of a circle's area), the tolerance is halved,
/// up to [`MAX_REFINEMENTS`] times; the tolerance actually used is recorded.
pub fn mesh_part(
    part: &PartSolid,
    tol_mm: f64,
    volume_bound: f64,
) -> Result<BuiltPart, GeometryError> {
    let mut tol = tol_mm;
    for attempt in 0..=MAX_REFINEMENTS {
        let mesh = mesh::mesh_solid(&part.name, &part.solid, tol)?;
        let v = mesh.volume_mm3();
        let rel = (v - part.exact_volume_mm3) / part.exact_volume_mm3;
        if rel.abs() <= volume_bound {
            return Ok(BuiltPart {
                name: part.name.clone(),
                kind: part.kind,
                solid: part.solid.clone(),
                mesh,
                exact_volume_mm3: part.exact_volume_mm3,
                mesh_volume_mm3: v,
                mesh_tolerance_mm: tol,
            });
        }
        if attempt == MAX_REFINEMENTS || rel.is_nan() {
            return Err(MeshError {
                part: part.name.clone(),
                check: "volume",
                detail: format!(
                    "mesh volume {v:.3} mm³ differs from the exact {:.3} mm³ by {:.3} % at tolerance {tol} mm (allowed {:.3} %)",
                    part.exact_volume_mm3,
                    rel * 100.0,
                    volume_bound * 100.0
                ),
            }
            .into());
        }
        tol /= 2.0;
    }
    unreachable!("the loop returns on its last attempt")
}

/// Build, mesh and check the selected parts at `tol_mm` (the printer's default when
/// None). Parts sharing a solid are meshed once. Fails on the first bad part.
pub fn build_parts(
    design: &Design,
    tol_mm: Option<f64>,
    selection: Option<&[String]>,
) -> Result<Vec<BuiltPart>, GeometryError> {
    let default = design.printer.default_tolerance_mm();
    let tol = tol_mm.unwrap_or(default);
    if !(0.001..=1.0).contains(&tol) {
        return Err(GeometryError::Tolerance(tol));
    }
    let bound = volume_bound(tol, default);
    let solids = build_solids(design, selection)?;
    // Mesh each distinct solid once (inserts share theirs), in parallel.
    let mut firsts: Vec<usize> = Vec::new();
    for (i, s) in solids.iter().enumerate() {
        if !(s.kind == PartKind::Insert
            && firsts.iter().any(|&j| solids[j].kind == PartKind::Insert))
        {
            firsts.push(i);
        }
    }
    let meshed: Vec<BuiltPart> = firsts
        .par_iter()
        .map(|&i| mesh_part(&solids[i], tol, bound))
        .collect::<Result<_, _>>()?;
    let mut out = Vec::with_capacity(solids.len());
    for s in &solids {
        let m = meshed
            .iter()
            .find(|b| b.kind == s.kind && (b.name == s.name || s.kind == PartKind::Insert))
            .expect("every kind was meshed");
        let mut b = m.clone();
        b.name = s.name.clone();
        out.push(b);
    }
    Ok(out)
}

/// What one design build wrote.
#[derive(Debug, Clone)]
pub struct BuildReport {
    /// Output folder.
    pub dir: PathBuf,
    /// Parts built.
    pub parts: Vec<BuiltPart>,
    /// Every file written, manifest last.
    pub files: Vec<PathBuf>,
    /// Each fiber's traced way out (empty unless cap, core and an insert were built).
    pub fibers: Vec<assembly::FiberTrace>,
}

/// Trace the fibers and check the assembly when the whole module was built (cap, core
/// and, if the design has any, an insert); None otherwise.
pub fn check_assembly(
    design: &Design,
    built: &[BuiltPart],
) -> Result<Option<Vec<assembly::FiberTrace>>, GeometryError> {
    let Some(m) = &design.module else {
        return Ok(None);
    };
    let has = |k: PartKind| built.iter().any(|b| b.kind == k);
    if !has(PartKind::Cap)
        || !has(PartKind::Core)
        || (!m.inserts.is_empty() && !has(PartKind::Insert))
    {
        return Ok(None);
    }
    let module: Vec<BuiltPart> = built
        .iter()
        .filter(|b| matches!(b.kind, PartKind::Cap | PartKind::Core | PartKind::Insert))
        .cloned()
        .collect();
    // A mesh's chords cut into a concave wall by about its tolerance (truck keeps the
    // chord error near, not strictly under, it), so two parts
    // designed closer than that (a press fit at zero clearance) cannot be told apart
    // from overlapping ones: such a pair is not checked.
    let tol = module
        .iter()
        .map(|b| b.mesh_tolerance_mm)
        .fold(0.0, f64::max);
    let press = |a: PartKind, b: PartKind| match (a, b) {
        (PartKind::Cap, PartKind::Core) | (PartKind::Core, PartKind::Cap) => {
            m.cap_core_clearance_mm > 2.0 * tol
        }
        (PartKind::Core, PartKind::Insert) | (PartKind::Insert, PartKind::Core) => {
            m.core_insert_clearance_mm > 2.0 * tol
        }
        _ => true,
    };
    assembly::check_no_interference(&module, &press)?;
    Ok(Some(assembly::trace_fibers(design, &module)?))
}

/// Build a loaded design into `dir`: every part is built, meshed and checked and every
/// file rendered in memory before the first file is written.
pub fn build_design(
    design: &Design,
    dir: &Path,
    tolerance_mm: Option<f64>,
    parts: Option<&[String]>,
) -> anyhow::Result<BuildReport> {
    let nothing = || format!("design `{}`: nothing was written", design.name);
    let built = build_parts(design, tolerance_mm, parts).with_context(nothing)?;
    let fibers = check_assembly(design, &built).with_context(nothing)?;
    let tol = tolerance_mm.unwrap_or(design.printer.default_tolerance_mm());
    let rendered = export::render(design, &built, tol, fibers.as_deref())?;
    let files = export::write_all(dir, &rendered)?;
    Ok(BuildReport {
        dir: dir.to_path_buf(),
        parts: built,
        files,
        fibers: fibers.unwrap_or_default(),
    })
}
