//! The clip-on module as an axisymmetric finite-element problem: mesh, materials,
//! supports, ties and the apex load, all from [`ModuleProfile`].
//!
//! # Mesh
//! Every wall of the module is an offset of the cap's outer surface: a cylinder of
//! radius r_b up to its junction with a sphere of radius ρ_b about the common dome
//! centre (0, z_c) (see `crate::profile`). The mesher therefore uses one meridian
//! coordinate s for all walls: the height z below z_c, and above it the polar angle θ
//! of a ray from the dome centre (θ = 0 horizontal, θ = 90° on the axis). A point of
//! wall b at station θ lies on that ray at distance min(ρ_b, r_b / cos θ), i.e. on the
//! cylinder below the junction and on the sphere above it. All walls share the same
//! stations, so nodes facing each other across a clearance sit on the same ray and can
//! be tied one to one. The layers, from the outside in:
//!
//! | layer | radii | material |
//! |---|---|---|
//! | cap | cap outer → cap inner, to the axis | cap |
//! | clearance ring | cap inner → pillar outer (if clearance > 0), to the pillar top | cap's alignment pillars, smeared |
//! | groove ring | pillar outer → groove bottom, to the pillar top | core pillar flanks + cap pillar, smeared |
//! | web ring | groove bottom → core outer, to the pillar top | core pillar web (holds the fiber), smeared |
//! | core | core outer → core inner, to the top hole | core |
//! | insert (Case I) | solid, to the axis: an O-grid (square + two ray blocks) above z_c and a rectangle below | insert |
//!
//! # Pillars
//! The pillars are not axisymmetric. They are replaced by rings whose modulus is the
//! material's modulus times the pillars' angular fill fraction at the layer's mid
//! radius, count · width / (2π r) (Voigt sum where a layer holds core flanks and the
//! cap's alignment pillar). Such a ring has the pillars' axial stiffness E·A and the
//! same shear area for passing load between cap and core, which is what carries the
//! force to the gratings; it adds a small hoop stiffness the real pillars do not have.
//!
//! # Contacts, supports, load
//! - Cap, pillars and core are one body (the pillar rings are bonded to both walls:
//!   the paper's "no sliding between CC and PSC"), [`PillarCoupling::Bonded`]. The
//!   alternative [`PillarCoupling::BaseClip`] lets the cap slide axially over the
//!   pillars' outer face except in a clip band at the base: the closed form's
//!   series load path.
//! - Above the pillars, the cap's dome and the core's dome are one cap/core clearance
//!   apart in the printed geometry (0.1 mm in the paper design; the profile puts the
//!   core's dome sphere just inside the cap's). [`DomeContact::Gap`] keeps that gap
//!   (the force reaches the core only through the pillars); [`DomeContact::Tied`] ties
//!   all facing dome nodes; [`DomeContact::ApexPatch`] (default) ties them within the
//!   apex contact patch, radius = apex flat radius + cap wall / 2, so that the force
//!   reaches the core's dome there (the paper's assumption 2, and the closed form's
//!   direct path). A tie spans the printed gap as a rigid link.
//! - Case I: the insert stands on the table (u_z = 0 on its base, free to slide
//!   radially); cap and core hang free. The insert is tied to the core across the
//!   insert clearance: on the dome always in both components; on the cylinder either
//!   in both ([`InsertContact::Bonded`]) or in u_r only ([`InsertContact::SlidingWall`],
//!   frictionless: "the module extends along the insert freely").
//! - Case II: no insert; the bases of cap, pillar rings and core stand on the table
//!   (u_z = 0, free to slide radially).
//! - The force is a uniform pressure on the projected apex patch of radius
//!   `apex_flat_radius_mm` of the cap's outer surface, pointing down (−z). On the axis
//!   u_r = 0.
//!
//! # Files
//! - `options`: the modelling choices ([`FemOptions`], the contact readings);
//! - mesh generation: `stations` (the common meridian coordinate), `walls` and
//!   `insert` (the meshes of the walls and of the solid insert), `materials` (the
//!   regions' elastic constants, the pillar rings smeared);
//! - `couplings`: supports, ties, contact pairs and the apex load;
//! - this file: the inputs checked and everything assembled into one [`Problem`]
//!   ([`build`]);
//! - `readings`: a grating's strain read from a solution.

mod couplings;
mod insert;
mod materials;
mod options;
mod readings;
mod stations;
mod walls;

