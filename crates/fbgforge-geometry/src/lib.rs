//! Printable parts of a design: B-rep solids, checked meshes and exact volumes.
//!
//! [`DesignProfile`] derives every dimension of a design once per build;
//! [`registry::PARTS`] lists the printable parts (`cap`, `core`, `insert-<name>` for
//! each insert, `mold` and `mold-plug` for an array), each with its builder.
//! [`build_solids_for`] builds the selected parts' B-rep solids from the profile;
//! [`build_parts_for`] meshes them at a chord tolerance and runs every mesh check,
//! including agreement of the mesh volume with the closed-form volume. Nothing here
//! writes files but [`build_design`]: [`export`] turns checked parts into STL, STEP, 3MF
//! and a manifest, with the drawings the caller's [`BuildSink`] makes of them (the
//! cut-away previews are `fbgforge-report`'s), written only once every part has passed.

// Sibling crates under the names the modules used inside one crate.
#[allow(unused_imports)]
use fbgforge_core::{design, family, grating, logs, output, profile, progress, spec};

pub mod assembly;
pub mod brep;
pub mod design_profile;
pub mod export;
pub mod fits;
pub mod gaps;
pub mod mesh;
pub mod meshing;
pub mod module;
pub mod mold;
pub mod mold_plug;
pub mod part;
pub mod print_notes;
pub mod refine;
pub mod registry;
pub mod step_assembly;
mod step_text;
pub mod threemf;
mod triangle;

pub use design_profile::DesignProfile;
pub use part::{BuiltSolid, PartKind, Print, PrintablePart};
pub use registry::part_names;

use crate::spec::{Design, SpecError};
use anyhow::Context;
use mesh::{MeshError, TriMesh};
use registry::PARTS;
use std::path::{Path, PathBuf};
use truck_modeling::Solid;

pub use meshing::VOLUME_TOLERANCE_AT_DEFAULT;

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
    /// A requested tolerance at which a part does not mesh.
    #[error(transparent)]
    TooCoarse(#[from] Box<meshing::ToleranceTooCoarse>),
    /// A designed gap the meshes cannot keep.
    #[error(transparent)]
    GapEaten(#[from] Box<meshing::GapEaten>),
    /// A tolerance outside the range truck can mesh with.
    #[error("field `BuildRequest.tolerance_mm`: meshing tolerance {0} mm is out of range; allowed 0.001 to 1 mm")]
    Tolerance(f64),
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

/// Build the B-rep solids of the selected parts (all when `selection` is None).
pub fn build_solids(
    design: &Design,
    selection: Option<&[String]>,
) -> Result<Vec<PartSolid>, GeometryError> {
    build_solids_for(&DesignProfile::new(design), selection)
}

/// [`build_solids`] from dimensions already derived. Parts of one kind share a solid:
/// the inserts differ only in material.
pub(crate) fn build_solids_for(
    profile: &DesignProfile,
    selection: Option<&[String]>,
) -> Result<Vec<PartSolid>, GeometryError> {
    let names = check_selection(profile.design, selection)?;
    if let Some(m) = &profile.module {
        m.check_buildable()?;
    }
    let mut out = Vec::new();
    for part in PARTS {
        let chosen: Vec<String> = part
            .names(profile.design)
            .into_iter()
            .filter(|n| names.contains(n))
            .collect();
        let Some(first) = chosen.first() else {
            continue;
        };
        let s = part.solid(profile, first)?;
        for name in chosen {
            out.push(PartSolid {
                name,
                kind: part.kind(),
                solid: s.solid.clone(),
                exact_volume_mm3: s.exact_volume_mm3,
            });
        }
    }
    Ok(out)
}

/// Build, mesh and check the selected parts at `tol_mm` ([`default_tolerance_for`] when
/// None). Parts sharing a solid are meshed once. Fails on the first bad part.
pub fn build_parts(
    design: &Design,
    tol_mm: Option<f64>,
    selection: Option<&[String]>,
) -> Result<Vec<BuiltPart>, GeometryError> {
    build_parts_for(&DesignProfile::new(design), tol_mm, selection)
}

/// The meshing tolerance used when none is given: the printer's (half its
/// resolution), mm. The surfaces facing a designed gap are meshed finer where the gap
/// needs it ([`meshing`]).
pub(crate) fn default_tolerance_for(profile: &DesignProfile) -> f64 {
    profile.design.printer.default_tolerance_mm()
}

/// [`build_parts`], with every designed gap of the built parts as the meshes keep it
/// (fits between mating parts, fiber passages round a revolved wall).
///
/// ```
/// let d = fbgforge_core::design::load(std::path::Path::new(concat!(
///     env!("CARGO_MANIFEST_DIR"),
///     "/../../designs/clip-on-10mm.toml"
/// )))
/// .unwrap();
/// let sel = ["cap".to_string(), "core".into()];
/// let (parts, gaps) = fbgforge_geometry::build_parts_measured(&d, None, Some(&sel)).unwrap();
/// assert_eq!(parts.len(), 2);
/// assert!(gaps.iter().all(|g| g.meshed_gap_mm >= 0.8 * g.designed_gap_mm));
/// ```
pub fn build_parts_measured(
    design: &Design,
    tol_mm: Option<f64>,
    selection: Option<&[String]>,
) -> Result<(Vec<BuiltPart>, Vec<gaps::MeshedGap>), GeometryError> {
    mesh_parts_for(&DesignProfile::new(design), tol_mm, selection)
}

/// [`build_parts`] from dimensions already derived.
pub(crate) fn build_parts_for(
    profile: &DesignProfile,
    tol_mm: Option<f64>,
    selection: Option<&[String]>,
) -> Result<Vec<BuiltPart>, GeometryError> {
    Ok(mesh_parts_for(profile, tol_mm, selection)?.0)
}

/// Build and mesh the selected parts (each distinct solid once), with every designed
/// gap measured on the meshes ([`meshing::mesh_solids`]).
pub(crate) fn mesh_parts_for(
    profile: &DesignProfile,
    tol_mm: Option<f64>,
    selection: Option<&[String]>,
) -> Result<(Vec<BuiltPart>, Vec<gaps::MeshedGap>), GeometryError> {
    let tol = tol_mm.unwrap_or_else(|| default_tolerance_for(profile));
    if !(0.001..=1.0).contains(&tol) {
        return Err(GeometryError::Tolerance(tol));
    }
    let solids = build_solids_for(profile, selection)?;
    let (meshed, gaps) = meshing::mesh_solids(profile, &solids, tol)?;
    let mut out = Vec::with_capacity(solids.len());
    for s in &solids {
        let m = meshed
            .iter()
            .find(|b| b.kind == s.kind)
            .expect("every kind was meshed");
        let mut b = m.clone();
        b.name = s.name.clone();
        out.push(b);
    }
    Ok((out, gaps))
}

/// What a build is asked for besides the design and the folder.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BuildRequest {
    /// Meshing chord tolerance, mm ([`default_tolerance_for`] when `None`).
    pub tolerance_mm: Option<f64>,
    /// The parts to build, by name (`cap`, `core`, `insert-<name>`, `mold`,
    /// `mold-plug`; every part of the design when `None`).
    pub parts: Option<Vec<String>>,
}

/// A build's checked parts before any file is written: what its drawings are made of.
#[derive(Debug, Clone, Copy)]
pub struct CheckedBuild<'a> {
    /// The design and its derived dimensions.
    pub profile: &'a DesignProfile<'a>,
    /// Every part built, meshed and checked.
    pub parts: &'a [BuiltPart],
    /// Each fiber's traced way out, when the whole module was built.
    pub fibers: Option<&'a [assembly::FiberTrace]>,
    /// Every designed gap measured on the meshes.
    pub gaps: &'a [gaps::MeshedGap],
}

