//! The peak finder: candidates above the noise floor, overlapping ones decomposed by a
//! joint Gaussian fit, each lone one estimated by the chosen estimator, then bound,
//! SNR and flags.

use super::crb::gaussian_position_crb_pm;
use super::gaussian::fit_gaussians;
use super::{
    Centroid, GaussianLeastSquares, Parabola, Peak, PeakEstimate, PeakEstimator, PeakFlags,
    PeakWindow, TemplateMatch,
};
use crate::error::SpectrumError;
use crate::spectrum::Spectrum;
use crate::stats;

/// Which estimator gives each lone peak's wavelength.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum EstimatorChoice {
    /// Gaussian least squares ([`GaussianLeastSquares`]): the default, see the crate
    /// README's speed-against-accuracy table.
    #[default]
    Gaussian,
    /// 3-point parabola on log power ([`Parabola`]).
    Parabola,
    /// Centroid over the half maximum ([`Centroid`]).
    Centroid,
    /// Cross-correlation with the gratings' unloaded spectra ([`TemplateMatch`]).
    CrossCorrelation(TemplateMatch),
}

impl EstimatorChoice {
    /// The estimator.
    pub fn estimator(&self) -> &dyn PeakEstimator {
        match self {
            EstimatorChoice::Gaussian => &GaussianLeastSquares,
            EstimatorChoice::Parabola => &Parabola { log_power: true },
            EstimatorChoice::Centroid => &Centroid {
                threshold_fraction: 0.5,
            },
            EstimatorChoice::CrossCorrelation(t) => t,
        }
    }

    /// A choice by name: `gaussian`, `parabola`, `centroid` (`xcorr` needs templates: use
    /// the variant directly).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "gaussian" => Some(EstimatorChoice::Gaussian),
            "parabola" => Some(EstimatorChoice::Parabola),
            "centroid" => Some(EstimatorChoice::Centroid),
            _ => None,
        }
    }
}

/// Settings of [`find_peaks`].
#[derive(Debug, Clone, PartialEq)]
pub struct FindOptions {
    /// Estimator for lone peaks.
    pub estimator: EstimatorChoice,
    /// A candidate's height above the floor and its prominence must both reach this many
    /// noise σ (6: about one false peak in 10⁵ spectra of 20,000 white-noise samples).
    pub detection_sigma: f64,
    /// A candidate's prominence must also reach this fraction of its height above the
    /// floor (0.1): noise on the top of a strong peak, which in dB-recorded spectra is far
    /// larger than the floor's, does not make extra candidates.
    pub min_prominence_fraction: f64,
    /// A local maximum closer than `side_lobe_fwhm` FWHM to one more than 1/`lobe_fraction`
    /// times higher is that peak's side lobe, not a peak (0.25, i.e. −6 dB).
    pub lobe_fraction: f64,
    /// Reach of that side-lobe rule, in FWHM of the higher peak (10: a uniform grating's
    /// side lobes decay slowly; the tenth FWHM away they are ~−25 dB).
    pub side_lobe_fwhm: f64,
    /// Peaks closer than this many FWHM (mean of the two) overlap and are fitted jointly (4).
    pub overlap_fwhm: f64,
    /// Half-width of a lone peak's window, in FWHM (2; at least 5 samples each side).
    pub window_fwhm: f64,
    /// `low_snr` below this SNR (20).
    pub low_snr: f64,
    /// `undersampled` below this many samples per FWHM (1.2).
    pub undersampled_samples: f64,
    /// `undersampled` also below this many samples per FWHM (2.5) when the line is
    /// measurably not the estimator's shape: a residual-based standard error above
    /// `misfit_ratio` × the bound (a reduced χ² above 4). Pixel-locking then sets in at
    /// wider sampling: the scenario study (`studies/src/spectra.rs`) measured Gaussian
    /// fits of 1.2–2 sample transfer-matrix, chirped and split lines off by 3–30× their
    /// standard error with no flag.
    pub misfit_undersampled_samples: f64,
    /// See `misfit_undersampled_samples` (2).
    pub misfit_ratio: f64,
    /// `estimator_disagreement` when the estimator and a second one (the parabola for the
    /// Gaussian, the Gaussian for the others) differ by more than this factor times the
    /// bound, the bound being the CRB or, if larger, the combined standard error of the
    /// two estimates (so noise alone flags about 0.3 % of peaks) (3).
    pub disagreement_factor: f64,
    /// Run the second estimator at all.
    pub check_disagreement: bool,
    /// Noise σ in linear power units instead of the robust estimate.
    pub noise_sigma: Option<f64>,
}

