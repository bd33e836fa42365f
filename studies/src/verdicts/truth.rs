//! What a scenario's verdict should be, from its truth: the verdicts that are right
//! (the published rule — tolerance, then the band between the bounding contact
//! readings — applied to the true K, both neighbours allowed within 2.5 % of a
//! boundary; FAIL for a dead grating, a wrong sign or a loose bond well past the
//! hysteresis limit), whether the data decide it (a definite-truth scenario, the ones
//! the ≥ 90 % rate counts), and the faults present, which a refusal may name truthfully.
//!
//! A refusal that names a fault of fact — the instrument, the clock, an untrusted force,
//! no response at all — is wrong when that fault is absent ("refused for a false
//! reason"); one that names an uncertainty — a rival alignment, temperature, the
//! force's unit, the bond — is cautious: never wrong, but it costs the definite rate.

use super::space::{press_length, Class, Protocol, Scenario};
use serde::Serialize;

/// A verdict as the study counts it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Given {
    /// PASS.
    Pass,
    /// FAIL.
    Fail,
    /// IN BAND.
    InBand,
    /// CALIBRATE CONTACT.
    CalibrateContact,
    /// NOT JUDGED.
    NotJudged,
    /// NO RESPONSE.
    NoResponse,
    /// An error (nothing judged).
    Error,
}

impl Given {
    /// The word in the tables.
    pub fn word(self) -> &'static str {
        match self {
            Given::Pass => "PASS",
            Given::Fail => "FAIL",
            Given::InBand => "IN BAND",
            Given::CalibrateContact => "CALIBRATE CONTACT",
            Given::NotJudged => "NOT JUDGED",
            Given::NoResponse => "NO RESPONSE",
            Given::Error => "error",
        }
    }

    /// A definitive verdict (a claim about the part).
    pub fn definite(self) -> bool {
        matches!(self, Given::Pass | Given::Fail | Given::InBand)
    }
}

/// A fault whose presence a refusal may state as a fact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fault {
    /// The interrogator: saturation, frozen peaks, peaks lost under load.
    Instrument,
    /// The clocks: a jump, pauses in whole-second timestamps.
    Clock,
    /// The force log: a saturated channel, gaps.
    Force,
    /// No grating responds to this force (unloaded, another run's force, no press in
    /// the overlap).
    NoResponse,
}

/// What the verdict should be.
#[derive(Debug, Clone, Serialize)]
pub struct Expectation {
    /// The definite verdicts that are right.
    pub right: Vec<Given>,
    /// The data decide it: a careful analysis gives one of `right`.
    pub definite: bool,
    /// Faults present.
    pub faults: Vec<Fault>,
    /// The expected verdict in one word for the confusion table: `PASS`, `FAIL`,
    /// `IN BAND`, `PASS or FAIL` (a boundary), `refuse`.
    pub label: String,
}

/// The model's K and band of the two strain gratings, pm/N.
#[derive(Debug, Clone, Copy)]
pub struct ModelK {
    /// K of each.
    pub k: [f64; 2],
    /// Band of each, (low, high).
    pub band: [[f64; 2]; 2],
    /// Tolerance on the relative error.
    pub tolerance: f64,
    /// The verifier's hysteresis limit for this core's material, % of span.
    pub hysteresis_limit_percent: f64,
}

/// Half-width of the zone around a boundary (tolerance, band edge) where either side
/// is right: the measurement's own error at low rates and few presses.
const BOUNDARY: f64 = 0.025;

/// The statuses the rule gives a true ratio `r` of K to the model's for grating `g`.
fn rule(m: &ModelK, g: usize, r: f64) -> Vec<Given> {
    let k = m.k[g] * r;
    let [a, b] = m.band[g];
    let (lo, hi) = (a.min(b), a.max(b));
    let status = |k: f64| {
        let e = (k - m.k[g]).abs() / m.k[g].abs();
        if e <= m.tolerance {
            Given::Pass
        } else if k >= lo && k <= hi {
            Given::InBand
        } else {
            Given::Fail
        }
    };
    let mut out = vec![status(k)];
    for d in [-BOUNDARY, BOUNDARY] {
        let s = status(k + d * m.k[g].abs());
        if !out.contains(&s) {
            out.push(s);
        }
    }
    out
}

/// The module's statuses from each grating's possible ones (FAIL over IN BAND over
/// PASS, as the verifier combines them).
fn combine(per: &[Vec<Given>]) -> Vec<Given> {
    let mut out = Vec::new();
    let (a, b) = (&per[0], &per[1]);
    for x in a {
        for y in b {
            let m = if *x == Given::Fail || *y == Given::Fail {
                Given::Fail
            } else if *x == Given::InBand || *y == Given::InBand {
                Given::InBand
            } else {
                Given::Pass
            };
            if !out.contains(&m) {
                out.push(m);
            }
        }
    }
    out
}

/// The presses both logs cover whole, with their peaks.
pub fn covered_presses(s: &Scenario) -> Vec<f64> {
    let (a, b) = (
        s.wl_span.0.max(s.force_span.0),
        s.wl_span.1.min(s.force_span.1),
    );
    s.presses
        .iter()
        .filter(|p| p.start_s >= a && p.start_s + press_length(p, s.protocol) <= b)
        .map(|p| p.peak_n)
        .collect()
}

