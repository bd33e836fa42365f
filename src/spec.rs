//! The design spec: the TOML file that describes one fbgforge design.
//!
//! A spec holds the printer, a material table, and optionally a clip-on module
//! (cap, cores, inserts, gratings) and a flat tactile array with its casting mold.
//! Every length is in mm, every modulus in MPa, every wavelength in nm; the unit is
//! part of each field name. Unknown fields are rejected, and [`Design::validate`]
//! checks every number against its allowed range so that geometry, model, verifier
//! and optimiser can trust a loaded design.
//!
//! Derived dimensions (radii, heights, slit positions) are not stored here: they are
//! computed once in [`crate::profile`], the single source of truth that both the solid
//! geometry and the opto-mechanical model read. Loading a design file goes through
//! [`crate::design`], which adds the checks that need those derived dimensions.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;

/// An error in a design spec, naming the file and the field at fault.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecError {
    /// The file the spec came from, if any.
    pub file: Option<PathBuf>,
    /// Dotted path of the offending field, e.g. `module.cap_wall_mm`.
    pub field: String,
    /// What is wrong and what was expected.
    pub message: String,
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(p) = &self.file {
            write!(f, "{}: ", p.display())?;
        }
        // File-level errors (unreadable file, TOML syntax at the top level) name no field.
        if !self.field.is_empty() {
            write!(f, "field `{}`: ", self.field)?;
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for SpecError {}

/// Printing process; it sets sensible defaults but the numbers in [`Printer`] rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PrintProcess {
    /// Material jetting (e.g. Stratasys J750): fine features, soft and rigid inks.
    Polyjet,
    /// Fused deposition modelling: coarser, walls limited by the nozzle width.
    Fdm,
}

impl fmt::Display for PrintProcess {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PrintProcess::Polyjet => "polyjet",
            PrintProcess::Fdm => "fdm",
        })
    }
}

/// The printer the parts are made on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Printer {
    /// Printing process.
    pub process: PrintProcess,
    /// Smallest in-plane feature the printer resolves, mm. The default meshing
    /// tolerance is half of it: a chord error below what the printer can show.
    pub resolution_mm: f64,
    /// Thinnest wall the printer makes reliably, mm.
    pub min_wall_mm: f64,
    /// Nozzle diameter of an FDM printer, mm (default 0.4 mm for `fdm`; unused for
    /// PolyJet). A printed gap narrower than the nozzle closes up, so fiber slits and
    /// channels are never made narrower than this.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nozzle_diameter_mm: Option<f64>,
}

impl Printer {
    /// Default meshing tolerance (maximum chord deviation), mm.
    pub fn default_tolerance_mm(&self) -> f64 {
        self.resolution_mm / 2.0
    }

    /// Narrowest gap (slit, channel) the printer keeps open, mm: the nozzle for FDM
    /// (0.4 mm when not stated), the resolution for PolyJet.
    pub fn min_gap_mm(&self) -> f64 {
        match self.process {
            PrintProcess::Fdm => self.nozzle_diameter_mm.unwrap_or(DEFAULT_FDM_NOZZLE_MM),
            PrintProcess::Polyjet => self.resolution_mm,
        }
    }
}

/// Nozzle diameter assumed for an FDM printer that states none, mm.
pub const DEFAULT_FDM_NOZZLE_MM: f64 = 0.4;

/// An isotropic linear-elastic material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Material {
    /// Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// Poisson's ratio, dimensionless, in [0, 0.5).
    pub poisson_ratio: f64,
    /// Free text: where the numbers come from.
    #[serde(default)]
    pub note: Option<String>,
    /// Largest strain a snap-fit may impose on this material, percent (a datasheet or
    /// snap-fit-guide value; needed for the cap's material when the module has a
    /// `[module.snap]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub permissible_strain_percent: Option<f64>,
}

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
    /// Free-hanging through the core's top hole: temperature only.
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
}

/// How the cap's cylinder couples to the core's along the pillars.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CylinderCoupling {
    /// The cap's alignment ribs slide in the pillars' grooves (they fit with a
    /// clearance); cap and core are joined only where the cap clips over the core at the
    /// base. Default: the reading consistent with the paper's experiments
    /// (docs/model.md §5.6).
    #[default]
    Sliding,
    /// The pillars are glued to the cap over their whole length (the paper's literal
    /// "no sliding between CC and PSC").
    Bonded,
}