pub use options::{
    ContactReading, DomeContact, FemOptions, InsertContact, PillarCoupling, SolverKind,
};
pub use readings::AxialStrainProfile;

use super::contact::ContactPair;
use super::element::ElasticConstants;
use super::mesh::Mesh;
use super::solve::{Problem, R, Z};
use crate::model::LoadCase;
use crate::profile::ModuleProfile;
use crate::spec::Design;
use anyhow::{anyhow, bail, Result};
use couplings::{apex_load, clip_band_coupling, dome_coupling, insert_coupling, Couplings};
use materials::{constants, smeared_materials};
use stations::make_stations;
use std::collections::HashMap;
use std::ops::Range;
use walls::{wall_layers, WallMesh};

/// One assembled module problem with what is needed to read the gratings.
#[derive(Debug, Clone)]
pub struct ModuleModel {
    /// The boundary-value problem (loaded with F = 1 N).
    pub problem: Problem,
    /// Elements of the web ring (the layer holding the fiber holes).
    pub web_elements: Range<usize>,
    /// Radius of the fiber axis, mm.
    pub fiber_radius_mm: f64,
    /// Heights of element boundaries along the fiber below the seam, mm.
    pub z_breaks_mm: Vec<f64>,
    /// Unilateral contact pairs (empty unless a contact reading asks for them): the
    /// problem is then solved by `fem::contact`.
    pub contact_pairs: Vec<ContactPair>,
    /// For each contact pair: whether it lies along the cylinders (else on the domes).
    pub pair_on_cylinders: Vec<bool>,
    /// Every facing pair of dome nodes above the pillars (cap's inner, core's outer
    /// dome), whether tied or not: what a reading with a wider contact zone ties more
    /// of (`fem::solve_configurations` condenses those ties on one factorisation).
    pub dome_pairs: Vec<DomePair>,
}

/// A cap node facing a core node across the domes' clearance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DomePair {
    /// Node on the cap's inner dome.
    pub cap: usize,
    /// Node on the core's outer dome.
    pub core: usize,
    /// Radius of the core's node, mm (a contact zone of radius r ties the pairs with
    /// `radius_mm` ≤ r).
    pub radius_mm: f64,
    /// Whether this model ties the pair.
    pub tied: bool,
}

/// The module read from the design and checked: what the mesher builds from.
struct ModuleInputs<'a> {
    module: &'a crate::spec::Module,
    profile: ModuleProfile,
    cap: ElasticConstants,
    core: ElasticConstants,
    /// The insert's material (Case I only).
    insert: Option<ElasticConstants>,
    /// Radius of the apex contact patch between the domes, mm.
    patch_radius_mm: f64,
    /// Height of the clip band when the cap is not bonded to the pillars, mm.
    clip_mm: Option<f64>,
}

/// Read the module, its materials and the contact geometry, and check the mesh options.
fn module_inputs<'a>(
    design: &'a Design,
    core_material: &str,
    insert_material: Option<&str>,
    case: LoadCase,
    opt: &FemOptions,
) -> Result<ModuleInputs<'a>> {
    let m = design
        .module
        .as_ref()
        .ok_or_else(|| anyhow!("the design has no [module] section"))?;
    let sizes_ok = [opt.element_size_mm, opt.dome_element_size_mm]
        .iter()
        .all(|v| v.is_finite() && *v > 0.0);
    if !sizes_ok || opt.elements_through_wall == 0 {
        bail!("finite-element options: element size must be > 0 mm and at least one element through a wall");
    }
    if let Some(d) = opt.reference_diameter_mm {
        if !(d.is_finite() && d > 0.0) {
            bail!("finite-element options: the reference diameter must be a positive number of mm, got {d}");
        }
    }
    let p = ModuleProfile::from_module(m);
    let cap = constants(design.material(&m.cap_material, "module.cap_material")?);
    let core = constants(design.material(core_material, "module.cores[].material")?);
    let insert = match (case, insert_material) {
        (LoadCase::I, Some(k)) => Some(constants(design.material(k, "module.inserts[].material")?)),
        (LoadCase::I, None) => bail!("Case I needs an insert, and none was given"),
        (LoadCase::II, _) => None,
    };
    let patch_radius_mm = match opt.dome_contact_radius_mm {
        None => p.apex_flat_radius_mm + 0.5 * m.cap_wall_mm,
        Some(r) if r.is_finite() && r > 0.0 && r < p.core_dome_outer_sphere_radius_mm => r,
        Some(r) => bail!(
            "the domes' contact radius must lie between 0 and the core's dome radius {:.3} mm, got {r} mm",
            p.core_dome_outer_sphere_radius_mm
        ),
    };
    let clip_mm = match opt.pillar_coupling {
        PillarCoupling::Bonded => None,
        _ => Some(opt.clip_height_mm.unwrap_or(m.cap_wall_mm)),
    };
    Ok(ModuleInputs {
        module: m,
        profile: p,
        cap,
        core,
        insert,
        patch_radius_mm,
        clip_mm,
    })
}

