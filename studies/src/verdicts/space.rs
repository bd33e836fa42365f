//! The scenario space of the verdict study: what a lab's run can be, drawn at random.
//!
//! A scenario is a good run of the shipped clip-on module (core `psc2`, Case II, the
//! model's K of about −170 pm/N) with one class of trouble drawn on top (and, a
//! quarter of the time, a second one): a part off the model, a loose bond, creep, a
//! dead grating, an unloaded sensor, temperature with and without a reference
//! grating, a saturated or stuck interrogator, dropouts, a saturated or gapped force
//! channel, recordings cut on either side, a force log of another run, clock jumps,
//! whole-second timestamps with pauses, force in other units, clock skew, transport
//! delay, preloaded sines, a flipped force sign. The base run itself varies: the
//! protocol (impulses, press-hold-release, staircase, sine), the rates (1 Hz to
//! 1 kHz), the noise, the interrogator's step, the dynamics (one or two relaxation
//! times, a delay), the clocks. Nothing here calls the project's synthetic-log
//! generator: the study's forward model ([`super::forward`]) is its own.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// A force-stand protocol.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Protocol {
    /// Short presses (raised-cosine, rise and fall of different lengths).
    Impulses,
    /// Ramp up, hold, ramp down.
    PressHoldRelease,
    /// Steps up then down, each held.
    Staircase,
    /// Sinusoidal loading from rest, in blocks of cycles.
    Sine,
    /// A sinusoid on a preload that never returns to rest.
    PreloadedSine,
}

/// The trouble drawn on top of a good run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Hash, PartialOrd, Ord)]
#[serde(rename_all = "kebab-case")]
pub enum Class {
    /// Nothing: a good part, a clean run.
    Good,
    /// The part's K off the model (softer or stiffer, 10–45 %).
    OffModel,
    /// The part's K near the tolerance (the verdict may go either way).
    NearTolerance,
    /// A loosely glued grating: friction in the bond (a Jenkins element), 12–40 % of
    /// span of hysteresis, the part somewhat soft.
    LooseBond,
    /// A little hysteresis (1–3 % of span): a good bond.
    SlightHysteresis,
    /// The grating's strain relaxes under load (the bond creeps), 15–40 %.
    BondCreep,
    /// A second, slower relaxation time of the part (its own viscoelasticity).
    TwoTimeConstants,
    /// One strain grating shows nothing.
    DeadGrating,
    /// No grating sees the force (the sensor was not in the load path).
    Unloaded,
    /// Unloaded, and a temperature swing with no reference grating.
    UnloadedWithTemperature,
    /// A temperature swing, the reference grating present (embedded gratings see
    /// more of it than the free reference).
    TemperatureWithReference,
    /// A temperature swing and no reference grating.
    TemperatureWithoutReference,
    /// The interrogator pins peaks at a ceiling of its range.
    WavelengthSaturation,
    /// The interrogator repeats a frozen peak for stretches.
    StuckPeaks,
    /// Peaks drop out at random (a few per cent).
    RandomDropouts,
    /// Peaks drop out under load (the peak leaves the detection range).
    DropoutsUnderLoad,
    /// The load cell clips at a ceiling below the largest presses.
    ForceSaturation,
    /// The force logger stalls for a few seconds, once or twice.
    ForceGaps,
    /// The interrogator started late or stopped early: the wavelength log covers only
    /// some presses.
    WavelengthCut,
    /// The force stand started late or stopped early.
    ForceCut,
    /// The force log belongs to another run.
    OtherRunForce,
    /// The wavelength log's wall clock jumps (DST, an NTP step).
    ClockJump,
    /// Whole-second timestamps (I-MON export) with pauses in the recording.
    WholeSecondPauses,
    /// Force logged in lbf, kgf or gf, the unit named in the header.
    UnitsNamed,
    /// Force logged in lbf or kgf, the column naming no unit.
    UnitsUnnamed,
    /// A per-row units column (Mark-10 style).
    UnitsColumn,
    /// The force stand's clock runs fast or slow (100–1000 ppm).
    ClockSkew,
    /// A pure transport delay of the response (a slow interrogator buffer).
    TransportDelay,
    /// Compression logged as negative force.
    NegativeForce,
    /// The part's K has the wrong sign.
    WrongSign,
}

