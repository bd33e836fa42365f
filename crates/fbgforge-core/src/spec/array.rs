//! `[array]`: the flat tactile array's TOML types (the sheet, its gratings, the casting
//! mold, how the sheet rests on the table, which model predicts its sensing matrix) and
//! the mold's derived slit dimensions.

use super::{Design, Printer};
use serde::{Deserialize, Serialize};

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
    /// printer ([`FiberRouting::channel_width_mm`](super::FiberRouting::channel_width_mm)); a stated value may not be narrower.
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
    /// Sheet thickness, mm (the fibers lie at `fiber_depth_mm`, mid-thickness by default).
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
    /// Depth of the fibers' axes below the loaded face, mm (default: mid-thickness).
    /// The loaded face is the one cast against the mold's floor (the paper's sensing
    /// surface), so this is also the fibers' height above the cavity floor, from which
    /// the mold's slit depth derives.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fiber_depth_mm: Option<f64>,
    /// How the sheet rests on the table: `[array.base]` with `condition = "bonded"`,
    /// `"frictionless"` or `"gripping"` (then `tangential_stiffness_n_per_mm3`).
    /// Default: gripping with the stiffness fitted to the paper's Table 1
    /// ([`PAPER_TANGENTIAL_STIFFNESS_N_PER_MM3`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base: Option<BaseCondition>,
    /// Diameter of the disc through which a load presses on a cell, mm (default 20,
    /// the paper's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub indenter_diameter_mm: Option<f64>,
    /// Which model predicts the sensing matrix wherever a model matrix is used
    /// (`reconstruct --design`, `place`, `live`, Python): `sheet` (default, the
    /// physical model of docs/array.md §12) or `kernel` (the empirical distance kernel
    /// fitted to the paper's tables, §1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<ArrayModelKind>,
}

/// The table interface fitted to the paper's Table 1 with the sheet model, N/mm³
/// (docs/array.md §12.3): the default when a design has no `[array.base]`.
pub const PAPER_TANGENTIAL_STIFFNESS_N_PER_MM3: f64 = 0.02;

/// How the sheet's underside holds on the table (it never lifts off).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "condition", rename_all = "lowercase", deny_unknown_fields)]
pub enum BaseCondition {
    /// Glued to the table: no tangential displacement at the underside.
    Bonded,
    /// Lubricated: no shear traction at the underside.
    Frictionless,
    /// Resting on the table, held tangentially by an interface of this stiffness per
    /// area: the shear traction is −k_t times the tangential slip.
    Gripping {
        /// k_t, N/mm³ (MPa per mm of slip).
        tangential_stiffness_n_per_mm3: f64,
    },
}

impl BaseCondition {
    /// A short description for tables and reports.
    pub fn describe(&self) -> String {
        match self {
            BaseCondition::Bonded => "bonded to the table".to_string(),
            BaseCondition::Frictionless => "frictionless on the table".to_string(),
            BaseCondition::Gripping {
                tangential_stiffness_n_per_mm3: k,
            } => format!("gripping the table, k_t = {k} N/mm³"),
        }
    }

    /// The same condition's name in a design file.
    pub fn name(&self) -> &'static str {
        match self {
            BaseCondition::Bonded => "bonded",
            BaseCondition::Frictionless => "frictionless",
            BaseCondition::Gripping { .. } => "gripping",
        }
    }
}

/// Which model predicts an array's sensing matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ArrayModelKind {
    /// The physical model of the sheet, its fibers and its table.
    Sheet,
    /// The empirical distance kernel fitted to the paper's Tables 1 and 2.
    Kernel,
}

impl ArrayModelKind {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ArrayModelKind::Sheet => "sheet",
            ArrayModelKind::Kernel => "kernel",
        }
    }

    /// Parse `sheet` or `kernel`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "sheet" => Some(ArrayModelKind::Sheet),
            "kernel" => Some(ArrayModelKind::Kernel),
            _ => None,
        }
    }
}

impl TactileArray {
    /// Depth of the fibers' axes below the loaded face, mm (mid-thickness by default).
    pub fn fiber_depth(&self) -> f64 {
        self.fiber_depth_mm.unwrap_or(self.thickness_mm / 2.0)
    }

    /// The table condition (the paper's fitted interface by default).
    pub fn base_condition(&self) -> BaseCondition {
        self.base.unwrap_or(BaseCondition::Gripping {
            tangential_stiffness_n_per_mm3: PAPER_TANGENTIAL_STIFFNESS_N_PER_MM3,
        })
    }

    /// The indenter's diameter, mm (20 by default).
    pub fn indenter_diameter(&self) -> f64 {
        self.indenter_diameter_mm.unwrap_or(20.0)
    }

    /// The model that predicts the sensing matrix (the sheet model by default).
    pub fn model_kind(&self) -> ArrayModelKind {
        self.model.unwrap_or(ArrayModelKind::Sheet)
    }
}

/// Height of the fiber's seat (the slit bottom) above the mold's underside: where the
/// coated fiber resting on it has its axis at the fiber depth (mid-thickness by default), put on the
/// nearest layer boundary of `printer` (a slicer prints it there anyway; the fiber's
/// axis is then off mid-sheet by at most half a layer, and the solid says by how
/// much), mm.
pub fn seat_z_mm(a: &TactileArray, coated_diameter_mm: f64, printer: &Printer) -> f64 {
    let ideal = a.mold.base_thickness_mm + a.fiber_depth() - coated_diameter_mm / 2.0;
    printer.nearest_layer_mm(ideal)
}

/// Depth of a mold slit below the wall top down to the fiber's seat ([`seat_z_mm`]),
/// mm.
pub fn derived_slit_depth_mm(a: &TactileArray, coated_diameter_mm: f64, printer: &Printer) -> f64 {
    a.mold.base_thickness_mm + a.mold.wall_height_mm - seat_z_mm(a, coated_diameter_mm, printer)
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
