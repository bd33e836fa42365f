//! Cramér–Rao bound of a peak's position.
//!
//! For a Gaussian peak A·g(λ; λ0, s), g = exp(−(λ−λ0)²/(2s²)), sampled at λᵢ with white
//! additive Gaussian noise of standard deviation σ, and λ0 the only unknown, the Fisher
//! information is (A/σ)²·Σᵢ(∂gᵢ/∂λ0)² and
//!
//! var(λ̂0) ≥ (σ/A)² / Σᵢ (∂gᵢ/∂λ0)²,  ∂g/∂λ0 = (λ − λ0)/s² · g.
//!
//! The sum is evaluated on the actual grid (so pixel-locking of narrow peaks shows: the
//! bound then depends on where λ0 sits between samples). For s ≳ Δ on a uniform grid of
//! pitch Δ the sum is ≈ √π/(2sΔ) and the bound ≈ (σ/A)·√(2sΔ/√π) = (σ/A)·√(1.128·s·Δ)
//! ([`gaussian_position_crb_closed_form_pm`]). With amplitude, width and baseline unknown
//! as well the bound is the same when the window is symmetric about the peak (the
//! position derivative is odd, the others even) and slightly larger otherwise.

/// FWHM / s of a Gaussian: 2√(2 ln 2).
pub const FWHM_PER_SIGMA: f64 = 2.354_820_045_030_949_3;

/// The bound (pm) evaluated on `wavelengths_nm` for a Gaussian of the given centre,
/// FWHM, amplitude (above the floor) and noise σ (same units as the amplitude).
pub fn gaussian_position_crb_pm(
    wavelengths_nm: &[f64],
    center_nm: f64,
    fwhm_nm: f64,
    amplitude: f64,
    noise_sigma: f64,
) -> f64 {
    let s = fwhm_nm / FWHM_PER_SIGMA;
    let sum: f64 = wavelengths_nm
        .iter()
        .map(|&x| {
            let u = (x - center_nm) / s;
            let d = u / s * (-0.5 * u * u).exp();
            d * d
        })
        .sum();
    if !(sum > 0.0) || !(amplitude > 0.0) {
        return f64::INFINITY;
    }
    1e3 * (noise_sigma / amplitude) / sum.sqrt()
}

/// The bound (pm) with amplitude, width and a constant floor unknown as well: the
/// position entry of the inverse 4×4 Fisher matrix (A/σ²-scaled JᵀJ of A·g + b). It
/// equals [`gaussian_position_crb_pm`] when the samples sit symmetrically about the
/// centre and exceeds it otherwise, markedly below ~1.5 samples per FWHM, where the
/// position and the width are estimated from the same two or three samples.
pub fn gaussian_position_crb_joint_pm(
    wavelengths_nm: &[f64],
    center_nm: f64,
    fwhm_nm: f64,
    amplitude: f64,
    noise_sigma: f64,
) -> f64 {
    let s = fwhm_nm / FWHM_PER_SIGMA;
    let mut fisher = nalgebra::Matrix4::<f64>::zeros();
    for &x in wavelengths_nm {
        let u = (x - center_nm) / s;
        let g = (-0.5 * u * u).exp();
        // ∂/∂A, ∂/∂λ0, ∂/∂s, ∂/∂b of A·g + b.
        let d = nalgebra::Vector4::new(g, amplitude * g * u / s, amplitude * g * u * u / s, 1.0);
        fisher += d * d.transpose();
    }
    match fisher.try_inverse() {
        Some(inv) if inv[(1, 1)] > 0.0 => 1e3 * noise_sigma * inv[(1, 1)].sqrt(),
        _ => f64::INFINITY,
    }
}

/// The well-sampled closed form (σ/A)·√(2sΔ/√π), pm, for a uniform pitch Δ (nm).
pub fn gaussian_position_crb_closed_form_pm(
    pitch_nm: f64,
    fwhm_nm: f64,
    amplitude: f64,
    noise_sigma: f64,
) -> f64 {
    let s = fwhm_nm / FWHM_PER_SIGMA;
    1e3 * (noise_sigma / amplitude) * (2.0 * s * pitch_nm / std::f64::consts::PI.sqrt()).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numeric_sum_approaches_the_closed_form_when_well_sampled() {
        let pitch = 0.008;
        let grid: Vec<f64> = (0..2001).map(|i| 1545.0 + pitch * i as f64).collect();
        for fwhm_samples in [3.0, 6.0, 20.0] {
            let fwhm = fwhm_samples * pitch;
            let numeric = gaussian_position_crb_pm(&grid, 1553.0031, fwhm, 1.0, 0.01);
            let closed = gaussian_position_crb_closed_form_pm(pitch, fwhm, 1.0, 0.01);
            assert!(
                (numeric / closed - 1.0).abs() < 1e-3,
                "{fwhm_samples}: {numeric} vs {closed}"
            );
        }
        // Pixel-locking: one sample per FWHM, the bound moves with the sub-sample position.
        let on = gaussian_position_crb_pm(&grid, 1553.0, pitch, 1.0, 0.01);
        let between = gaussian_position_crb_pm(&grid, 1553.0 + 0.5 * pitch, pitch, 1.0, 0.01);
        assert!((on / between - 1.0).abs() > 0.05, "{on} {between}");
    }

    #[test]
    fn joint_bound_equals_the_position_bound_on_symmetric_samples_and_exceeds_it_otherwise() {
        let pitch = 0.01;
        let grid: Vec<f64> = (-40..=40).map(|i| 1550.0 + pitch * i as f64).collect();
        for fwhm_samples in [1.0, 2.0, 5.0] {
            let fwhm = fwhm_samples * pitch;
            let one = gaussian_position_crb_pm(&grid, 1550.0, fwhm, 1.0, 0.01);
            let joint = gaussian_position_crb_joint_pm(&grid, 1550.0, fwhm, 1.0, 0.01);
            assert!(
                (joint / one - 1.0).abs() < 1e-6,
                "{fwhm_samples}: {joint} vs {one}"
            );
            let off = 1550.0 + 0.3 * pitch;
            let one = gaussian_position_crb_pm(&grid, off, fwhm, 1.0, 0.01);
            let joint = gaussian_position_crb_joint_pm(&grid, off, fwhm, 1.0, 0.01);
            // Never below the position-only bound; well above it at one sample per FWHM,
            // equal to it (to rounding) when well sampled.
            assert!(
                joint >= one * (1.0 - 1e-9),
                "{fwhm_samples}: {joint} vs {one}"
            );
            if fwhm_samples == 1.0 {
                assert!(joint > 1.2 * one, "{joint} vs {one}");
            } else if fwhm_samples == 5.0 {
                assert!((joint / one - 1.0).abs() < 1e-6, "{joint} vs {one}");
            }
        }
    }
}
