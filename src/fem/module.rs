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

use super::contact::ContactPair;
use super::element::{ElasticConstants, Formulation};
use super::mesh::{edge_forces, edge_param_at_radius, Mesh};
use super::solve::{EnvelopeCholesky, LinearSolver, Problem, Solution, SparseCholesky, R, Z};
use crate::model::LoadCase;
use crate::profile::ModuleProfile;
use crate::spec::{CylinderCoupling, Design, Material};
use anyhow::{anyhow, bail, Result};
use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use std::ops::Range;

/// How the insert meets the core's inner wall (Case I).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InsertContact {
    /// Bonded over the whole interface (no sliding anywhere).
    Bonded,
    /// Bonded on the dome, frictionless (radial tie only) along the cylinder.
    SlidingWall,
}

/// Whether the cap's dome presses on the core's dome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DomeContact {
    /// The printed gap stays open: the force passes through the pillars only.
    Gap,
    /// Facing dome nodes tied over the whole dome (cap and core touch everywhere).
    Tied,
    /// Facing dome nodes tied within the apex contact patch only: the apex flat widened
    /// through half the cap wall, radius = apex flat radius + cap wall / 2 (the same
    /// patch as the closed form's direct path). Default.
    ApexPatch,
    /// Unilateral contact across the printed clearance: every facing pair of dome nodes
    /// may touch and push but never pull, and touches only once its gap has closed
    /// (`fem::contact`). The contact zone grows with the force.
    Unilateral,
}

/// How the pillars couple cap and core along the cylinder.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PillarCoupling {
    /// Pillar rings bonded to cap and core over their whole length (the paper's "no
    /// sliding between CC and PSC"). Default.
    Bonded,
    /// The cap slides axially over the core's pillars (radial contact only) and is
    /// bonded to them only in a clip band at the base, one cap wall high: the load
    /// path the closed form assumes (cap and core in series through the base clip).
    BaseClip,
    /// Bonded in the clip band at the base; above it cap and core meet in unilateral,
    /// frictionless contact across the printed radial clearance (`fem::contact`): they
    /// may push each other apart but not pull, and touch only once the gap has closed.
    BaseClipContact,
}

/// A reading of how cap and core touch and are held together: the contact choices of
/// [`FemOptions`] that the model policy (`crate::prediction`) solves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactReading {
    /// The design's `[module.contact]`: cylinders sliding above the base clip (or
    /// bonded); in Case I the domes bear on each other within the design's contact
    /// radius, in Case II over the whole dome (no insert holds the hollow core's dome
    /// up, so the cap's dome presses all of it). The nominal prediction.
    Design,
    /// Pillars bonded to cap and core along their length, domes tied over the apex
    /// patch (the paper's literal "no sliding"): the most tightly coupled reading,
    /// lower end of Case I's band.
    BondedPillars,
    /// Cylinders sliding above the base clip, the domes touching over the apex patch
    /// only: the least coupled reading with the domes in contact, upper end of Case I's
    /// band.
    SlidingApexPatch,
    /// Cylinders as the design says (sliding: unilateral contact across the printed
    /// radial clearance above the clip), domes in unilateral contact across the printed
    /// dome clearance: the contact zone grows with the force, so K depends on F.
    Unilateral,
}

impl ContactReading {
    /// Short description for tables and reports.
    pub fn describe(self, m: &crate::spec::Module, case: LoadCase) -> String {
        let clip = m.clip_height_mm();
        let cyl = match m.contact.cylinders {
            CylinderCoupling::Sliding => {
                format!("cylinders sliding above a {clip:.2} mm base clip")
            }
            CylinderCoupling::Bonded => "pillars bonded to the cap".to_string(),
        };
        match self {
            ContactReading::Design if case == LoadCase::II => {
                format!("{cyl}, domes in contact over the whole dome (Case II)")
            }
            ContactReading::Design => format!(
                "{cyl}, domes in contact within r = {:.3} mm",
                m.dome_contact_radius_mm()
            ),
            ContactReading::BondedPillars => format!(
                "pillars bonded to the cap, domes tied over the apex patch (r = {:.3} mm)",
                m.apex_patch_radius_mm()
            ),
            ContactReading::SlidingApexPatch => format!(
                "cylinders sliding above a {clip:.2} mm base clip, domes touching over the apex patch only (r = {:.3} mm)",
                m.apex_patch_radius_mm()
            ),
            ContactReading::Unilateral => format!(
                "{cyl}, unilateral contact across the printed {:.3} mm dome clearance",
                m.dome_clearance_mm()
            ),
        }
    }
}