impl Default for FindOptions {
    fn default() -> Self {
        FindOptions {
            estimator: EstimatorChoice::default(),
            detection_sigma: 6.0,
            min_prominence_fraction: 0.1,
            lobe_fraction: 0.25,
            side_lobe_fwhm: 10.0,
            overlap_fwhm: 4.0,
            window_fwhm: 2.0,
            low_snr: 20.0,
            undersampled_samples: 1.2,
            misfit_undersampled_samples: 2.5,
            misfit_ratio: 2.0,
            disagreement_factor: 3.0,
            check_disagreement: true,
            noise_sigma: None,
        }
    }
}

const MIN_SIDE_SAMPLES: usize = 5;

#[derive(Debug, Clone, Copy)]
struct Candidate {
    index: usize,
    height: f64,
    fwhm_nm: f64,
}

/// Finds the peaks of a spectrum (converted to linear power first).
///
/// The noise σ is the robust estimate 1.4826·MAD(Δy)/√2 of the first differences
/// (slow baselines and sparse peaks do not move it); the floor is the median power.
/// Candidates are local maxima whose height above the floor and prominence both reach
/// `detection_sigma`·σ (and the prominence `min_prominence_fraction` of the height),
/// found on the spectrum smoothed by a Gaussian of half the narrowest peak's FWHM when
/// that is 4 samples or more (σ scaled to the smoothed noise); side lobes (see [`FindOptions::lobe_fraction`]) are dropped;
/// candidates within `overlap_fwhm` FWHM are decomposed by one joint multi-Gaussian fit
/// (`overlap` flag, shared `overlap_group`); lone ones by the chosen estimator on a
/// window of ±`window_fwhm` FWHM.
///
/// ```
/// use fbgforge_spectra::{find_peaks, synth::{SynthPeak, SynthSpectrum}, FindOptions};
/// // A Gaussian peak of FWHM 0.2 nm (25 samples of 8 pm) at SNR 300 on a noise floor.
/// let truth = SynthSpectrum::uniform(1549.0, 0.008, 250, 0.01)
///     .with_peak(SynthPeak::gaussian(1550.0123, 0.2, 3.0));
/// let spectrum = truth.spectrum(7);
/// let peaks = find_peaks(&spectrum, &FindOptions::default()).unwrap();
/// assert_eq!(peaks.len(), 1);
/// let p = &peaks[0];
/// assert!((p.wavelength_nm - 1550.0123).abs() * 1e3 < 5.0 * p.crb_pm);
/// assert!(p.flags.is_clean(), "{:?}", p.flags);
/// ```
pub fn find_peaks(spectrum: &Spectrum, options: &FindOptions) -> Result<Vec<Peak>, SpectrumError> {
    spectrum.validate()?;
    find_peaks_in(&spectrum.wavelengths_nm, &spectrum.linear_power(), options)
}

/// [`find_peaks`] on raw arrays: strictly increasing wavelengths (nm), linear power.
pub fn find_peaks_in(
    wavelengths_nm: &[f64],
    power: &[f64],
    options: &FindOptions,
) -> Result<Vec<Peak>, SpectrumError> {
    if wavelengths_nm.len() != power.len() || wavelengths_nm.len() < 3 {
        return Err(SpectrumError::Invalid(
            "find_peaks: need equally long wavelength and power arrays of 3 samples or more".into(),
        ));
    }
    let scale = power.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let sigma = options
        .noise_sigma
        .unwrap_or_else(|| stats::noise_sigma_mad_diff(power))
        .max(1e-12 * scale)
        .max(f64::MIN_POSITIVE);
    let floor = stats::median(&mut power.to_vec());
    let candidates = candidates(wavelengths_nm, power, floor, sigma, options);
    let mut peaks = Vec::new();
    let mut group = 0;
    for cluster in clusters(wavelengths_nm, &candidates, options.overlap_fwhm) {
        if cluster.len() == 1 {
            if let Some(p) = lone_peak(wavelengths_nm, power, cluster[0], floor, sigma, options)? {
                peaks.push(p);
            }
        } else {
            peaks.extend(joint_peaks(
                wavelengths_nm,
                power,
                &cluster,
                floor,
                sigma,
                options,
                group,
            )?);
            group += 1;
        }
    }
    peaks.sort_by(|a, b| a.wavelength_nm.total_cmp(&b.wavelength_nm));
    Ok(peaks)
}

