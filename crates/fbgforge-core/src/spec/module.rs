//! `[module]`: the clip-on module's TOML types: the cap's shell, the pillars, cores,
//! inserts, gratings and the snap-fit. The contact reading (`[module.contact]`) has its
//! own file, `contact`.

use super::contact::Contact;
use serde::{Deserialize, Serialize};

/// The four grooved pillars on the core's outer wall, each with a fiber through-hole,
/// and the matching alignment pillars on the cap's inner wall.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pillars {
    /// How many pillars, equally spaced around the core (the paper has 4).
    pub count: u32,
    /// Tangential width of each core pillar, mm.
    pub width_mm: f64,
    /// Radial height of each core pillar above the core's outer wall, mm.
    pub height_mm: f64,
    /// Width of the axial groove in each core pillar's outer face, mm.
    pub groove_width_mm: f64,
    /// Radial depth of that groove, mm.
    pub groove_depth_mm: f64,
    /// Diameter of the fiber through-hole along each pillar, mm (1 mm in the paper).
    pub fiber_hole_diameter_mm: f64,
    /// Angular position of pillar 0 from the +x axis, degrees.
    #[serde(default = "default_first_pillar_angle_deg")]
    pub first_pillar_angle_deg: f64,
}

fn default_first_pillar_angle_deg() -> f64 {
    45.0
}

/// One printed plug-in sensor core (PSC). Cores share the module geometry and may
/// differ in material (the paper prints two, E1 = 3.2 MPa and 1.4 MPa).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Core {
    /// Name used by gratings and reports, e.g. `psc1`.
    pub name: String,
    /// Key into the material table.
    pub material: String,
}

/// One solid insert (PSC-solid): a solid cylinder with a matching spherical top.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Insert {
    /// Name, e.g. `blue`.
    pub name: String,
    /// Key into the material table.
    pub material: String,
}

/// What a grating measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GratingRole {
    /// Bonded in a pillar's fiber hole: strain (force) sensing.
    Strain,
    /// Free-hanging on the module's axis, strain free: in the insert's reference
    /// chamber (Case I) or the hollow core (Case II); temperature only. See
    /// docs/geometry.md, "The reference grating".
    TemperatureReference,
}

/// A fiber Bragg grating of the clip-on module.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModuleGrating {
    /// Name, e.g. `lambda_11`.
    pub name: String,
    /// Nominal Bragg wavelength at the reference temperature, nm.
    pub bragg_wavelength_nm: f64,
    /// Grating length along the fiber, mm.
    pub length_mm: f64,
    /// Strain or temperature reference.
    pub role: GratingRole,
    /// Core this grating is bonded in (strain gratings); a reference grating without a
    /// core serves every core.
    #[serde(default)]
    pub core: Option<String>,
    /// Pillar index 0..count (strain gratings).
    #[serde(default)]
    pub pillar: Option<u32>,
    /// Height of the grating's centre above the core's base, mm (strain gratings).
    #[serde(default)]
    pub center_height_mm: Option<f64>,
    /// Bare fiber left past the grating's upper end up to the cleaved tip, mm
    /// (reference gratings; default [`DEFAULT_REFERENCE_TAIL_MM`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tail_mm: Option<f64>,
}

/// Fiber left between the ends of two gratings on one fiber, mm. A design choice: a
/// grating's place along its fiber is known to a fraction of a millimetre from how it
/// was written and bonded, and two gratings that touch cannot be told apart by where a
/// load strains them; 1 mm keeps them apart with room for that placement.
pub const GRATING_END_GAP_MM: f64 = 1.0;

/// Fiber left past a reference grating's end when the spec states none, mm: a grating
/// is written a few millimetres from the cleaved tip.
pub const DEFAULT_REFERENCE_TAIL_MM: f64 = 3.0;

impl ModuleGrating {
    /// Fiber past the grating's end, mm (the stated tail or the default).
    pub fn tail_mm(&self) -> f64 {
        self.tail_mm.unwrap_or(DEFAULT_REFERENCE_TAIL_MM)
    }
}

