//! Hankel transforms of the layer's kernels: from one wavenumber at a time
//! ([`super::layer`]) to functions of the distance in the sheet's plane.
//!
//! Every response the sheet model needs is axisymmetric about its source or a
//! cos 2θ harmonic of it, so the 2D inverse Fourier transform of a kernel F(|k|)
//! reduces to (1/2π) ∫ F(k) Jₙ(kρ) k dk with n = 0, 1 or 2. The integral is a sum over
//! a fixed set of nodes: geometric panels near k = 0 (where a soft interface makes the
//! kernels peak) and uniform panels beyond, each with 8 Gauss–Legendre points; a panel
//! is narrower than one period of Jₙ(kρ) at the largest distance tabulated, and each
//! kernel's sum stops where it has decayed by e⁻²⁵ (they fall as e^{−k·depth}). The
//! transforms are tabulated on a uniform grid of ρ and read by linear interpolation.

/// Gauss–Legendre nodes and weights on [−1, 1], 8 points.
const GL8: [(f64, f64); 8] = [
    (-0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
    (-0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (-0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (-0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_47),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// Quadrature nodes k (1/mm) and weights for ∫₀^∞ · dk.
#[derive(Debug, Clone)]
pub struct KGrid {
    /// Nodes, 1/mm, increasing.
    pub k: Vec<f64>,
    /// Weights, 1/mm.
    pub w: Vec<f64>,
}

impl KGrid {
    /// Nodes up to `k_max` (1/mm) for transforms read up to `rho_max_mm`, with panels
    /// `panel_fraction` of a Bessel period 2π/ρ_max wide (0.5 is fine; larger is
    /// coarser). Below `k_small` = 0.05/mm the panels are geometric from 10⁻⁵/mm.
    pub fn new(rho_max_mm: f64, k_max: f64, panel_fraction: f64) -> Self {
        let k_small = 0.05_f64;
        let k_max = k_max.max(4.0 * k_small);
        let width =
            (panel_fraction * 2.0 * std::f64::consts::PI / rho_max_mm.max(1.0)).min(k_small);
        let mut edges = vec![0.0];
        let geometric = 24;
        let k0 = 1e-5_f64;
        for i in 0..=geometric {
            edges.push(k0 * (k_small / k0).powf(i as f64 / geometric as f64));
        }
        let n_uniform = ((k_max - k_small) / width).ceil().max(1.0) as usize;
        let step = (k_max - k_small) / n_uniform as f64;
        for i in 1..=n_uniform {
            edges.push(k_small + step * i as f64);
        }
        let mut k = Vec::with_capacity(8 * edges.len());
        let mut w = Vec::with_capacity(8 * edges.len());
        for e in edges.windows(2) {
            let (a, b) = (e[0], e[1]);
            for &(x, wt) in &GL8 {
                k.push(0.5 * (b - a) * x + 0.5 * (a + b));
                w.push(0.5 * (b - a) * wt);
            }
        }
        KGrid { k, w }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.k.len()
    }

    /// Whether there are no nodes.
    pub fn is_empty(&self) -> bool {
        self.k.is_empty()
    }
}

/// A function of ρ tabulated on a uniform grid from 0, read by linear interpolation
/// (held at the last value beyond the table).
#[derive(Debug, Clone)]
pub struct RadialTable {
    /// Grid step, mm.
    pub step_mm: f64,
    /// Values at ρ = i · step.
    pub values: Vec<f64>,
}

impl RadialTable {
    /// Value at `rho_mm` ≥ 0.
    #[inline]
    pub fn at(&self, rho_mm: f64) -> f64 {
        let t = rho_mm / self.step_mm;
        let i = t.floor();
        if i < 0.0 {
            return self.values[0];
        }
        let i = i as usize;
        if i + 1 >= self.values.len() {
            return *self.values.last().unwrap_or(&0.0);
        }
        let f = t - i as f64;
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }
}

/// Which Bessel order a transform uses, and whether its small-k part is measured from
/// its value at ρ = 0 (for a kernel that grows like 1/k² as k → 0: a frictionless
/// table lets the sheet slide as a whole, so only differences of displacement are
/// defined; the fiber forces are self-equilibrated and never see the constant).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// J₀, the full value.
    J0,
    /// J₀ − 1 below k = 0.05/mm.
    J0Relative,
    /// J₁.
    J1,
    /// J₂.
    J2,
}

/// One kernel to transform: its values at the grid's nodes, the Bessel order, and the
/// wavenumber beyond which it is negligible (the sum stops there).
#[derive(Debug, Clone, Copy)]
pub struct Transformable<'a> {
    /// f(k) at the grid's nodes.
    pub values: &'a [f64],
    /// Bessel order (and small-k treatment).
    pub order: Order,
    /// Largest k that contributes, 1/mm.
    pub k_max: f64,
}

/// Tabulate (1/2π) ∫ f(k) Jₙ(kρ) k dk for several kernels at ρ = 0, step, …,
/// `rho_max_mm`.
pub fn transform(
    grid: &KGrid,
    kernels: &[Transformable],
    step_mm: f64,
    rho_max_mm: f64,
) -> Vec<RadialTable> {
    use rayon::prelude::*;
    let n = (rho_max_mm / step_mm).ceil() as usize + 1;
    // Pre-multiply each kernel by k w / 2π once; each stops at its own k_max.
    let scaled: Vec<Vec<f64>> = kernels
        .iter()
        .map(|t| {
            t.values
                .iter()
                .zip(grid.k.iter().zip(&grid.w))
                .take_while(|(_, (k, _))| **k <= t.k_max)
                .map(|(v, (k, w))| v * k * w / (2.0 * std::f64::consts::PI))
                .collect()
        })
        .collect();
    let last = scaled.iter().map(Vec::len).max().unwrap_or(0);
    // Up to which node J₀ (and J₂) are needed, and J₁.
    let need = |f: &dyn Fn(Order) -> bool| {
        kernels
            .iter()
            .zip(&scaled)
            .filter(|(t, _)| f(t.order))
            .map(|(_, s)| s.len())
            .max()
            .unwrap_or(0)
    };
    let n_j02 = need(&|o| !matches!(o, Order::J1));
    let n_j1 = need(&|o| matches!(o, Order::J1 | Order::J2));
    let rows: Vec<Vec<f64>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let rho = i as f64 * step_mm;
            let mut acc = vec![0.0; kernels.len()];
            for (q, &k) in grid.k.iter().enumerate().take(last) {
                let x = k * rho;
                let j0 = if q < n_j02 { libm::j0(x) } else { 0.0 };
                let j1 = if q < n_j1 { libm::j1(x) } else { 0.0 };
                for (a, (t, s)) in acc.iter_mut().zip(kernels.iter().zip(&scaled)) {
                    let Some(&v) = s.get(q) else { continue };
                    let j = match t.order {
                        Order::J0 => j0,
                        Order::J0Relative if k < 0.05 => j0 - 1.0,
                        Order::J0Relative => j0,
                        Order::J1 => j1,
                        Order::J2 if x.abs() < 1e-3 => x * x / 8.0,
                        Order::J2 => 2.0 * j1 / x - j0,
                    };
                    *a += v * j;
                }
            }
            acc
        })
        .collect();
    (0..kernels.len())
        .map(|c| RadialTable {
            step_mm,
            values: rows.iter().map(|r| r[c]).collect(),
        })
        .collect()
}
