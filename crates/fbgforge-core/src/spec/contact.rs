//! `[module.contact]`: how cap and core touch and are held together, with the
//! defaults the models use when the table (or a field of it) is absent, and the family
//! rule that carries the contact to a module of another size.
//!
//! Every length of the contact reading is stated relative to the geometric feature it
//! scales with ([`ContactRatios`]): the clip band to the cap wall, the printed dome
//! clearance to the cap/core fit clearance, the domes' contact zone to the apex patch.
//! A length given in mm (a measurement at one size) is converted to its ratio before
//! any geometry edit ([`Module::restate_contact_relative`]), so `family`, `optimize`
//! and `sweep` all scale the contact by this one rule.

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
/// experiments (docs/model.md §5.6). Each length is stated either relative to its
/// feature (`*_to_*`, the family rule) or, for one size only, in mm; not both.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Contact {
    /// Cap/core coupling along the cylinders (`sliding` or `bonded`).
    #[serde(default)]
    pub cylinders: CylinderCoupling,
    /// Height of the clip band at the base, in cap walls (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clip_height_to_cap_wall: Option<f64>,
    /// Radial gap between the cap's dome and the core's dome as printed, as a multiple
    /// of `cap_core_clearance_mm` (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dome_clearance_to_fit_clearance: Option<f64>,
    /// Radius of the zone around the apex over which the domes bear on each other under
    /// working loads, as a multiple of the apex contact patch (apex flat radius + cap
    /// wall / 2); default [`Contact::DEFAULT_CONTACT_TO_PATCH`]. The one contact
    /// parameter a measured Case I sensitivity calibrates (`verify --calibrate-into`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dome_contact_radius_to_patch: Option<f64>,
    /// The clip band's height in mm at this size (instead of `clip_height_to_cap_wall`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clip_height_mm: Option<f64>,
    /// The printed dome clearance in mm at this size (instead of
    /// `dome_clearance_to_fit_clearance`). The unilateral contact analysis closes it
    /// under load.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dome_clearance_mm: Option<f64>,
    /// The domes' contact radius in mm at this size, measured on the core's dome
    /// (instead of `dome_contact_radius_to_patch`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dome_contact_radius_mm: Option<f64>,
    /// Where the numbers come from (e.g. the log a calibration was fitted to).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// The contact reading's lengths as multiples of the features they scale with: the
/// family rule (what stays fixed when a module is scaled, interpolated or optimised).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ContactRatios {
    /// Clip band height / cap wall.
    pub clip_height_to_cap_wall: f64,
    /// Printed dome clearance / cap–core fit clearance.
    pub dome_clearance_to_fit_clearance: f64,
    /// Domes' contact radius / apex contact patch radius.
    pub dome_contact_radius_to_patch: f64,
}

impl Contact {
    /// Default contact radius as a multiple of the apex contact patch radius: the
    /// middle of the window in which the FE model meets the paper's Case I statements
    /// and puts the blue insert within 8 % of the paper's model (34 mm, docs/model.md
    /// §5.6).
    pub const DEFAULT_CONTACT_TO_PATCH: f64 = 1.376;

    /// The window of contact radii, as multiples of the apex patch, within which the FE
    /// model meets every qualitative Case I statement of the paper on the 34 mm module
    /// (docs/model.md §5.6): the model's own uncertainty about the contact, which the
    /// robust optimiser scores designs over.
    pub const PAPER_WINDOW_TO_PATCH: (f64, f64) = (1.30, 1.48);

    /// Whether every field is at its default (then the table is not written).
    pub(crate) fn is_default(&self) -> bool {
        *self == Contact::default()
    }
}

/// Relative tolerance within which a contact radius counts as the shipped default.
const DEFAULT_MATCH: f64 = 1e-3;

impl Module {
    /// Radius of the apex contact patch on the domes' neutral surface: the apex flat
    /// widened through half the cap wall, mm.
    pub fn apex_patch_radius_mm(&self) -> f64 {
        0.5 * self.apex_flat_diameter_mm + 0.5 * self.cap_wall_mm
    }

    /// The clip band's height, mm.
    pub fn clip_height_mm(&self) -> f64 {
        self.contact
            .clip_height_mm
            .unwrap_or(self.contact.clip_height_to_cap_wall.unwrap_or(1.0) * self.cap_wall_mm)
    }

    /// The dome clearance as printed, mm.
    pub fn dome_clearance_mm(&self) -> f64 {
        self.contact.dome_clearance_mm.unwrap_or(
            self.contact.dome_clearance_to_fit_clearance.unwrap_or(1.0)
                * self.cap_core_clearance_mm,
        )
    }

    /// The domes' contact radius under working loads, mm.
    pub fn dome_contact_radius_mm(&self) -> f64 {
        self.contact.dome_contact_radius_mm.unwrap_or(
            self.contact
                .dome_contact_radius_to_patch
                .unwrap_or(Contact::DEFAULT_CONTACT_TO_PATCH)
                * self.apex_patch_radius_mm(),
        )
    }

