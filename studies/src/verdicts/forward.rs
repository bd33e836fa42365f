//! The verdict study's own forward model: the force a protocol applies, the part's
//! response through its relaxation, delay, bond friction and bond creep, the
//! temperature the gratings see, and what the interrogator and the force stand write
//! down (rates, noise, steps, ceilings, frozen peaks, dropouts, pauses, clocks).
//! Written apart from the project's synthetic-log generator (`synth::module_log`) on
//! purpose: a different pulse shape, a relaxation integrated by the trapezoidal rule
//! with any number of time constants, friction and creep the verifier's lag model
//! does not have, so that the study finds what that generator hides.

use super::space::{press_length, Press, Protocol, Scenario};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::PI;

/// Force of one press at `t`, N.
fn press_force(p: &Press, protocol: Protocol, t: f64) -> f64 {
    let x = t - p.start_s;
    let len = press_length(p, protocol);
    if x < 0.0 || x > len {
        return 0.0;
    }
    let rise = |u: f64| (1.0 - (PI * u.clamp(0.0, 1.0)).cos()) / 2.0;
    p.peak_n
        * match protocol {
            Protocol::Impulses => {
                if x < p.a_s {
                    rise(x / p.a_s)
                } else {
                    1.0 - rise((x - p.a_s) / p.b_s)
                }
            }
            Protocol::PressHoldRelease => {
                if x < p.a_s {
                    rise(x / p.a_s)
                } else if x < p.a_s + p.b_s {
                    1.0
                } else {
                    1.0 - rise((x - p.a_s - p.b_s) / p.a_s)
                }
            }
            Protocol::Staircase => {
                let n = p.steps as f64;
                let step = p.a_s + p.b_s;
                let k = (x / step).floor().min(2.0 * n - 1.0);
                let within = x - k * step;
                let level = |j: f64| {
                    if j < n {
                        (j + 1.0) / n
                    } else {
                        (2.0 * n - j - 1.0) / n
                    }
                };
                let before = if k == 0.0 { 0.0 } else { level(k - 1.0) };
                before + (level(k) - before) * rise(within / p.a_s)
            }
            Protocol::Sine | Protocol::PreloadedSine => (1.0 - (2.0 * PI * x / p.a_s).cos()) / 2.0,
        }
}

/// The preload under a preloaded sine: ramps to 30 % of the largest press over 2 s
/// before the first press and back after the last.
fn preload(presses: &[Press], protocol: Protocol, t: f64) -> f64 {
    if protocol != Protocol::PreloadedSine || presses.is_empty() {
        return 0.0;
    }
    let level = 0.3 * presses.iter().map(|p| p.peak_n).fold(0.0, f64::max);
    let a = presses[0].start_s;
    let last = presses[presses.len() - 1];
    let b = last.start_s + press_length(&last, protocol);
    let up = ((t - (a - 2.0)) / 2.0).clamp(0.0, 1.0);
    let down = (((b + 2.0) - t) / 2.0).clamp(0.0, 1.0);
    level * up.min(down)
}

/// The force the protocol applies at `t`, N.
pub fn force_at(presses: &[Press], protocol: Protocol, t: f64) -> f64 {
    preload(presses, protocol, t)
        + presses
            .iter()
            .map(|p| press_force(p, protocol, t))
            .sum::<f64>()
}

/// The run simulated on a fine grid: time, force, the part's strain in force units
/// (relaxation, delay, friction, creep), and temperature.
pub struct Physics {
    /// Grid step, s.
    pub dt: f64,
    /// Force, N.
    pub force: Vec<f64>,
    /// Strain the gratings follow, in newtons of static load (K × this is the shift).
    pub strain_n: Vec<f64>,
    /// Temperature change, K.
    pub temperature_k: Vec<f64>,
}

impl Physics {
    /// Linear interpolation of `v` at time `t`.
    pub fn at(&self, v: &[f64], t: f64) -> f64 {
        let x = (t / self.dt).clamp(0.0, (v.len() - 1) as f64);
        let i = (x.floor() as usize).min(v.len() - 2);
        let f = x - i as f64;
        v[i] * (1.0 - f) + v[i + 1] * f
    }
}

