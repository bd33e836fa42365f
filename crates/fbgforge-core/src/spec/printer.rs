//! What the parts are printed on and in: the printer (`[printer]`), the material table
//! (`[materials.*]`) and the fiber routing (`[fiber_routing]`: the coated fiber and the
//! channels the printer leaves open for it).

use serde::{Deserialize, Serialize};
use std::fmt;

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
    /// PolyJet). A printed gap narrower than the nozzle closes up, so no fiber
    /// passage is narrower than the nozzle plus the channel clearance
    /// ([`FiberRouting::min_passage_mm`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nozzle_diameter_mm: Option<f64>,
    /// Layer height the parts are sliced at, mm (default 0.2 mm for `fdm`, 0.027 mm
    /// for PolyJet, the J750's high-speed layer). The first layer is taken to be as
    /// high; horizontal faces a fiber rests on (the mold's seats) are put on a layer
    /// boundary so the slicer prints them where the solid has them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layer_height_mm: Option<f64>,
}

impl Printer {
    /// Default meshing tolerance (maximum chord deviation), mm.
    pub fn default_tolerance_mm(&self) -> f64 {
        self.resolution_mm / 2.0
    }

    /// The nozzle diameter of an FDM printer (the stated one, else 0.4 mm); None for
    /// PolyJet.
    pub fn nozzle_mm(&self) -> Option<f64> {
        (self.process == PrintProcess::Fdm)
            .then(|| self.nozzle_diameter_mm.unwrap_or(DEFAULT_FDM_NOZZLE_MM))
    }

    /// Layer height, mm: the stated one, else 0.2 mm (FDM) or 0.027 mm (PolyJet).
    pub fn layer_height_mm(&self) -> f64 {
        self.layer_height_mm.unwrap_or(match self.process {
            PrintProcess::Fdm => DEFAULT_FDM_LAYER_MM,
            PrintProcess::Polyjet => DEFAULT_POLYJET_LAYER_MM,
        })
    }

    /// The layer boundary nearest `z_mm` (layers of [`layer_height_mm`](Self::layer_height_mm)
    /// from z = 0): where a slicer, which samples each layer at its middle, prints a
    /// horizontal face modelled at `z_mm`.
    pub(crate) fn nearest_layer_mm(&self, z_mm: f64) -> f64 {
        let h = self.layer_height_mm();
        (z_mm / h).round() * h
    }

    /// The lowest layer boundary at or above `z_mm` (to within 1e-9 mm).
    pub fn layer_at_or_above_mm(&self, z_mm: f64) -> f64 {
        let h = self.layer_height_mm();
        (z_mm / h - 1e-9).ceil() * h
    }

    /// The hysteresis `verify` allows a grating in a part from this printer when its
    /// material states none, % of span: 10 % for both processes. The tactile-array
    /// paper's single encapsulated grating showed ±4.33 % of span (reference §2): a
    /// loop of at most 8.7 % even read as half its width; a bonded grating that
    /// follows its part stays within 10 %, a loose one (friction in the bond) reads
    /// 12–40 %.
    pub fn default_hysteresis_limit_percent_span(&self) -> f64 {
        match self.process {
            PrintProcess::Polyjet | PrintProcess::Fdm => 10.0,
        }
    }
}

/// Layer height assumed for an FDM printer that states none, mm.
pub const DEFAULT_FDM_LAYER_MM: f64 = 0.2;
/// Layer height assumed for a PolyJet printer that states none (J750 high speed), mm.
pub const DEFAULT_POLYJET_LAYER_MM: f64 = 0.027;

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
    /// The vendor's name of the printing material (e.g. `VeroBlue RGD840`,
    /// `Agilus30 FLX935`, `Prusament PLA`): what the printer's software calls it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vendor_name: Option<String>,
    /// Shore hardness as the datasheet states it, scale last or first: `30A`, `85A`,
    /// `D83`, `00-30`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shore_hardness: Option<String>,
    /// Display colour of the material in the 3MF files and previews, `#RRGGBB`
    /// (default: one of a fixed palette, by the material's place in the table).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub display_colour: Option<String>,
    /// Largest hysteresis a grating bonded in this material may show in `verify`, % of
    /// span (loading against unloading of the lag-corrected signal; default: the
    /// printer's, [`Printer::default_hysteresis_limit_percent_span`]). Above it the
    /// grating is not following the part: the part FAILs whatever its K.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hysteresis_limit_percent_span: Option<f64>,
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
    /// The printer's floor for any fiber passage (hole, bore, slot, slit): the
    /// narrowest one it leaves open around this fiber, mm.
    ///
    /// - PolyJet: the coated fiber + the printer's resolution (a surface prints within
    ///   the resolution of where it is drawn).
    /// - FDM: the wider of (coated fiber + resolution) and the nozzle, + the channel
    ///   clearance. A passage narrower than the nozzle cannot be drawn around, and the
    ///   slicer's perimeters eat into a small hole: PrusaSlicer 2.5 (0.4 mm nozzle,
    ///   0.45 mm perimeters) leaves 0.21 mm open of a 0.35 mm hole, 0.29 of 0.40 and
    ///   0.40 of 0.50 (docs/geometry.md, "The printer's floor"), so the fiber keeps
    ///   its clearance only above the nozzle.
    pub fn min_passage_mm(&self, printer: &Printer) -> f64 {
        let fiber = self.coated_diameter_mm + printer.resolution_mm;
        match printer.nozzle_mm() {
            Some(nozzle) => fiber.max(nozzle) + self.channel_clearance_mm,
            None => fiber,
        }
    }

    /// How [`min_passage_mm`](Self::min_passage_mm) is made up, in words, for messages.
    pub fn min_passage_words(&self, printer: &Printer) -> String {
        let need = self.min_passage_mm(printer);
        let fiber = self.coated_diameter_mm + printer.resolution_mm;
        match printer.nozzle_mm() {
            Some(nozzle) if nozzle >= fiber => format!(
                "{need:.3} mm: the FDM printer's floor, its nozzle {nozzle} mm (printer.nozzle_diameter_mm) + the channel clearance {} mm (fiber_routing.channel_clearance_mm)",
                self.channel_clearance_mm
            ),
            Some(_) => format!(
                "{need:.3} mm: the coated fiber {} mm + the printer's resolution {} mm + the channel clearance {} mm (an FDM printer's perimeters eat into a small hole)",
                self.coated_diameter_mm, printer.resolution_mm, self.channel_clearance_mm
            ),
            None => format!(
                "{need:.3} mm: the coated fiber {} mm + the printer's resolution {} mm",
                self.coated_diameter_mm, printer.resolution_mm
            ),
        }
    }

    /// Width of a fiber channel or slit on `printer`: the coated fiber plus its
    /// clearance each side, but never narrower than the printer's floor
    /// ([`min_passage_mm`](Self::min_passage_mm)), mm.
    pub fn channel_width_mm(&self, printer: &Printer) -> f64 {
        (self.coated_diameter_mm + 2.0 * self.channel_clearance_mm)
            .max(self.min_passage_mm(printer))
    }
}