    /// The contact reading relative to its features, at this module's geometry.
    pub(crate) fn contact_ratios(&self) -> ContactRatios {
        // A stated ratio (or a default one) is returned as written: dividing the length
        // it resolves to by its feature would round it, and a family knot would not
        // come back exactly.
        let c = &self.contact;
        let fit = self.cap_core_clearance_mm;
        ContactRatios {
            clip_height_to_cap_wall: match (c.clip_height_to_cap_wall, c.clip_height_mm) {
                (Some(k), _) => k,
                (None, Some(h)) => h / self.cap_wall_mm,
                (None, None) => 1.0,
            },
            dome_clearance_to_fit_clearance: match (
                c.dome_clearance_to_fit_clearance,
                c.dome_clearance_mm,
            ) {
                (Some(k), _) => k,
                (None, Some(g)) if fit > 0.0 => g / fit,
                _ => 1.0,
            },
            dome_contact_radius_to_patch: match (
                c.dome_contact_radius_to_patch,
                c.dome_contact_radius_mm,
            ) {
                (Some(k), _) => k,
                (None, Some(r)) => r / self.apex_patch_radius_mm(),
                (None, None) => Contact::DEFAULT_CONTACT_TO_PATCH,
            },
        }
    }

    /// Restate every contact length given in mm as its ratio to its feature at this
    /// geometry (the family rule), so that a later edit of the geometry carries the
    /// contact along. Fields left to their defaults stay unset. A dome clearance over a
    /// zero fit clearance has no ratio and stays in mm.
    pub fn restate_contact_relative(&mut self) {
        let r = self.contact_ratios();
        let c = &mut self.contact;
        if c.clip_height_mm.take().is_some() {
            c.clip_height_to_cap_wall = Some(r.clip_height_to_cap_wall);
        }
        if c.dome_clearance_mm.is_some() && self.cap_core_clearance_mm > 0.0 {
            c.dome_clearance_mm = None;
            c.dome_clearance_to_fit_clearance = Some(r.dome_clearance_to_fit_clearance);
        }
        if c.dome_contact_radius_mm.take().is_some() {
            c.dome_contact_radius_to_patch = Some(r.dome_contact_radius_to_patch);
        }
    }

    /// This module with its contact set to `ratios` (every length relative).
    pub(crate) fn set_contact_ratios(&mut self, ratios: &ContactRatios) {
        let c = &mut self.contact;
        c.clip_height_mm = None;
        c.dome_clearance_mm = None;
        c.dome_contact_radius_mm = None;
        c.clip_height_to_cap_wall = Some(ratios.clip_height_to_cap_wall);
        c.dome_clearance_to_fit_clearance = Some(ratios.dome_clearance_to_fit_clearance);
        c.dome_contact_radius_to_patch = Some(ratios.dome_contact_radius_to_patch);
    }

    /// Whether the domes' contact radius is the shipped default, 1.376 × the apex patch
    /// (to 0.1 %): chosen to meet the paper's statements, not measured.
    pub fn contact_radius_is_default(&self) -> bool {
        let r = self.contact_ratios().dome_contact_radius_to_patch;
        (r / Contact::DEFAULT_CONTACT_TO_PATCH - 1.0).abs() <= DEFAULT_MATCH
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn module() -> Module {
        let d =
            crate::spec::parse_unvalidated(include_str!("../../../../designs/clip-on-16mm.toml"))
                .unwrap();
        d.module.unwrap()
    }

    #[test]
    fn a_length_in_mm_is_restated_as_its_ratio_and_resolves_to_the_same_length() {
        let mut m = module();
        m.contact = Contact {
            clip_height_mm: Some(1.8),
            dome_clearance_mm: Some(0.04),
            dome_contact_radius_mm: Some(1.5),
            ..Contact::default()
        };
        let before = (
            m.clip_height_mm(),
            m.dome_clearance_mm(),
            m.dome_contact_radius_mm(),
        );
        m.restate_contact_relative();
        assert!(m.contact.clip_height_mm.is_none());
        assert!(m.contact.dome_clearance_mm.is_none());
        assert!(m.contact.dome_contact_radius_mm.is_none());
        let after = (
            m.clip_height_mm(),
            m.dome_clearance_mm(),
            m.dome_contact_radius_mm(),
        );
        for (a, b) in [
            (before.0, after.0),
            (before.1, after.1),
            (before.2, after.2),
        ] {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        // And then scales with its feature: a thicker cap wall widens the patch and the
        // contact zone in proportion.
        let r0 = m.dome_contact_radius_mm() / m.apex_patch_radius_mm();
        m.cap_wall_mm *= 2.0;
        m.cap_core_clearance_mm *= 3.0;
        assert!((m.dome_contact_radius_mm() / m.apex_patch_radius_mm() - r0).abs() < 1e-12);
        assert!((m.clip_height_mm() - 2.0 * 1.8).abs() < 1e-12);
        assert!((m.dome_clearance_mm() - 3.0 * 0.04).abs() < 1e-12);
    }

    #[test]
    fn the_default_radius_is_recognised_in_either_form() {
        let mut m = module();
        m.contact = Contact::default();
        assert!(m.contact_radius_is_default());
        m.contact.dome_contact_radius_mm = Some(1.376 * m.apex_patch_radius_mm());
        assert!(m.contact_radius_is_default());
        m.contact.dome_contact_radius_mm = Some(1.45 * m.apex_patch_radius_mm());
        assert!(!m.contact_radius_is_default());
    }
}
