//! The flag study's own generator: arrays, streams and the faults injected into
//! them. Wider than the cases the flags were designed on: three layouts (the paper's
//! 6 × 8, a 10 × 20 hexagonal sheet no method was tuned on, a 16 × 64 grid), per
//! stream a noise level drawn from 0.25–1 pm, 0–4 loads per frame of 30–240 g
//! anywhere, the paper's ± 4 % additivity, and one fault per scenario.

use fbgforge::array::kernel::{
    fiber_grid_layout, matrix_from_positions, paper_layout, DistanceKernel,
};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Largest load per cell, g.
pub const ULIMIT_G: f64 = 250.0;
/// The loads drawn, g (uniform).
pub const MASS_RANGE_G: (f64, f64) = (30.0, 240.0);
/// The paper's additivity error (uniform, per grating) on multi-load frames.
pub const BASE_ADDITIVITY: f64 = 0.04;

/// One array of the study.
pub struct ArrayDef {
    /// Name in the tables.
    pub name: &'static str,
    /// Cell centres, mm.
    pub cells: Vec<(f64, f64)>,
    /// Grating positions, mm.
    pub gratings: Vec<(f64, f64)>,
    /// The kernel that makes the true matrix.
    pub kernel: DistanceKernel,
    /// Whether the enumerations (`support`, `wsupport`) are run on it.
    pub enumerations: bool,
}

/// A 10 × 20 hexagonal sheet: 20 cells on a hexagonal lattice (4 rows of 5, pitch
/// 20 mm, odd rows shifted half a pitch), two fibers along x at y = ±13 mm, five
/// gratings each, staggered by a quarter pitch.
/// Points in the sheet's plane, mm.
pub type Points = Vec<(f64, f64)>;

/// (cells, gratings) of a layout.
pub fn hex_layout() -> (Points, Points) {
    let pitch = 20.0;
    let dy = pitch * 3f64.sqrt() / 2.0;
    let mut cells = Vec::new();
    for r in 0..4 {
        let y = (r as f64 - 1.5) * dy;
        let shift = if r % 2 == 1 { 0.5 * pitch } else { 0.0 };
        for c in 0..5 {
            cells.push(((c as f64 - 2.25) * pitch + shift, y));
        }
    }
    let mut gratings = Vec::new();
    for (f, y) in [(0, -13.0), (1, 13.0)] {
        for g in 0..5 {
            let x = (g as f64 - 2.0) * pitch + if f == 0 { -0.25 } else { 0.25 } * pitch;
            gratings.push((x, y));
        }
    }
    (cells, gratings)
}

/// The study's arrays; `quick` keeps the two small ones.
pub fn arrays(quick: bool) -> Vec<ArrayDef> {
    let (c, g) = paper_layout();
    let (ch, gh) = hex_layout();
    let mut v = vec![
        ArrayDef {
            name: "6x8 paper",
            cells: c,
            gratings: g,
            kernel: DistanceKernel::paper(),
            enumerations: true,
        },
        ArrayDef {
            name: "10x20 hex",
            cells: ch,
            gratings: gh,
            kernel: DistanceKernel::table1_power_law(3.0),
            enumerations: true,
        },
    ];
    if !quick {
        let (c3, g3) = fiber_grid_layout(8, 8, 4, 4);
        v.push(ArrayDef {
            name: "16x64 grid",
            cells: c3,
            gratings: g3,
            kernel: DistanceKernel::table1_power_law(3.0),
            enumerations: false,
        });
    }
    v
}

/// One fault scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Nothing wrong.
    Clean,
    /// The matrix seen off by 2 % per entry (stated), loads ± 0.1 mm off.
    Calibration,
    /// ± 30 % additivity error instead of ± 4 %.
    Additivity,
    /// A common offset of 1–3 pm per frame (either sign).
    Offset,
    /// A common offset drifting from 0 to ± 5 pm over the stream (temperature).
    TemperatureDrift,
    /// One grating reads noise only.
    Dead,
    /// One grating reads a constant 5–20 pm.
    Stuck,
    /// One grating drifts from 0 to ± 8 pm over the stream.
    Drift,
    /// Two neighbouring gratings' channels exchanged.
    Swapped,
    /// One grating clipped at 60 % of its largest reading.
    Saturated,
    /// One grating six times noisier than stated.
    Noisy,
    /// A quarter of the frames carry one load of 300–500 g (array rated 250 g).
    Overload,
    /// 3 % of the frames hold an absurd shift (1e155, −1e200 or 5e4 pm).
    Absurd,
    /// Calibration, additivity, offset and a dead grating together.
    All,
}