impl Class {
    /// Every class, in the table's order.
    pub const ALL: [Class; 30] = [
        Class::Good,
        Class::OffModel,
        Class::NearTolerance,
        Class::LooseBond,
        Class::SlightHysteresis,
        Class::BondCreep,
        Class::TwoTimeConstants,
        Class::DeadGrating,
        Class::Unloaded,
        Class::UnloadedWithTemperature,
        Class::TemperatureWithReference,
        Class::TemperatureWithoutReference,
        Class::WavelengthSaturation,
        Class::StuckPeaks,
        Class::RandomDropouts,
        Class::DropoutsUnderLoad,
        Class::ForceSaturation,
        Class::ForceGaps,
        Class::WavelengthCut,
        Class::ForceCut,
        Class::OtherRunForce,
        Class::ClockJump,
        Class::WholeSecondPauses,
        Class::UnitsNamed,
        Class::UnitsUnnamed,
        Class::UnitsColumn,
        Class::ClockSkew,
        Class::TransportDelay,
        Class::NegativeForce,
        Class::WrongSign,
    ];

    /// The class of a name in the table (`loose-bond`).
    pub fn named(name: &str) -> Option<Class> {
        Class::ALL.into_iter().find(|c| c.name() == name)
    }

    /// Its name in the table.
    pub fn name(self) -> String {
        serde_json::to_value(self)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default()
    }
}

/// One press (or block of cycles) of the protocol, on the run's true time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Press {
    /// Start, s.
    pub start_s: f64,
    /// Peak force, N.
    pub peak_n: f64,
    /// Rise (impulse), ramp (press-hold-release, staircase steps) or period (sine), s.
    pub a_s: f64,
    /// Fall (impulse), hold (press-hold-release, each step), cycles (sine), s or count.
    pub b_s: f64,
    /// Steps (staircase), 0 otherwise.
    pub steps: u32,
}

/// How the wavelength log writes its times.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum WlClock {
    /// `time_s` from the first row (CSV).
    Relative,
    /// ISO date and time with milliseconds (CSV), the PC's wall clock.
    Iso,
    /// ENLIGHT Peaks export, `dd/mm/yyyy HH:MM:SS.ffffff`.
    Enlight,
    /// I-MON evaluation log: whole seconds on a 12-hour clock.
    ImonWholeSeconds,
}

/// How the force log is written.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ForceUnits {
    /// `time_s,force_N`.
    NewtonNamed,
    /// `time_s,force_lbf`.
    LbfNamed,
    /// `time_s,force_kgf`.
    KgfNamed,
    /// `time_s,force_gf`.
    GfNamed,
    /// `time_s,force` in lbf (the unit not named).
    LbfUnnamed,
    /// `time_s,force` in kgf (the unit not named).
    KgfUnnamed,
    /// `Reading,Force,Unit,Time` with the unit in every row (Mark-10 style), lbf or N.
    UnitColumn(bool),
}

impl ForceUnits {
    /// Newtons per unit written.
    pub fn n_per_unit(self) -> f64 {
        match self {
            ForceUnits::NewtonNamed | ForceUnits::UnitColumn(false) => 1.0,
            ForceUnits::LbfNamed | ForceUnits::LbfUnnamed | ForceUnits::UnitColumn(true) => {
                4.448_221_615_260_5
            }
            ForceUnits::KgfNamed | ForceUnits::KgfUnnamed => 9.806_65,
            ForceUnits::GfNamed => 0.009_806_65,
        }
    }
}

