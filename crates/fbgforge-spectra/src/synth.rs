//! Synthetic spectra with known truth: Gaussian or transfer-matrix grating peaks on a
//! floor with white Gaussian noise, in linear power, written in any of the three
//! formats.
//!
//! Truth model: y(λ) = floor + Σ peaks + n, n white Gaussian with standard deviation σ
//! in linear units (mW, or counts for I-MON), point-sampled (no pixel integration). SNR
//! = peak amplitude / σ. When a format stores dB or dBm, samples that the noise has made
//! ≤ 0 are clamped to 10⁻⁶ of the largest truth value before the logarithm (choose a
//! floor of several σ to avoid it; [`SynthSpectrum::uniform`] puts it at 10σ).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::error::SpectrumError;
use crate::formats::{
    write_enlight, write_imon, write_osa_csv, ImonWriteOptions, PixelCalibration, SpectrumFormat,
};
use crate::grating::{grating_spectrum, Grating, StrainProfile};
use crate::peaks::FWHM_PER_SIGMA;
use crate::spectrum::{PowerUnit, Spectrum, SpectrumLog, SpectrumRow};

/// The shape of a synthetic peak.
#[derive(Debug, Clone, PartialEq)]
pub enum SynthShape {
    /// amplitude·exp(−4 ln2·(λ − centre)²/FWHM²).
    Gaussian {
        /// Centre, nm.
        center_nm: f64,
        /// FWHM, nm.
        fwhm_nm: f64,
    },
    /// amplitude·R(λ): the transfer-matrix reflectivity of a grating under strain
    /// (amplitude = the power it would reflect at R = 1).
    Grating {
        /// The grating.
        grating: Box<Grating>,
        /// Its strain profile.
        strain: StrainProfile,
    },
}

/// One synthetic peak.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthPeak {
    /// Linear power scale of the peak.
    pub amplitude: f64,
    /// Its shape.
    pub shape: SynthShape,
}

impl SynthPeak {
    /// A Gaussian peak.
    pub fn gaussian(center_nm: f64, fwhm_nm: f64, amplitude: f64) -> Self {
        SynthPeak {
            amplitude,
            shape: SynthShape::Gaussian { center_nm, fwhm_nm },
        }
    }

    /// A transfer-matrix grating peak.
    pub fn grating(grating: Grating, strain: StrainProfile, amplitude: f64) -> Self {
        SynthPeak {
            amplitude,
            shape: SynthShape::Grating {
                grating: Box::new(grating),
                strain,
            },
        }
    }

    fn add_to(&self, wavelengths_nm: &[f64], power: &mut [f64]) -> Result<(), SpectrumError> {
        match &self.shape {
            SynthShape::Gaussian { center_nm, fwhm_nm } => {
                let s = fwhm_nm / FWHM_PER_SIGMA;
                for (p, &w) in power.iter_mut().zip(wavelengths_nm) {
                    *p += self.amplitude * (-0.5 * ((w - center_nm) / s).powi(2)).exp();
                }
            }
            SynthShape::Grating { grating, strain } => {
                let r = grating_spectrum(grating, strain, wavelengths_nm)?;
                for (p, v) in power.iter_mut().zip(r.power) {
                    *p += self.amplitude * v;
                }
            }
        }
        Ok(())
    }
}

/// A synthetic spectrum: grid, floor, noise and peaks.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthSpectrum {
    /// Wavelengths, nm, strictly increasing.
    pub wavelengths_nm: Vec<f64>,
    /// Constant floor, linear units.
    pub floor: f64,
    /// White-noise standard deviation, linear units.
    pub noise_sigma: f64,
    /// Peaks.
    pub peaks: Vec<SynthPeak>,
    /// Unit of the linear values (`Mw` by default, `Counts` for I-MON).
    pub unit: PowerUnit,
    /// Channel label.
    pub channel: String,
}

impl SynthSpectrum {
    /// `samples` wavelengths from `start_nm` at `pitch_nm`, floor 10σ, in mW.
    pub fn uniform(start_nm: f64, pitch_nm: f64, samples: usize, noise_sigma: f64) -> Self {
        SynthSpectrum {
            wavelengths_nm: (0..samples)
                .map(|i| start_nm + pitch_nm * i as f64)
                .collect(),
            floor: 10.0 * noise_sigma,
            noise_sigma,
            peaks: Vec::new(),
            unit: PowerUnit::Mw,
            channel: "CH 1".into(),
        }
    }

    /// One Gaussian peak of amplitude 1 at `center_nm` with FWHM `fwhm_samples`·pitch and
    /// the given SNR (σ = 1/SNR), on a grid of ±(15 FWHM + 10 samples) at whole
    /// multiples of the pitch (so the centre keeps its sub-sample position).
    pub fn gaussian_case(center_nm: f64, fwhm_samples: f64, pitch_nm: f64, snr: f64) -> Self {
        let half = (15.0 * fwhm_samples).ceil() as usize + 10;
        let start = ((center_nm / pitch_nm).round() - half as f64) * pitch_nm;
        SynthSpectrum::uniform(start, pitch_nm, 2 * half + 1, 1.0 / snr)
            .with_peak(SynthPeak::gaussian(center_nm, fwhm_samples * pitch_nm, 1.0))
    }