fn prominence(y: &[f64], i: usize) -> f64 {
    let mut left_min = y[i];
    for j in (0..i).rev() {
        if y[j] > y[i] {
            break;
        }
        left_min = left_min.min(y[j]);
    }
    let mut right_min = y[i];
    for &v in &y[i + 1..] {
        if v > y[i] {
            break;
        }
        right_min = right_min.min(v);
    }
    y[i] - left_min.max(right_min)
}

/// FWHM of a candidate from the half-level crossings relative to `floor` (nm).
fn candidate_fwhm(x: &[f64], y: &[f64], i: usize, floor: f64) -> f64 {
    let half = floor + 0.5 * (y[i] - floor);
    let cross = |a: usize, b: usize| x[a] + (half - y[a]) / (y[b] - y[a]) * (x[b] - x[a]);
    let left = (0..i)
        .rev()
        .find(|&j| y[j] < half)
        .map(|j| cross(j, j + 1))
        .unwrap_or(x[0]);
    let right = (i + 1..y.len())
        .find(|&j| y[j] < half)
        .map(|j| cross(j - 1, j))
        .unwrap_or(x[x.len() - 1]);
    right - left
}

/// Gaussian smoothing kernel of FWHM `fwhm_samples` (normalised, ±3σ).
fn kernel(fwhm_samples: f64) -> Vec<f64> {
    let s = fwhm_samples / super::FWHM_PER_SIGMA;
    let half = (3.0 * s).ceil() as isize;
    let k: Vec<f64> = (-half..=half)
        .map(|j| (-0.5 * (j as f64 / s).powi(2)).exp())
        .collect();
    let total: f64 = k.iter().sum();
    k.into_iter().map(|v| v / total).collect()
}

fn smooth(y: &[f64], k: &[f64]) -> Vec<f64> {
    let half = (k.len() / 2) as isize;
    let n = y.len() as isize;
    (0..n)
        .map(|i| {
            k.iter()
                .enumerate()
                .map(|(j, w)| w * y[(i + j as isize - half).clamp(0, n - 1) as usize])
                .sum()
        })
        .collect()
}

/// Candidates: local maxima of the spectrum smoothed by a Gaussian of half the narrowest
/// peak's FWHM (a matched filter; no smoothing below 4 samples per FWHM), whose height
/// and prominence pass the thresholds at the smoothed noise level; each then moved to
/// the highest raw sample within the kernel's reach. Smoothing keeps noise on a strong
/// peak's top (large in dB-recorded spectra) from making extra candidates.
fn candidates(x: &[f64], y: &[f64], floor: f64, sigma: f64, o: &FindOptions) -> Vec<Candidate> {
    let threshold = o.detection_sigma * sigma;
    let raw_maxima: Vec<usize> = (1..y.len() - 1)
        .filter(|&i| y[i] > y[i - 1] && y[i] >= y[i + 1] && y[i] - floor >= threshold)
        .collect();
    let pitch = (x[x.len() - 1] - x[0]) / (x.len() - 1) as f64;
    let narrowest = raw_maxima
        .iter()
        .map(|&i| candidate_fwhm(x, y, i, floor) / pitch)
        .fold(f64::INFINITY, f64::min);
    let (ys, sigma_s, reach) = if narrowest.is_finite() && narrowest >= 4.0 {
        let k = kernel(0.5 * narrowest);
        let gain = k.iter().map(|w| w * w).sum::<f64>().sqrt();
        (smooth(y, &k), sigma * gain, k.len() / 2)
    } else {
        (y.to_vec(), sigma, 0)
    };
    let threshold_s = o.detection_sigma * sigma_s;
    let mut found: Vec<Candidate> = (1..ys.len() - 1)
        .filter(|&i| ys[i] > ys[i - 1] && ys[i] >= ys[i + 1] && ys[i] - floor >= threshold_s)
        .filter(|&i| {
            prominence(&ys, i) >= threshold_s.max(o.min_prominence_fraction * (ys[i] - floor))
        })
        .map(|i| {
            let (lo, hi) = (i.saturating_sub(reach).max(1), (i + reach).min(y.len() - 2));
            let best = (lo..=hi)
                .max_by(|&a, &b| y[a].total_cmp(&y[b]))
                .unwrap_or(i);
            Candidate {
                index: best,
                height: y[best] - floor,
                fwhm_nm: candidate_fwhm(x, y, best, floor),
            }
        })
        .collect();
    found.dedup_by_key(|c| c.index);
    // Side lobes: near a peak more than 1/lobe_fraction times higher.
    let all = found.clone();
    found.retain(|c| {
        !all.iter().any(|d| {
            let distance = (x[d.index] - x[c.index]).abs();
            d.height * o.lobe_fraction > c.height && distance < o.side_lobe_fwhm * d.fwhm_nm
        })
    });
    found
}