/// Simulate the run of `s`: the force, the relaxation (trapezoidal rule, each term
/// z' = (F − z)/τ), the delay, the bond's friction (a play operator on the strain: the
/// grating sticks until the part has moved half the loop's width) and creep (the
/// grating's strain relaxing towards a slow copy of itself), and the temperature.
pub fn simulate(s: &Scenario) -> Physics {
    let rate = (s.wl_rate_hz * 4.0)
        .max(s.force_rate_hz)
        .clamp(100.0, 2000.0);
    let dt = 1.0 / rate;
    let n = (s.duration_s / dt).ceil() as usize + 2;
    let force: Vec<f64> = (0..n)
        .map(|i| force_at(&s.presses, s.protocol, i as f64 * dt))
        .collect();
    let mut resp: Vec<f64> = force.iter().map(|f| s.instant * f).collect();
    for &(share, tau) in &s.relax {
        let c = dt / (2.0 * tau);
        let mut z = 0.0;
        for i in 0..n {
            let prev = if i == 0 { 0.0 } else { force[i - 1] };
            z = (z * (1.0 - c) + c * (prev + force[i])) / (1.0 + c);
            resp[i] += share * z;
        }
    }
    // The delay: the response of t − d.
    let shift = (s.delay_s / dt).round() as usize;
    let delayed: Vec<f64> = (0..n)
        .map(|i| if i >= shift { resp[i - shift] } else { 0.0 })
        .collect();
    let peak = delayed.iter().copied().fold(0.0, f64::max).max(1e-9);
    let mut strain = delayed.clone();
    if s.hysteresis > 0.0 {
        // Loop width (loading against unloading, same load) = hysteresis × span.
        let w = s.hysteresis * peak;
        let mut z = 0.0f64;
        for (i, x) in delayed.iter().enumerate() {
            z = z.clamp(x - w, x + w);
            strain[i] = x + 0.5 * (z - x);
        }
    }
    if let Some((loss, tau)) = s.creep {
        let c = dt / tau;
        let mut slow = 0.0;
        for v in strain.iter_mut() {
            slow += (*v - slow) * c / (1.0 + c);
            *v -= loss * slow;
        }
    }
    let temperature_k = (0..n).map(|i| temperature_at(s, i as f64 * dt)).collect();
    Physics {
        dt,
        force,
        strain_n: strain,
        temperature_k,
    }
}

/// Temperature change at `t`, K.
fn temperature_at(s: &Scenario, t: f64) -> f64 {
    let Some(tm) = &s.temperature else {
        return 0.0;
    };
    let u = t / s.duration_s;
    tm.swing_k
        * match tm.shape {
            0 => u,
            1 => 1.0 - (2.0 * u - 1.0).abs(),
            2 => 0.5 * (2.0 * PI * t / tm.scale_s + s.seed as f64).sin(),
            _ => {
                let t0 = 0.3 * s.duration_s;
                if t < t0 {
                    0.0
                } else {
                    1.0 - (-(t - t0) / tm.scale_s).exp()
                }
            }
        }
}

/// What the interrogator wrote: per row its true time, and the wavelengths (nm, NaN =
/// no peak) of the two strain gratings and the reference.
pub struct WavelengthRecord {
    /// True time of each row, s.
    pub t: Vec<f64>,
    /// Per row: strain grating 1, strain grating 2, reference (nm).
    pub nm: Vec<[f64; 3]>,
}

/// The gratings' nominal wavelengths and model K (pm/N).
#[derive(Debug, Clone, Copy)]
pub struct Gratings {
    /// Strain grating 1, strain grating 2, reference, nm.
    pub nominal_nm: [f64; 3],
    /// Model K of the two strain gratings, pm/N.
    pub model_k: [f64; 2],
}