    /// The I-MON pixel grid of a calibration (sorted to increase), in counts, floor 10σ.
    pub fn imon(
        calibration: &PixelCalibration,
        pixels: usize,
        noise_sigma: f64,
    ) -> Result<Self, SpectrumError> {
        let mut w = calibration.pixel_wavelengths_nm(pixels)?;
        if w[1] < w[0] {
            w.reverse();
        }
        Ok(SynthSpectrum {
            wavelengths_nm: w,
            floor: 10.0 * noise_sigma,
            noise_sigma,
            peaks: Vec::new(),
            unit: PowerUnit::Counts,
            channel: "I-MON".into(),
        })
    }

    /// With another peak.
    pub fn with_peak(mut self, peak: SynthPeak) -> Self {
        self.peaks.push(peak);
        self
    }

    /// With another floor.
    pub fn with_floor(mut self, floor: f64) -> Self {
        self.floor = floor;
        self
    }

    /// The noiseless truth, linear units.
    pub fn truth(&self) -> Result<Vec<f64>, SpectrumError> {
        let mut p = vec![self.floor; self.wavelengths_nm.len()];
        for peak in &self.peaks {
            peak.add_to(&self.wavelengths_nm, &mut p)?;
        }
        Ok(p)
    }

    /// Truth plus noise drawn from a ChaCha8 generator seeded with `seed`.
    pub fn noisy(&self, seed: u64) -> Result<Vec<f64>, SpectrumError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, self.noise_sigma.max(0.0))
            .map_err(|e| SpectrumError::Invalid(format!("noise σ {}: {e}", self.noise_sigma)))?;
        Ok(self
            .truth()?
            .into_iter()
            .map(|v| v + normal.sample(&mut rng))
            .collect())
    }

    /// A noisy spectrum in linear units.
    ///
    /// # Panics
    /// Never for a valid grid; use [`SynthSpectrum::try_spectrum`] to get errors instead.
    pub fn spectrum(&self, seed: u64) -> Spectrum {
        self.try_spectrum(seed)
            .expect("synthetic spectrum: invalid grid, grating or noise")
    }

    /// A noisy spectrum in linear units.
    pub fn try_spectrum(&self, seed: u64) -> Result<Spectrum, SpectrumError> {
        Spectrum::new(
            self.channel.clone(),
            self.wavelengths_nm.clone(),
            self.noisy(seed)?,
            self.unit,
        )
    }

    /// A noisy spectrum in `unit` (dB and dBm: 10·log10 of the linear value, clamped
    /// as the module notes say).
    pub fn spectrum_in(&self, seed: u64, unit: PowerUnit) -> Result<Spectrum, SpectrumError> {
        let mut s = self.try_spectrum(seed)?;
        if unit.is_logarithmic() {
            let truth_max = self.truth()?.into_iter().fold(0.0f64, f64::max);
            let least = 1e-6 * truth_max.max(f64::MIN_POSITIVE);
            s.power = s
                .power
                .iter()
                .map(|&v| 10.0 * v.max(least).log10())
                .collect();
        }
        s.unit = unit;
        Ok(s)
    }

    /// A single-acquisition file: ENLIGHT (dBm) or OSA CSV (in `osa_unit`).
    pub fn write(
        &self,
        format: SpectrumFormat,
        seed: u64,
        osa_unit: PowerUnit,
    ) -> Result<String, SpectrumError> {
        let one = |s: Spectrum| SpectrumLog {
            format,
            metadata: vec![("Source".into(), "fbgforge-spectra synthetic".into())],
            rows: vec![SpectrumRow {
                time_s: 1_700_000_000.0,
                spectra: vec![s],
                reported_peaks_nm: Vec::new(),
            }],
        };
        match format {
            SpectrumFormat::EnlightSpectrum => {
                write_enlight(&one(self.spectrum_in(seed, PowerUnit::Dbm)?))
            }
            SpectrumFormat::OsaCsv => write_osa_csv(&one(self.spectrum_in(seed, osa_unit)?)),
            SpectrumFormat::ImonPixels => Err(SpectrumError::Invalid(
                "an I-MON log: use SynthSpectrum::imon_log".into(),
            )),
        }
    }

    /// An I-MON log of `rows` acquisitions one second apart (fresh noise each; seeds
    /// `seed`, `seed + 1`, …), each reporting the true Gaussian centres as its peak
    /// wavelengths.
    pub fn imon_log(
        &self,
        calibration: &PixelCalibration,
        rows: usize,
        seed: u64,
    ) -> Result<String, SpectrumError> {
        let reported: Vec<f64> = self
            .peaks
            .iter()
            .filter_map(|p| match p.shape {
                SynthShape::Gaussian { center_nm, .. } => Some(center_nm),
                SynthShape::Grating { .. } => None,
            })
            .collect();
        let log = SpectrumLog {
            format: SpectrumFormat::ImonPixels,
            metadata: Vec::new(),
            rows: (0..rows)
                .map(|k| {
                    let mut s = self.try_spectrum(seed + k as u64)?;
                    s.unit = PowerUnit::Counts;
                    Ok(SpectrumRow {
                        time_s: 1_604_076_250.0 + k as f64,
                        spectra: vec![s],
                        reported_peaks_nm: reported.clone(),
                    })
                })
                .collect::<Result<Vec<_>, SpectrumError>>()?,
        };
        write_imon(
            &log,
            &ImonWriteOptions {
                calibration: calibration.clone(),
                wavelength_cells: reported.len().max(1),
            },
        )
    }
}