fn clusters(x: &[f64], candidates: &[Candidate], overlap_fwhm: f64) -> Vec<Vec<Candidate>> {
    let mut out: Vec<Vec<Candidate>> = Vec::new();
    for &c in candidates {
        if let Some(last) = out
            .last_mut()
            .and_then(|cl| cl.last().copied().map(|l| (l, cl)))
        {
            let (l, cl) = last;
            if x[c.index] - x[l.index] < overlap_fwhm * 0.5 * (l.fwhm_nm + c.fwhm_nm) {
                cl.push(c);
                continue;
            }
        }
        out.push(vec![c]);
    }
    out
}

/// Index range of ±`half_nm` around `center`, with at least `MIN_SIDE_SAMPLES` each side.
fn window_range(
    x: &[f64],
    lo_nm: f64,
    hi_nm: f64,
    first: usize,
    last: usize,
) -> std::ops::Range<usize> {
    let lo = x
        .partition_point(|&v| v < lo_nm)
        .min(first.saturating_sub(MIN_SIDE_SAMPLES));
    let hi = x
        .partition_point(|&v| v <= hi_nm)
        .max((last + MIN_SIDE_SAMPLES + 1).min(x.len()));
    lo..hi
}

fn lone_peak(
    x: &[f64],
    y: &[f64],
    c: Candidate,
    floor: f64,
    sigma: f64,
    o: &FindOptions,
) -> Result<Option<Peak>, SpectrumError> {
    let half = o.window_fwhm * c.fwhm_nm;
    let range = window_range(x, x[c.index] - half, x[c.index] + half, c.index, c.index);
    let window = PeakWindow::new(x, y, range, c.index, 0.75 * half, floor, sigma)?;
    let primary = o.estimator.estimator();
    let (estimate, name) = match primary.estimate(&window) {
        Ok(e) => (e, primary.name().to_string()),
        Err(_) => match Centroid::default().estimate(&window) {
            Ok(e) => (e, "centroid (fallback)".to_string()),
            Err(_) => return Ok(None),
        },
    };
    let mut peak = assemble(&estimate, &window, name, sigma, o);
    if o.check_disagreement {
        let second: &dyn PeakEstimator = if primary.name() == "gaussian" {
            &Parabola { log_power: true }
        } else {
            &GaussianLeastSquares
        };
        if let Ok(other) = second.estimate(&window) {
            let difference_pm = 1e3 * (other.wavelength_nm - estimate.wavelength_nm).abs();
            let noise_pm = (peak.std_error_pm.powi(2) + other.std_error_pm.powi(2)).sqrt();
            peak.flags.estimator_disagreement =
                difference_pm > o.disagreement_factor * peak.crb_pm.max(noise_pm);
        }
    }
    Ok(Some(peak))
}

fn assemble(
    e: &PeakEstimate,
    w: &PeakWindow,
    estimator: String,
    sigma: f64,
    o: &FindOptions,
) -> Peak {
    let crb_pm = gaussian_position_crb_pm(
        w.wavelengths_nm,
        e.wavelength_nm,
        e.fwhm_nm,
        e.amplitude,
        sigma,
    );
    let snr = e.amplitude / sigma;
    let misfit = residual_based(&estimator)
        && e.fwhm_nm < o.misfit_undersampled_samples * w.pitch_nm()
        && e.std_error_pm > o.misfit_ratio * crb_pm;
    Peak {
        wavelength_nm: e.wavelength_nm,
        std_error_pm: e.std_error_pm,
        crb_pm,
        fwhm_pm: 1e3 * e.fwhm_nm,
        snr,
        amplitude: e.amplitude,
        baseline: e.baseline,
        estimator,
        flags: PeakFlags {
            undersampled: e.fwhm_nm < o.undersampled_samples * w.pitch_nm() || misfit,
            low_snr: snr < o.low_snr,
            ..PeakFlags::default()
        },
        overlap_group: None,
    }
}