/// `[module.contact]`: how cap and core touch and are held together. Every field is
/// optional; the defaults are the reading most consistent with the paper's
/// experiments (docs/model.md §5.6).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Contact {
    /// Cap/core coupling along the cylinders (`sliding` or `bonded`).
    #[serde(default)]
    pub cylinders: CylinderCoupling,
    /// Height of the band at the base where the cap clips onto the core and the two are
    /// held together axially, mm (sliding cylinders); default: one cap wall.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clip_height_mm: Option<f64>,
    /// Radial gap between the cap's dome and the core's dome as printed, mm; default:
    /// `cap_core_clearance_mm`. The unilateral contact analysis closes it under load.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dome_clearance_mm: Option<f64>,
    /// Radius of the zone around the apex over which the cap's dome bears on the core's
    /// dome under working loads (measured on the core's dome), mm; default: 1.376 × the
    /// apex contact patch (apex flat radius + cap wall / 2). The one contact parameter a
    /// measured Case I sensitivity calibrates (`verify --calibrate-into`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dome_contact_radius_mm: Option<f64>,
    /// Where the numbers come from (e.g. the log a calibration was fitted to).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

impl Contact {
    /// Default contact radius as a multiple of the apex contact patch radius.
    pub const DEFAULT_CONTACT_TO_PATCH: f64 = 1.376;

    /// Whether every field is at its default (then the table is not written).
    pub fn is_default(&self) -> bool {
        *self == Contact::default()
    }
}

impl Module {
    /// Radius of the apex contact patch on the domes' neutral surface: the apex flat
    /// widened through half the cap wall, mm.
    pub fn apex_patch_radius_mm(&self) -> f64 {
        0.5 * self.apex_flat_diameter_mm + 0.5 * self.cap_wall_mm
    }

    /// The clip band's height, mm.
    pub fn clip_height_mm(&self) -> f64 {
        self.contact.clip_height_mm.unwrap_or(self.cap_wall_mm)
    }

    /// The dome clearance as printed, mm.
    pub fn dome_clearance_mm(&self) -> f64 {
        self.contact
            .dome_clearance_mm
            .unwrap_or(self.cap_core_clearance_mm)
    }

    /// The domes' contact radius under working loads, mm.
    pub fn dome_contact_radius_mm(&self) -> f64 {
        self.contact
            .dome_contact_radius_mm
            .unwrap_or(Contact::DEFAULT_CONTACT_TO_PATCH * self.apex_patch_radius_mm())
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

/// How the fibers leave the module and the mold: the fiber's size and stiffness and
/// the clearance the printed channels give it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiberRouting {
    /// Diameter of the coated fiber, mm (250 µm acrylate coating of standard SMF).
    #[serde(default = "default_coated_diameter_mm")]
    pub coated_diameter_mm: f64,
    /// Smallest bend radius the fiber may take, mm (10 mm for standard SMF, G.652;
    /// 7.5 or 5 mm for bend-insensitive G.657.A2 / B3 fiber).
    #[serde(default = "default_min_bend_radius_mm")]
    pub min_bend_radius_mm: f64,
    /// Clearance between the coated fiber and a printed channel on each side, mm.
    #[serde(default = "default_channel_clearance_mm")]
    pub channel_clearance_mm: f64,
    /// Height of the fiber axis above the base where a fiber leaving the module has
    /// turned horizontal, mm.
    #[serde(default = "default_exit_height_mm")]
    pub exit_height_mm: f64,
}

fn default_coated_diameter_mm() -> f64 {
    0.25
}
fn default_min_bend_radius_mm() -> f64 {
    10.0
}
fn default_channel_clearance_mm() -> f64 {
    0.1
}
fn default_exit_height_mm() -> f64 {
    1.0
}

impl Default for FiberRouting {
    fn default() -> Self {
        FiberRouting {
            coated_diameter_mm: default_coated_diameter_mm(),
            min_bend_radius_mm: default_min_bend_radius_mm(),
            channel_clearance_mm: default_channel_clearance_mm(),
            exit_height_mm: default_exit_height_mm(),
        }
    }
}

impl FiberRouting {
    /// Width of a fiber channel or slit on `printer`: the coated fiber plus its
    /// clearance each side, but never narrower than the printer keeps open, mm.
    pub fn channel_width_mm(&self, printer: &Printer) -> f64 {
        (self.coated_diameter_mm + 2.0 * self.channel_clearance_mm).max(printer.min_gap_mm())
    }
}

/// A grating of the flat array.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArrayGrating {
    /// Name, e.g. `fbg1`.
    pub name: String,
    /// Index into `array.fiber_x_mm`.
    pub fiber: u32,
    /// Position of the grating centre along its fiber from the array centre, mm.
    pub y_mm: f64,
    /// Nominal Bragg wavelength at the reference temperature, nm.
    pub bragg_wavelength_nm: f64,
    /// Grating length, mm.
    pub length_mm: f64,
}