/// Mesh density and modelling choices of a finite-element solve.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FemOptions {
    /// Target element size along the cylinders (and radially in the insert), mm.
    pub element_size_mm: f64,
    /// Target element size along the domes' meridian, mm. The domes carry the load by
    /// bending and membrane action near the apex contact and decide how the force is
    /// shared, so they need finer elements than the cylinders' smooth far field.
    pub dome_element_size_mm: f64,
    /// Elements through the thinner of the cap and core walls (thinner layers get
    /// at least one).
    pub elements_through_wall: usize,
    /// Insert/core contact in Case I.
    pub insert_contact: InsertContact,
    /// Cap/core dome contact.
    pub dome_contact: DomeContact,
    /// Cap/core coupling along the pillars.
    pub pillar_coupling: PillarCoupling,
    /// Radius of the zone around the apex over which the domes bear on each other with
    /// [`DomeContact::ApexPatch`] (measured on the core's outer dome), mm; `None`: the
    /// apex contact patch, apex flat radius + cap wall / 2.
    #[serde(default)]
    pub dome_contact_radius_mm: Option<f64>,
    /// Height of the clip band at the base where cap and core are bonded when the
    /// pillars are not ([`PillarCoupling::BaseClip`], [`PillarCoupling::BaseClipContact`]),
    /// mm; `None`: one cap wall.
    #[serde(default)]
    pub clip_height_mm: Option<f64>,
    /// Mixed (locking-free) or plain displacement elements.
    #[serde(skip, default = "default_formulation")]
    pub formulation: Formulation,
    /// Linear solver.
    pub solver: SolverKind,
    /// When set, also solve a mesh twice as coarse and extrapolate each grating's
    /// strain as ε_h + (ε_h − ε_2h) / (2^p − 1) with this order p (Richardson). The
    /// apex-patch tie of Case I converges at a low order (0.5 to 1.2 measured), so
    /// p = 1 removes most of the discretisation error for a 15 % longer solve.
    #[serde(default)]
    pub richardson_order: Option<f64>,
}

/// Which linear solver factorises the stiffness matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SolverKind {
    /// [`EnvelopeCholesky`] (default: fastest here).
    Envelope,
    /// [`SparseCholesky`] from nalgebra-sparse.
    Sparse,
}

impl SolverKind {
    /// The solver behind the name.
    pub fn solver(self) -> &'static dyn LinearSolver {
        match self {
            SolverKind::Envelope => &EnvelopeCholesky,
            SolverKind::Sparse => &SparseCholesky,
        }
    }
}

fn default_formulation() -> Formulation {
    Formulation::MixedQ9P1
}

impl Default for FemOptions {
    /// Level 1 with two-level Richardson extrapolation (order 1) from level 0.
    fn default() -> Self {
        FemOptions {
            richardson_order: Some(1.0),
            ..FemOptions::level(1)
        }
    }
}

impl FemOptions {
    /// The same options on a mesh twice as coarse (sizes doubled, half the elements
    /// through a wall, at least one), without extrapolation.
    pub fn coarsened(&self) -> Self {
        FemOptions {
            element_size_mm: 2.0 * self.element_size_mm,
            dome_element_size_mm: 2.0 * self.dome_element_size_mm,
            elements_through_wall: (self.elements_through_wall / 2).max(1),
            richardson_order: None,
            ..*self
        }
    }

    /// These options (mesh, solver) with the contact choices of `reading` for module `m`
    /// in `case`.
    pub fn with_reading(
        self,
        m: &crate::spec::Module,
        reading: ContactReading,
        case: LoadCase,
    ) -> Self {
        let sliding = m.contact.cylinders == CylinderCoupling::Sliding;
        let clip = Some(m.clip_height_mm());
        let (pillar_coupling, dome_contact, radius) = match reading {
            ContactReading::Design => (
                if sliding {
                    PillarCoupling::BaseClip
                } else {
                    PillarCoupling::Bonded
                },
                if case == LoadCase::II {
                    DomeContact::Tied
                } else {
                    DomeContact::ApexPatch
                },
                Some(m.dome_contact_radius_mm()),
            ),
            ContactReading::BondedPillars => (PillarCoupling::Bonded, DomeContact::ApexPatch, None),
            ContactReading::SlidingApexPatch => {
                (PillarCoupling::BaseClip, DomeContact::ApexPatch, None)
            }
            ContactReading::Unilateral => (
                if sliding {
                    PillarCoupling::BaseClipContact
                } else {
                    PillarCoupling::Bonded
                },
                DomeContact::Unilateral,
                None,
            ),
        };
        FemOptions {
            pillar_coupling,
            dome_contact,
            dome_contact_radius_mm: radius,
            clip_height_mm: clip,
            ..self
        }
    }

