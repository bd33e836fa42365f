//! Transfer-matrix grating model against closed forms.

use fbgforge_spectra::grating::{
    clean_peak_limit, grating_spectrum, reflection_shape, reflectivity, spectrum_shape,
    Apodisation, CleanPeakCriteria, Grating, LoadCase, StrainProfile,
};

/// First reflectivity zero beyond `from_nm` in direction `dir` (±1): walk to the first
/// local minimum, then golden-section search.
fn first_zero(g: &Grating, from_nm: f64, dir: f64, step: f64) -> f64 {
    let strain = StrainProfile::Uniform(0.0);
    let r = |x: f64| reflectivity(g, &strain, x);
    let mut x = from_nm;
    while r(x + dir * step) < r(x) {
        x += dir * step;
    }
    let (mut a, mut b) = (x - step, x + step);
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..80 {
        let (c, d) = (b - phi * (b - a), a + phi * (b - a));
        if r(c) < r(d) {
            b = d;
        } else {
            a = c;
        }
    }
    0.5 * (a + b)
}

#[test]
fn uniform_grating_matches_the_closed_forms_within_one_percent() {
    for (length_mm, dn) in [
        (10.0, 2.5e-5),
        (10.0, 5e-5),
        (10.0, 1e-4),
        (5.0, 1e-4),
        (10.0, 1.5e-4),
        (3.0, 3e-4),
    ] {
        let g = Grating {
            length_mm,
            index_modulation: dn,
            sections: 50,
            ..Grating::default()
        };
        let r_peak = reflectivity(&g, &StrainProfile::Uniform(0.0), g.bragg_wavelength_nm);
        let closed = g.uniform_peak_reflectivity();
        assert!(
            (r_peak / closed - 1.0).abs() < 0.01,
            "L {length_mm} Δn {dn}: R {r_peak} vs tanh²(κL) {closed}"
        );
        let bw = g.uniform_bandwidth_nm();
        let step = bw / 2000.0;
        let width = first_zero(&g, g.bragg_wavelength_nm, 1.0, step)
            - first_zero(&g, g.bragg_wavelength_nm, -1.0, step);
        assert!(
            (width / bw - 1.0).abs() < 0.01,
            "L {length_mm} Δn {dn}: zero-to-zero {width} nm vs closed form {bw} nm"
        );
        // And the peak of the sampled spectrum lies at λ_B.
        let s = spectrum_shape(
            &g,
            &StrainProfile::Uniform(0.0),
            &CleanPeakCriteria::default(),
        )
        .unwrap();
        assert!(
            (s.peak_wavelength_nm - g.bragg_wavelength_nm).abs() < 1e-4,
            "{}",
            s.peak_wavelength_nm
        );
    }
}

#[test]
fn sections_of_a_uniform_grating_multiply_to_the_single_matrix() {
    let one = Grating {
        sections: 1,
        ..Grating::default()
    };
    let many = Grating {
        sections: 137,
        ..Grating::default()
    };
    let grid: Vec<f64> = (0..300).map(|i| 1549.7 + 0.002 * i as f64).collect();
    let a = grating_spectrum(&one, &StrainProfile::Uniform(0.0), &grid).unwrap();
    let b = grating_spectrum(&many, &StrainProfile::Uniform(0.0), &grid).unwrap();
    for (x, y) in a.power.iter().zip(&b.power) {
        assert!((x - y).abs() < 1e-9, "{x} vs {y}");
    }
}

#[test]
fn uniform_strain_shifts_the_peak_by_the_photoelastic_law() {
    let g = Grating::default();
    for microstrain in [-300.0, 50.0, 1000.0] {
        let s = spectrum_shape(
            &g,
            &StrainProfile::Uniform(microstrain * 1e-6),
            &CleanPeakCriteria::default(),
        )
        .unwrap();
        let expected = g.bragg_wavelength_nm * (1.0 - g.photoelastic) * microstrain * 1e-6 * 1e3;
        assert!(
            (s.peak_shift_pm - expected).abs() < 0.2,
            "{microstrain} µε: {} pm vs {expected} pm",
            s.peak_shift_pm
        );
        assert!(s.clean && s.fwhm_change_pct.abs() < 0.5, "{s:?}");
    }
}