/// Temperature over the run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Temperature {
    /// Peak-to-peak swing, K.
    pub swing_k: f64,
    /// 0 ramp, 1 tent, 2 sine, 3 exponential step (a door opened).
    pub shape: u8,
    /// Period of the sine, or time constant of the step, s.
    pub scale_s: f64,
    /// Temperature sensitivity of each strain grating, pm/K (embedded: more than the
    /// free reference's).
    pub strain_pm_per_k: [f64; 2],
    /// Of the free reference grating, pm/K.
    pub reference_pm_per_k: f64,
}

/// One drawn scenario: everything the forward model needs, and the truth.
#[derive(Debug, Clone, Serialize)]
pub struct Scenario {
    /// Number in the study.
    pub id: usize,
    /// Its seed.
    pub seed: u64,
    /// The trouble drawn.
    pub class: Class,
    /// A second trouble, when drawn.
    pub second: Option<Class>,
    /// The protocol.
    pub protocol: Protocol,
    /// The presses.
    pub presses: Vec<Press>,
    /// The run's length, s.
    pub duration_s: f64,
    /// Wavelength log rate, Hz.
    pub wl_rate_hz: f64,
    /// Force log rate, Hz.
    pub force_rate_hz: f64,
    /// True K / model K of each strain grating.
    pub k_ratio: [f64; 2],
    /// Instant fraction of the relaxation.
    pub instant: f64,
    /// Relaxation terms (share, time constant s); shares and `instant` sum to 1.
    pub relax: Vec<(f64, f64)>,
    /// Pure delay of the response, s.
    pub delay_s: f64,
    /// Loop width of the bond's friction, fraction of the span (0: none).
    pub hysteresis: f64,
    /// Bond creep: (fraction lost under a long hold, time constant s).
    pub creep: Option<(f64, f64)>,
    /// Temperature (None: constant).
    pub temperature: Option<Temperature>,
    /// The design has a reference grating.
    pub reference: bool,
    /// Peak noise, pm.
    pub noise_pm: f64,
    /// Interrogator step, pm (0: none).
    pub step_pm: f64,
    /// Peaks pinned at this shift magnitude, pm.
    pub wl_ceiling_pm: Option<f64>,
    /// Stuck stretches: (start s, length s).
    pub stuck: Vec<(f64, f64)>,
    /// Random dropout probability.
    pub dropout: f64,
    /// Dropout probability at full load (rising as the 4th power of the load).
    pub dropout_at_load: f64,
    /// How the wavelength log writes its times.
    pub wl_clock: WlClock,
    /// Pauses of the interrogator: (start s, length s).
    pub pauses: Vec<(f64, f64)>,
    /// The wavelength log's clock jumps by this at this time: (at s, jump s).
    pub wl_jump: Option<(f64, f64)>,
    /// The span the wavelength log covers, s.
    pub wl_span: (f64, f64),
    /// The span the force log covers, s.
    pub force_span: (f64, f64),
    /// The force log carries wall-clock times (of the same PC as the wavelength log,
    /// off by this many seconds) rather than relative ones.
    pub force_wall_clock: Option<f64>,
    /// Force clock rate error, ppm.
    pub force_skew_ppm: f64,
    /// Force noise, N.
    pub force_noise_n: f64,
    /// Load cell ceiling, N.
    pub force_ceiling_n: Option<f64>,
    /// Force logger stalls: (start s, length s).
    pub force_gaps: Vec<(f64, f64)>,
    /// Force units as written.
    pub force_units: ForceUnits,
    /// Compression logged negative.
    pub force_negative: bool,
    /// The force log is of another run (another draw of the presses).
    pub other_run: Option<Vec<Press>>,
}

/// Uniform in [a, b).
fn uni(rng: &mut ChaCha8Rng, a: f64, b: f64) -> f64 {
    a + (b - a) * rng.random::<f64>()
}

/// Log-uniform in [a, b).
fn log_uni(rng: &mut ChaCha8Rng, a: f64, b: f64) -> f64 {
    (uni(rng, a.ln(), b.ln())).exp()
}