    /// Refinement levels of the convergence study: level k has cylinder elements of
    /// 4 / 2^k mm, dome elements a quarter of that, and 2^k elements through a wall:
    /// every level halves every element size of the one before (level 1 = default).
    pub fn level(k: u32) -> Self {
        let h = 4.0 / 2f64.powi(k as i32);
        FemOptions {
            element_size_mm: h,
            dome_element_size_mm: h / 4.0,
            elements_through_wall: 1usize << k,
            insert_contact: InsertContact::SlidingWall,
            dome_contact: DomeContact::ApexPatch,
            pillar_coupling: PillarCoupling::Bonded,
            clip_height_mm: None,
            dome_contact_radius_mm: None,
            formulation: Formulation::MixedQ9P1,
            solver: SolverKind::Envelope,
            richardson_order: None,
        }
    }
}

/// Station of the common meridian coordinate.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Station {
    /// Height z ≤ z_c (cylinder section).
    Z(f64),
    /// Polar angle of a ray from the dome centre, radians (0 horizontal).
    Theta(f64),
}

/// A wall surface: cylinder radius and sphere radius (∞ for a pure cylinder), mm.
#[derive(Debug, Clone, Copy)]
struct Surface {
    r: f64,
    rho: f64,
}

fn lerp_surface(a: Surface, b: Surface, t: f64) -> Surface {
    let rho = if t == 0.0 {
        a.rho
    } else if t == 1.0 {
        b.rho
    } else if a.rho.is_infinite() || b.rho.is_infinite() {
        f64::INFINITY
    } else {
        a.rho + (b.rho - a.rho) * t
    };
    Surface {
        r: a.r + (b.r - a.r) * t,
        rho,
    }
}

fn point(s: Surface, st: Station, zc: f64) -> [f64; 2] {
    match st {
        Station::Z(z) => [s.r, z],
        Station::Theta(t) => {
            if (FRAC_PI_2 - t).abs() < 1e-12 {
                return [0.0, zc + s.rho];
            }
            let (sn, c) = t.sin_cos();
            let len = (s.r / c).min(s.rho);
            [len * c, zc + len * sn]
        }
    }
}

/// Doubled meridian stations and the doubled indices of the break points.
struct Stations {
    st: Vec<Station>,
    j_seam: usize,
    j_pillar_top: usize,
    j_45: usize,
    j_hole: usize,
    j_patch: usize,
    j_axis: usize,
    /// Heights of the element boundaries below the seam (for strain integration).
    z_breaks: Vec<f64>,
}

