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
        if let Some(h) = p.layer_height_mm {
            positive("printer.layer_height_mm", h, 0.005, 1.0)?;
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
        // Every slot and bore is a channel: it must pass the fiber with the printer's
        // floor, or it prints closed on the fiber. Only a PolyJet channel can fall
        // below it (an FDM floor includes the clearance).
        let w = fr.channel_width_mm(p);
        let need = fr.min_passage_mm(p);
        if w < need - 1e-9 {
            return Err(err(
                "fiber_routing.channel_clearance_mm",
                format!(
                    "{} mm makes fiber channels {w:.3} mm wide, narrower than the {need:.3} mm a passage needs (coated diameter {} mm + the printer's resolution {} mm); allowed from {:.4} mm",
                    fr.channel_clearance_mm,
                    fr.coated_diameter_mm,
                    p.resolution_mm,
                    p.resolution_mm / 2.0
                ),
            ));
        }
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
        range("fiber.index_modulation", fo.index_modulation, 1e-6, 1e-2)?;
        range("fiber.effective_index", fo.effective_index, 1.0, 2.0)?;
        if let fbgforge_spectra::Apodisation::Gaussian { fwhm_fraction } = fo.apodisation {
            range(
                "fiber.apodisation.gaussian.fwhm_fraction",
                fwhm_fraction,
                0.05,
                10.0,
            )?;
        }
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
            if let Some(h) = m.hysteresis_limit_percent_span {
                positive(
                    &format!("materials.{name}.hysteresis_limit_percent_span"),
                    h,
                    0.1,
                    100.0,
                )?;
            }
            if let Some(v) = &m.vendor_name {
                if v.trim().is_empty() || v.chars().any(char::is_control) {
                    return Err(err(
                        &format!("materials.{name}.vendor_name"),
                        "expected the vendor's material name on one line, e.g. \"VeroBlue RGD840\"",
                    ));
                }
            }
            if let Some(h) = &m.shore_hardness {
                if !is_shore_hardness(h) {
                    return Err(err(
                        &format!("materials.{name}.shore_hardness"),
                        format!("`{h}` is not a Shore hardness; expected a number 0 to 100 and its scale, e.g. \"30A\", \"85A\", \"D83\", \"00-30\""),
                    ));
                }
            }
            if let Some(c) = &m.display_colour {
                if !is_hex_colour(c) {
                    return Err(err(
                        &format!("materials.{name}.display_colour"),
                        format!("`{c}` is not a colour; expected #RRGGBB, e.g. \"#1f4fd8\""),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// `#RRGGBB`.
pub(crate) fn is_hex_colour(c: &str) -> bool {
    c.len() == 7 && c.starts_with('#') && c[1..].chars().all(|x| x.is_ascii_hexdigit())
}

/// A Shore hardness as datasheets write it: a value 0–100 with its scale before or
/// after it (`30A`, `A30`, `85 A`, `D83`, `Shore 30A`, `00-30`).
fn is_shore_hardness(h: &str) -> bool {
    let t = h.trim();
    let t = t.strip_prefix("Shore").unwrap_or(t).trim();
    let (scale, value) = if let Some(v) = t.strip_prefix("00-") {
        ("00", v)
    } else if t.starts_with(|c: char| c.is_ascii_alphabetic()) {
        (&t[..1], t[1..].trim())
    } else {
        let cut = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
        (t[cut..].trim(), t[..cut].trim())
    };
    let scale_ok = matches!(scale, "00" | "A" | "B" | "C" | "D" | "O" | "OO" | "M");
    let value_ok = value
        .parse::<f64>()
        .is_ok_and(|v| (0.0..=100.0).contains(&v));
    scale_ok && value_ok
}
