"""Spectra in, peaks out, and the spectrum a grating makes (docs/spectra.md)."""

import numpy as np

from . import _fbgforge

__all__ = ["read_spectra", "find_peaks", "grating_spectrum"]


def read_spectra(path, format=None, imon_calibration=None):
    """Read a spectrum file: a Luna ENLIGHT / Hyperion spectrum export, an Ibsen I-MON
    log with pixel columns, or an OSA / swept-laser CSV.

    Parameters
    ----------
    path : path
    format : {"enlight-spectrum", "imon-pixels", "osa-csv"}, optional
        Detected if omitted.
    imon_calibration : sequence of float, optional
        I-MON pixel-to-wavelength polynomial a0, a1, ... (nm, pixel index from 1 as the
        header writes it); required for an I-MON log.

    Returns
    -------
    dict
        ``format``, ``metadata`` (key, value pairs of the header) and ``rows``: one per
        acquisition with ``time_s``, ``reported_peaks_nm`` (the instrument's own peaks,
        I-MON) and ``spectra``: per channel ``channel``, ``unit``, ``wavelengths_nm``
        and ``power`` (numpy arrays, wavelengths increasing, power in ``unit``).

    Examples
    --------
    >>> import fbgforge, numpy as np, tempfile, os
    >>> x = np.arange(1549.0, 1551.0, 0.008)
    >>> y = 0.01 + np.exp(-4 * np.log(2) * ((x - 1550.0123) / 0.2) ** 2)
    >>> path = os.path.join(tempfile.mkdtemp(), "osa.csv")
    >>> with open(path, "w") as f:
    ...     _ = f.write("Wavelength (nm),Power (mW)\\n")
    ...     _ = f.writelines(f"{a:.5f},{b:.7g}\\n" for a, b in zip(x, y))
    >>> s = fbgforge.read_spectra(path)
    >>> s["format"], s["rows"][0]["spectra"][0]["unit"], len(s["rows"][0]["spectra"][0]["power"])
    ('osa-csv', 'mW', 250)
    """
    cal = None if imon_calibration is None else [float(a) for a in imon_calibration]
    return _fbgforge.read_spectra(str(path), format, cal)


def find_peaks(wavelengths_nm, power, estimator="gaussian", unit="linear"):
    """Find the peaks of one spectrum, each with its uncertainty and quality flags.

    Parameters
    ----------
    wavelengths_nm : array of float
        Strictly increasing (or decreasing: the spectrum is reversed), nm.
    power : array of float
        In ``unit``; every estimator works on linear power.
    estimator : {"gaussian", "parabola", "centroid"}
        Gaussian least squares (the default: within 2x the Cramer-Rao bound wherever it
        can be met), 3-point parabola on log power, centroid over the half maximum.
        (``xcorr`` needs the grating's unloaded spectrum: use it on a spectrum file
        through the command line's ``peaks``.)
    unit : {"linear", "mW", "counts", "dBm", "dB"}

    Returns
    -------
    list of dict
        Per peak ``wavelength_nm``, ``std_error_pm`` (from the fit's residuals),
        ``crb_pm`` (Cramer-Rao bound), ``fwhm_pm``, ``snr``, ``amplitude``,
        ``baseline``, ``estimator``, ``flags`` (``undersampled``,
        ``estimator_disagreement``, ``overlap``, ``low_snr``, ``split``) and
        ``overlap_group``.

    Examples
    --------
    >>> import fbgforge, numpy as np
    >>> x = np.arange(1549.0, 1551.0, 0.008)
    >>> y = 0.01 + np.exp(-4 * np.log(2) * ((x - 1550.0123) / 0.2) ** 2)
    >>> p = fbgforge.find_peaks(x, y)[0]
    >>> round(p["wavelength_nm"], 4), round(p["fwhm_pm"]), p["flags"]
    (1550.0123, 200, [])
    """
    x = np.ascontiguousarray(wavelengths_nm, dtype=np.float64)
    y = np.ascontiguousarray(power, dtype=np.float64)
    return _fbgforge.find_peaks(x, y, estimator, unit)


def grating_spectrum(
    bragg_wavelength_nm,
    length_mm,
    wavelengths_nm,
    index_modulation=2e-4,
    strain=0.0,
    strain_end=None,
    apodisation="uniform",
):
    """Reflectivity (0 to 1) of a fiber Bragg grating by the transfer-matrix model.

    Parameters
    ----------
    bragg_wavelength_nm : float
        Unstrained Bragg wavelength, nm.
    length_mm : float
    wavelengths_nm : array of float
    index_modulation : float
        Amplitude of the index fringes (coupling kappa = pi * dn / lambda); the design
        default 2e-4.
    strain : float
        Axial strain (uniform, or at the grating's start with ``strain_end``).
    strain_end : float, optional
        Strain at the grating's end: a linear gradient (a chirp).
    apodisation : {"uniform", "raised_cosine"}

    Returns
    -------
    numpy.ndarray
        Reflectivity at each wavelength.

    Examples
    --------
    >>> import fbgforge, numpy as np
    >>> x = np.linspace(1549.5, 1550.5, 2001)
    >>> r = fbgforge.grating_spectrum(1550.0, 5.0, x)
    >>> kl = np.pi * 2e-4 / 1550e-6 * 5.0   # kappa * L
    >>> bool(abs(r.max() - np.tanh(kl) ** 2) < 1e-3)
    True
    """
    x = np.ascontiguousarray(wavelengths_nm, dtype=np.float64)
    return _fbgforge.grating_spectrum(
        float(bragg_wavelength_nm),
        float(length_mm),
        x,
        float(index_modulation),
        float(strain),
        None if strain_end is None else float(strain_end),
        apodisation,
    )
