//! Transfer-matrix (coupled-mode) model of a fiber Bragg grating under a strain profile
//! (Erdogan, J. Lightwave Technol. 15(8), 1997).
//!
//! The grating is cut into `sections` uniform pieces of length Δz. In piece j the local
//! Bragg wavelength is λ_D,j = λ_B·(1 + (1 − p_e)·ε(z_j)) and the ac coupling
//! κ_j = π·Δn·a(z_j)/λ (Δn the index-modulation amplitude, a the apodisation, 0…1); the
//! detuning is σ̂_j = 2π·n_eff·(1/λ − 1/λ_D,j). Each piece's 2×2 matrix
//!
//! ```text
//! F = [ C − i(σ̂/γ)·sinh(γΔz)     −i(κ/γ)·sinh(γΔz) ]      γ² = κ² − σ̂²,
//!     [ i(κ/γ)·sinh(γΔz)      C + i(σ̂/γ)·sinh(γΔz) ]      C = cosh(γΔz)
//! ```
//!
//! (with γ = i·g, cosh → cos and sinh(γΔz)/γ → sin(gΔz)/g when |σ̂| > κ) multiplies the
//! amplitudes (R, S) from the far end (R = 1, S = 0) to the input; the reflectivity is
//! |S/R|².
//!
//! Assumptions: a single-mode fiber, one polarisation (no birefringence: transverse
//! stress does not split the peak in this model); the mean index is uniform along the
//! grating (apodisation changes the fringe visibility only, as with a dithered phase
//! mask), so the dc self-coupling is a constant folded into n_eff and λ_B; strain
//! changes the local Bragg wavelength only (period and index together through p_e),
//! not n_eff in the detuning prefactor nor κ; no loss; strain piecewise constant over
//! a section.

mod shape;

use nalgebra::Complex;
use serde::{Deserialize, Serialize};

use crate::error::SpectrumError;
use crate::spectrum::{PowerUnit, Spectrum};

pub use shape::{
    auto_grid, clean_peak_limit, clean_peak_limit_against, reflection_shape, spectrum_shape,
    spectrum_shape_against, unstrained_shape, CleanPeakCriteria, CleanPeakLimit, LoadCase,
    SpectrumShape,
};

/// How the index modulation varies along the grating (z from 0 to L).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Apodisation {
    /// Constant modulation.
    Uniform,
    /// exp(−4 ln2·((z − L/2)/W)²) with W = `fwhm_fraction`·L the FWHM of the modulation.
    Gaussian {
        /// FWHM of the modulation profile as a fraction of the length.
        fwhm_fraction: f64,
    },
    /// Raised cosine ½(1 + cos(2π(z − L/2)/L)): zero at both ends.
    RaisedCosine,
}

impl Apodisation {
    /// The profile a(z) ∈ [0, 1] at position `z_mm` of a grating of `length_mm`.
    pub fn profile(self, z_mm: f64, length_mm: f64) -> f64 {
        let u = (z_mm - 0.5 * length_mm) / length_mm;
        match self {
            Apodisation::Uniform => 1.0,
            Apodisation::Gaussian { fwhm_fraction } => {
                (-4.0 * std::f64::consts::LN_2 * (u / fwhm_fraction).powi(2)).exp()
            }
            Apodisation::RaisedCosine => 0.5 * (1.0 + (2.0 * std::f64::consts::PI * u).cos()),
        }
    }
}

/// A fiber Bragg grating. Defaults: λ_B = 1550 nm, L = 10 mm, Δn = 1·10⁻⁴ (κL ≈ 2.03,
/// peak reflectivity tanh²(κL) ≈ 0.93), n_eff = 1.447 (SMF-28 at 1550 nm), p_e = 0.22
/// (silica; 1.21 pm/µε at 1550 nm), uniform apodisation, 100 sections.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Grating {
    /// Unstrained Bragg (peak) wavelength λ_B = 2·n_eff·Λ, nm.
    pub bragg_wavelength_nm: f64,
    /// Grating length L, mm.
    pub length_mm: f64,
    /// Amplitude Δn of the index fringes (fringe visibility × mean index change); the ac
    /// coupling is κ = π·Δn/λ.
    pub index_modulation: f64,
    /// Effective index of the guided mode.
    pub n_eff: f64,
    /// Effective photo-elastic coefficient p_e: Δλ_B/λ_B = (1 − p_e)·ε.
    pub photoelastic: f64,
    /// Apodisation profile.
    pub apodisation: Apodisation,
    /// Number of uniform sections of the transfer-matrix product.
    pub sections: usize,
}

