//! Synthetic array calibration runs whose answers are known: dead weights on the cells
//! as a schedule says (one cell at a time, staircases, several together), read through
//! a true sensing matrix, with the sheet's imperfections and the run's faults on
//! demand.
//!
//! Each grating reads Σ_c A_gc · ℓ(L_c), where L_c is the mass on cell c and
//! ℓ(L) = L + bow(L) ± hysteresis(L) the load the sheet transmits:
//! * bow(L) = 4 β S t(1 − t), t = L/S (S the span, β `linearity_frac`), the same on
//!   both branches;
//! * hysteresis(L) = ± ½ η S · 4 t(1 − t) (η `hysteresis_frac`), + while the cell's
//!   mass last went up and − while it last went down, so the up and down branches at
//!   mid-span differ by η S;
//!
//! then each change relaxes towards its new reading with creep (a fraction
//! `creep_frac` of the change left at the change, decaying with `creep_tau_s`), a
//! drift is added (common, and per grating), white noise on every sample, and two
//! rows of the matrix may be exchanged (two gratings laid in each other's slits).

use crate::array::calibrate::schedule::load_states;
use crate::array::calibrate::{Loading, RunData};
use crate::array::SensingMatrix;
use crate::module_log::SynthLog;
use crate::spec::Design;
use anyhow::{bail, Result};

/// How the synthetic sheet responds and what goes wrong in the run.
#[derive(Debug, Clone, PartialEq)]
pub struct ArrayRunSettings {
    /// Wavelength sample rate, Hz.
    pub sample_rate_hz: f64,
    /// White noise on every peak, pm (standard deviation).
    pub noise_pm: f64,
    /// Drift of every grating, pm/s.
    pub drift_pm_per_s: f64,
    /// Drift of single gratings over the whole run, (grating index, pm), linear in time.
    pub grating_drift_pm: Vec<(usize, f64)>,
    /// The span the bow and the hysteresis are shaped over, g.
    pub span_g: f64,
    /// β: the bow's height at mid-span as a fraction of the span.
    pub linearity_frac: f64,
    /// η: the gap between the up and down branches at mid-span as a fraction of the
    /// span.
    pub hysteresis_frac: f64,
    /// Fraction of each change still missing at the change (creep).
    pub creep_frac: f64,
    /// Time constant of the creep, s.
    pub creep_tau_s: f64,
    /// Two gratings (row indices) in each other's places.
    pub swapped: Option<(usize, usize)>,
    /// Unloaded time logged after the last load ends, s.
    pub tail_s: f64,
    /// Random seed.
    pub seed: u64,
}

impl Default for ArrayRunSettings {
    fn default() -> Self {
        ArrayRunSettings {
            sample_rate_hz: 10.0,
            noise_pm: 0.2,
            drift_pm_per_s: 0.0,
            grating_drift_pm: Vec::new(),
            span_g: 250.0,
            linearity_frac: 0.0,
            hysteresis_frac: 0.0,
            creep_frac: 0.0,
            creep_tau_s: 0.5,
            swapped: None,
            tail_s: 10.0,
            seed: 1,
        }
    }
}

impl ArrayRunSettings {
    /// The load the sheet transmits for a mass `l_g`, on the rising (`up`) or falling
    /// branch, g.
    pub fn transmitted_g(&self, l_g: f64, up: bool) -> f64 {
        if l_g <= 0.0 || self.span_g <= 0.0 {
            return l_g.max(0.0);
        }
        let t = l_g / self.span_g;
        let shape = 4.0 * t * (1.0 - t);
        let h = 0.5 * self.hysteresis_frac * self.span_g * shape;
        l_g + self.linearity_frac * self.span_g * shape + if up { h } else { -h }
    }
}

/// A staircase on one cell: `cycles` × (up from `step_g` to `top_g` in steps of
/// `step_g`, down again to `step_g`, then unloaded), each state `step_s` long, from
/// `start_s`.
///
/// ```
/// // The paper's run: 25 g steps to 250 g, 5 s each, three cycles.
/// let s = fbgforge_synth::array_log::staircase(2, 25.0, 250.0, 5.0, 3, 10.0);
/// assert_eq!(s.len(), 3 * 19);
/// assert_eq!((s[9].load_g, s[18].load_g), (250.0, 25.0));
/// assert_eq!(s[19].start_s, 10.0 + 20.0 * 5.0); // an unloaded step between cycles
/// ```
pub fn staircase(
    cell: usize,
    step_g: f64,
    top_g: f64,
    step_s: f64,
    cycles: usize,
    start_s: f64,
) -> Vec<Loading> {
    let n = (top_g / step_g).round() as usize;
    let mut out = Vec::new();
    let mut t = start_s;
    for _ in 0..cycles {
        let masses = (1..=n).chain((1..n).rev());
        for k in masses {
            out.push(Loading {
                start_s: t,
                end_s: t + step_s,
                cell,
                load_g: step_g * k as f64,
            });
            t += step_s;
        }
        t += step_s;
    }
    out
}

/// The cells in order, each `load_g` for `on_s` with `off_s` unloaded between, from
/// `start_s`.
pub fn cell_by_cell(
    cells: &[usize],
    load_g: f64,
    on_s: f64,
    off_s: f64,
    start_s: f64,
) -> Vec<Loading> {
    cells
        .iter()
        .enumerate()
        .map(|(k, &cell)| {
            let t = start_s + k as f64 * (on_s + off_s);
            Loading {
                start_s: t,
                end_s: t + on_s,
                cell,
                load_g,
            }
        })
        .collect()
}