/// The protocol's presses from `lead_s`, and the run's length.
pub(crate) fn draw_presses(
    rng: &mut ChaCha8Rng,
    protocol: Protocol,
    wl_rate_hz: f64,
    max_force_n: f64,
) -> (Vec<Press>, f64) {
    // Shortest feature the interrogator can follow: three of its samples.
    let min_feature = (3.0 / wl_rate_hz).max(0.3);
    let lead = uni(rng, 4.0, 15.0);
    let n = rng.random_range(4..=10usize);
    let equal = rng.random::<f64>() < 0.25;
    let base_peak = uni(rng, 0.4, 1.0) * max_force_n;
    let mut presses = Vec::with_capacity(n);
    let mut t = lead;
    for _ in 0..n {
        let peak = if equal {
            base_peak
        } else {
            uni(rng, 0.3, 1.0) * max_force_n
        };
        let (a, b, steps, length) = match protocol {
            Protocol::Impulses => {
                let a = uni(rng, min_feature, (min_feature * 4.0).max(2.0));
                let b = a * uni(rng, 0.7, 2.0);
                (a, b, 0, a + b)
            }
            Protocol::PressHoldRelease => {
                let ramp = uni(rng, min_feature, (min_feature * 3.0).max(1.5));
                let hold = uni(rng, (4.0 * min_feature).max(2.0), 15.0);
                (ramp, hold, 0, 2.0 * ramp + hold)
            }
            Protocol::Staircase => {
                let steps = rng.random_range(2..=5u32);
                let ramp = uni(rng, min_feature / 2.0, min_feature * 1.5);
                let hold = uni(rng, (3.0 * min_feature).max(1.5), 6.0);
                (ramp, hold, steps, 2.0 * steps as f64 * (ramp + hold))
            }
            Protocol::Sine | Protocol::PreloadedSine => {
                let period = uni(rng, (4.0 * min_feature).max(2.0), 12.0);
                let cycles = rng.random_range(2..=5u32) as f64;
                (period, cycles, 0, period * cycles)
            }
        };
        presses.push(Press {
            start_s: t,
            peak_n: peak,
            a_s: a,
            b_s: b,
            steps,
        });
        let rest = match protocol {
            Protocol::PreloadedSine => 0.0,
            _ => uni(rng, 1.5, 4.0) * length.max(2.0) + uni(rng, 1.0, 6.0),
        };
        t += length + rest;
    }
    let duration = t + uni(rng, 5.0, 15.0);
    (presses, duration)
}

/// Draw scenario `id` from `seed`.
pub fn draw(id: usize, seed: u64) -> Scenario {
    draw_of(id, seed, None)
}

/// A scenario drawn as [`draw`] does, its class `only` when given (the rest of the
/// run drawn at random: a test of one class sees that class's whole space).
pub fn draw_of(id: usize, seed: u64, only: Option<Class>) -> Scenario {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let drawn = Class::ALL[rng.random_range(0..Class::ALL.len())];
    let class = only.unwrap_or(drawn);
    let second = (rng.random::<f64>() < 0.25)
        .then(|| Class::ALL[rng.random_range(0..Class::ALL.len())])
        .filter(|c| compatible(class, *c));
    let mut s = base(&mut rng, id, seed, class, second);
    apply(&mut rng, &mut s, class);
    if let Some(c) = second {
        apply(&mut rng, &mut s, c);
    }
    s
}

/// Pairs of classes that describe one run without contradicting each other.
fn compatible(a: Class, b: Class) -> bool {
    use Class::*;
    let harmless = [
        RandomDropouts,
        ClockSkew,
        TransportDelay,
        NegativeForce,
        UnitsNamed,
        UnitsColumn,
        TemperatureWithReference,
        TwoTimeConstants,
        SlightHysteresis,
        WholeSecondPauses,
        ForceGaps,
    ];
    a != b && (harmless.contains(&b) || harmless.contains(&a))
}