/// The Gaussian-apodised weak grating of the chirp tests: L = 20 mm, modulation FWHM
/// W = 0.3·L (truncation at ±1.67 W), Δn = 1e-5 (peak reflectivity ≈ 1.7 %).
fn weak_gaussian() -> Grating {
    Grating {
        length_mm: 20.0,
        index_modulation: 1e-5,
        apodisation: Apodisation::Gaussian { fwhm_fraction: 0.3 },
        sections: 400,
        ..Grating::default()
    }
}

/// Linear strain from 0 to the value that makes the local Bragg wavelength change by
/// `chirp_nm_per_mm` per mm.
fn gradient(g: &Grating, chirp_nm_per_mm: f64) -> StrainProfile {
    let span_nm = chirp_nm_per_mm * g.length_mm;
    StrainProfile::Linear {
        start: 0.0,
        end: span_nm / (g.bragg_wavelength_nm * (1.0 - g.photoelastic)),
    }
}

/// Weak-grating (first Born) closed form. The reflection is |∫κ(z)·e^{i(2δz + φ(z))}dz|².
/// For κ ∝ exp(−z²/2w²) and a linear chirp C = dλ_B/dz (φ = a·z², a = 2π·n_eff·C/λ²)
/// it is a Gaussian in δ whose variance grows from p = 1/(2w²) to p + a²/p, so
///   FWHM² = FWHM₀² + (C·L_κ²)²,  FWHM₀ = √(ln 2)·λ²/(2π·n_eff·w),
/// with L_κ² = 2√(ln 2)·w = W/√2 the FWHM of κ²(z) (W the FWHM of κ): the chirp span
/// across the coupling's intensity FWHM adds in quadrature.
#[test]
fn a_linear_strain_gradient_broadens_the_peak_as_the_weak_grating_closed_form_says() {
    let g = weak_gaussian();
    let criteria = CleanPeakCriteria::default();
    let s0 = spectrum_shape(&g, &StrainProfile::Uniform(0.0), &criteria).unwrap();
    let big_w = 0.3 * g.length_mm;
    let w = big_w / (2.0 * (2.0 * std::f64::consts::LN_2).sqrt());
    let lambda_mm = g.bragg_wavelength_nm * 1e-6;
    let fwhm0_closed_pm = 1e9 * std::f64::consts::LN_2.sqrt() * lambda_mm * lambda_mm
        / (2.0 * std::f64::consts::PI * g.n_eff * w);
    assert!(
        (s0.fwhm_pm / fwhm0_closed_pm - 1.0).abs() < 0.01,
        "unchirped FWHM {} pm vs closed form {fwhm0_closed_pm} pm",
        s0.fwhm_pm
    );
    for ratio in [0.5, 1.0, 2.0, 4.0] {
        // Chirp span across W/√2 equal to `ratio` unchirped FWHMs.
        let span_nm = ratio * 1e-3 * s0.fwhm_pm;
        let c = span_nm / (big_w / 2f64.sqrt());
        let s = spectrum_shape(&g, &gradient(&g, c), &criteria).unwrap();
        let expected_pm = (s0.fwhm_pm.powi(2) + (1e3 * span_nm).powi(2)).sqrt();
        assert!(
            (s.fwhm_pm / expected_pm - 1.0).abs() < 0.01,
            "ratio {ratio}: FWHM {} pm vs closed form {expected_pm} pm",
            s.fwhm_pm
        );
        assert!((s.fwhm_change_pct - 100.0 * (expected_pm / s0.fwhm_pm - 1.0)).abs() < 2.0);
        // The centre moves by half the total span (the mean strain).
        let mean_shift_pm = 0.5e3 * c * g.length_mm;
        assert!(
            (s.peak_shift_pm - mean_shift_pm).abs() < 0.05 * s0.fwhm_pm,
            "{} vs {mean_shift_pm}",
            s.peak_shift_pm
        );
    }
}