/// The longest press, s.
fn longest_press(s: &Scenario) -> f64 {
    s.presses
        .iter()
        .map(|p| press_length(p, s.protocol))
        .fold(0.0, f64::max)
}

/// Whether the temperature changes slowly against the presses (five times the
/// longest press at least): a careful analysis tells it apart from the force.
fn temperature_is_slow(s: &Scenario) -> bool {
    let Some(t) = &s.temperature else {
        return true;
    };
    let scale = match t.shape {
        0 | 1 => s.duration_s / 2.0,
        2 => t.scale_s / (2.0 * std::f64::consts::PI),
        _ => t.scale_s,
    };
    scale >= 5.0 * longest_press(s)
}

/// What `s`'s verdict should be, with the offset given (`given`) or estimated.
pub fn expect(s: &Scenario, m: &ModelK, given: bool) -> Expectation {
    let mut e = Expectation {
        right: Vec::new(),
        definite: true,
        faults: Vec::new(),
        label: String::new(),
    };
    let classes: Vec<Class> = std::iter::once(s.class).chain(s.second).collect();
    let mut per: Vec<Vec<Given>> = (0..2).map(|g| rule(m, g, s.k_ratio[g])).collect();
    let dead = |r: f64| r.abs() < 0.01;
    let alive = s.k_ratio.iter().filter(|r| !dead(**r)).count();
    for (g, r) in s.k_ratio.iter().enumerate() {
        if dead(*r) {
            per[g] = vec![Given::Fail];
        }
    }
    let mut right = combine(&per);
    let covered = covered_presses(s);
    let h = 100.0 * s.hysteresis;
    let limit = m.hysteresis_limit_percent;
    for c in &classes {
        match c {
            Class::LooseBond | Class::SlightHysteresis => {
                if h >= 1.5 * limit {
                    right = vec![Given::Fail];
                } else if h > 0.5 * limit {
                    right.push(Given::Fail);
                    e.definite = false;
                }
            }
            Class::BondCreep => {
                let loss = s.creep.map_or(0.0, |c| c.0);
                let low: Vec<Vec<Given>> = (0..2)
                    .map(|g| rule(m, g, s.k_ratio[g] * (1.0 - loss)))
                    .collect();
                right.extend(combine(&low));
                right.push(Given::Fail);
                e.definite = false;
            }
            Class::TwoTimeConstants => {
                let slow: f64 = s.relax.iter().skip(1).map(|r| r.0).sum();
                let low: Vec<Vec<Given>> = (0..2)
                    .map(|g| rule(m, g, s.k_ratio[g] * (1.0 - slow)))
                    .collect();
                right.extend(combine(&low));
                e.definite = false;
            }
            Class::Unloaded | Class::UnloadedWithTemperature | Class::OtherRunForce => {
                right.clear();
                e.faults.push(Fault::NoResponse);
                e.definite = false;
            }
            Class::TemperatureWithReference | Class::TemperatureWithoutReference
                if !temperature_is_slow(s) =>
            {
                e.definite = false;
            }
            Class::WavelengthSaturation | Class::StuckPeaks | Class::DropoutsUnderLoad => {
                e.faults.push(Fault::Instrument);
                e.definite = false;
            }
            Class::ForceSaturation | Class::ForceGaps => {
                e.faults.push(Fault::Force);
                let ceiling = s.force_ceiling_n.unwrap_or(f64::INFINITY);
                let clean = covered.iter().filter(|p| **p < 0.95 * ceiling).count();
                if clean < 3 || *c == Class::ForceGaps && covered.len() < 5 {
                    e.definite = false;
                }
            }
            Class::ClockJump => {
                e.faults.push(Fault::Clock);
                e.definite = false;
            }
            Class::WholeSecondPauses => e.faults.push(Fault::Clock),
            Class::UnitsUnnamed => e.definite = false,
            Class::WavelengthCut | Class::ForceCut if covered.is_empty() => {
                e.faults.push(Fault::NoResponse);
            }
            _ => {}
        }
    }
    // Enough presses, both logs: fewer than three covered leave an estimated offset
    // unpinned, and none leaves nothing to judge.
    let varied = covered.iter().fold(0.0f64, |a, &p| a.max(p))
        > 1.15 * covered.iter().fold(f64::INFINITY, |a, &p| a.min(p));
    if covered.is_empty() || (!given && (covered.len() < 3 || !varied && covered.len() < 5)) {
        e.definite = false;
    }
    if alive == 0 {
        right.clear();
        e.faults.push(Fault::NoResponse);
        e.definite = false;
    }
    if s.protocol == Protocol::PreloadedSine && s.wl_rate_hz < 2.0 {
        e.definite = false;
    }
    right.sort();
    right.dedup();
    e.label = match right.as_slice() {
        [] => "refuse".into(),
        [one] => one.word().into(),
        many => many
            .iter()
            .map(|g| g.word())
            .collect::<Vec<_>>()
            .join(" or "),
    };
    e.right = right;
    e
}