fn make_stations(
    p: &ModuleProfile,
    h: f64,
    h_dome: f64,
    fiber_r: f64,
    patch_r: f64,
    clip_mm: Option<f64>,
) -> Result<Stations> {
    let zc = p.dome_center_z_mm;
    if zc <= 0.0 {
        bail!(
            "the finite-element mesher needs the dome centre above the base (dome centre at z = {zc:.3} mm): use a taller module or a higher dome"
        );
    }
    // Element boundaries along the cylinders: uniform, with one on the clip band's top
    // edge when there is one, so the bonded band ends on a node and K varies
    // continuously with every dimension (a band edge between nodes jumps from node to
    // node as the module changes).
    let mut z_breaks: Vec<f64> = Vec::new();
    let mut segment = |z0: f64, z1: f64, min: usize| {
        let n = (((z1 - z0) / h).ceil() as usize).max(min);
        for k in 0..n {
            z_breaks.push(z0 + (z1 - z0) * k as f64 / n as f64);
        }
    };
    match clip_mm.filter(|c| *c > 0.0 && *c < zc) {
        Some(c) => {
            segment(0.0, c, 1);
            segment(c, zc, 1);
        }
        None => segment(0.0, zc, 2),
    }
    z_breaks.push(zc);
    let mut st: Vec<Station> = Vec::with_capacity(2 * z_breaks.len());
    for w in z_breaks.windows(2) {
        st.push(Station::Z(w[0]));
        st.push(Station::Z(0.5 * (w[0] + w[1])));
    }
    st.push(Station::Z(zc));
    let j_seam = st.len() - 1;
    // Ring top: the ray through the fiber radius at the pillar top.
    // Kept below the rays where the rings' bounding walls (cap inner, core outer) turn
    // onto their spheres, so the rings stay on the cylinders.
    let corner = |r: f64, rho: f64| if r < rho { (r / rho).acos() } else { 0.0 };
    let theta_p = if p.pillar_top_mm > zc + 1e-9 {
        ((p.pillar_top_mm - zc) / fiber_r)
            .atan()
            .min(corner(
                p.cap_inner_radius_mm,
                p.cap_dome_inner_sphere_radius_mm,
            ))
            .min(corner(
                p.core_outer_radius_mm,
                p.core_dome_outer_sphere_radius_mm,
            ))
    } else {
        0.0
    };
    // Core top hole: the ray through the hole edge at the core's mid-wall sphere.
    let rho_mid = 0.5 * (p.core_dome_outer_sphere_radius_mm + p.core_dome_inner_sphere_radius_mm);
    let theta_h = (p.top_hole_radius_mm / rho_mid).clamp(0.0, 1.0).acos();
    // Apex contact patch edge on the core's outer dome (kept below the hole's ray).
    let theta_c = (patch_r / p.core_dome_outer_sphere_radius_mm)
        .clamp(0.0, 1.0)
        .acos()
        .min(theta_h);
    let mut breaks = vec![0.0, theta_p, FRAC_PI_4, theta_c, theta_h, FRAC_PI_2];
    // For a dome flatter than a hemisphere each wall surface turns a corner where its
    // cylinder meets its sphere; a station on each corner's ray keeps quadratic
    // elements from spanning (and folding over) a corner.
    for (r, rho) in [
        (p.cap_outer_radius_mm, p.cap_dome_outer_sphere_radius_mm),
        (p.cap_inner_radius_mm, p.cap_dome_inner_sphere_radius_mm),
        (p.core_outer_radius_mm, p.core_dome_outer_sphere_radius_mm),
        (p.core_inner_radius_mm, p.core_dome_inner_sphere_radius_mm),
        (p.insert_radius_mm, p.insert_sphere_radius_mm),
    ] {
        if r < rho {
            let t = (r / rho).acos();
            if t > 1e-4 && t < theta_c {
                breaks.push(t);
            }
        }
    }
    breaks.sort_by(|a, b| a.total_cmp(b));
    breaks.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    let rho_ref = p.cap_dome_outer_sphere_radius_mm;
    let mut idx = HashMap::new();
    for w in breaks.windows(2) {
        let n = ((rho_ref * (w[1] - w[0]) / h_dome).ceil() as usize).max(1);
        for k in 1..=2 * n {
            st.push(Station::Theta(
                w[0] + (w[1] - w[0]) * k as f64 / (2 * n) as f64,
            ));
        }
        idx.insert((w[1] * 1e6).round() as i64, st.len() - 1);
    }
    idx.insert(0, j_seam);
    let find = |t: f64| -> usize {
        breaks
            .iter()
            .find(|b| (**b - t).abs() < 1e-6)
            .and_then(|b| idx.get(&((b * 1e6).round() as i64)).copied())
            .unwrap_or(j_seam)
    };
    Ok(Stations {
        j_patch: find(theta_c),
        j_seam,
        j_pillar_top: find(theta_p),
        j_45: find(FRAC_PI_4),
        j_hole: find(theta_h),
        j_axis: st.len() - 1,
        st,
        z_breaks,
    })
}

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
}

fn constants(m: &Material) -> ElasticConstants {
    ElasticConstants {
        youngs_modulus_mpa: m.youngs_modulus_mpa,
        poisson_ratio: m.poisson_ratio,
    }
}

/// Smear materials with angular fill fractions into one ring (Voigt sum of moduli,
/// Poisson's ratio weighted by stiffness share).
fn smeared(parts: &[(ElasticConstants, f64)]) -> ElasticConstants {
    let e: f64 = parts.iter().map(|(m, f)| m.youngs_modulus_mpa * f).sum();
    let nu = parts
        .iter()
        .map(|(m, f)| m.poisson_ratio * m.youngs_modulus_mpa * f)
        .sum::<f64>()
        / e;
    ElasticConstants {
        youngs_modulus_mpa: e,
        poisson_ratio: nu,
    }
}

