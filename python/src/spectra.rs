//! Spectra from Python: `read_spectra` (every acquisition of a spectrum file as numpy
//! columns), `find_peaks` (one spectrum's peaks with their uncertainty) and
//! `grating_spectrum` (the transfer-matrix reflectivity of a grating under strain).

use crate::errors::{err, input};
use fbgforge::spectra::{
    self, EstimatorChoice, FindOptions, Grating, PixelCalibration, PowerUnit, StrainProfile,
};
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

fn spectrum_err(py: Python<'_>, what: &str, e: impl std::fmt::Display) -> PyErr {
    input(py, format!("{what}: {e}"))
}

/// Every acquisition of a spectrum file: `{format, metadata, rows: [{time_s,
/// reported_peaks_nm, spectra: [{channel, unit, wavelengths_nm, power}]}]}`, the
/// arrays as numpy.
#[pyfunction]
#[pyo3(signature = (path, format, imon_calibration))]
pub fn read_spectra<'py>(
    py: Python<'py>,
    path: PathBuf,
    format: Option<&str>,
    imon_calibration: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyAny>> {
    crate::errors::must_exist(py, &path, "path")?;
    let format = format
        .map(|f| {
            spectra::SpectrumFormat::from_name(f).ok_or_else(|| {
                input(
                    py,
                    format!(
                        "format `{f}`: expected \"enlight-spectrum\", \"imon-pixels\" or \"osa-csv\""
                    ),
                )
            })
        })
        .transpose()?;
    let imon_calibration = imon_calibration
        .map(PixelCalibration::new)
        .transpose()
        .map_err(|e| spectrum_err(py, "imon_calibration (a0, a1, … in nm, pixel from 1)", e))?;
    let opts = spectra::ReadOptions {
        format,
        imon_calibration,
    };
    let text = std::fs::read_to_string(&path).map_err(|e| {
        err(
            py,
            anyhow::Error::new(e).context(format!("cannot read {}", path.display())),
        )
    })?;
    let log = py
        .detach(|| spectra::read_spectrum_log(&text, &opts))
        .map_err(|e| spectrum_err(py, &path.display().to_string(), e))?;
    let out = PyDict::new(py);
    out.set_item("format", log.format.name())?;
    out.set_item("metadata", log.metadata.clone())?;
    let rows = PyList::empty(py);
    for row in log.rows {
        let r = PyDict::new(py);
        r.set_item("time_s", row.time_s)?;
        r.set_item("reported_peaks_nm", row.reported_peaks_nm)?;
        let list = PyList::empty(py);
        for s in row.spectra {
            let d = PyDict::new(py);
            d.set_item("channel", s.channel)?;
            d.set_item("unit", s.unit.label())?;
            d.set_item("wavelengths_nm", s.wavelengths_nm.into_pyarray(py))?;
            d.set_item("power", s.power.into_pyarray(py))?;
            list.append(d)?;
        }
        r.set_item("spectra", list)?;
        rows.append(r)?;
    }
    out.set_item("rows", rows)?;
    Ok(out.into_any())
}

/// The peaks of one spectrum (wavelengths in nm, power in `unit`) by `estimator`:
/// a list of dicts with the fields `fbgforge peaks --json` prints, plus amplitude,
/// baseline and the estimator that made each.
#[pyfunction]
#[pyo3(signature = (wavelengths_nm, power, estimator, unit))]
pub fn find_peaks<'py>(
    py: Python<'py>,
    wavelengths_nm: PyReadonlyArray1<'py, f64>,
    power: PyReadonlyArray1<'py, f64>,
    estimator: &str,
    unit: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let choice = match estimator {
        "xcorr" => {
            return Err(input(
                py,
                "estimator `xcorr` needs the grating's unloaded spectrum as a template: use it \
                 through read_log/verify on a spectrum file, or choose gaussian, parabola or centroid"
                    .to_string(),
            ))
        }
        other => EstimatorChoice::from_name(other).ok_or_else(|| {
            input(
                py,
                format!("estimator `{other}`: expected gaussian, parabola, centroid or xcorr"),
            )
        })?,
    };
    let unit = match unit {
        "dBm" | "dbm" => PowerUnit::Dbm,
        "dB" | "db" => PowerUnit::Db,
        "mW" | "mw" => PowerUnit::Mw,
        "counts" => PowerUnit::Counts,
        "linear" => PowerUnit::Linear,
        other => {
            return Err(input(
                py,
                format!("unit `{other}`: expected dBm, dB, mW, counts or linear"),
            ))
        }
    };
    let spectrum = spectra::Spectrum::new(
        "spectrum",
        wavelengths_nm.as_slice()?.to_vec(),
        power.as_slice()?.to_vec(),
        unit,
    )
    .map_err(|e| spectrum_err(py, "wavelengths_nm, power", e))?;
    let options = FindOptions {
        estimator: choice,
        ..FindOptions::default()
    };
    let peaks = py
        .detach(|| spectra::find_peaks(&spectrum, &options))
        .map_err(|e| spectrum_err(py, "find_peaks", e))?;
    crate::convert::to_py(py, &peaks)
}

/// Reflectivity (0–1) of a grating at `wavelengths_nm` by the transfer-matrix model,
/// its strain uniform (`strain`) or linear from `strain` at z = 0 to `strain_end` at L.
#[pyfunction]
#[pyo3(signature = (bragg_wavelength_nm, length_mm, wavelengths_nm, index_modulation, strain, strain_end, apodisation))]
#[allow(clippy::too_many_arguments)]
pub fn grating_spectrum<'py>(
    py: Python<'py>,
    bragg_wavelength_nm: f64,
    length_mm: f64,
    wavelengths_nm: PyReadonlyArray1<'py, f64>,
    index_modulation: f64,
    strain: f64,
    strain_end: Option<f64>,
    apodisation: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let apodisation = match apodisation {
        "uniform" => spectra::Apodisation::Uniform,
        "raised_cosine" => spectra::Apodisation::RaisedCosine,
        other => {
            return Err(input(
                py,
                format!("apodisation `{other}`: expected \"uniform\" or \"raised_cosine\""),
            ))
        }
    };
    let grating = Grating {
        bragg_wavelength_nm,
        length_mm,
        index_modulation,
        apodisation,
        ..Grating::default()
    };
    let profile = match strain_end {
        None => StrainProfile::Uniform(strain),
        Some(end) => StrainProfile::Linear { start: strain, end },
    };
    let x = wavelengths_nm.as_slice()?.to_vec();
    let s = py
        .detach(|| spectra::grating_spectrum(&grating, &profile, &x))
        .map_err(|e| spectrum_err(py, "grating_spectrum", e))?;
    Ok(s.power.into_pyarray(py).into_any())
}