/// Estimators whose standard error comes from the fit's residuals (so a shape they do
/// not model shows in it).
fn residual_based(estimator: &str) -> bool {
    matches!(estimator, "gaussian" | "xcorr")
}

#[allow(clippy::too_many_arguments)]
fn joint_peaks(
    x: &[f64],
    y: &[f64],
    cluster: &[Candidate],
    floor: f64,
    sigma: f64,
    o: &FindOptions,
    group: usize,
) -> Result<Vec<Peak>, SpectrumError> {
    let (first, last) = (cluster[0], cluster[cluster.len() - 1]);
    let range = window_range(
        x,
        x[first.index] - o.window_fwhm * first.fwhm_nm,
        x[last.index] + o.window_fwhm * last.fwhm_nm,
        first.index,
        last.index,
    );
    let (wx, wy) = (&x[range.clone()], &y[range.clone()]);
    let mut outer: Vec<f64> = wx
        .iter()
        .zip(wy)
        .filter(|(v, _)| {
            cluster
                .iter()
                .all(|c| (**v - x[c.index]).abs() > 1.5 * c.fwhm_nm)
        })
        .map(|(_, p)| *p)
        .collect();
    let baseline = if outer.len() >= 4 {
        stats::median(&mut outer)
    } else {
        floor
    };
    let initial: Vec<(f64, f64, f64)> = cluster
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let gap = |j: usize| (x[cluster[j].index] - x[c.index]).abs();
            let nearest = (0..cluster.len())
                .filter(|&j| j != k)
                .map(gap)
                .fold(f64::INFINITY, f64::min);
            (y[c.index] - baseline, x[c.index], c.fwhm_nm.min(nearest))
        })
        .collect();
    let fit = match fit_gaussians(wx, wy, &initial, baseline) {
        Ok(f) => f,
        Err(_) => return separate_peaks(x, y, cluster, floor, sigma, o, group),
    };
    let pitch = |c: f64| {
        let i = wx.partition_point(|&v| v < c).clamp(1, wx.len() - 1);
        wx[i] - wx[i - 1]
    };
    Ok(fit
        .components
        .iter()
        .map(|c| {
            let snr = c.amplitude / sigma;
            Peak {
                wavelength_nm: c.center_nm,
                std_error_pm: 1e3 * c.center_std_error_nm,
                crb_pm: 1e3 * sigma * c.center_bound_per_sigma_nm,
                fwhm_pm: 1e3 * c.fwhm_nm,
                snr,
                amplitude: c.amplitude,
                baseline: fit.baseline,
                estimator: "gaussian-joint".into(),
                flags: PeakFlags {
                    undersampled: c.fwhm_nm < o.undersampled_samples * pitch(c.center_nm),
                    low_snr: snr < o.low_snr,
                    overlap: true,
                    ..PeakFlags::default()
                },
                overlap_group: Some(group),
            }
        })
        .collect())
}

/// When the joint fit fails: each candidate alone on a window cut at the midpoints to
/// its neighbours, still flagged `overlap`.
#[allow(clippy::too_many_arguments)]
fn separate_peaks(
    x: &[f64],
    y: &[f64],
    cluster: &[Candidate],
    floor: f64,
    sigma: f64,
    o: &FindOptions,
    group: usize,
) -> Result<Vec<Peak>, SpectrumError> {
    let mut out = Vec::new();
    for (k, c) in cluster.iter().enumerate() {
        let lo = if k > 0 {
            (cluster[k - 1].index + c.index) / 2
        } else {
            c.index.saturating_sub(MIN_SIDE_SAMPLES)
        };
        let hi = if k + 1 < cluster.len() {
            (cluster[k + 1].index + c.index).div_ceil(2)
        } else {
            (c.index + MIN_SIDE_SAMPLES + 1).min(x.len())
        };
        let window = PeakWindow::new(
            x,
            y,
            lo..hi.max(c.index + 1),
            c.index,
            f64::INFINITY,
            floor,
            sigma,
        )?;
        if let Ok(e) = o
            .estimator
            .estimator()
            .estimate(&window)
            .or_else(|_| Centroid::default().estimate(&window))
        {
            let mut p = assemble(
                &e,
                &window,
                format!("{} (overlap, separate)", o.estimator.estimator().name()),
                sigma,
                o,
            );
            p.flags.overlap = true;
            p.overlap_group = Some(group);
            out.push(p);
        }
    }
    Ok(out)
}
