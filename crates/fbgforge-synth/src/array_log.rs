//! A synthetic array calibration run: each grating at its nominal wavelength plus A·load
//! for the cell a schedule loads at that time, a drift, and white noise.

use crate::array::calibrate::Loading;
use crate::array::SensingMatrix;
use crate::module_log::SynthLog;
use crate::spec::Design;
use anyhow::{bail, Result};

/// A synthetic calibration log: each grating at its nominal wavelength plus
/// A·load for the cell loaded at that time, a drift, and white noise.
pub fn synth_calibration_log(
    design: &Design,
    matrix: &SensingMatrix,
    schedule: &[Loading],
    sample_rate_hz: f64,
    noise_pm: f64,
    drift_pm_per_s: f64,
    seed: u64,
) -> Result<SynthLog> {
    use rand::SeedableRng;
    use rand_distr::Distribution;
    let Some(a) = &design.array else {
        bail!("design `{}` has no [array]", design.name)
    };
    let end = schedule.iter().map(|l| l.end_s).fold(0.0, f64::max) + 10.0;
    let n = (end * sample_rate_hz).ceil() as usize;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let normal = rand_distr::Normal::new(0.0, 1.0).expect("unit normal");
    let time_s: Vec<f64> = (0..n).map(|i| i as f64 / sample_rate_hz).collect();
    let wavelength_nm = time_s
        .iter()
        .map(|&t| {
            let load = schedule.iter().find(|l| t >= l.start_s && t < l.end_s);
            a.gratings
                .iter()
                .enumerate()
                .map(|(g, gr)| {
                    let s =
                        load.map_or(0.0, |l| matrix.sensitivity_pm_per_g[(g, l.cell)] * l.load_g);
                    gr.bragg_wavelength_nm
                        + (s + drift_pm_per_s * t + noise_pm * normal.sample(&mut rng)) * 1e-3
                })
                .collect()
        })
        .collect();
    Ok(SynthLog {
        time_s,
        names: a.gratings.iter().map(|g| g.name.clone()).collect(),
        wavelength_nm,
    })
}
