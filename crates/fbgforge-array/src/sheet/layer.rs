//! The elastic sheet as a layer on a table, solved exactly for one horizontal
//! wavenumber: the building block of every Fourier–Hankel transform in [`super`].
//!
//! The sheet is an infinite, homogeneous, isotropic, linear elastic layer of thickness h
//! (depth z from the loaded face, z = 0, down to the table, z = h). Under a load
//! varying as e^{i k·x} in the plane, the displacement splits into a P-SV part (along
//! the wave vector and vertical) and an SH part (horizontal, normal to the wave
//! vector). In each sub-layer the P-SV solution of Navier's equations is
//! (A + B ξ) e^{−ξ} along k and (−A − κB − Bξ) e^{−ξ} vertically (ξ = k (z − z₁)),
//! plus the mirror family growing towards the sub-layer's bottom, with
//! κ = 3 − 4ν; the SH solution is a e^{−ξ} + b e^{ξ}. Each family is anchored at the
//! face towards which it grows, so every basis function is bounded by 1 inside its
//! sub-layer and the 8 × 8 (P-SV) and 4 × 4 (SH) systems stay well conditioned for any
//! k h. The layer is split at one depth s (a source plane, or simply the depth where
//! the answer is read) so that a horizontal point force inside the sheet is a jump of
//! the shear traction across s.
//!
//! Conventions (with the factor e^{i k x} along the wave vector left out): the
//! displacement along k is i·U, the vertical one W, the shear traction σ_xz = i·T and
//! the normal traction σ_zz = N, so U, W, T, N are real.
//!
//! The table: no lift-off (w = 0 at z = h everywhere: the sheet is pressed onto it) and
//! a tangential condition: bonded (u = 0), frictionless (σ_xz = 0), or gripping
//! through an interface of tangential stiffness k_t per area (σ_xz = −k_t u, N/mm³),
//! which spans the two.

use nalgebra::{SMatrix, SVector};
use serde::Serialize;

pub use crate::spec::BaseCondition;

/// The elastic layer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Layer {
    /// Thickness h, mm.
    pub thickness_mm: f64,
    /// Shear modulus μ, MPa.
    pub shear_modulus_mpa: f64,
    /// Poisson's ratio ν (below 0.5).
    pub poisson_ratio: f64,
    /// The table under it.
    pub base: BaseCondition,
}

/// What drives the P-SV problem (per unit amplitude, real by the conventions above).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PsvLoad {
    /// Normal pressure p on the loaded face (σ_zz(0) = −p), MPa per unit amplitude.
    SurfacePressure,
    /// A horizontal force per area along the wave vector on the plane z = s
    /// (σ_xz jumps by −f there).
    HorizontalForce,
    /// A vertical force per area, downward, on the plane z = s.
    VerticalForce,
}

/// P-SV coefficients of one wavenumber: evaluate displacements and tractions at any
/// depth with [`PsvField::at`].
#[derive(Debug, Clone, Copy)]
pub struct PsvField {
    k: f64,
    split_mm: f64,
    h: f64,
    mu: f64,
    nu: f64,
    coef: SVector<f64, 8>,
}

/// P-SV state at a depth: U (along k, times i), W (down), T (shear traction, times i),
/// N (normal traction); displacements in mm and tractions in MPa per unit load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PsvState {
    /// Horizontal displacement amplitude U (the displacement is i·U along k), mm.
    pub u: f64,
    /// Vertical displacement W (positive down, into the sheet), mm.
    pub w: f64,
    /// Shear traction amplitude T (σ_xz = i·T), MPa.
    pub t: f64,
    /// Normal traction σ_zz, MPa.
    pub n: f64,
}

/// The P-SV basis rows (U, W, T/μ, N/μ) of sub-layer [z1, z2] at depth z, for the
/// coefficients (A, B) of the family decaying from z1 and (C, D) of the family
/// decaying from z2.
fn psv_rows(k: f64, nu: f64, z1: f64, z2: f64, z: f64) -> [[f64; 4]; 4] {
    let kap = 3.0 - 4.0 * nu;
    let x1 = k * (z - z1);
    let x2 = k * (z - z2);
    let e1 = (-x1).exp();
    let e2 = x2.exp();
    [
        [e1, x1 * e1, e2, x2 * e2],
        [-e1, (-kap - x1) * e1, e2, (-kap + x2) * e2],
        [
            -2.0 * k * e1,
            k * (1.0 - kap - 2.0 * x1) * e1,
            2.0 * k * e2,
            k * (1.0 - kap + 2.0 * x2) * e2,
        ],
        [
            2.0 * k * e1,
            2.0 * k * (2.0 * (1.0 - nu) + x1) * e1,
            2.0 * k * e2,
            2.0 * k * (-2.0 * (1.0 - nu) + x2) * e2,
        ],
    ]
}