impl Default for Grating {
    fn default() -> Self {
        Grating {
            bragg_wavelength_nm: 1550.0,
            length_mm: 10.0,
            index_modulation: 1e-4,
            n_eff: 1.447,
            photoelastic: 0.22,
            apodisation: Apodisation::Uniform,
            sections: 100,
        }
    }
}

impl Grating {
    /// Checks that every field is usable.
    pub fn validate(&self) -> Result<(), SpectrumError> {
        let ok = self.bragg_wavelength_nm > 0.0
            && self.length_mm > 0.0
            && self.index_modulation >= 0.0
            && self.n_eff > 0.0
            && self.photoelastic < 1.0
            && self.sections >= 1
            && match self.apodisation {
                Apodisation::Gaussian { fwhm_fraction } => fwhm_fraction > 0.0,
                _ => true,
            };
        if ok {
            Ok(())
        } else {
            Err(SpectrumError::Invalid(format!(
                "grating parameters out of range: {self:?}"
            )))
        }
    }

    /// Peak coupling κ = π·Δn/λ_B, 1/mm.
    pub fn kappa_per_mm(&self) -> f64 {
        std::f64::consts::PI * self.index_modulation / (self.bragg_wavelength_nm * 1e-6)
    }

    /// Closed form for a uniform grating: peak reflectivity tanh²(κL).
    pub fn uniform_peak_reflectivity(&self) -> f64 {
        (self.kappa_per_mm() * self.length_mm).tanh().powi(2)
    }

    /// Closed form for a uniform grating: bandwidth between the first zeros around the
    /// peak, (λ_B²/(π·n_eff·L))·√((κL)² + π²), nm.
    pub fn uniform_bandwidth_nm(&self) -> f64 {
        let kl = self.kappa_per_mm() * self.length_mm;
        let lambda_mm = self.bragg_wavelength_nm * 1e-6;
        1e6 * lambda_mm * lambda_mm / (std::f64::consts::PI * self.n_eff * self.length_mm)
            * (kl * kl + std::f64::consts::PI.powi(2)).sqrt()
    }

    /// Strain sensitivity λ_B·(1 − p_e), pm/µε.
    pub fn strain_sensitivity_pm_per_microstrain(&self) -> f64 {
        self.bragg_wavelength_nm * (1.0 - self.photoelastic) * 1e-3
    }

    /// Local Bragg wavelength (nm) at strain ε.
    pub fn local_bragg_nm(&self, strain: f64) -> f64 {
        self.bragg_wavelength_nm * (1.0 + (1.0 - self.photoelastic) * strain)
    }
}

/// Axial strain along the grating, z in mm from its start (0) to its end (L).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StrainProfile {
    /// The same strain everywhere.
    Uniform(f64),
    /// Linear from `start` (z = 0) to `end` (z = L): a strain gradient, i.e. a linear chirp.
    Linear {
        /// Strain at z = 0.
        start: f64,
        /// Strain at z = L.
        end: f64,
    },
    /// Samples (an FE profile), linearly interpolated, constant beyond the ends.
    Samples {
        /// Positions, mm, strictly increasing.
        z_mm: Vec<f64>,
        /// Strain at each position.
        strain: Vec<f64>,
    },
}

impl StrainProfile {
    /// A sampled profile; checks lengths and strictly increasing positions.
    pub fn samples(z_mm: Vec<f64>, strain: Vec<f64>) -> Result<Self, SpectrumError> {
        if z_mm.is_empty() || z_mm.len() != strain.len() || z_mm.windows(2).any(|w| !(w[1] > w[0]))
        {
            return Err(SpectrumError::Invalid(
                "strain profile: need equally many strictly increasing positions and strains"
                    .into(),
            ));
        }
        Ok(StrainProfile::Samples { z_mm, strain })
    }

    /// Strain at `z_mm` on a grating of `length_mm`.
    pub fn at(&self, z_mm: f64, length_mm: f64) -> f64 {
        match self {
            StrainProfile::Uniform(e) => *e,
            StrainProfile::Linear { start, end } => start + (end - start) * (z_mm / length_mm),
            StrainProfile::Samples { z_mm: z, strain } => {
                let k = z.partition_point(|&v| v <= z_mm);
                if k == 0 {
                    strain[0]
                } else if k == z.len() {
                    strain[z.len() - 1]
                } else {
                    let t = (z_mm - z[k - 1]) / (z[k] - z[k - 1]);
                    strain[k - 1] + t * (strain[k] - strain[k - 1])
                }
            }
        }
    }

    /// The profile sampled at the centres of `sections` equal pieces of the grating.
    pub fn at_sections(&self, length_mm: f64, sections: usize) -> Vec<f64> {
        let dz = length_mm / sections as f64;
        (0..sections)
            .map(|j| self.at((j as f64 + 0.5) * dz, length_mm))
            .collect()
    }
}

