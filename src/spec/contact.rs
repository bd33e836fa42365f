//! `[module.contact]`: how cap and core touch and are held together, with the
//! defaults the models use when the table (or a field of it) is absent.

use super::module::Module;
use serde::{Deserialize, Serialize};

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