impl Layer {
    /// k_t/μ of the base (1/mm), or `None` for bonded.
    fn base_ratio(&self) -> Option<f64> {
        match self.base {
            BaseCondition::Bonded => None,
            BaseCondition::Frictionless => Some(0.0),
            BaseCondition::Gripping {
                tangential_stiffness_n_per_mm3: k,
            } => Some(k / self.shear_modulus_mpa),
        }
    }

    /// Solve the P-SV problem at wavenumber `k` (1/mm, > 0) with the layer split at
    /// `split_mm` (0 < s < h; the source plane of a force, or any depth for a surface
    /// load), for a unit `load`.
    pub fn psv(&self, k: f64, split_mm: f64, load: PsvLoad) -> PsvField {
        let (h, nu) = (self.thickness_mm, self.poisson_ratio);
        let s = split_mm.clamp(1e-9 * h, h * (1.0 - 1e-9));
        let mut m = SMatrix::<f64, 8, 8>::zeros();
        let mut r = SVector::<f64, 8>::zeros();
        // Working in units of μ (tractions divided by μ), answers scaled back below.
        let top = psv_rows(k, nu, 0.0, s, 0.0);
        for c in 0..4 {
            m[(0, c)] = top[2][c];
            m[(1, c)] = top[3][c];
        }
        let a = psv_rows(k, nu, 0.0, s, s);
        let b = psv_rows(k, nu, s, h, s);
        for c in 0..4 {
            m[(2, c)] = a[0][c];
            m[(2, c + 4)] = -b[0][c];
            m[(3, c)] = a[1][c];
            m[(3, c + 4)] = -b[1][c];
            m[(4, c)] = -a[2][c];
            m[(4, c + 4)] = b[2][c];
            m[(5, c)] = -a[3][c];
            m[(5, c + 4)] = b[3][c];
        }
        let bot = psv_rows(k, nu, s, h, h);
        let ratio = self.base_ratio();
        for c in 0..4 {
            m[(6, c + 4)] = bot[1][c];
            m[(7, c + 4)] = match ratio {
                None => bot[0][c],
                Some(q) => bot[2][c] + q * bot[0][c],
            };
        }
        // Loads, in units of μ: a unit pressure, σ_zz(0) = −1; a unit horizontal force
        // f along k on the plane s makes σ_xz jump by −f, i.e. i·ΔT = −f, ΔT = i f: the
        // real problem is solved with ΔT = 1 and its displacement along k (i·U) becomes
        // i·(i f U) = −f U, hence the sign flip in `horizontal_force_along`.
        match load {
            PsvLoad::SurfacePressure => r[1] = -1.0,
            PsvLoad::HorizontalForce => r[4] = 1.0,
            PsvLoad::VerticalForce => r[5] = -1.0,
        }
        let coef = m.lu().solve(&r).unwrap_or_else(SVector::zeros);
        PsvField {
            k,
            split_mm: s,
            h,
            mu: self.shear_modulus_mpa,
            nu,
            coef,
        }
    }