/// Where a build's results go; every method has a no-op default.
pub trait BuildSink {
    /// Drawings of the checked parts to write beside them, as (file name, bytes):
    /// asked once every part has passed and before the first file is written, so the
    /// manifest lists them (`previews`).
    fn drawings(&mut self, _build: &CheckedBuild) -> anyhow::Result<Vec<(String, Vec<u8>)>> {
        Ok(Vec::new())
    }
    /// The build, once written.
    fn built(&mut self, _design: &Design, _report: &BuildReport) -> anyhow::Result<()> {
        Ok(())
    }
}

impl BuildSink for () {}

impl<A: BuildSink, B: BuildSink> BuildSink for (A, B) {
    fn drawings(&mut self, build: &CheckedBuild) -> anyhow::Result<Vec<(String, Vec<u8>)>> {
        let mut d = self.0.drawings(build)?;
        d.extend(self.1.drawings(build)?);
        Ok(d)
    }
    fn built(&mut self, design: &Design, report: &BuildReport) -> anyhow::Result<()> {
        self.0.built(design, report)?;
        self.1.built(design, report)
    }
}

impl<S: BuildSink + ?Sized> BuildSink for &mut S {
    fn drawings(&mut self, build: &CheckedBuild) -> anyhow::Result<Vec<(String, Vec<u8>)>> {
        (**self).drawings(build)
    }
    fn built(&mut self, design: &Design, report: &BuildReport) -> anyhow::Result<()> {
        (**self).built(design, report)
    }
}

/// A sink that hears every build with `warnings` added to the report's: what a model
/// above this floor found about the design (e.g. a grating that stops being one clean
/// peak inside the force range, `fbgforge_model::prediction::spectrum::design_warnings`),
/// stated where the build's own warnings are.
pub struct WithWarnings<S> {
    /// Warnings to add, in words.
    pub warnings: Vec<String>,
    /// The sink that hears the build.
    pub sink: S,
}

