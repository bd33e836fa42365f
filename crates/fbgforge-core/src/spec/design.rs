//! [`Design`]: what one TOML file holds; parsing it without validation, writing it
//! back, looking up a material and filling the fields a file may leave to be derived.

use super::array::derived_slit_depth_mm;
use super::error::{err, toml_error, SpecError};
use super::{FiberRouting, Material, Module, Printer, TactileArray};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

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

impl Design {
    /// Serialise to TOML (used by the optimiser to write new designs).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).expect("a Design always serialises to TOML")
    }

    /// The transfer-matrix model of the grating `name` (module or array): its Bragg
    /// wavelength and length from the spec, its index modulation, effective index,
    /// photo-elastic constant and apodisation from `[fiber]`.
    pub fn bragg_grating(&self, name: &str) -> Option<fbgforge_spectra::Grating> {
        let module = self
            .module
            .iter()
            .flat_map(|m| &m.gratings)
            .map(|g| (&g.name, g.bragg_wavelength_nm, g.length_mm));
        let array = self
            .array
            .iter()
            .flat_map(|a| &a.gratings)
            .map(|g| (&g.name, g.bragg_wavelength_nm, g.length_mm));
        module
            .chain(array)
            .find(|(n, _, _)| *n == name)
            .map(|(_, lambda, length)| self.fiber.bragg_grating(lambda, length))
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

    /// Fill the fields a file may leave to be derived (the mold's slit width and
    /// depth); [`crate::design`] calls this before validation.
    pub fn fill_derived(&mut self) {
        let width = self.fiber_routing.channel_width_mm(&self.printer);
        let coated = self.fiber_routing.coated_diameter_mm;
        if let Some(a) = &mut self.array {
            let depth = derived_slit_depth_mm(a, coated, &self.printer);
            if a.mold.slit_width_mm.is_nan() {
                a.mold.slit_width_mm = width;
            }
            if a.mold.slit_depth_mm.is_nan() {
                a.mold.slit_depth_mm = depth;
            }
        }
    }
}