    /// SH displacement at `obs_mm` for a unit horizontal force per area normal to the
    /// wave vector on the plane `source_mm`, mm/MPa.
    pub fn sh_displacement(&self, k: f64, source_mm: f64, obs_mm: f64) -> f64 {
        let h = self.thickness_mm;
        let s = source_mm.clamp(1e-9 * h, h * (1.0 - 1e-9));
        // Rows (V, τ/μ) of sub-layer [z1, z2] at z for coefficients (a, b).
        let rows = |z1: f64, z2: f64, z: f64| {
            let e1 = (-k * (z - z1)).exp();
            let e2 = (k * (z - z2)).exp();
            ([e1, e2], [-k * e1, k * e2])
        };
        let mut m = SMatrix::<f64, 4, 4>::zeros();
        let mut r = SVector::<f64, 4>::zeros();
        let (_, t0) = rows(0.0, s, 0.0);
        m[(0, 0)] = t0[0];
        m[(0, 1)] = t0[1];
        let (va, ta) = rows(0.0, s, s);
        let (vb, tb) = rows(s, h, s);
        for c in 0..2 {
            m[(1, c)] = va[c];
            m[(1, c + 2)] = -vb[c];
            m[(2, c)] = -ta[c];
            m[(2, c + 2)] = tb[c];
        }
        r[2] = -1.0;
        let (vh, th) = rows(s, h, h);
        for c in 0..2 {
            m[(3, c + 2)] = match self.base_ratio() {
                None => vh[c],
                Some(q) => th[c] + q * vh[c],
            };
        }
        let x = m.lu().solve(&r).unwrap_or_else(SVector::zeros);
        let (v, _) = if obs_mm <= s {
            rows(0.0, s, obs_mm)
        } else {
            rows(s, h, obs_mm)
        };
        let off = if obs_mm <= s { 0 } else { 2 };
        (v[0] * x[off] + v[1] * x[off + 1]) / self.shear_modulus_mpa
    }

    /// Displacement along the wave vector at `obs_mm` per unit horizontal force per
    /// area along it on the plane `source_mm`, mm/MPa (the kernel A(k)).
    pub fn horizontal_force_along(&self, k: f64, source_mm: f64, obs_mm: f64) -> f64 {
        -self
            .psv(k, source_mm, PsvLoad::HorizontalForce)
            .at(obs_mm)
            .u
    }
}

impl PsvField {
    /// State at depth `z_mm` (0 ≤ z ≤ h): displacements in mm and tractions in MPa per
    /// unit load (the load's own units: MPa for a pressure, N/mm² for a force per area).
    pub fn at(&self, z_mm: f64) -> PsvState {
        let (z1, z2, off) = if z_mm <= self.split_mm {
            (0.0, self.split_mm, 0)
        } else {
            (self.split_mm, self.h, 4)
        };
        let rows = psv_rows(self.k, self.nu, z1, z2, z_mm);
        let dot = |row: &[f64; 4]| (0..4).map(|c| row[c] * self.coef[off + c]).sum::<f64>();
        PsvState {
            u: dot(&rows[0]) / self.mu,
            w: dot(&rows[1]) / self.mu,
            t: dot(&rows[2]),
            n: dot(&rows[3]),
        }
    }
}

/// The kernels of one wavenumber that the sheet model transforms: for a unit pressure
/// on the loaded face, the horizontal amplitude U at the fiber depth (`pressure_u`) and
/// the face's settlement W(0) (`pressure_w`); for a unit horizontal force per area on
/// the fiber plane, the displacement along the wave vector (`along`, A) and normal to
/// it (`normal`, B) on that plane. mm/MPa.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kernels {
    /// U(z_f) for a unit surface pressure.
    pub pressure_u: f64,
    /// W(0) for a unit surface pressure.
    pub pressure_w: f64,
    /// A(k): along-k displacement per along-k force, both on the fiber plane.
    pub along: f64,
    /// B(k): normal displacement per normal force, both on the fiber plane.
    pub normal: f64,
}

impl Layer {
    /// All four kernels at wavenumber `k` with the fiber plane at `fiber_depth_mm`
    /// (one 8 × 8 factorisation serves both P-SV loads).
    pub fn kernels(&self, k: f64, fiber_depth_mm: f64) -> Kernels {
        let p = self.psv(k, fiber_depth_mm, PsvLoad::SurfacePressure);
        Kernels {
            pressure_u: p.at(fiber_depth_mm).u,
            pressure_w: p.at(0.0).w,
            along: self.horizontal_force_along(k, fiber_depth_mm, fiber_depth_mm),
            normal: self.sh_displacement(k, fiber_depth_mm, fiber_depth_mm),
        }
    }

    /// Kelvin's infinite-space kernels on the source plane (the k → ∞ limit of
    /// [`Self::kernels`]): A = (3 − 4ν)/(8μ(1 − ν)k), B = 1/(2μk).
    pub fn kelvin_along_normal(&self, k: f64) -> (f64, f64) {
        let (mu, nu) = (self.shear_modulus_mpa, self.poisson_ratio);
        (
            (3.0 - 4.0 * nu) / (8.0 * mu * (1.0 - nu) * k),
            1.0 / (2.0 * mu * k),
        )
    }
}