impl<S: BuildSink> BuildSink for WithWarnings<S> {
    fn drawings(&mut self, build: &CheckedBuild) -> anyhow::Result<Vec<(String, Vec<u8>)>> {
        self.sink.drawings(build)
    }
    fn built(&mut self, design: &Design, report: &BuildReport) -> anyhow::Result<()> {
        if self.warnings.is_empty() {
            return self.sink.built(design, report);
        }
        let mut r = report.clone();
        r.warnings.extend(self.warnings.iter().cloned());
        self.sink.built(design, &r)
    }
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
    /// Every designed gap (fits and fiber passages) measured on the written meshes
    /// (those whose parts were built).
    pub gaps: Vec<gaps::MeshedGap>,
    /// What the lab must know before using the parts (nothing holding the cap on).
    pub warnings: Vec<String>,
}

/// Trace the fibers and check the assembly when the whole module was built (cap, core
/// and, if the design has any, an insert); None otherwise.
pub fn check_assembly(
    design: &Design,
    built: &[BuiltPart],
) -> Result<Option<Vec<assembly::FiberTrace>>, GeometryError> {
    check_assembly_for(&DesignProfile::new(design), built)
}

/// [`check_assembly`] from dimensions already derived: the fits and every fiber's
/// passages on exact dimensions first (independent of the meshes), then the meshes of
/// every mating pair against each other (all but press fits, which meshes cannot
/// show), then each fiber traced through the meshes. (Each designed gap has been
/// measured on the meshes while they were made: [`meshing`].)
pub(crate) fn check_assembly_for(
    profile: &DesignProfile,
    built: &[BuiltPart],
) -> Result<Option<Vec<assembly::FiberTrace>>, GeometryError> {
    if profile.module.is_none() {
        return Ok(None);
    }
    // Every module part the design has must have been built.
    let whole = PARTS
        .iter()
        .filter(|p| p.in_module())
        .all(|p| p.names(profile.design).is_empty() || built.iter().any(|b| b.kind == p.kind()));
    if !whole {
        return Ok(None);
    }
    let module: Vec<BuiltPart> = built
        .iter()
        .filter(|b| b.kind.part().in_module())
        .cloned()
        .collect();
    let (fits, _) = fits::check_exact(profile)?;
    // A pair designed to touch somewhere (a press fit) is not compared on its meshes:
    // its exact fit above is the check.
    let press_fit = |a: PartKind, b: PartKind| {
        fits.iter()
            .any(|f| ((f.outer, f.inner) == (a, b) || (f.inner, f.outer) == (a, b)) && f.press_fit)
    };
    assembly::check_no_interference(&module, &|a, b| !press_fit(a, b))?;
    Ok(Some(assembly::trace_fibers_for(profile, &module)?))
}

/// Build a loaded design into `dir`: every part is built, meshed and checked and every
/// file rendered in memory (with the drawings `sink` makes of the checked parts) before
/// the first file is written; then `sink` hears what was written. The design's
/// dimensions are derived once, here, and lent to every step.
///
/// ```
/// use fbgforge_geometry::{build_design, BuildRequest};
///
/// let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
/// let design = fbgforge_core::design::load(&root.join("designs/clip-on-10mm.toml"))?;
/// let dir = tempfile::tempdir()?;
/// let request = BuildRequest {
///     tolerance_mm: None,
///     parts: Some(vec!["cap".into()]),
/// };
/// let r = build_design(&design, dir.path(), &request, &mut ())?;
/// // One part, its mesh within the volume bound of the exact solid, and its files
/// // (STL, STEP, the 3MF plate, the manifest last) written.
/// assert_eq!(r.parts.len(), 1);
/// assert!(r.parts[0].volume_error().abs() <= fbgforge_geometry::VOLUME_TOLERANCE_AT_DEFAULT);
/// assert!(r.files.iter().all(|f| f.is_file()));
/// assert!(r.files.last().unwrap().ends_with("manifest.json"));
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn build_design(
    design: &Design,
    dir: &Path,
    request: &BuildRequest,
    sink: &mut dyn BuildSink,
) -> anyhow::Result<BuildReport> {
    let nothing = || format!("design `{}`: nothing was written", design.name);
    let profile = DesignProfile::new(design);
    // Derived once: the parts are meshed at it and the manifest states it.
    let tol = request
        .tolerance_mm
        .unwrap_or_else(|| default_tolerance_for(&profile));
    let (built, gaps) =
        mesh_parts_for(&profile, Some(tol), request.parts.as_deref()).with_context(nothing)?;
    let fibers = check_assembly_for(&profile, &built).with_context(nothing)?;
    let drawings = sink.drawings(&CheckedBuild {
        profile: &profile,
        parts: &built,
        fibers: fibers.as_deref(),
        gaps: &gaps,
    })?;
    let rendered = export::render(
        &profile,
        &export::Checked {
            parts: &built,
            tolerance_mm: tol,
            fibers: fibers.as_deref(),
            gaps: &gaps,
        },
        drawings,
    )?;
    let files = export::write_all(dir, &rendered)?;
    let report = BuildReport {
        dir: dir.to_path_buf(),
        parts: built,
        files,
        fibers: fibers.unwrap_or_default(),
        gaps,
        warnings: rendered
            .manifest
            .retention
            .iter()
            .filter_map(|r| r.warning().map(String::from))
            .collect(),
    };
    sink.built(design, &report)?;
    Ok(report)
}