/// The element materials: 0 cap, 1 clearance ring, 2 groove ring, 3 web ring, 4 core,
/// 5 insert (Case I). The pillar rings smear the pillars over the circumference by
/// their share of it.
fn smeared_materials(
    m: &crate::spec::Module,
    p: &ModuleProfile,
    cap: ElasticConstants,
    core: ElasticConstants,
    insert: Option<ElasticConstants>,
    sliding: bool,
) -> Vec<ElasticConstants> {
    let pl = &m.pillars;
    let n = pl.count as f64;
    let fill = |width: f64, r0: f64, r1: f64| (n * width / (PI * (r0 + r1))).min(1.0);
    let flanks = (
        core,
        fill(
            pl.width_mm - pl.groove_width_mm,
            p.groove_bottom_radius_mm,
            p.pillar_outer_radius_mm,
        ),
    );
    let (ring_clear, ring_groove) = if sliding {
        // The cap's ribs slide in the grooves with the cap, so their axial stiffness
        // must sit on the cap's side of the sliding face: the clearance ring gets the
        // ribs' whole E·A (rib section n · width · groove depth over the ring's
        // section), the groove ring the core's flanks only. Without a clearance ring the
        // ribs' share of the cap's section (≈ 1.5 % in the paper's module) is dropped.
        let ring_area = PI * (p.cap_inner_radius_mm.powi(2) - p.pillar_outer_radius_mm.powi(2));
        let rib_area = n * p.cap_pillar_width_mm * pl.groove_depth_mm;
        let clear = ElasticConstants {
            youngs_modulus_mpa: cap.youngs_modulus_mpa * rib_area / ring_area.max(1e-12),
            poisson_ratio: cap.poisson_ratio,
        };
        (clear, smeared(&[flanks]))
    } else {
        let clear = smeared(&[(
            cap,
            fill(
                p.cap_pillar_width_mm,
                p.pillar_outer_radius_mm,
                p.cap_inner_radius_mm,
            ),
        )]);
        let groove = smeared(&[
            flanks,
            (
                cap,
                fill(
                    p.cap_pillar_width_mm,
                    p.groove_bottom_radius_mm,
                    p.pillar_outer_radius_mm,
                ),
            ),
        ]);
        (clear, groove)
    };
    let ring_web = smeared(&[(
        core,
        fill(
            pl.width_mm,
            p.core_outer_radius_mm,
            p.groove_bottom_radius_mm,
        ),
    )]);
    let mut materials = vec![cap, ring_clear, ring_groove, ring_web, core];
    materials.extend(insert);
    materials
}

