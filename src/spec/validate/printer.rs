//! Checks on the printer, the fiber (optics and routing) and the material table.

use super::rules::{positive, range};
use crate::spec::error::{err, SpecError};
use crate::spec::Design;

impl Design {
    /// The printer, the fiber routing and the fiber's optical constants.
    pub(super) fn validate_printer(&self) -> Result<(), SpecError> {
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
        Ok(())
    }

    /// The material table: not empty, each modulus, Poisson's ratio and permissible
    /// strain in range.
    pub(super) fn validate_materials(&self) -> Result<(), SpecError> {
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
        Ok(())
    }
}