/// The clip-on cylindrical module: cap (CC), cores (PSC), inserts (PSC-solid).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Module {
    /// Outer diameter of the cap, mm (34 mm in the paper).
    pub outer_diameter_mm: f64,
    /// Overall height from the base to the cap's apex, mm (77 mm in the paper).
    pub overall_height_mm: f64,
    /// Height of the cap's outer spherical dome above its cylinder, mm; equal to the
    /// outer radius for a hemisphere, smaller for a flatter dome.
    pub dome_height_mm: f64,
    /// Wall thickness of the clip-on cap (CC), mm.
    pub cap_wall_mm: f64,
    /// Wall thickness of the plug-in sensor core (PSC), mm.
    pub core_wall_mm: f64,
    /// Radial fit clearance between the cap's inner wall and the core's pillars, mm.
    pub cap_core_clearance_mm: f64,
    /// Radial fit clearance between the core's inner wall and an insert, mm.
    pub core_insert_clearance_mm: f64,
    /// Diameter of the hole at the core's apex for the temperature-reference grating, mm.
    pub top_hole_diameter_mm: f64,
    /// Diameter of the small flat at the apex of the cap and of each insert, mm. It is
    /// the force contact patch and keeps the solids free of a singular pole.
    pub apex_flat_diameter_mm: f64,
    /// Key into the material table for the cap.
    pub cap_material: String,
    /// Grooved pillars and fiber holes.
    pub pillars: Pillars,
    /// Printed cores.
    pub cores: Vec<Core>,
    /// Solid inserts, one per material; may be empty.
    #[serde(default)]
    pub inserts: Vec<Insert>,
    /// Gratings.
    #[serde(default)]
    pub gratings: Vec<ModuleGrating>,
    /// How cap and core touch and are held together: the contact reading the models
    /// use for Case I (and the finite-element model for Case II). Defaults when absent.
    #[serde(default, skip_serializing_if = "Contact::is_default")]
    pub contact: Contact,
    /// Snap-fit between cap and core; without it the cap is a plain sliding fit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub snap: Option<Snap>,
    /// Wavelength sample rate of the interrogator the module is read with, Hz: the
    /// floor of the lag Δt_max the optimiser predicts (one sample period). Absent: 2 Hz,
    /// the paper's SM125.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interrogator_rate_hz: Option<f64>,
    /// The load the module is rated for: `optimize` writes the force and strain limit
    /// it held the written design to, and `predict` states each grating's strain there
    /// from the far end of its design interval. Absent: `predict` uses its requested
    /// force and the grating's linear limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits: Option<Limits>,
}

/// The load a module is rated for.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// The largest apex force the module is meant to take, N.
    pub max_force_n: f64,
    /// The largest |grating strain| allowed at that force, µε (default 3000: a third of
    /// the 1 % proof test).
    #[serde(default = "default_max_grating_strain_microstrain")]
    pub max_grating_strain_microstrain: f64,
}

fn default_max_grating_strain_microstrain() -> f64 {
    3000.0
}

impl Module {
    /// The paper's interrogator (Micron Optics SM125) samples at 2 Hz.
    pub const DEFAULT_INTERROGATOR_RATE_HZ: f64 = 2.0;

    /// The interrogator's sample rate, Hz (the design's, or the paper's 2 Hz).
    pub fn interrogator_rate_hz(&self) -> f64 {
        self.interrogator_rate_hz
            .unwrap_or(Self::DEFAULT_INTERROGATOR_RATE_HZ)
    }
}

/// The annular snap-fit that holds the cap on the core: a bead ring on the cap's inner
/// wall, just below the core's pillars, that the pillar bottoms hook over (see
/// docs/geometry.md, "Snap-fit").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Snap {
    /// Radial undercut y: how far the bead reaches inside the pillar faces, mm.
    pub undercut_mm: f64,
    /// Axial height of the bead's cylindrical crest, mm.
    pub bead_height_mm: f64,
    /// Angle of the bead's lead-in cone to the module axis, degrees (30° typical).
    #[serde(default = "default_lead_in_angle_deg")]
    pub lead_in_angle_deg: f64,
    /// Angle of the bead's retention cone to the module axis, degrees (90° = flat,
    /// self-locking; 45° typical for a joint meant to come apart).
    #[serde(default = "default_retention_angle_deg")]
    pub retention_angle_deg: f64,
    /// Coefficient of friction between cap and core, dimensionless.
    #[serde(default = "default_friction_coefficient")]
    pub friction_coefficient: f64,
}

fn default_lead_in_angle_deg() -> f64 {
    30.0
}
fn default_retention_angle_deg() -> f64 {
    45.0
}
fn default_friction_coefficient() -> f64 {
    0.3
}