/// The silicone-casting mold of the flat array.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mold {
    /// Internal size of the cavity along x (the fibers cross the walls normal to y), mm.
    pub internal_x_mm: f64,
    /// Internal size of the cavity along y, mm.
    pub internal_y_mm: f64,
    /// Height of the walls above the cavity floor, mm.
    pub wall_height_mm: f64,
    /// Thickness of the walls, mm.
    pub wall_thickness_mm: f64,
    /// Thickness of the base plate, mm.
    pub base_thickness_mm: f64,
    /// Depth of each fiber slit from the top of the wall, mm. Derived when absent: the
    /// slit stops where the coated fiber, resting on its bottom, has its axis at the
    /// sheet's mid-thickness; a stated value must equal that.
    #[serde(default = "unset")]
    pub slit_depth_mm: f64,
    /// Width of each fiber slit, mm. Derived when absent from the coated fiber and the
    /// printer ([`FiberRouting::channel_width_mm`]); a stated value may not be narrower.
    #[serde(default = "unset")]
    pub slit_width_mm: f64,
    /// Print a plug per slit: the slit is then a narrow seat as high as the fiber and a
    /// wider pocket above it that the plug fills, so the silicone cannot run out.
    #[serde(default)]
    pub plugs: bool,
    /// Key into the material table for what the mold (and its plugs) is printed in;
    /// the cast sheet's material is `array.material`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub print_material: Option<String>,
}

/// Marks a derived field not given in the file ([`Design::fill_derived`] fills it).
fn unset() -> f64 {
    f64::NAN
}

/// The flat tactile sensor array (TSA) and its mold.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TactileArray {
    /// Size of the silicone sheet along x, mm.
    pub size_x_mm: f64,
    /// Size of the silicone sheet along y, mm.
    pub size_y_mm: f64,
    /// Sheet thickness, mm (the fibers lie at mid-thickness).
    pub thickness_mm: f64,
    /// Number of cells along x.
    pub cells_x: u32,
    /// Number of cells along y.
    pub cells_y: u32,
    /// Key into the material table for the cast sheet.
    pub material: String,
    /// Largest load per cell the reconstruction may return, g.
    pub ulimit_g: f64,
    /// x position of each fiber (fibers run along y), mm from the array centre.
    pub fiber_x_mm: Vec<f64>,
    /// Gratings on the fibers.
    pub gratings: Vec<ArrayGrating>,
    /// Casting mold.
    pub mold: Mold,
    /// Most cells loaded at once that reconstruction considers (default 4, the
    /// paper's largest test; 1 to 64).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_loads: Option<u32>,
}

/// A complete design: what one TOML file holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Design {
    /// Short identifier, used for output names.
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: Option<String>,
    /// The printer.
    pub printer: Printer,
    /// Optical constants of the fiber (defaults: standard silica SMF near 1550 nm).
    #[serde(default)]
    pub fiber: crate::grating::FiberOptics,
    /// Material table: name → material.
    pub materials: BTreeMap<String, Material>,
    /// Clip-on module, if this design has one.
    #[serde(default)]
    pub module: Option<Module>,
    /// Flat tactile array, if this design has one.
    #[serde(default)]
    pub array: Option<TactileArray>,
    /// Fiber size, bend radius and channel clearance for routing (defaults: standard
    /// SMF with a 250 µm coating).
    #[serde(default)]
    pub fiber_routing: FiberRouting,
}

/// Deserialise a design from TOML text without validating it (the design layer,
/// [`crate::design`], parses and validates).
pub fn parse_unvalidated(text: &str) -> Result<Design, SpecError> {
    toml::from_str(text).map_err(|e| toml_error(text, e))
}

fn toml_error(text: &str, e: toml::de::Error) -> SpecError {
    let mut message = e.message().to_string();
    let mut field = String::new();
    if let Some(span) = e.span() {
        let before = &text[..span.start.min(text.len())];
        let line = before.matches('\n').count() + 1;
        message = format!("line {line}: {message}");
        // toml names no key path; the table the line sits in is the next best thing.
        field = before
            .lines()
            .rev()
            .find_map(table_header)
            .unwrap_or_default();
    }
    SpecError {
        file: None,
        field,
        message,
    }
}

/// The table a TOML header line opens (`[module.pillars]`, `[[module.cores]]`).
fn table_header(line: &str) -> Option<String> {
    let t = line.trim();
    let inner = t
        .strip_prefix("[[")
        .and_then(|r| r.strip_suffix("]]"))
        .or_else(|| t.strip_prefix('[').and_then(|r| r.strip_suffix(']')))?;
    Some(inner.trim().to_string())
}