/// Mesh the solid insert of Case I: a rectangle below the dome seam, an O-grid (a
/// square and two ray blocks) above it, its base held axially. Returns the node on the
/// insert's surface at each station j (the core's inner wall is tied to them).
fn mesh_insert(
    mesh: &mut Mesh,
    fixed: &mut Vec<(usize, usize)>,
    p: &ModuleProfile,
    s: &Stations,
    h: f64,
    zc: f64,
) -> Vec<usize> {
    let ins_surf = Surface {
        r: p.insert_radius_mm,
        rho: p.insert_sphere_radius_mm,
    };
    let sq = 0.5 * p.insert_radius_mm.min(p.insert_sphere_radius_mm);
    let n_rad = (((p.insert_radius_mm - sq) / h).ceil() as usize).max(1);
    let theta = |j: usize| match s.st[j] {
        Station::Theta(t) => t,
        Station::Z(_) => 0.0,
    };
    let n_e = s.j_45 - s.j_seam; // doubled steps along θ ∈ [0, 45°]
    let n_n = s.j_axis - s.j_45; // doubled steps along θ ∈ [45°, 90°]
                                 // Column abscissae of rectangle and square (doubled): square part then ray part.
    let mut xs: Vec<f64> = (0..=n_n)
        .map(|u| sq / theta(s.j_axis - u).tan().max(1e-300))
        .collect();
    xs[0] = 0.0;
    for k in 1..=2 * n_rad {
        xs.push(sq + (p.insert_radius_mm - sq) * k as f64 / (2 * n_rad) as f64);
    }
    let rect: Vec<Vec<usize>> = xs
        .iter()
        .map(|&x| {
            (0..=s.j_seam)
                .map(|j| {
                    let z = match s.st[j] {
                        Station::Z(z) => z,
                        Station::Theta(_) => zc,
                    };
                    mesh.add_node(x, z)
                })
                .collect()
        })
        .collect();
    mesh.add_block(&rect, 5);
    for col in &rect {
        fixed.push((col[0], Z));
    }
    // Square: columns share x with the rectangle, rows at y = sq tan θ.
    let square: Vec<Vec<usize>> = (0..=n_n)
        .map(|c| {
            (0..=n_e)
                .map(|t| {
                    if t == 0 {
                        rect[c][s.j_seam]
                    } else {
                        mesh.add_node(xs[c], zc + sq * theta(s.j_seam + t).tan())
                    }
                })
                .collect()
        })
        .collect();
    mesh.add_block(&square, 5);
    let ray = |mesh: &mut Mesh, inner: [f64; 2], j: usize, k: usize| {
        let o = point(ins_surf, s.st[j], zc);
        let t = k as f64 / (2 * n_rad) as f64;
        mesh.add_node(
            inner[0] + (o[0] - inner[0]) * t,
            inner[1] + (o[1] - inner[1]) * t,
        )
    };
    // East block: rays θ ∈ [0, 45°] from the square's right side to the surface.
    let east: Vec<Vec<usize>> = (0..=2 * n_rad)
        .map(|k| {
            (0..=n_e)
                .map(|t| {
                    if k == 0 {
                        square[n_n][t]
                    } else if t == 0 {
                        rect[n_n + k][s.j_seam]
                    } else {
                        let th = theta(s.j_seam + t);
                        ray(mesh, [sq, zc + sq * th.tan()], s.j_seam + t, k)
                    }
                })
                .collect()
        })
        .collect();
    mesh.add_block(&east, 5);
    // North block: rays θ ∈ [45°, 90°] from the square's top side to the surface.
    let north: Vec<Vec<usize>> = (0..=2 * n_rad)
        .map(|k| {
            (0..=n_n)
                .map(|u| {
                    if k == 0 {
                        square[n_n - u][n_e]
                    } else if u == 0 {
                        east[k][n_e]
                    } else {
                        ray(mesh, [xs[n_n - u], zc + sq], s.j_45 + u, k)
                    }
                })
                .collect()
        })
        .collect();
    mesh.add_block(&north, 5);
    (0..=s.j_axis)
        .map(|j| {
            if j <= s.j_seam {
                rect[xs.len() - 1][j]
            } else if j <= s.j_45 {
                east[2 * n_rad][j - s.j_seam]
            } else {
                north[2 * n_rad][j - s.j_45]
            }
        })
        .collect()
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

/// One wall layer: its outer d-line, elements through it, last station, material.
#[derive(Debug, Clone, Copy)]
struct Layer {
    first: usize,
    n: usize,
    j_end: usize,
    material: usize,
}

/// The layered walls on shared "d-lines" (curves of constant offset), outside in.
struct Walls {
    dlines: Vec<Surface>,
    layers: Vec<Layer>,
    /// Element thickness through a wall, mm.
    t_el: f64,
    /// With a sliding pillar coupling: the cap side's d-line on the pillars' outer
    /// face (the core side's is the next one).
    split: Option<usize>,
    web_layer: usize,
    cap_inner: usize,
    core_outer: usize,
    core_inner: usize,
}

impl Walls {
    /// Add a layer from the innermost d-line to `inner`, `thk` mm thick; returns its
    /// inner d-line.
    fn add_layer(&mut self, inner: Surface, thk: f64, j_end: usize, material: usize) -> usize {
        let n = ((thk / self.t_el).round() as usize).max(1);
        let outer = *self.dlines.last().expect("at least one d-line");
        let first = self.dlines.len() - 1;
        for k in 1..=2 * n {
            self.dlines
                .push(lerp_surface(outer, inner, k as f64 / (2 * n) as f64));
        }
        self.layers.push(Layer {
            first,
            n,
            j_end,
            material,
        });
        self.dlines.len() - 1
    }
}

/// Lay out the walls: cap, clearance ring, groove ring, web ring, core (materials 0–4).
fn wall_layers(
    m: &crate::spec::Module,
    p: &ModuleProfile,
    s: &Stations,
    opt: &FemOptions,
) -> Walls {
    let cyl = |r: f64| Surface {
        r,
        rho: f64::INFINITY,
    };
    let has_clearance = p.cap_inner_radius_mm - p.pillar_outer_radius_mm > 1e-9;
    let mut w = Walls {
        dlines: vec![Surface {
            r: p.cap_outer_radius_mm,
            rho: p.cap_dome_outer_sphere_radius_mm,
        }],
        layers: Vec::new(),
        t_el: m.cap_wall_mm.min(m.core_wall_mm) / opt.elements_through_wall as f64,
        split: None,
        web_layer: 2 + usize::from(has_clearance),
        cap_inner: 0,
        core_outer: 0,
        core_inner: 0,
    };
    let cap_inner = Surface {
        r: p.cap_inner_radius_mm,
        rho: p.cap_dome_inner_sphere_radius_mm,
    };
    w.cap_inner = w.add_layer(cap_inner, m.cap_wall_mm, s.j_axis, 0);
    if has_clearance {
        let clearance = m.cap_core_clearance_mm;
        w.add_layer(cyl(p.pillar_outer_radius_mm), clearance, s.j_pillar_top, 1);
    }
    // Base clip: the cap side (cap + its alignment pillars) and the core side (core
    // pillars) get separate nodes on the pillar's outer face, tied below.
    if opt.pillar_coupling != PillarCoupling::Bonded {
        let outer = *w.dlines.last().expect("d-lines");
        w.dlines.push(outer);
        w.split = Some(w.dlines.len() - 2);
    }
    let groove = m.pillars.groove_depth_mm;
    w.add_layer(cyl(p.groove_bottom_radius_mm), groove, s.j_pillar_top, 2);
    let core_outer = Surface {
        r: p.core_outer_radius_mm,
        rho: p.core_dome_outer_sphere_radius_mm,
    };
    let web = p.groove_bottom_radius_mm - p.core_outer_radius_mm;
    w.core_outer = w.add_layer(core_outer, web, s.j_pillar_top, 3);
    let core_inner = Surface {
        r: p.core_inner_radius_mm,
        rho: p.core_dome_inner_sphere_radius_mm,
    };
    w.core_inner = w.add_layer(core_inner, m.core_wall_mm, s.j_hole, 4);
    w
}

/// The mesh being built, with the node at each (d-line, station) made once.
struct WallMesh<'a> {
    mesh: Mesh,
    node_of: HashMap<(usize, usize), usize>,
    dlines: &'a [Surface],
    stations: &'a Stations,
    zc: f64,
}

