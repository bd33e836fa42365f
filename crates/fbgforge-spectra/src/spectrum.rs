//! Spectra and spectrum logs: wavelengths in nm (strictly increasing once read), one
//! power value per wavelength, the unit the instrument wrote it in, and metadata.

use serde::{Deserialize, Serialize};

use crate::error::SpectrumError;

/// The unit a spectrum's power values are written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PowerUnit {
    /// Absolute power in dBm (10·log10 of mW): ENLIGHT / Hyperion exports, OSAs.
    Dbm,
    /// Relative power in dB (10·log10 of a ratio): reflection / transmission of a swept laser.
    Db,
    /// Absolute power in mW.
    Mw,
    /// A linear ratio or arbitrary linear units (`AU`).
    Linear,
    /// Detector counts (I-MON pixels), linear in power.
    Counts,
}

impl PowerUnit {
    /// True for the logarithmic units (dBm, dB).
    pub fn is_logarithmic(self) -> bool {
        matches!(self, PowerUnit::Dbm | PowerUnit::Db)
    }

    /// The unit that [`PowerUnit::to_linear_value`] returns: dBm → mW, dB → linear ratio,
    /// linear units unchanged.
    pub fn linear_unit(self) -> PowerUnit {
        match self {
            PowerUnit::Dbm => PowerUnit::Mw,
            PowerUnit::Db => PowerUnit::Linear,
            other => other,
        }
    }

    /// One value converted to linear power: 10^(p/10) for dBm and dB, unchanged otherwise.
    pub fn to_linear_value(self, value: f64) -> f64 {
        if self.is_logarithmic() {
            10f64.powf(value / 10.0)
        } else {
            value
        }
    }

    /// The short label used in CSV headers: `dBm`, `dB`, `mW`, `AU`, `counts`.
    pub fn label(self) -> &'static str {
        match self {
            PowerUnit::Dbm => "dBm",
            PowerUnit::Db => "dB",
            PowerUnit::Mw => "mW",
            PowerUnit::Linear => "AU",
            PowerUnit::Counts => "counts",
        }
    }
}

/// One spectrum of one channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    /// Channel or column label as the file names it (`CH 1`, `Rx`, `I-MON`).
    pub channel: String,
    /// Wavelengths, nm, strictly increasing.
    pub wavelengths_nm: Vec<f64>,
    /// Power at each wavelength, in `unit`.
    pub power: Vec<f64>,
    /// Unit of `power`.
    pub unit: PowerUnit,
    /// Key/value metadata in file order (an ENLIGHT channel's `CH n Configuration:` block).
    pub metadata: Vec<(String, String)>,
}

impl Spectrum {
    /// A spectrum without metadata; checks lengths and strictly increasing wavelengths.
    pub fn new(
        channel: impl Into<String>,
        wavelengths_nm: Vec<f64>,
        power: Vec<f64>,
        unit: PowerUnit,
    ) -> Result<Self, SpectrumError> {
        let spectrum = Spectrum {
            channel: channel.into(),
            wavelengths_nm,
            power,
            unit,
            metadata: Vec::new(),
        };
        spectrum.validate()?;
        Ok(spectrum)
    }

    /// Checks the invariants: equal lengths, at least 2 samples, finite strictly increasing
    /// wavelengths.
    pub fn validate(&self) -> Result<(), SpectrumError> {
        if self.wavelengths_nm.len() != self.power.len() {
            return Err(SpectrumError::Invalid(format!(
                "spectrum {}: {} wavelengths but {} power values",
                self.channel,
                self.wavelengths_nm.len(),
                self.power.len()
            )));
        }
        if self.wavelengths_nm.len() < 2 {
            return Err(SpectrumError::Invalid(format!(
                "spectrum {}: fewer than 2 samples",
                self.channel
            )));
        }
        for (i, w) in self.wavelengths_nm.windows(2).enumerate() {
            if !(w[1] > w[0]) || !w[0].is_finite() || !w[1].is_finite() {
                return Err(SpectrumError::Invalid(format!(
                    "spectrum {}: wavelengths must increase strictly (sample {}: {} nm, then {} nm)",
                    self.channel,
                    i,
                    w[0],
                    w[1]
                )));
            }
        }
        Ok(())
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.wavelengths_nm.len()
    }