/// A good run: the protocol, rates, noise, dynamics and clocks drawn.
fn base(
    rng: &mut ChaCha8Rng,
    id: usize,
    seed: u64,
    class: Class,
    second: Option<Class>,
) -> Scenario {
    let protocol = match rng.random_range(0..9u32) {
        0..=2 => Protocol::Impulses,
        3 | 4 => Protocol::PressHoldRelease,
        5 | 6 => Protocol::Staircase,
        7 => Protocol::Sine,
        _ => Protocol::PreloadedSine,
    };
    // Rates from 1 Hz to 1 kHz; long runs at high rates are kept short enough to
    // study (the presses then scale with the rate's shortest feature).
    let wl_rate_hz =
        [1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 250.0, 1000.0][rng.random_range(0..9usize)];
    let force_rate_hz = (wl_rate_hz * uni(rng, 1.0, 10.0)).clamp(10.0, 1000.0);
    // Largest press: up to a 1.9 nm shift at the model's K (the default window is
    // 2.5 nm).
    let max_force_n = uni(rng, 2.0, 10.0);
    let (presses, duration_s) = draw_presses(rng, protocol, wl_rate_hz, max_force_n);
    let k0 = uni(rng, 0.97, 1.03);
    let instant = uni(rng, 0.2, 0.9);
    let tau = log_uni(rng, 0.05, 1.5);
    let wl_clock = match rng.random_range(0..4u32) {
        0 => WlClock::Relative,
        1 => WlClock::Iso,
        _ => WlClock::Enlight,
    };
    let pc = rng.random::<f64>() < 0.4;
    Scenario {
        id,
        seed,
        class,
        second,
        protocol,
        presses,
        duration_s,
        wl_rate_hz,
        force_rate_hz,
        k_ratio: [k0, k0 * uni(rng, 0.985, 1.015)],
        instant,
        relax: vec![(1.0 - instant, tau)],
        delay_s: uni(rng, 0.0, 0.05),
        hysteresis: 0.0,
        creep: None,
        temperature: None,
        reference: true,
        noise_pm: log_uni(rng, 0.1, 1.0),
        step_pm: if rng.random::<f64>() < 0.3 { 1.0 } else { 0.0 },
        wl_ceiling_pm: None,
        stuck: Vec::new(),
        dropout: 0.0,
        dropout_at_load: 0.0,
        wl_clock,
        pauses: Vec::new(),
        wl_jump: None,
        wl_span: (0.0, duration_s),
        force_span: (uni(rng, 0.0, 3.0), duration_s - uni(rng, 0.0, 3.0)),
        force_wall_clock: (pc && wl_clock != WlClock::Relative).then(|| uni(rng, -20.0, 20.0)),
        force_skew_ppm: uni(rng, -20.0, 20.0),
        force_noise_n: log_uni(rng, 0.002, 0.03),
        force_ceiling_n: None,
        force_gaps: Vec::new(),
        force_units: ForceUnits::NewtonNamed,
        force_negative: false,
        other_run: None,
    }
}

/// Largest press force, N.
pub fn max_press_n(presses: &[Press]) -> f64 {
    presses.iter().map(|p| p.peak_n).fold(0.0, f64::max)
}

/// A stretch of a length drawn in `(lo, hi)` s, starting inside a random press.
fn in_a_press(rng: &mut ChaCha8Rng, s: &Scenario, (lo, hi): (f64, f64)) -> (f64, f64) {
    let len = uni(rng, lo, hi);
    let p = s.presses[rng.random_range(0..s.presses.len())];
    (
        p.start_s + uni(rng, 0.0, press_length(&p, s.protocol) * 0.6),
        len,
    )
}

/// How long a press lasts, s.
pub fn press_length(p: &Press, protocol: Protocol) -> f64 {
    match protocol {
        Protocol::Impulses => p.a_s + p.b_s,
        Protocol::PressHoldRelease => 2.0 * p.a_s + p.b_s,
        Protocol::Staircase => 2.0 * p.steps as f64 * (p.a_s + p.b_s),
        Protocol::Sine | Protocol::PreloadedSine => p.a_s * p.b_s,
    }
}