/// Per-section constants of the product: (local Bragg wavelength in mm, apodisation).
struct Sections {
    dz_mm: f64,
    bragg_mm: Vec<f64>,
    apodisation: Vec<f64>,
}

impl Sections {
    fn new(g: &Grating, strain: &StrainProfile) -> Self {
        let dz = g.length_mm / g.sections as f64;
        let eps = strain.at_sections(g.length_mm, g.sections);
        Sections {
            dz_mm: dz,
            bragg_mm: eps.iter().map(|&e| g.local_bragg_nm(e) * 1e-6).collect(),
            apodisation: (0..g.sections)
                .map(|j| g.apodisation.profile((j as f64 + 0.5) * dz, g.length_mm))
                .collect(),
        }
    }

    /// Power reflectivity at `wavelength_nm`.
    fn reflectivity(&self, g: &Grating, wavelength_nm: f64) -> f64 {
        let lambda = wavelength_nm * 1e-6;
        let two_pi_n = 2.0 * std::f64::consts::PI * g.n_eff;
        let kappa0 = std::f64::consts::PI * g.index_modulation / lambda;
        let i = Complex::new(0.0, 1.0);
        let (mut r, mut s) = (Complex::new(1.0, 0.0), Complex::new(0.0, 0.0));
        // From the far end (z = L) back to the input (z = 0).
        for j in (0..self.bragg_mm.len()).rev() {
            let kappa = kappa0 * self.apodisation[j];
            let sigma = two_pi_n * (1.0 / lambda - 1.0 / self.bragg_mm[j]);
            let gamma2 = kappa * kappa - sigma * sigma;
            let (c, sinh_over_gamma) = if gamma2 >= 0.0 {
                let gm = gamma2.sqrt();
                let x = gm * self.dz_mm;
                (x.cosh(), if x > 1e-8 { x.sinh() / gm } else { self.dz_mm })
            } else {
                let gm = (-gamma2).sqrt();
                let x = gm * self.dz_mm;
                (x.cos(), if x > 1e-8 { x.sin() / gm } else { self.dz_mm })
            };
            let f11 = Complex::new(c, -sigma * sinh_over_gamma);
            let f12 = -i * (kappa * sinh_over_gamma);
            let f21 = i * (kappa * sinh_over_gamma);
            let f22 = Complex::new(c, sigma * sinh_over_gamma);
            (r, s) = (f11 * r + f12 * s, f21 * r + f22 * s);
        }
        (s / r).norm_sqr()
    }
}

/// Power reflectivity of the grating under a strain profile at one wavelength.
pub fn reflectivity(grating: &Grating, strain: &StrainProfile, wavelength_nm: f64) -> f64 {
    Sections::new(grating, strain).reflectivity(grating, wavelength_nm)
}

/// The grating's reflection spectrum (power reflectivity, unit `Linear`) on the given
/// wavelengths, by the transfer-matrix method.
///
/// ```
/// use fbgforge_spectra::grating::{grating_spectrum, Grating, StrainProfile};
/// let g = Grating::default(); // 10 mm, Δn = 1e-4, λ_B = 1550 nm
/// let grid: Vec<f64> = (0..401).map(|i| 1549.8 + 0.001 * i as f64).collect();
/// // 100 µε of uniform strain moves the peak by λ_B·(1 − p_e)·ε ≈ 121 pm.
/// let s = grating_spectrum(&g, &StrainProfile::Uniform(100e-6), &grid).unwrap();
/// let (k, r_max) = s.power.iter().enumerate().fold((0, 0.0), |m, (k, &r)| if r > m.1 { (k, r) } else { m });
/// assert!((s.wavelengths_nm[k] - 1550.1209).abs() < 0.002);
/// assert!((r_max - g.uniform_peak_reflectivity()).abs() < 1e-3);
/// ```
pub fn grating_spectrum(
    grating: &Grating,
    strain: &StrainProfile,
    wavelengths_nm: &[f64],
) -> Result<Spectrum, SpectrumError> {
    grating.validate()?;
    let sections = Sections::new(grating, strain);
    let power = wavelengths_nm
        .iter()
        .map(|&w| sections.reflectivity(grating, w))
        .collect();
    let mut s = Spectrum::new(
        "reflectivity",
        wavelengths_nm.to_vec(),
        power,
        PowerUnit::Linear,
    )?;
    s.metadata = vec![
        (
            "model".into(),
            "transfer-matrix (coupled-mode), Erdogan 1997".into(),
        ),
        (
            "grating".into(),
            serde_json::to_string(grating).unwrap_or_default(),
        ),
    ];
    Ok(s)
}