/// The interrogator's rows: times at its rate over its span (skipping pauses, with a
/// little jitter), each peak the shift plus noise, pinned at the ceiling, rounded to
/// the step, frozen in stuck stretches, dropped at random and under load.
pub fn interrogate(s: &Scenario, ph: &Physics, g: &Gratings) -> WavelengthRecord {
    let mut rng = ChaCha8Rng::seed_from_u64(s.seed ^ 0x5eed_0001);
    let noise = Normal::new(0.0, s.noise_pm).expect("a finite noise");
    let period = 1.0 / s.wl_rate_hz;
    let strain_peak = ph.strain_n.iter().copied().fold(0.0, f64::max).max(1e-9);
    let mut t = s.wl_span.0 + rng.random::<f64>() * period;
    let mut rec = WavelengthRecord {
        t: Vec::new(),
        nm: Vec::new(),
    };
    let mut last = [f64::NAN; 3];
    while t < s.wl_span.1.min(s.duration_s - 0.01) {
        if let Some(&(a, len)) = s.pauses.iter().find(|(a, len)| t >= *a && t < a + len) {
            t = a + len + rng.random::<f64>() * period;
            continue;
        }
        let strain = ph.at(&ph.strain_n, t);
        let temp = ph.at(&ph.temperature_k, t);
        let mut row = [f64::NAN; 3];
        for k in 0..3 {
            let shift = if k < 2 {
                g.model_k[k] * s.k_ratio[k] * strain
                    + s.temperature.map_or(0.0, |tm| tm.strain_pm_per_k[k] * temp)
            } else {
                s.temperature.map_or(0.0, |tm| tm.reference_pm_per_k * temp)
            };
            let mut pm = shift + noise.sample(&mut rng);
            if let (Some(cap), true) = (s.wl_ceiling_pm, k < 2) {
                // The peak cannot leave the interrogator's range in the direction the
                // load moves it: pinned at the edge, noise gone.
                let dir = g.model_k[k].signum();
                if pm * dir > cap {
                    pm = cap * dir;
                }
            }
            let mut nm = g.nominal_nm[k] + pm / 1e3;
            if s.step_pm > 0.0 {
                nm = (nm * 1e3 / s.step_pm).round() * s.step_pm / 1e3;
            }
            if k == 0
                && s.stuck.iter().any(|(a, len)| t >= *a && t < a + len)
                && last[0].is_finite()
            {
                nm = last[0];
            }
            let load = (strain / strain_peak).clamp(0.0, 1.0);
            let p_drop = s.dropout
                + if k < 2 {
                    s.dropout_at_load * load.powi(4)
                } else {
                    0.0
                };
            last[k] = nm;
            row[k] = if rng.random::<f64>() < p_drop {
                f64::NAN
            } else {
                nm
            };
        }
        rec.t.push(t);
        rec.nm.push(row);
        t += period * (1.0 + 0.002 * (rng.random::<f64>() - 0.5));
    }
    rec
}

/// What the force stand wrote: true time and force (N, as measured, before units).
pub struct ForceRecord {
    /// True time of each sample, s.
    pub t: Vec<f64>,
    /// Force, N (compression positive; noise, ceiling applied).
    pub n: Vec<f64>,
}

/// The force stand's samples over its span, skipping its stalls: the force (of this
/// run, or of another) with noise, clipped at the load cell's ceiling.
pub fn stand(s: &Scenario) -> ForceRecord {
    let mut rng = ChaCha8Rng::seed_from_u64(s.seed ^ 0x5eed_0002);
    let noise = Normal::new(0.0, s.force_noise_n).expect("a finite noise");
    let period = 1.0 / s.force_rate_hz;
    let presses = s.other_run.as_deref().unwrap_or(&s.presses);
    let mut rec = ForceRecord {
        t: Vec::new(),
        n: Vec::new(),
    };
    let n = ((s.force_span.1 - s.force_span.0) / period).floor() as usize;
    for i in 0..=n {
        let t = s.force_span.0 + i as f64 * period;
        if s.force_gaps.iter().any(|(a, len)| t >= *a && t < a + len) {
            continue;
        }
        let mut f = force_at(presses, s.protocol, t) + noise.sample(&mut rng);
        if let Some(c) = s.force_ceiling_n {
            f = f.min(c);
        }
        rec.t.push(t);
        rec.n.push(f);
    }
    rec
}