/// Put `class`'s trouble on the run.
fn apply(rng: &mut ChaCha8Rng, s: &mut Scenario, class: Class) {
    use Class::*;
    match class {
        Good => {}
        OffModel => {
            let off = uni(rng, 0.10, 0.45) * if rng.random::<bool>() { 1.0 } else { -1.0 };
            let k = 1.0 + off;
            s.k_ratio = [k, k * uni(rng, 0.985, 1.015)];
            scale_forces_to_window(s);
        }
        NearTolerance => {
            let off = uni(rng, 0.06, 0.10) * if rng.random::<bool>() { 1.0 } else { -1.0 };
            s.k_ratio = [1.0 + off, 1.0 + off];
        }
        LooseBond => {
            s.hysteresis = uni(rng, 0.12, 0.40);
            let k = uni(rng, 0.75, 1.0);
            s.k_ratio = [k, s.k_ratio[1] * k];
        }
        SlightHysteresis => s.hysteresis = uni(rng, 0.01, 0.03),
        BondCreep => s.creep = Some((uni(rng, 0.15, 0.4), uni(rng, 5.0, 30.0))),
        TwoTimeConstants => {
            let slow = uni(rng, 0.05, 0.2);
            let inst = (s.instant - slow).max(0.1);
            let fast = 1.0 - inst - slow;
            s.instant = inst;
            s.relax = vec![(fast, s.relax[0].1), (slow, uni(rng, 2.0, 6.0))];
        }
        DeadGrating => {
            let g = rng.random_range(0..2usize);
            s.k_ratio[g] = uni(rng, -0.003, 0.003);
        }
        Unloaded => s.k_ratio = [0.0, 0.0],
        UnloadedWithTemperature => {
            s.k_ratio = [0.0, 0.0];
            s.reference = false;
            s.temperature = Some(temperature(rng, (1.0, 3.0)));
        }
        TemperatureWithReference => s.temperature = Some(temperature(rng, (1.0, 5.0))),
        TemperatureWithoutReference => {
            s.reference = false;
            s.temperature = Some(temperature(rng, (0.5, 3.0)));
        }
        WavelengthSaturation => {
            let peak = 170.0 * s.k_ratio[0].abs() * max_press_n(&s.presses);
            s.wl_ceiling_pm = Some(peak * uni(rng, 0.55, 0.85));
        }
        StuckPeaks => {
            let n = rng.random_range(1..=3usize);
            s.stuck = (0..n).map(|_| in_a_press(rng, s, (1.0, 4.0))).collect();
        }
        RandomDropouts => s.dropout = uni(rng, 0.005, 0.05),
        DropoutsUnderLoad => s.dropout_at_load = uni(rng, 0.3, 0.9),
        ForceSaturation => s.force_ceiling_n = Some(max_press_n(&s.presses) * uni(rng, 0.5, 0.85)),
        ForceGaps => {
            let n = rng.random_range(1..=2usize);
            s.force_gaps = (0..n)
                .map(|_| {
                    (
                        uni(rng, s.force_span.0 + 2.0, s.force_span.1 - 5.0),
                        uni(rng, 1.0, 4.0),
                    )
                })
                .collect();
        }
        WavelengthCut => s.wl_span = cut(rng, s),
        ForceCut => s.force_span = cut(rng, s),
        OtherRunForce => {
            let max_f = max_press_n(&s.presses);
            let (p, _) = draw_presses(rng, s.protocol, s.wl_rate_hz, max_f);
            s.other_run = Some(p);
        }
        ClockJump => {
            if s.wl_clock == WlClock::Relative {
                s.wl_clock = WlClock::Iso;
            }
            let jump = match rng.random_range(0..4u32) {
                0 => -3600.0,
                1 => 3600.0,
                2 => -uni(rng, 2.0, 30.0),
                _ => uni(rng, 2.0, 30.0),
            };
            let at = uni(rng, 0.3, 0.7) * s.duration_s;
            s.wl_jump = Some((at, jump));
        }
        WholeSecondPauses => {
            s.wl_clock = WlClock::ImonWholeSeconds;
            s.force_wall_clock = Some(0.0);
            s.wl_rate_hz = [2.0, 5.0, 10.0][rng.random_range(0..3usize)];
            let n = rng.random_range(1..=3usize);
            // Pauses between presses, where an operator pauses a recording.
            s.pauses = (0..n)
                .filter_map(|_| {
                    let k = rng.random_range(1..s.presses.len());
                    let before = s.presses[k - 1];
                    let end = before.start_s + press_length(&before, s.protocol) + 1.5;
                    let room = s.presses[k].start_s - 1.5 - end;
                    (room > 1.0).then(|| {
                        let at = end + uni(rng, 0.0, room * 0.3);
                        (at, uni(rng, 0.5, 1.0) * (s.presses[k].start_s - 1.0 - at))
                    })
                })
                .collect();
        }
        UnitsNamed => {
            s.force_units = [
                ForceUnits::LbfNamed,
                ForceUnits::KgfNamed,
                ForceUnits::GfNamed,
            ][rng.random_range(0..3usize)];
        }
        UnitsUnnamed => {
            s.force_units =
                [ForceUnits::LbfUnnamed, ForceUnits::KgfUnnamed][rng.random_range(0..2usize)];
        }
        UnitsColumn => s.force_units = ForceUnits::UnitColumn(rng.random::<bool>()),
        ClockSkew => {
            s.force_skew_ppm =
                uni(rng, 100.0, 1000.0) * if rng.random::<bool>() { 1.0 } else { -1.0 };
        }
        TransportDelay => s.delay_s = uni(rng, 0.1, 0.5),
        NegativeForce => s.force_negative = true,
        WrongSign => {
            let k = -uni(rng, 0.5, 1.2);
            s.k_ratio = [k, k];
        }
    }
}