#[test]
fn the_clean_peak_limit_force_matches_the_closed_form() {
    // Strain gradient proportional to force: C(F) = k·F. With Y = 50 % growth the closed
    // form gives C·W/√2 = FWHM₀·√(1.5² − 1), so F* = FWHM₀·√1.25·√2/(W·k).
    let g = weak_gaussian();
    let criteria = CleanPeakCriteria::default();
    let s0 = spectrum_shape(&g, &StrainProfile::Uniform(0.0), &criteria).unwrap();
    let k = 2e-3; // nm/mm per N
    let cases: Vec<LoadCase> = (1..=10)
        .map(|i| LoadCase {
            force_n: 2.0 * i as f64,
            strain: gradient(&g, k * 2.0 * i as f64),
        })
        .collect();
    let limit = clean_peak_limit(&g, &cases, &criteria).unwrap();
    assert!(limit.unstrained_clean);
    let big_w = 0.3 * g.length_mm;
    let expected = 1e-3 * s0.fwhm_pm * 1.25f64.sqrt() * 2f64.sqrt() / (big_w * k);
    let force = limit.force_n.expect("goes unclean within 20 N");
    assert!(
        (force / expected - 1.0).abs() < 0.02,
        "limit {force} N vs closed form {expected} N"
    );
    assert_eq!(limit.shapes.len(), 10);
    assert!(limit.shapes.iter().all(|(f, s)| s.clean == (*f < force)));
    // Clean over a range that stays below it.
    let low: Vec<LoadCase> = cases
        .iter()
        .filter(|c| c.force_n < 0.9 * expected)
        .cloned()
        .collect();
    assert_eq!(clean_peak_limit(&g, &low, &criteria).unwrap().force_n, None);
}

#[test]
fn a_strong_chirp_splits_a_uniform_grating_into_lobes() {
    let g = Grating::default();
    let criteria = CleanPeakCriteria::default();
    let s0 = spectrum_shape(&g, &StrainProfile::Uniform(0.0), &criteria).unwrap();
    // Unstrained default grating: one lobe, highest side lobe between −6 dB and −13.3 dB
    // (the weak-grating sinc² limit).
    assert!(s0.clean && s0.lobes == 1);
    let side = s0.highest_side_lobe_db.unwrap();
    assert!(side < -6.0 && side > -13.3, "{side}");
    let span_nm = 4.0 * 1e-3 * s0.fwhm_pm;
    let s = spectrum_shape(&g, &gradient(&g, span_nm / g.length_mm), &criteria).unwrap();
    assert!(!s.clean && s.lobes >= 2, "{s:?}");
}

#[test]
fn apodisation_lowers_the_side_lobes() {
    let criteria = CleanPeakCriteria::default();
    let uniform =
        spectrum_shape(&Grating::default(), &StrainProfile::Uniform(0.0), &criteria).unwrap();
    for apodisation in [
        Apodisation::RaisedCosine,
        Apodisation::Gaussian { fwhm_fraction: 0.4 },
    ] {
        let g = Grating {
            apodisation,
            index_modulation: 2e-4,
            ..Grating::default()
        };
        let s = spectrum_shape(&g, &StrainProfile::Uniform(0.0), &criteria).unwrap();
        let side = s.highest_side_lobe_db.unwrap_or(f64::NEG_INFINITY);
        assert!(
            side < uniform.highest_side_lobe_db.unwrap() - 10.0,
            "{apodisation:?}: {side} dB"
        );
    }
}

#[test]
fn reflection_shape_counts_lobes_and_measures_fwhm() {
    // Two Gaussians 3 widths apart, the second 2 dB down: two lobes; 8 dB down: one.
    let x: Vec<f64> = (0..2001).map(|i| 1549.0 + 0.001 * i as f64).collect();
    let g = |c: f64, a: f64, v: f64| {
        a * (-4.0 * std::f64::consts::LN_2 * ((v - c) / 0.1).powi(2)).exp()
    };
    let criteria = CleanPeakCriteria::default();
    for (second_db, lobes) in [(-2.0, 2), (-8.0, 1)] {
        let a2 = 10f64.powf(second_db / 10.0);
        let r: Vec<f64> = x
            .iter()
            .map(|&v| g(1549.8, 1.0, v) + g(1550.1, a2, v))
            .collect();
        let s = reflection_shape(&x, &r, None, &criteria).unwrap();
        assert_eq!(s.lobes, lobes, "{second_db} dB: {s:?}");
        assert!((s.highest_side_lobe_db.unwrap() - second_db).abs() < 0.2);
    }
    let r: Vec<f64> = x.iter().map(|&v| g(1550.0, 0.5, v)).collect();
    let s = reflection_shape(&x, &r, Some((1549.99, 0.08)), &criteria).unwrap();
    assert!((s.fwhm_pm - 100.0).abs() < 0.01 && (s.peak_shift_pm - 10.0).abs() < 1e-6);
    assert!((s.fwhm_change_pct - 25.0).abs() < 0.02 && s.clean);
}