/// A synthetic run of `design`'s array: `events` are what really happened (the
/// schedule a test writes may differ), `matrix` the true sensing matrix.
pub fn synth_array_run(
    design: &Design,
    matrix: &SensingMatrix,
    events: &[Loading],
    s: &ArrayRunSettings,
) -> Result<SynthLog> {
    use rand::SeedableRng;
    use rand_distr::Distribution;
    let Some(a) = &design.array else {
        bail!("design `{}` has no [array]", design.name)
    };
    let n_cells = matrix.n_cells();
    let end = events.iter().map(|l| l.end_s).fold(0.0, f64::max) + s.tail_s;
    let n = (end * s.sample_rate_hz).ceil() as usize;
    let states = load_states(events, n_cells, end);
    let mut a_true = matrix.sensitivity_pm_per_g.clone();
    if let Some((i, j)) = s.swapped {
        a_true.swap_rows(i, j);
    }
    // Each state's reading: the branch of each cell is the direction of its last change.
    let mut up = vec![true; n_cells];
    let readings: Vec<Vec<f64>> = states
        .iter()
        .enumerate()
        .map(|(k, st)| {
            for (c, branch) in up.iter_mut().enumerate() {
                let before = if k == 0 {
                    0.0
                } else {
                    states[k - 1].loads_g[c]
                };
                if st.loads_g[c] != before {
                    *branch = st.loads_g[c] > before;
                }
            }
            (0..a_true.nrows())
                .map(|g| {
                    (0..n_cells)
                        .map(|c| a_true[(g, c)] * s.transmitted_g(st.loads_g[c], up[c]))
                        .sum()
                })
                .collect()
        })
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(s.seed);
    let normal = rand_distr::Normal::new(0.0, 1.0).expect("unit normal");
    let time_s: Vec<f64> = (0..n).map(|i| i as f64 / s.sample_rate_hz).collect();
    let mut k = 0;
    let wavelength_nm = time_s
        .iter()
        .map(|&t| {
            while k + 1 < states.len() && t >= states[k + 1].start_s {
                k += 1;
            }
            a.gratings
                .iter()
                .enumerate()
                .map(|(g, gr)| {
                    let prev = if k == 0 { 0.0 } else { readings[k - 1][g] };
                    let creep = s.creep_frac
                        * (readings[k][g] - prev)
                        * (-(t - states[k].start_s) / s.creep_tau_s.max(1e-9)).exp();
                    let own: f64 = s
                        .grating_drift_pm
                        .iter()
                        .filter(|d| d.0 == g)
                        .map(|d| d.1 * t / end)
                        .sum();
                    gr.bragg_wavelength_nm
                        + (readings[k][g] - creep
                            + s.drift_pm_per_s * t
                            + own
                            + s.noise_pm * normal.sample(&mut rng))
                            * 1e-3
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

/// A synthetic log's shifts as the calibration reads them: pm from each grating's
/// nominal wavelength, times from the first row.
pub fn run_data(design: &Design, log: &SynthLog) -> Result<RunData> {
    let Some(a) = &design.array else {
        bail!("design `{}` has no [array]", design.name)
    };
    let t0 = log.time_s.first().copied().unwrap_or(0.0);
    Ok(RunData {
        time_s: log.time_s.iter().map(|t| t - t0).collect(),
        shifts_pm: (0..a.gratings.len())
            .map(|g| {
                log.wavelength_nm
                    .iter()
                    .map(|row| (row[g] - a.gratings[g].bragg_wavelength_nm) * 1e3)
                    .collect()
            })
            .collect(),
    })
}

/// A plain synthetic calibration log: each grating at its nominal wavelength plus A·load
/// for what is loaded at that time, a drift, and white noise (what `synth-log
/// --schedule` writes).
pub fn synth_calibration_log(
    design: &Design,
    matrix: &SensingMatrix,
    schedule: &[Loading],
    sample_rate_hz: f64,
    noise_pm: f64,
    drift_pm_per_s: f64,
    seed: u64,
) -> Result<SynthLog> {
    synth_array_run(
        design,
        matrix,
        schedule,
        &ArrayRunSettings {
            sample_rate_hz,
            noise_pm,
            drift_pm_per_s,
            seed,
            ..Default::default()
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_papers_staircase_has_ten_steps_up_nine_down_and_a_rest() {
        let s = staircase(0, 25.0, 250.0, 5.0, 3, 10.0);
        assert_eq!(s.len(), 3 * 19);
        assert_eq!(s[9].load_g, 250.0);
        assert_eq!(s[18].load_g, 25.0);
        // The next cycle starts after one unloaded step.
        assert_eq!(s[19].start_s, s[18].end_s + 5.0);
    }

    #[test]
    fn the_branches_differ_by_eta_times_span_at_mid_span() {
        let s = ArrayRunSettings {
            hysteresis_frac: 0.04,
            linearity_frac: 0.02,
            ..Default::default()
        };
        let (u, d) = (s.transmitted_g(125.0, true), s.transmitted_g(125.0, false));
        assert!((u - d - 0.04 * 250.0).abs() < 1e-12);
        assert!((0.5 * (u + d) - 125.0 - 0.02 * 250.0).abs() < 1e-12);
        assert_eq!(s.transmitted_g(250.0, true), 250.0);
    }
}
