//! Fiber Bragg grating physics: wavelength shift from axial strain and temperature,
//! and temperature compensation with a free reference grating.
//!
//! Δλ/λ = (1 − p_e) ε + (α + ξ) ΔT, with p_e the effective photo-elastic constant,
//! α the fiber's thermal expansion and ξ its thermo-optic coefficient. Defaults are
//! standard values for silica single-mode fiber near 1550 nm: p_e = 0.22 gives
//! ≈ 1.2 pm/µε, α + ξ = 6.45e-6 /K gives ≈ 10 pm/K.

use serde::{Deserialize, Serialize};

/// Optical constants of the fiber, settable in a design's optional `[fiber]` section.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiberOptics {
    /// Effective photo-elastic (Pockels) constant p_e, dimensionless.
    #[serde(default = "default_pe")]
    pub photoelastic_pe: f64,
    /// Thermal expansion coefficient of the fiber α, 1/K.
    #[serde(default = "default_alpha")]
    pub thermal_expansion_per_k: f64,
    /// Thermo-optic coefficient ξ = (dn/dT)/n, 1/K.
    #[serde(default = "default_xi")]
    pub thermo_optic_per_k: f64,
    /// Amplitude Δn of the gratings' index fringes (the transfer-matrix model's coupling
    /// κ = π·Δn/λ). Default 2·10⁻⁴: κL ≈ 2 and a peak reflectivity of about 93 % for a
    /// 5 mm grating at 1550 nm (no paper states it; docs/spectra.md §8).
    #[serde(default = "default_index_modulation")]
    pub index_modulation: f64,
    /// Effective index of the guided mode (1.447: SMF-28 at 1550 nm).
    #[serde(default = "default_effective_index")]
    pub effective_index: f64,
    /// Apodisation of the gratings' index modulation (default uniform, the strongest
    /// side lobes: `uniform`, `raised_cosine`, or `{ gaussian = { fwhm_fraction = 0.5 } }`).
    #[serde(default = "default_apodisation")]
    pub apodisation: fbgforge_spectra::Apodisation,
}

fn default_pe() -> f64 {
    0.22
}
fn default_alpha() -> f64 {
    0.55e-6
}
fn default_xi() -> f64 {
    5.9e-6
}
fn default_index_modulation() -> f64 {
    2e-4
}
fn default_effective_index() -> f64 {
    1.447
}
fn default_apodisation() -> fbgforge_spectra::Apodisation {
    fbgforge_spectra::Apodisation::Uniform
}

impl Default for FiberOptics {
    fn default() -> Self {
        FiberOptics {
            photoelastic_pe: default_pe(),
            thermal_expansion_per_k: default_alpha(),
            thermo_optic_per_k: default_xi(),
            index_modulation: default_index_modulation(),
            effective_index: default_effective_index(),
            apodisation: default_apodisation(),
        }
    }
}

impl FiberOptics {
    /// Strain sensitivity of a grating at `lambda_nm`, pm per microstrain.
    pub fn strain_sensitivity_pm_per_microstrain(&self, lambda_nm: f64) -> f64 {
        lambda_nm * 1e3 * (1.0 - self.photoelastic_pe) * 1e-6
    }

    /// Temperature sensitivity of a bare grating at `lambda_nm`, pm per kelvin.
    pub fn temperature_sensitivity_pm_per_k(&self, lambda_nm: f64) -> f64 {
        lambda_nm * 1e3 * (self.thermal_expansion_per_k + self.thermo_optic_per_k)
    }

    /// Wavelength shift, pm, of a grating at `lambda_nm` under axial strain `strain`
    /// (dimensionless, positive in tension) and temperature change `delta_t_k`.
    pub fn shift_pm(&self, lambda_nm: f64, strain: f64, delta_t_k: f64) -> f64 {
        lambda_nm
            * 1e3
            * ((1.0 - self.photoelastic_pe) * strain
                + (self.thermal_expansion_per_k + self.thermo_optic_per_k) * delta_t_k)
    }

    /// The transfer-matrix model of a grating of this fiber (`fbgforge_spectra::Grating`):
    /// its Bragg wavelength and length from the design, Δn, n_eff, p_e and apodisation
    /// from `[fiber]`, 100 sections.
    pub fn bragg_grating(
        &self,
        bragg_wavelength_nm: f64,
        length_mm: f64,
    ) -> fbgforge_spectra::Grating {
        fbgforge_spectra::Grating {
            bragg_wavelength_nm,
            length_mm,
            index_modulation: self.index_modulation,
            n_eff: self.effective_index,
            photoelastic: self.photoelastic_pe,
            apodisation: self.apodisation,
            sections: 100,
        }
    }

    /// Axial strain (dimensionless) that produces `shift_pm` at `lambda_nm` with no
    /// temperature change.
    pub fn strain_from_shift(&self, lambda_nm: f64, shift_pm: f64) -> f64 {
        shift_pm / (lambda_nm * 1e3 * (1.0 - self.photoelastic_pe))
    }
}

/// Remove temperature from a strain grating's shift with a free reference grating.
///
/// The reference sees only temperature, and a grating's thermal response scales with
/// its wavelength, so the reference shift is scaled by λ_sensor / λ_reference before
/// it is subtracted. Returns the strain-only shift, pm.
pub fn compensate_temperature_pm(
    sensor_shift_pm: f64,
    sensor_lambda_nm: f64,
    reference_shift_pm: f64,
    reference_lambda_nm: f64,
) -> f64 {
    sensor_shift_pm - reference_shift_pm * sensor_lambda_nm / reference_lambda_nm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_match_textbook_sensitivities() {
        let f = FiberOptics::default();
        // ≈ 1.2 pm/µε and ≈ 10 pm/K at 1550 nm (reference §1).
        let s = f.strain_sensitivity_pm_per_microstrain(1550.0);
        assert!((s - 1.209).abs() < 0.001, "{s}");
        let t = f.temperature_sensitivity_pm_per_k(1550.0);
        assert!((t - 10.0).abs() < 0.05, "{t}");
    }

    #[test]
    fn compensation_removes_a_pure_temperature_shift() {
        let f = FiberOptics::default();
        let (ls, lr) = (1546.295, 1560.146);
        let strain = 120e-6;
        let dt = 7.5;
        let sensor = f.shift_pm(ls, strain, dt);
        let reference = f.shift_pm(lr, 0.0, dt);
        let clean = compensate_temperature_pm(sensor, ls, reference, lr);
        assert!((clean - f.shift_pm(ls, strain, 0.0)).abs() < 1e-9);
        assert!((f.strain_from_shift(ls, clean) - strain).abs() < 1e-15);
    }
}