impl Fault {
    /// Every scenario, in table order.
    pub const ALL: [Fault; 14] = [
        Fault::Clean,
        Fault::Calibration,
        Fault::Additivity,
        Fault::Offset,
        Fault::TemperatureDrift,
        Fault::Dead,
        Fault::Stuck,
        Fault::Drift,
        Fault::Swapped,
        Fault::Saturated,
        Fault::Noisy,
        Fault::Overload,
        Fault::Absurd,
        Fault::All,
    ];

    /// Name in the tables.
    pub fn name(self) -> &'static str {
        match self {
            Fault::Clean => "clean",
            Fault::Calibration => "calibration",
            Fault::Additivity => "additivity",
            Fault::Offset => "offset",
            Fault::TemperatureDrift => "temperature drift",
            Fault::Dead => "dead",
            Fault::Stuck => "stuck",
            Fault::Drift => "drift",
            Fault::Swapped => "swapped",
            Fault::Saturated => "saturated",
            Fault::Noisy => "noisy",
            Fault::Overload => "overload",
            Fault::Absurd => "absurd",
            Fault::All => "all",
        }
    }

    fn calibration(self) -> bool {
        matches!(self, Fault::Calibration | Fault::All)
    }
}

/// What a stream's diagnosis should find.
#[derive(Debug, Clone, PartialEq)]
pub enum Expect {
    /// No suspect grating, no common offset.
    Nothing,
    /// This grating named for this reason (`dead or stuck`, `drifting`, …).
    Grating(usize, &'static str),
    /// These two named as swapped.
    Pair(usize, usize),
    /// The common offset turned on.
    CommonMode,
}

/// One stream: the matrix the methods see, the truth, the shifts.
pub struct Stream {
    /// The matrix as the methods see it (calibrated), pm/g.
    pub matrix: DMatrix<f64>,
    /// Per-entry sd stated with it (None: the default, one 200 g reading).
    pub matrix_sd_pct: Option<f64>,
    /// The interrogator resolution of this stream, pm (stated and true).
    pub resolution_pm: f64,
    /// True loads per frame, g.
    pub truth_g: Vec<Vec<f64>>,
    /// Shifts per frame, pm.
    pub shifts_pm: Vec<Vec<f64>>,
    /// What the diagnosis should find (beside the stream's own faults).
    pub expect: Vec<Expect>,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

fn sign(rng: &mut ChaCha8Rng) -> f64 {
    if rng.random_bool(0.5) {
        1.0
    } else {
        -1.0
    }
}

/// Loads of one frame: 0 loads on 10 % of the frames, else 1–4 distinct cells of
/// 30–240 g.
fn frame_loads(n: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let mut x = vec![0.0; n];
    if rng.random_bool(0.1) {
        return x;
    }
    let k = rng.random_range(1..=4usize).min(n);
    let mut cells: Vec<usize> = (0..n).collect();
    for i in 0..k {
        let j = rng.random_range(i..n);
        cells.swap(i, j);
        x[cells[i]] = rng.random_range(MASS_RANGE_G.0..MASS_RANGE_G.1);
    }
    x
}

/// Generate one stream of `frames` frames of array `arr` under `fault` from `seed`.
pub fn stream(arr: &ArrayDef, fault: Fault, frames: usize, seed: u64) -> Stream {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a_true = matrix_from_positions(&arr.cells, &arr.gratings, &arr.kernel);
    let (m, n) = a_true.shape();
    let sigma = [0.25, 0.5, 1.0][rng.random_range(0..3usize)];
    let matrix = if fault.calibration() {
        a_true.map(|v| v * (1.0 + 0.02 * normal(&mut rng)))
    } else {
        a_true.clone()
    };
    let g = rng.random_range(0..m);
    // A neighbour on the same fiber (gratings are listed fiber by fiber).
    let g2 = if g + 1 < m { g + 1 } else { g - 1 };
    let drift_sign = sign(&mut rng);
    let stuck_at = rng.random_range(5.0..20.0);
    let temp_sign = sign(&mut rng);
    let mut truth = Vec::with_capacity(frames);
    let mut shifts = Vec::with_capacity(frames);
    for f in 0..frames {
        let mut x = frame_loads(n, &mut rng);
        if fault == Fault::Overload && rng.random_bool(0.25) {
            let j = rng.random_range(0..n);
            x[j] = rng.random_range(300.0..500.0);
        }
        let k = x.iter().filter(|&&v| v > 0.0).count();
        let additivity = if matches!(fault, Fault::Additivity | Fault::All) {
            0.30
        } else {
            BASE_ADDITIVITY
        };
        let offset = match fault {
            Fault::Offset | Fault::All => sign(&mut rng) * rng.random_range(1.0..3.0),
            Fault::TemperatureDrift => temp_sign * 5.0 * f as f64 / (frames.max(2) - 1) as f64,
            _ => 0.0,
        };
        // The columns the loads act through (placed off their point when calibrated).
        let cols: Vec<(usize, Vec<f64>)> = (0..n)
            .filter(|&j| x[j] > 0.0)
            .map(|j| {
                if fault.calibration() {
                    let mut at = arr.cells[j];
                    at.0 += 0.1 * rng.random_range(-1.0..=1.0);
                    at.1 += 0.1 * rng.random_range(-1.0..=1.0);
                    let c = matrix_from_positions(&[at], &arr.gratings, &arr.kernel);
                    (j, c.iter().copied().collect())
                } else {
                    (j, a_true.column(j).iter().copied().collect())
                }
            })
            .collect();
        let mut y: Vec<f64> = (0..m)
            .map(|i| {
                let mut r: f64 = cols.iter().map(|(j, c)| c[i] * x[*j]).sum();
                if k >= 2 {
                    r *= 1.0 + additivity * rng.random_range(-1.0..=1.0);
                }
                let noise = if fault == Fault::Noisy && i == g {
                    6.0
                } else {
                    1.0
                };
                r + offset + noise * sigma * normal(&mut rng)
            })
            .collect();
        match fault {
            Fault::Dead | Fault::All => y[g] = sigma * normal(&mut rng),
            Fault::Stuck => y[g] = stuck_at,
            Fault::Drift => y[g] += drift_sign * 8.0 * f as f64 / (frames.max(2) - 1) as f64,
            Fault::Swapped => y.swap(g, g2),
            Fault::Absurd if rng.random_bool(0.03) => {
                y[rng.random_range(0..m)] = [1e155, -1e200, 5e4][rng.random_range(0..3usize)];
            }
            _ => {}
        }
        truth.push(x);
        shifts.push(y);
    }
    if fault == Fault::Saturated {
        let top = shifts.iter().map(|y| y[g]).fold(f64::MIN, f64::max);
        let clip = 0.6 * top;
        for y in &mut shifts {
            y[g] = y[g].min(clip);
        }
    }
    let expect = match fault {
        Fault::Dead | Fault::Stuck => vec![Expect::Grating(g, "dead or stuck")],
        Fault::All => vec![Expect::Grating(g, "dead or stuck"), Expect::CommonMode],
        Fault::Drift => vec![Expect::Grating(g, "drifting")],
        Fault::Swapped => vec![Expect::Pair(g.min(g2), g.max(g2))],
        Fault::Saturated => vec![Expect::Grating(g, "saturated")],
        Fault::Noisy => vec![Expect::Grating(g, "noisy")],
        Fault::Offset | Fault::TemperatureDrift => vec![Expect::CommonMode],
        _ => vec![Expect::Nothing],
    };
    Stream {
        matrix,
        matrix_sd_pct: fault.calibration().then_some(2.0),
        resolution_pm: sigma,
        truth_g: truth,
        shifts_pm: shifts,
        expect,
    }
}