/// The region materials [`build`] gives the problem of this core (and insert): the
/// mesh, ties and supports do not depend on them, so the problem of another core or
/// insert on the same geometry is the same mesh with these materials.
pub fn materials(
    design: &Design,
    core_material: &str,
    insert_material: Option<&str>,
    case: LoadCase,
    opt: &FemOptions,
) -> Result<Vec<ElasticConstants>> {
    let inputs = module_inputs(design, core_material, insert_material, case, opt)?;
    let sliding = opt.pillar_coupling != PillarCoupling::Bonded;
    Ok(smeared_materials(
        inputs.module,
        &inputs.profile,
        inputs.cap,
        inputs.core,
        inputs.insert,
        sliding,
    ))
}

/// Build the module problem for one core (and insert in Case I), loaded by 1 N.
pub fn build(
    design: &Design,
    core_material: &str,
    insert_material: Option<&str>,
    case: LoadCase,
    opt: &FemOptions,
) -> Result<ModuleModel> {
    let inputs = module_inputs(design, core_material, insert_material, case, opt)?;
    let (m, p) = (inputs.module, &inputs.profile);
    let scale = size_scale(m, opt);
    let (h, fiber_r) = (opt.element_size_mm * scale, p.fiber_hole_center_radius_mm);
    let dome_h = opt.dome_element_size_mm * scale;
    let s = make_stations(
        p,
        (h, dome_h),
        fiber_r,
        (inputs.patch_radius_mm, &opt.dome_station_radii_mm),
        inputs.clip_mm,
    )?;
    let sliding = opt.pillar_coupling != PillarCoupling::Bonded;
    let materials = smeared_materials(m, p, inputs.cap, inputs.core, inputs.insert, sliding);
    let walls = wall_layers(m, p, &s, opt);
    let mut wm = WallMesh {
        mesh: Mesh::default(),
        node_of: HashMap::new(),
        dlines: &walls.dlines,
        stations: &s,
        zc: p.dome_center_z_mm,
    };
    let (web_elements, base_nodes) = wm.mesh_layers(&walls);
    let mut c = Couplings::default();
    if case == LoadCase::II {
        c.fixed.extend(base_nodes.iter().map(|&b| (b, Z)));
    }
    if let Some(dl) = walls.split {
        clip_band_coupling(&mut wm, dl, m, opt, &mut c)?;
    }
    let cylinder_pairs = c.contact_pairs.len();
    let dome_pairs = dome_coupling(&mut wm, &walls, opt, &mut c);
    if inputs.insert.is_some() {
        insert_coupling(&mut wm, &walls, p, h, opt, &mut c);
    }
    // Axis: no radial motion.
    for (i, q) in wm.mesh.nodes.iter().enumerate() {
        if q[0].abs() < 1e-9 {
            c.fixed.push((i, R));
        }
    }
    let loads = apex_load(&mut wm, p);
    let mesh = wm.mesh;
    Ok(ModuleModel {
        problem: Problem {
            mesh,
            materials,
            formulation: opt.formulation,
            fixed: c.fixed,
            ties: c.ties,
            interpolations: c.interpolations,
            loads,
        },
        web_elements,
        fiber_radius_mm: fiber_r,
        z_breaks_mm: s.z_breaks,
        pair_on_cylinders: (0..c.contact_pairs.len())
            .map(|i| i < cylinder_pairs)
            .collect(),
        contact_pairs: c.contact_pairs,
        dome_pairs,
    })
}

/// What every element size of `opt` is multiplied by on module `m`: its diameter over
/// the options' reference diameter (1 when the sizes are absolute).
pub fn size_scale(m: &crate::spec::Module, opt: &FemOptions) -> f64 {
    opt.reference_diameter_mm
        .map_or(1.0, |d| m.outer_diameter_mm / d)
}
