"""Spectra from Python (issue 36): a spectrum file read back with its known peak,
the peak found with its uncertainty, and the transfer-matrix model against the uniform
grating's closed form."""

import numpy as np
import pytest

import fbgforge
from fbgforge.errors import InputError


def gaussian_line(center_nm=1550.0123, fwhm_nm=0.04, snr=300.0, seed=1):
    # A wide grid: the robust noise estimate needs the peak to be a small part of it.
    x = np.arange(1546.0, 1554.0, 0.008)
    rng = np.random.default_rng(seed)
    y = 0.1 + np.exp(-4 * np.log(2) * ((x - center_nm) / fwhm_nm) ** 2)
    return x, y + rng.normal(0.0, 1.0 / snr, x.size)


def test_find_peaks_is_within_its_standard_error_and_names_every_field():
    errors, ses, flagged = [], [], 0
    for seed in range(40):
        x, y = gaussian_line(seed=seed)
        (p,) = fbgforge.find_peaks(x, y)
        errors.append((p["wavelength_nm"] - 1550.0123) * 1e3)
        ses.append(p["std_error_pm"])
        flagged += p["flags"] != []
        assert p["estimator"] == "gaussian"
        assert p["crb_pm"] > 0 and p["snr"] == pytest.approx(300, rel=0.3)
    # Noise alone flags a clean peak now and then (estimator_disagreement), rarely (at
    # 5 samples per FWHM; on peaks of 25 samples the 3-point parabola's curvature is lost
    # in the noise and about 11 % are flagged, docs/spectra.md §12).
    assert flagged <= 2
    # The scatter over 40 noisy spectra matches the reported standard error.
    assert np.std(errors) == pytest.approx(np.mean(ses), rel=0.35)
    (q,) = fbgforge.find_peaks(x, y, estimator="parabola")
    assert q["estimator"] == "parabola"


def test_find_peaks_refuses_unknown_estimators_and_units():
    x, y = gaussian_line()
    with pytest.raises(InputError, match="estimator `fit`"):
        fbgforge.find_peaks(x, y, estimator="fit")
    with pytest.raises(InputError, match="unit `W`"):
        fbgforge.find_peaks(x, y, unit="W")


def test_read_spectra_reads_an_osa_csv_and_its_peak(tmp_path):
    x, y = gaussian_line()
    path = tmp_path / "osa.csv"
    path.write_text("Wavelength (nm),Power (mW)\n" + "".join(f"{a:.5f},{b:.7g}\n" for a, b in zip(x, y)))
    s = fbgforge.read_spectra(path)
    assert s["format"] == "osa-csv" and len(s["rows"]) == 1
    sp = s["rows"][0]["spectra"][0]
    assert np.allclose(sp["wavelengths_nm"], x, atol=1e-5)
    (p,) = fbgforge.find_peaks(sp["wavelengths_nm"], sp["power"], unit=sp["unit"])
    assert abs(p["wavelength_nm"] - 1550.0123) * 1e3 < 4 * p["std_error_pm"]


def test_an_imon_log_needs_its_calibration(tmp_path, cli):
    cli("synth-log", "designs/clip-on-34mm.toml", "--format", "imon-pixels", "--out", tmp_path)
    with pytest.raises(InputError, match="calibration"):
        fbgforge.read_spectra(tmp_path / "log.txt")
    s = fbgforge.read_spectra(tmp_path / "log.txt", imon_calibration=[1595.1663405088063, -0.16634050880626223])
    assert s["format"] == "imon-pixels" and len(s["rows"][0]["spectra"][0]["power"]) == 512


def test_grating_spectrum_meets_the_uniform_closed_form():
    x = np.linspace(1549.0, 1551.0, 8001)
    r = fbgforge.grating_spectrum(1550.0, 5.0, x, index_modulation=2e-4)
    kl = np.pi * 2e-4 / 1550e-6 * 5.0
    assert r.max() == pytest.approx(np.tanh(kl) ** 2, rel=1e-3)
    # A linear strain gradient broadens the line.
    chirped = fbgforge.grating_spectrum(1550.0, 5.0, x, strain=-2e-4, strain_end=2e-4)
    width = lambda v: np.ptp(x[v > 0.5 * v.max()])
    assert width(chirped) > 1.5 * width(r)