impl Design {
    /// Serialise to TOML (used by the optimiser to write new designs).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("a Design always serialises to TOML")
    }

    /// Look up a material, naming the field that referenced it on failure.
    pub fn material(&self, key: &str, field: &str) -> Result<&Material, SpecError> {
        self.materials.get(key).ok_or_else(|| {
            let known: Vec<&str> = self.materials.keys().map(|s| s.as_str()).collect();
            err(
                field,
                format!(
                    "unknown material `{key}`; the material table has: {}",
                    known.join(", ")
                ),
            )
        })
    }

    /// Check every field against its allowed range and every cross-field constraint
    /// that needs no derived dimension; [`crate::design`] adds the checks on the
    /// derived profile (radial stack, pillar pitch, holes against the domes).
    pub fn validate_fields(&self) -> Result<(), SpecError> {
        let p = &self.printer;
        positive("printer.resolution_mm", p.resolution_mm, 0.001, 2.0)?;
        positive("printer.min_wall_mm", p.min_wall_mm, 0.01, 5.0)?;
        if let Some(n) = p.nozzle_diameter_mm {
            positive("printer.nozzle_diameter_mm", n, 0.1, 2.0)?;
        }
        let fr = &self.fiber_routing;
        positive(
            "fiber_routing.coated_diameter_mm",
            fr.coated_diameter_mm,
            0.05,
            2.0,
        )?;
        positive(
            "fiber_routing.min_bend_radius_mm",
            fr.min_bend_radius_mm,
            1.0,
            200.0,
        )?;
        range(
            "fiber_routing.channel_clearance_mm",
            fr.channel_clearance_mm,
            0.0,
            1.0,
        )?;
        range(
            "fiber_routing.exit_height_mm",
            fr.exit_height_mm,
            fr.coated_diameter_mm / 2.0,
            50.0,
        )?;
        let fo = &self.fiber;
        range("fiber.photoelastic_pe", fo.photoelastic_pe, 0.0, 0.9)?;
        range(
            "fiber.thermal_expansion_per_k",
            fo.thermal_expansion_per_k,
            -1e-4,
            1e-4,
        )?;
        range(
            "fiber.thermo_optic_per_k",
            fo.thermo_optic_per_k,
            -1e-4,
            1e-4,
        )?;
        if self.materials.is_empty() {
            return Err(err(
                "materials",
                "the material table is empty; list at least one material",
            ));
        }
        for (name, m) in &self.materials {
            positive(
                &format!("materials.{name}.youngs_modulus_mpa"),
                m.youngs_modulus_mpa,
                1e-4,
                1e7,
            )?;
            range(
                &format!("materials.{name}.poisson_ratio"),
                m.poisson_ratio,
                0.0,
                0.4999,
            )?;
            if let Some(e) = m.permissible_strain_percent {
                positive(
                    &format!("materials.{name}.permissible_strain_percent"),
                    e,
                    0.01,
                    500.0,
                )?;
            }
        }
        if self.module.is_none() && self.array.is_none() {
            return Err(err(
                "module",
                "a design needs a [module] or an [array] section (or both)",
            ));
        }
        if let Some(m) = &self.module {
            self.validate_module(m)?;
        }
        if let Some(a) = &self.array {
            self.validate_array(a)?;
        }
        Ok(())
    }

    /// Check a module: its shell, pillars, snap-fit, cores, inserts and gratings.
    fn validate_module(&self, m: &Module) -> Result<(), SpecError> {
        self.validate_module_shell(m)?;
        self.validate_pillars(m)?;
        let r = m.outer_diameter_mm / 2.0;
        positive(
            "module.top_hole_diameter_mm",
            m.top_hole_diameter_mm,
            0.1,
            0.5 * r,
        )?;
        positive(
            "module.apex_flat_diameter_mm",
            m.apex_flat_diameter_mm,
            0.01,
            0.5 * r,
        )?;
        if let Some(snap) = &m.snap {
            self.validate_snap(m, snap)?;
        }
        self.validate_cores_and_inserts(m)?;
        for (i, g) in m.gratings.iter().enumerate() {
            unique_name(
                m.gratings[..i].iter().map(|o| o.name.as_str()),
                &g.name,
                &format!("module.gratings[{i}].name"),
                "grating",
            )?;
            Self::validate_module_grating(m, i, g)?;
        }
        Ok(())
    }

    /// The module's outer size, walls, clearances, cap material and contact overrides.
    fn validate_module_shell(&self, m: &Module) -> Result<(), SpecError> {
        let min_wall = self.printer.min_wall_mm;
        positive("module.outer_diameter_mm", m.outer_diameter_mm, 4.0, 200.0)?;
        let r = m.outer_diameter_mm / 2.0;
        positive("module.overall_height_mm", m.overall_height_mm, 2.0, 500.0)?;
        range("module.dome_height_mm", m.dome_height_mm, 0.1 * r, r)?;
        range("module.cap_wall_mm", m.cap_wall_mm, min_wall, 0.25 * r)?;
        range("module.core_wall_mm", m.core_wall_mm, min_wall, 0.25 * r)?;
        range(
            "module.cap_core_clearance_mm",
            m.cap_core_clearance_mm,
            0.0,
            2.0,
        )?;
        range(
            "module.core_insert_clearance_mm",
            m.core_insert_clearance_mm,
            0.0,
            2.0,
        )?;
        self.material(&m.cap_material, "module.cap_material")?;
        let c = &m.contact;
        if let Some(h) = c.clip_height_mm {
            positive(
                "module.contact.clip_height_mm",
                h,
                1e-3,
                m.overall_height_mm,
            )?;
        }
        if let Some(g) = c.dome_clearance_mm {
            range("module.contact.dome_clearance_mm", g, 0.0, 2.0)?;
        }
        if let Some(a) = c.dome_contact_radius_mm {
            positive("module.contact.dome_contact_radius_mm", a, 1e-3, 0.5 * r)?;
        }
        Ok(())
    }

    /// The pillars: count, groove and fiber hole sized to leave printable walls.
    fn validate_pillars(&self, m: &Module) -> Result<(), SpecError> {
        let min_wall = self.printer.min_wall_mm;
        let r = m.outer_diameter_mm / 2.0;
        let pl = &m.pillars;
        if !(3..=8).contains(&pl.count) {
            return Err(err(
                "module.pillars.count",
                format!("expected 3 to 8 pillars, got {}", pl.count),
            ));
        }
        finite(
            "module.pillars.first_pillar_angle_deg",
            pl.first_pillar_angle_deg,
        )?;
        positive(
            "module.pillars.fiber_hole_diameter_mm",
            pl.fiber_hole_diameter_mm,
            0.13,
            5.0,
        )?;
        positive(
            "module.pillars.groove_depth_mm",
            pl.groove_depth_mm,
            0.05,
            5.0,
        )?;
        positive(
            "module.pillars.groove_width_mm",
            pl.groove_width_mm,
            0.1,
            10.0,
        )?;
        // The groove must leave printable walls on both sides of it.
        let max_groove_w = pl.width_mm - 2.0 * min_wall;
        if pl.groove_width_mm > max_groove_w {
            return Err(err(
                "module.pillars.groove_width_mm",
                format!(
                    "{} mm leaves pillar walls thinner than the printer minimum {min_wall} mm; allowed up to {max_groove_w:.3} mm (pillar width − 2 × min wall)",
                    pl.groove_width_mm
                ),
            ));
        }
        // The cap's alignment pillar is the groove less a clearance on each side.
        if pl.groove_width_mm - 2.0 * m.cap_core_clearance_mm < min_wall {
            return Err(err(
                "module.pillars.groove_width_mm",
                format!(
                    "the cap's alignment pillar (groove width − 2 × clearance = {:.3} mm) is thinner than the printer minimum {min_wall} mm",
                    pl.groove_width_mm - 2.0 * m.cap_core_clearance_mm
                ),
            ));
        }
        // The fiber hole sits between the core wall and the groove bottom.
        let web = pl.height_mm - pl.groove_depth_mm;
        let max_hole_radial = web - 2.0 * min_wall;
        let max_hole_tangential = pl.width_mm - 2.0 * min_wall;
        let max_hole = max_hole_radial.min(max_hole_tangential);
        if pl.fiber_hole_diameter_mm > max_hole {
            return Err(err(
                "module.pillars.fiber_hole_diameter_mm",
                format!(
                    "{} mm is wider than its pillar allows; allowed up to {max_hole:.3} mm (pillar height − groove depth − 2 × min wall = {max_hole_radial:.3}, pillar width − 2 × min wall = {max_hole_tangential:.3})",
                    pl.fiber_hole_diameter_mm
                ),
            ));
        }
        positive("module.pillars.height_mm", pl.height_mm, 0.1, 0.3 * r)?;
        positive("module.pillars.width_mm", pl.width_mm, 0.1, r)?;
        Ok(())
    }

    /// At least one core; cores and inserts of known materials and distinct names.
    fn validate_cores_and_inserts(&self, m: &Module) -> Result<(), SpecError> {
        if m.cores.is_empty() {
            return Err(err("module.cores", "list at least one core"));
        }
        for (i, c) in m.cores.iter().enumerate() {
            self.material(&c.material, &format!("module.cores[{i}].material"))?;
            unique_name(
                m.cores[..i].iter().map(|o| o.name.as_str()),
                &c.name,
                &format!("module.cores[{i}].name"),
                "core",
            )?;
        }
        for (i, ins) in m.inserts.iter().enumerate() {
            self.material(&ins.material, &format!("module.inserts[{i}].material"))?;
            unique_name(
                m.inserts[..i].iter().map(|o| o.name.as_str()),
                &ins.name,
                &format!("module.inserts[{i}].name"),
                "insert",
            )?;
        }
        Ok(())
    }

    /// One module grating (index `i`): wavelength, length, core, and what its role
    /// needs (a strain grating its core, pillar and height; a reference none).
    fn validate_module_grating(m: &Module, i: usize, g: &ModuleGrating) -> Result<(), SpecError> {
        let pl = &m.pillars;
        let f = |s: &str| format!("module.gratings[{i}].{s}");
        range(
            &f("bragg_wavelength_nm"),
            g.bragg_wavelength_nm,
            400.0,
            2000.0,
        )?;
        positive(&f("length_mm"), g.length_mm, 0.1, 50.0)?;
        if let Some(core) = &g.core {
            if !m.cores.iter().any(|c| &c.name == core) {
                return Err(err(&f("core"), format!("no core named `{core}`")));
            }
        }
        match g.role {
            GratingRole::Strain => {
                if g.core.is_none() {
                    return Err(err(
                        &f("core"),
                        "a strain grating needs the core it is bonded in",
                    ));
                }
                let pillar = g
                    .pillar
                    .ok_or_else(|| err(&f("pillar"), "a strain grating needs its pillar index"))?;
                if pillar >= pl.count {
                    return Err(err(
                        &f("pillar"),
                        format!("expected 0 to {}, got {pillar}", pl.count - 1),
                    ));
                }
                // Its range along the pillar needs the derived profile:
                // checked in crate::design.
                g.center_height_mm.ok_or_else(|| {
                    err(
                        &f("center_height_mm"),
                        "a strain grating needs its centre height",
                    )
                })?;
            }
            GratingRole::TemperatureReference => {
                if g.pillar.is_some() || g.center_height_mm.is_some() {
                    return Err(err(
                        &f("pillar"),
                        "a temperature-reference grating hangs free in the top hole: give it no pillar or centre height",
                    ));
                }
            }
        }
        Ok(())
    }

    fn validate_snap(&self, m: &Module, s: &Snap) -> Result<(), SpecError> {
        let res = self.printer.resolution_mm;
        positive(
            "module.snap.undercut_mm",
            s.undercut_mm,
            res.min(0.01),
            m.pillars.groove_depth_mm.max(res),
        )?;
        positive("module.snap.bead_height_mm", s.bead_height_mm, res, 20.0)?;
        range(
            "module.snap.friction_coefficient",
            s.friction_coefficient,
            0.0,
            1.5,
        )?;
        range(
            "module.snap.lead_in_angle_deg",
            s.lead_in_angle_deg,
            5.0,
            80.0,
        )?;
        range(
            "module.snap.retention_angle_deg",
            s.retention_angle_deg,
            5.0,
            90.0,
        )?;
        // A lead-in steeper than the friction angle's complement jams: the joint
        // could not be pushed together at any force.
        let jam = s.friction_coefficient * s.lead_in_angle_deg.to_radians().tan();
        if jam >= 1.0 {
            return Err(err(
                "module.snap.lead_in_angle_deg",
                format!(
                    "{}° with friction {} jams (μ·tan α = {jam:.3} ≥ 1); allowed below {:.1}°",
                    s.lead_in_angle_deg,
                    s.friction_coefficient,
                    (1.0 / s.friction_coefficient.max(1e-9)).atan().to_degrees()
                ),
            ));
        }
        let cap = self.material(&m.cap_material, "module.cap_material")?;
        if cap.permissible_strain_percent.is_none() {
            return Err(err(
                &format!("materials.{}.permissible_strain_percent", m.cap_material),
                "the cap's material needs a permissible strain (percent) to size the snap-fit",
            ));
        }
        Ok(())
    }

    /// Fill the fields a file may leave to be derived (the mold's slit width and
    /// depth); [`crate::design`] calls this before validation.
    pub fn fill_derived(&mut self) {
        let width = self.fiber_routing.channel_width_mm(&self.printer);
        let coated = self.fiber_routing.coated_diameter_mm;
        if let Some(a) = &mut self.array {
            let depth = derived_slit_depth_mm(a, coated);
            if a.mold.slit_width_mm.is_nan() {
                a.mold.slit_width_mm = width;
            }
            if a.mold.slit_depth_mm.is_nan() {
                a.mold.slit_depth_mm = depth;
            }
        }
    }

    /// Check an array: the sheet, its mold, the fibers' positions and the gratings.
    fn validate_array(&self, a: &TactileArray) -> Result<(), SpecError> {
        self.validate_sheet(a)?;
        self.validate_mold(a)?;
        self.validate_fiber_positions(a)?;
        for (i, g) in a.gratings.iter().enumerate() {
            unique_name(
                a.gratings[..i].iter().map(|o| o.name.as_str()),
                &g.name,
                &format!("array.gratings[{i}].name"),
                "grating",
            )?;
            Self::validate_array_grating(a, i, g)?;
        }
        if a.gratings.is_empty() {
            return Err(err("array.gratings", "list at least one grating"));
        }
        if let Some(k) = a.max_loads {
            if !(1..=64).contains(&k) {
                return Err(err(
                    "array.max_loads",
                    format!("must be 1 to 64 simultaneous loads, got {k}"),
                ));
            }
        }
        Ok(())
    }

    /// The sheet: size, thickness (the coated fiber fits in it), cells, material, load
    /// limit, at least one fiber.
    fn validate_sheet(&self, a: &TactileArray) -> Result<(), SpecError> {
        positive("array.size_x_mm", a.size_x_mm, 1.0, 2000.0)?;
        positive("array.size_y_mm", a.size_y_mm, 1.0, 2000.0)?;
        positive("array.thickness_mm", a.thickness_mm, 0.2, 100.0)?;
        if self.fiber_routing.coated_diameter_mm >= a.thickness_mm {
            return Err(err(
                "fiber_routing.coated_diameter_mm",
                format!(
                    "{} mm does not fit in the {} mm sheet",
                    self.fiber_routing.coated_diameter_mm, a.thickness_mm
                ),
            ));
        }
        if a.cells_x == 0 || a.cells_x > 64 {
            return Err(err(
                "array.cells_x",
                format!("expected 1 to 64, got {}", a.cells_x),
            ));
        }
        if a.cells_y == 0 || a.cells_y > 64 {
            return Err(err(
                "array.cells_y",
                format!("expected 1 to 64, got {}", a.cells_y),
            ));
        }
        self.material(&a.material, "array.material")?;
        positive("array.ulimit_g", a.ulimit_g, 1e-3, 1e6)?;
        if a.fiber_x_mm.is_empty() {
            return Err(err("array.fiber_x_mm", "list at least one fiber"));
        }
        Ok(())
    }

    /// The casting mold: printable walls, a cavity that holds the sheet, and slits that
    /// hold the coated fiber at the sheet's mid-thickness.
    fn validate_mold(&self, a: &TactileArray) -> Result<(), SpecError> {
        let mold = &a.mold;
        if let Some(pm) = &mold.print_material {
            self.material(pm, "array.mold.print_material")?;
        }
        positive("array.mold.internal_x_mm", mold.internal_x_mm, 1.0, 3000.0)?;
        positive("array.mold.internal_y_mm", mold.internal_y_mm, 1.0, 3000.0)?;
        range(
            "array.mold.wall_thickness_mm",
            mold.wall_thickness_mm,
            self.printer.min_wall_mm,
            50.0,
        )?;
        range(
            "array.mold.base_thickness_mm",
            mold.base_thickness_mm,
            self.printer.min_wall_mm,
            50.0,
        )?;
        positive("array.mold.wall_height_mm", mold.wall_height_mm, 0.2, 200.0)?;
        if mold.wall_height_mm < a.thickness_mm {
            return Err(err(
                "array.mold.wall_height_mm",
                format!(
                    "{} mm is lower than the sheet thickness {} mm",
                    mold.wall_height_mm, a.thickness_mm
                ),
            ));
        }
        self.validate_mold_slits(a)?;
        if a.size_x_mm > mold.internal_x_mm {
            return Err(err(
                "array.mold.internal_x_mm",
                format!(
                    "{} mm does not hold the {} mm sheet",
                    mold.internal_x_mm, a.size_x_mm
                ),
            ));
        }
        if a.size_y_mm > mold.internal_y_mm {
            return Err(err(
                "array.mold.internal_y_mm",
                format!(
                    "{} mm does not hold the {} mm sheet",
                    mold.internal_y_mm, a.size_y_mm
                ),
            ));
        }
        Ok(())
    }

    /// The mold's slits: as wide as the coated fiber and its clearance need, and as deep
    /// as puts the fiber at the sheet's mid-thickness.
    fn validate_mold_slits(&self, a: &TactileArray) -> Result<(), SpecError> {
        let mold = &a.mold;
        range(
            "array.mold.slit_depth_mm",
            mold.slit_depth_mm,
            0.01,
            mold.wall_height_mm - self.printer.min_wall_mm.min(mold.wall_height_mm / 2.0),
        )?;
        range(
            "array.mold.slit_width_mm",
            mold.slit_width_mm,
            self.printer.resolution_mm,
            5.0,
        )?;
        // The slit holds the coated fiber with its clearance and stays open in print.
        let need = self.fiber_routing.channel_width_mm(&self.printer);
        if mold.slit_width_mm < need - 1e-9 {
            return Err(err(
                "array.mold.slit_width_mm",
                format!(
                    "{} mm is narrower than the {need:.3} mm the fiber needs (coated diameter {} mm + 2 × clearance {} mm, at least the printer's smallest open gap {} mm); leave the field out to derive it",
                    mold.slit_width_mm,
                    self.fiber_routing.coated_diameter_mm,
                    self.fiber_routing.channel_clearance_mm,
                    self.printer.min_gap_mm()
                ),
            ));
        }
        let depth = derived_slit_depth_mm(a, self.fiber_routing.coated_diameter_mm);
        if (mold.slit_depth_mm - depth).abs() > 1e-6 {
            return Err(err(
                "array.mold.slit_depth_mm",
                format!(
                    "{} mm does not put the fiber at the sheet's mid-thickness; expected {depth:.4} mm (wall height − thickness/2 + coated diameter/2); leave the field out to derive it",
                    mold.slit_depth_mm
                ),
            ));
        }
        Ok(())
    }

    /// The fibers lie on the sheet, with a printable wall between neighbouring slits
    /// (or plug pockets).
    fn validate_fiber_positions(&self, a: &TactileArray) -> Result<(), SpecError> {
        let mold = &a.mold;
        let half_x = a.size_x_mm / 2.0;
        let mut xs: Vec<f64> = Vec::with_capacity(a.fiber_x_mm.len());
        for (i, &x) in a.fiber_x_mm.iter().enumerate() {
            let field = format!("array.fiber_x_mm[{i}]");
            range(&field, x, -half_x, half_x)?;
            xs.push(x);
        }
        xs.sort_by(|a, b| a.total_cmp(b));
        let min_gap = mold_slot_width_mm(self, mold) + self.printer.min_wall_mm;
        for w in xs.windows(2) {
            if w[1] - w[0] < min_gap {
                return Err(err(
                    "array.fiber_x_mm",
                    format!(
                        "fibers at {} mm and {} mm are closer than slit width + min wall = {min_gap:.3} mm",
                        w[0], w[1]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// One array grating (index `i`): on a listed fiber, on the sheet, a plausible
    /// wavelength and length.
    fn validate_array_grating(
        a: &TactileArray,
        i: usize,
        g: &ArrayGrating,
    ) -> Result<(), SpecError> {
        let f = |s: &str| format!("array.gratings[{i}].{s}");
        if g.fiber as usize >= a.fiber_x_mm.len() {
            return Err(err(
                &f("fiber"),
                format!("expected 0 to {}, got {}", a.fiber_x_mm.len() - 1, g.fiber),
            ));
        }
        range(&f("y_mm"), g.y_mm, -a.size_y_mm / 2.0, a.size_y_mm / 2.0)?;
        range(
            &f("bragg_wavelength_nm"),
            g.bragg_wavelength_nm,
            400.0,
            2000.0,
        )?;
        positive(&f("length_mm"), g.length_mm, 0.1, 50.0)?;
        Ok(())
    }
}

/// Depth of a mold slit below the wall top that leaves the coated fiber, resting on
/// the slit bottom, with its axis at the sheet's mid-thickness, mm.
pub fn derived_slit_depth_mm(a: &TactileArray, coated_diameter_mm: f64) -> f64 {
    a.mold.wall_height_mm - a.thickness_mm / 2.0 + coated_diameter_mm / 2.0
}

/// Width of the widest part of a slit: the plug pocket when the mold has plugs (a plug
/// at least one printable wall thick, with a channel clearance each side), else the
/// slit itself, mm.
pub fn mold_slot_width_mm(d: &Design, mold: &Mold) -> f64 {
    if mold.plugs {
        mold.slit_width_mm
            .max(d.printer.min_wall_mm + 2.0 * d.fiber_routing.channel_clearance_mm)
    } else {
        mold.slit_width_mm
    }
}

/// Build a [`SpecError`] without a file (the loader adds it).
pub fn err(field: &str, message: impl Into<String>) -> SpecError {
    SpecError {
        file: None,
        field: field.to_string(),
        message: message.into(),
    }
}

/// `name` (the `what` at `field`) must differ from every earlier name in its list.
fn unique_name<'a>(
    earlier: impl IntoIterator<Item = &'a str>,
    name: &str,
    field: &str,
    what: &str,
) -> Result<(), SpecError> {
    if earlier.into_iter().any(|o| o == name) {
        return Err(err(field, format!("duplicate {what} name `{name}`")));
    }
    Ok(())
}

fn finite(field: &str, v: f64) -> Result<(), SpecError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(err(field, format!("expected a finite number, got {v}")))
    }
}

/// `v` must be finite and within [lo, hi].
pub fn range(field: &str, v: f64, lo: f64, hi: f64) -> Result<(), SpecError> {
    finite(field, v)?;
    if v < lo || v > hi {
        return Err(err(
            field,
            format!("{v} is out of range; allowed {lo:.4} to {hi:.4}"),
        ));
    }
    Ok(())
}

/// `v` must be finite, strictly positive and within [lo, hi].
pub fn positive(field: &str, v: f64, lo: f64, hi: f64) -> Result<(), SpecError> {
    finite(field, v)?;
    if v <= 0.0 {
        return Err(err(
            field,
            format!("{v} must be positive; allowed {lo:.4} to {hi:.4}"),
        ));
    }
    range(field, v, lo, hi)
}