/// Scale the presses down so the largest shift stays inside the default window.
fn scale_forces_to_window(s: &mut Scenario) {
    let k = s.k_ratio[0].abs().max(s.k_ratio[1].abs()) * 170.0;
    let most = 1900.0 / k;
    let max_f = max_press_n(&s.presses);
    if max_f > most {
        let f = most / max_f;
        for p in &mut s.presses {
            p.peak_n *= f;
        }
    }
}

/// A temperature swing drawn in `(lo, hi)` K.
fn temperature(rng: &mut ChaCha8Rng, (lo, hi): (f64, f64)) -> Temperature {
    let swing_k = uni(rng, lo, hi);
    let shape = rng.random_range(0..4u8);
    let reference = uni(rng, 9.5, 10.5);
    let emb = uni(rng, 10.0, 25.0);
    Temperature {
        swing_k,
        shape,
        scale_s: match shape {
            2 => uni(rng, 60.0, 600.0),
            3 => uni(rng, 10.0, 120.0),
            _ => 0.0,
        },
        strain_pm_per_k: [emb, emb * uni(rng, 0.95, 1.05)],
        reference_pm_per_k: reference,
    }
}

/// A span that covers only part of the presses: one side cut.
fn cut(rng: &mut ChaCha8Rng, s: &Scenario) -> (f64, f64) {
    let n = s.presses.len();
    let keep = rng.random_range(1..=n.saturating_sub(1).max(1));
    if rng.random::<bool>() {
        // Stops early: after `keep` presses.
        let p = s.presses[keep - 1];
        let end = p.start_s + press_length(&p, s.protocol);
        let next = s.presses.get(keep).map_or(s.duration_s, |q| q.start_s);
        (0.0, end + uni(rng, 0.2, 0.8) * (next - end))
    } else {
        // Starts late: before the last `keep` presses.
        let p = s.presses[n - keep];
        let prev_end = if n - keep == 0 {
            0.0
        } else {
            let q = s.presses[n - keep - 1];
            q.start_s + press_length(&q, s.protocol)
        };
        (
            prev_end + uni(rng, 0.2, 0.8) * (p.start_s - prev_end),
            s.duration_s,
        )
    }
}