impl WallMesh<'_> {
    /// The node on d-line `dl` at station `j`.
    fn node(&mut self, dl: usize, j: usize) -> usize {
        let (mesh, q) = (
            &mut self.mesh,
            point(self.dlines[dl], self.stations.st[j], self.zc),
        );
        *self
            .node_of
            .entry((dl, j))
            .or_insert_with(|| mesh.add_node(q[0], q[1]))
    }

    /// Mesh every wall layer; returns the web ring's elements and the nodes on the base.
    fn mesh_layers(&mut self, walls: &Walls) -> (Range<usize>, Vec<usize>) {
        let mut web_elements = 0..0;
        let mut base_nodes = Vec::new();
        for (li, l) in walls.layers.iter().enumerate() {
            let ids: Vec<Vec<usize>> = (0..=2 * l.n)
                .map(|i| (0..=l.j_end).map(|j| self.node(l.first + i, j)).collect())
                .collect();
            base_nodes.extend(ids.iter().map(|col| col[0]));
            let range = self.mesh.add_block(&ids, l.material);
            if li == walls.web_layer {
                web_elements = range;
            }
        }
        (web_elements, base_nodes)
    }
}

/// Supports and couplings: fixed components, ties and unilateral contact pairs.
#[derive(Default)]
struct Couplings {
    fixed: Vec<(usize, usize)>,
    ties: Vec<(usize, usize, usize)>,
    contact_pairs: Vec<ContactPair>,
}

/// Couple the cap side to the core side of the pillars' outer face (d-lines `dl`,
/// `dl + 1`): bonded in the clip band at the base, and above it either tied radially
/// or in unilateral contact across the printed clearance.
fn clip_band_coupling(
    wm: &mut WallMesh,
    dl: usize,
    m: &crate::spec::Module,
    opt: &FemOptions,
    c: &mut Couplings,
) -> Result<()> {
    let clip = opt.clip_height_mm.unwrap_or(m.cap_wall_mm);
    if !(clip.is_finite() && clip > 0.0) {
        bail!("the clip band's height must be a positive number of mm, got {clip}");
    }
    // Bonded only in the clip band at the base, so the cap slides axially over the
    // core above it.
    for j in 0..=wm.stations.j_pillar_top {
        let (a, b) = (wm.node(dl, j), wm.node(dl + 1, j));
        let in_clip = wm.mesh.nodes[a][1] <= clip + 1e-9;
        if in_clip {
            c.ties.push((a, b, R));
            c.ties.push((a, b, Z));
        } else if opt.pillar_coupling == PillarCoupling::BaseClipContact {
            // The cap side lies outside: the normal from it to the core points inwards.
            c.contact_pairs.push(ContactPair {
                a,
                b: Some(b),
                normal: [-1.0, 0.0],
                gap_mm: m.cap_core_clearance_mm,
            });
        } else {
            c.ties.push((a, b, R));
        }
    }
    Ok(())
}

/// Couple the cap's dome to the core's dome above the pillars as `opt.dome_contact`
/// says: a gap, unilateral contact, or ties over the whole dome or the apex patch.
fn dome_coupling(wm: &mut WallMesh, walls: &Walls, opt: &FemOptions, c: &mut Couplings) {
    let s = wm.stations;
    let tie_from = match opt.dome_contact {
        DomeContact::Gap | DomeContact::Unilateral => None,
        DomeContact::Tied => Some(s.j_pillar_top + 1),
        DomeContact::ApexPatch => Some(s.j_patch.max(s.j_pillar_top + 1)),
    };
    if opt.dome_contact == DomeContact::Unilateral {
        for j in s.j_pillar_top + 1..=s.j_hole {
            let a = wm.node(walls.cap_inner, j);
            let b = wm.node(walls.core_outer, j);
            // Facing nodes lie on one ray from the dome centre (or one horizontal line
            // below it): the normal points along it, inwards, from the cap to the core.
            let normal = match s.st[j] {
                Station::Z(_) => [-1.0, 0.0],
                Station::Theta(t) => [-t.cos(), -t.sin()],
            };
            let (xa, xb) = (wm.mesh.nodes[a], wm.mesh.nodes[b]);
            let gap = normal[0] * (xb[0] - xa[0]) + normal[1] * (xb[1] - xa[1]);
            c.contact_pairs.push(ContactPair {
                a,
                b: Some(b),
                normal,
                gap_mm: gap.max(0.0),
            });
        }
    }
    if let Some(j0) = tie_from {
        for j in j0..=s.j_hole {
            let a = wm.node(walls.cap_inner, j);
            let b = wm.node(walls.core_outer, j);
            c.ties.push((a, b, R));
            c.ties.push((a, b, Z));
        }
    }
}