    /// True when the spectrum holds no samples.
    pub fn is_empty(&self) -> bool {
        self.wavelengths_nm.is_empty()
    }

    /// Power converted to linear units (dBm → mW, dB → ratio; others unchanged).
    pub fn linear_power(&self) -> Vec<f64> {
        self.power
            .iter()
            .map(|&p| self.unit.to_linear_value(p))
            .collect()
    }

    /// The same spectrum with linear power (see [`Spectrum::linear_power`]).
    pub fn to_linear(&self) -> Spectrum {
        Spectrum {
            channel: self.channel.clone(),
            wavelengths_nm: self.wavelengths_nm.clone(),
            power: self.linear_power(),
            unit: self.unit.linear_unit(),
            metadata: self.metadata.clone(),
        }
    }

    /// Median sample pitch, nm.
    pub fn median_pitch_nm(&self) -> f64 {
        let mut d: Vec<f64> = self
            .wavelengths_nm
            .windows(2)
            .map(|w| w[1] - w[0])
            .collect();
        crate::stats::median(&mut d)
    }

    /// The value of a metadata key, if present.
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.metadata
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// One acquisition: a time and one spectrum per channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpectrumRow {
    /// Seconds since 1970-01-01 00:00:00 of the recording PC's clock (no time zone
    /// applied); 0 when the file states no time.
    pub time_s: f64,
    /// One spectrum per channel.
    pub spectra: Vec<Spectrum>,
    /// Peak wavelengths the instrument's own software reported in this row, nm (I-MON
    /// `Wavelength` cells without the `0` padding); empty for other formats.
    pub reported_peaks_nm: Vec<f64>,
}

/// Spectra over time, as one file holds them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpectrumLog {
    /// The format the log was read from (or will be written to).
    pub format: SpectrumFormat,
    /// Key/value metadata of the file header in file order.
    pub metadata: Vec<(String, String)>,
    /// Acquisitions in file order.
    pub rows: Vec<SpectrumRow>,
}

impl SpectrumLog {
    /// The value of a header metadata key, if present.
    pub fn meta(&self, key: &str) -> Option<&str> {
        self.metadata
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// Every spectrum converted to linear power.
    pub fn to_linear(&self) -> SpectrumLog {
        SpectrumLog {
            format: self.format,
            metadata: self.metadata.clone(),
            rows: self
                .rows
                .iter()
                .map(|r| SpectrumRow {
                    time_s: r.time_s,
                    spectra: r.spectra.iter().map(Spectrum::to_linear).collect(),
                    reported_peaks_nm: r.reported_peaks_nm.clone(),
                })
                .collect(),
        }
    }

    /// Channel labels of the first row.
    pub fn channels(&self) -> Vec<String> {
        self.rows
            .first()
            .map(|r| r.spectra.iter().map(|s| s.channel.clone()).collect())
            .unwrap_or_default()
    }
}

/// The spectrum file formats this crate reads and writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpectrumFormat {
    /// Luna ENLIGHT / Hyperion spectrum export: metadata block, `Wvl (nm)` + one column per
    /// channel, dBm, tab-separated.
    EnlightSpectrum,
    /// Ibsen I-MON evaluation-software log with `Pixel n` columns.
    ImonPixels,
    /// Two- or more-column OSA / swept-laser CSV: `Wavelength (nm)` then power columns.
    OsaCsv,
}

impl SpectrumFormat {
    /// The name used on command lines and in JSON (`enlight-spectrum`, `imon-pixels`, `osa-csv`).
    pub fn name(self) -> &'static str {
        match self {
            SpectrumFormat::EnlightSpectrum => "enlight-spectrum",
            SpectrumFormat::ImonPixels => "imon-pixels",
            SpectrumFormat::OsaCsv => "osa-csv",
        }
    }

    /// The format of a name given by [`SpectrumFormat::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        [
            SpectrumFormat::EnlightSpectrum,
            SpectrumFormat::ImonPixels,
            SpectrumFormat::OsaCsv,
        ]
        .into_iter()
        .find(|f| f.name() == name)
    }
}