/// Case I: mesh the solid insert and tie the core's inner wall to it (on the cylinder
/// radially only when the insert contact slides).
fn insert_coupling(
    wm: &mut WallMesh,
    walls: &Walls,
    p: &ModuleProfile,
    h: f64,
    opt: &FemOptions,
    c: &mut Couplings,
) {
    let s = wm.stations;
    let surface = mesh_insert(&mut wm.mesh, &mut c.fixed, p, s, h, wm.zc);
    for (j, &b) in surface.iter().enumerate().take(s.j_hole + 1) {
        let a = wm.node(walls.core_inner, j);
        let on_cylinder = wm.mesh.nodes[b][1] <= p.insert_junction_z_mm + 1e-9;
        c.ties.push((a, b, R));
        if !(on_cylinder && opt.insert_contact == InsertContact::SlidingWall) {
            c.ties.push((a, b, Z));
        }
    }
}

/// The apex load, 1 N downward, as uniform pressure on the projected apex patch of
/// the cap's outer surface.
fn apex_load(wm: &mut WallMesh, p: &ModuleProfile) -> Vec<(usize, usize, f64)> {
    let a = p.apex_flat_radius_mm;
    let pressure = 1.0 / (PI * a * a);
    let mut loads = Vec::new();
    let mut j = wm.stations.j_axis;
    while j >= 2 {
        let ids = [wm.node(0, j - 2), wm.node(0, j - 1), wm.node(0, j)];
        let nodes = &wm.mesh.nodes;
        let xy = [nodes[ids[0]], nodes[ids[1]], nodes[ids[2]]];
        if xy[2][0] >= a {
            break;
        }
        let s0 = if xy[0][0] <= a {
            -1.0
        } else {
            edge_param_at_radius(xy, a)
        };
        let f = edge_forces(xy, s0, 1.0, |_, _, dr, _| [0.0, -pressure * dr.abs()]);
        for k in 0..3 {
            loads.push((ids[k], Z, f[k][1]));
        }
        if xy[0][0] > a {
            break;
        }
        j -= 2;
    }
    loads
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
    let (h, fiber_r) = (opt.element_size_mm, p.fiber_hole_center_radius_mm);
    let dome_h = opt.dome_element_size_mm;
    let s = make_stations(
        p,
        h,
        dome_h,
        fiber_r,
        inputs.patch_radius_mm,
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
    dome_coupling(&mut wm, &walls, opt, &mut c);
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
            loads,
        },
        web_elements,
        fiber_radius_mm: fiber_r,
        z_breaks_mm: s.z_breaks,
        pair_on_cylinders: (0..c.contact_pairs.len())
            .map(|i| i < cylinder_pairs)
            .collect(),
        contact_pairs: c.contact_pairs,
    })
}

impl ModuleModel {
    /// Axial strain ε_zz averaged over z ∈ [z0, z1] on the fiber axis.
    pub fn mean_axial_strain(&self, sol: &Solution, z0: f64, z1: f64) -> Result<f64> {
        if z1.partial_cmp(&z0) != Some(std::cmp::Ordering::Greater) {
            bail!("grating range {z0}..{z1} mm is empty");
        }
        let mut cuts: Vec<f64> = vec![z0, z1];
        cuts.extend(
            self.z_breaks_mm
                .iter()
                .copied()
                .filter(|&z| z > z0 && z < z1),
        );
        let n_min = 16;
        for k in 1..n_min {
            cuts.push(z0 + (z1 - z0) * k as f64 / n_min as f64);
        }
        cuts.sort_by(|a, b| a.total_cmp(b));
        cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        let elems: Vec<usize> = self.web_elements.clone().collect();
        let (gp, gw) = super::element::GAUSS3;
        let mut sum = 0.0;
        for w in cuts.windows(2) {
            let half = 0.5 * (w[1] - w[0]);
            for (p, wt) in gp.iter().zip(gw) {
                let z = 0.5 * (w[0] + w[1]) + half * p;
                let e = sol
                    .strain_at(&self.problem.mesh, Some(&elems), self.fiber_radius_mm, z)
                    .ok_or_else(|| anyhow!("grating point (r = {:.3} mm, z = {z:.3} mm) lies outside the pillar ring", self.fiber_radius_mm))?;
                sum += e[1] * wt * half;
            }
        }
        Ok(sum / (z1 - z0))
    }
}
