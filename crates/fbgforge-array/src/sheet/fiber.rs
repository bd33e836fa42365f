//! The fibers: stiff bars embedded in the sheet, pulled along their axes by the
//! silicone through their surface, free at both ends.
//!
//! Each fiber runs straight along y across the whole sheet at depth z_f and is cut
//! into segments carrying a uniform axial force density. Its axial displacement is
//! v(y) = c + (1/EA) ∫ N, with N the axial force (tension positive) of the
//! self-equilibrated forces the silicone puts on it (free ends: N = 0 at both ends, so
//! the forces on one fiber sum to zero). The silicone, in turn, feels the opposite
//! forces; its displacement along y at a fiber node is the displacement it would have
//! without the fibers (`u0`, from the surface load) plus the response to those line
//! forces: Kelvin's point-force solution integrated over each segment in closed form
//! (the singular part, evaluated on the fiber's surface, radius a, for a segment's
//! own fiber) plus the smooth correction of the layer's two faces
//! ([`super::SheetTables`]). Requiring the fiber and the silicone to move together at
//! every node (collocation) gives
//!
//! ```text
//!   (G + C) F + c = u0,   Σ_segments of a fiber F = 0,
//! ```
//!
//! with G the silicone's compliance, C the fibers' (symmetric:
//! C_kl = (L − 2|y_k − y_l|)/(4EA) − δ_kl Δ/(6EA) for uniform forces over segments of
//! length Δ), F the segment forces on the fibers and c each fiber's rigid
//! displacement. The local shear-lag model (Cox) is the special case in which G is
//! diagonal, g = ln(R/a)/(2πμ) per unit length; [`FiberSystem::with_compliance`] takes
//! any G, which is how the tests check this solver against Cox's closed form. A grating
//! reads the fiber's axial strain N/EA averaged over its length.

use super::hankel::RadialTable;
use anyhow::{ensure, Result};
use nalgebra::{DMatrix, DVector};

/// The fiber as a bar: its axial stiffness and the radius through which the silicone
/// grips it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FiberBar {
    /// E·A of the glass, N (72 GPa × π (62.5 µm)² ≈ 884 N for standard fiber).
    pub axial_stiffness_n: f64,
    /// Radius of the surface the silicone grips (the coating's outer radius), mm.
    pub coupling_radius_mm: f64,
}

/// Young's modulus of fused silica, MPa (reference §6).
pub(crate) const SILICA_MODULUS_MPA: f64 = 72_000.0;
/// Cladding diameter of standard single-mode fiber, mm.
pub(crate) const CLADDING_DIAMETER_MM: f64 = 0.125;

impl FiberBar {
    /// Standard single-mode fiber whose coating has diameter `coated_diameter_mm`.
    pub fn standard(coated_diameter_mm: f64) -> Self {
        let r = CLADDING_DIAMETER_MM / 2.0;
        FiberBar {
            axial_stiffness_n: SILICA_MODULUS_MPA * std::f64::consts::PI * r * r,
            coupling_radius_mm: coated_diameter_mm / 2.0,
        }
    }
}

/// Where the fibers lie: x of each (they run along y), the span they cover in y, and
/// the segment count per fiber.
#[derive(Debug, Clone, PartialEq)]
pub struct FiberLines {
    /// x of each fiber, mm.
    pub x_mm: Vec<f64>,
    /// First and last y of every fiber inside the sheet (its free ends), mm.
    pub span_mm: (f64, f64),
    /// Segments per fiber.
    pub segments: usize,
}

impl FiberLines {
    /// Segment length Δ, mm.
    pub fn segment_mm(&self) -> f64 {
        (self.span_mm.1 - self.span_mm.0) / self.segments as f64
    }

    /// Centre of segment `l`, mm.
    pub fn node_y(&self, l: usize) -> f64 {
        self.span_mm.0 + (l as f64 + 0.5) * self.segment_mm()
    }

    /// Number of unknown segment forces.
    pub(crate) fn n_nodes(&self) -> usize {
        self.x_mm.len() * self.segments
    }
}

/// The silicone's compliance to the fibers' line forces: Kelvin in closed form plus the
/// layer's correction tables (cos 2θ harmonic), and the elastic constants.
pub struct SiliconeCompliance<'a> {
    /// Shear modulus, MPa.
    pub shear_modulus_mpa: f64,
    /// Poisson's ratio.
    pub poisson_ratio: f64,
    /// Correction, axisymmetric part, mm/N.
    pub correction_0: &'a RadialTable,
    /// Correction, cos 2θ part (θ from the x axis), mm/N.
    pub correction_2: &'a RadialTable,
}

/// ∫ Kelvin's u_y for a unit y-force over u ∈ [u1, u2] along the force's line at
/// perpendicular offset r (a line density of 1 N/mm): the closed form of
/// ∫ [(3 − 4ν)/ρ + u²/ρ³] du/(16πμ(1 − ν)), mm/N·mm.
fn kelvin_segment(mu: f64, nu: f64, r: f64, u1: f64, u2: f64) -> f64 {
    let f = |u: f64| (4.0 - 4.0 * nu) * (u / r).asinh() - u / (u * u + r * r).sqrt();
    (f(u2) - f(u1)) / (16.0 * std::f64::consts::PI * mu * (1.0 - nu))
}

/// 4-point Gauss–Legendre on [−1, 1].
const GL4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_85),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_2),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_2),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_85),
];

impl SiliconeCompliance<'_> {
    /// The compliance matrix G (mm/N): displacement along y at each node per unit
    /// force along y spread uniformly over each segment, with the fibers' coupling
    /// radius `a_mm` regularising a segment's own fiber.
    pub fn matrix(&self, lines: &FiberLines, a_mm: f64) -> DMatrix<f64> {
        let n = lines.segments;
        let nf = lines.x_mm.len();
        let dy = lines.segment_mm();
        let (mu, nu) = (self.shear_modulus_mpa, self.poisson_ratio);
        let mut g = DMatrix::zeros(nf * n, nf * n);
        // The matrix depends on (i, j) only through |x_i − x_j|; fill per pair.
        for i in 0..nf {
            for j in 0..nf {
                let dx = (lines.x_mm[i] - lines.x_mm[j]).abs();
                let r = if i == j { a_mm } else { dx };
                // Entries depend on k − l only: compute one row of offsets.
                let offsets: Vec<f64> = (0..2 * n - 1)
                    .map(|d| {
                        let off = (d as f64 - (n as f64 - 1.0)) * dy; // y_k − y_l
                        let kel = kelvin_segment(mu, nu, r, off - 0.5 * dy, off + 0.5 * dy) / dy;
                        let corr: f64 = GL4
                            .iter()
                            .map(|&(x, w)| {
                                let yy = off - 0.5 * x * dy;
                                let rho = dx.hypot(yy);
                                let c2 = if rho > 1e-12 {
                                    (dx * dx - yy * yy) / (rho * rho)
                                } else {
                                    -1.0
                                };
                                0.5 * w
                                    * (self.correction_0.at(rho) + c2 * self.correction_2.at(rho))
                            })
                            .sum();
                        kel + corr
                    })
                    .collect();
                for k in 0..n {
                    for l in 0..n {
                        g[(i * n + k, j * n + l)] = offsets[k + n - 1 - l];
                    }
                }
            }
        }
        g
    }
}

/// The factorised fiber–silicone system of one sheet and fiber layout.
pub struct FiberSystem {
    lines: FiberLines,
    bar: FiberBar,
    lu: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
    lu_t: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
}

/// Axial-force influence of a uniform unit force on a segment centred `t` mm away
/// (t = s − y_l), integrated from 0: P(t) with ∫_{t1}^{t2} clamp(−t/Δ, −½, ½) dt =
/// P(t2) − P(t1).
fn ramp_integral(t: f64, dy: f64) -> f64 {
    if t.abs() <= 0.5 * dy {
        -t * t / (2.0 * dy)
    } else {
        -dy / 8.0 - 0.5 * (t.abs() - 0.5 * dy)
    }
}

impl FiberSystem {
    /// Assemble and factorise with the silicone compliance `g` (mm/N, one row and
    /// column per node).
    pub fn with_compliance(lines: FiberLines, bar: FiberBar, g: DMatrix<f64>) -> Result<Self> {
        let nn = lines.n_nodes();
        let nf = lines.x_mm.len();
        ensure!(
            g.nrows() == nn && g.ncols() == nn,
            "compliance matrix is {}×{}, expected {nn}×{nn}",
            g.nrows(),
            g.ncols()
        );
        ensure!(
            lines.segments >= 2 && nf >= 1,
            "a fiber needs at least two segments"
        );
        let n = lines.segments;
        let dy = lines.segment_mm();
        let len = lines.span_mm.1 - lines.span_mm.0;
        let ea = bar.axial_stiffness_n;
        let mut k = DMatrix::zeros(nn + nf, nn + nf);
        k.view_mut((0, 0), (nn, nn)).copy_from(&g);
        for f in 0..nf {
            for a in 0..n {
                for b in 0..n {
                    let d = (a as f64 - b as f64).abs() * dy;
                    let mut c = (len - 2.0 * d) / (4.0 * ea);
                    if a == b {
                        c -= dy / (6.0 * ea);
                    }
                    k[(f * n + a, f * n + b)] += c;
                }
                k[(f * n + a, nn + f)] = 1.0;
                k[(nn + f, f * n + a)] = 1.0;
            }
        }
        let lu_t = k.transpose().lu();
        let lu = k.lu();
        ensure!(
            lu.is_invertible(),
            "the fiber–silicone system is singular (fibers on top of each other?)"
        );
        Ok(FiberSystem {
            lines,
            bar,
            lu,
            lu_t,
        })
    }

    /// The fiber layout.
    pub fn lines(&self) -> &FiberLines {
        &self.lines
    }

    /// The fiber bar.
    pub fn bar(&self) -> &FiberBar {
        &self.bar
    }

    /// Segment forces on the fibers (N, one column per load) for the silicone's
    /// displacements without fibers `u0` (mm, one column per load, one row per node).
    pub fn forces(&self, u0: &DMatrix<f64>) -> DMatrix<f64> {
        let nn = self.lines.n_nodes();
        let nf = self.lines.x_mm.len();
        let mut rhs = DMatrix::zeros(nn + nf, u0.ncols());
        rhs.view_mut((0, 0), (nn, u0.ncols())).copy_from(u0);
        let sol = self
            .lu
            .solve(&rhs)
            .unwrap_or_else(|| DMatrix::zeros(nn + nf, u0.ncols()));
        sol.rows(0, nn).into_owned()
    }

    /// Weights w over the nodes such that w · F is the axial strain of fiber `fiber`
    /// averaged over [y − ℓ/2, y + ℓ/2] (ℓ = `length_mm`; a point reading for ℓ = 0).
    pub fn strain_weights(&self, fiber: usize, y_mm: f64, length_mm: f64) -> DVector<f64> {
        let n = self.lines.segments;
        let dy = self.lines.segment_mm();
        let ea = self.bar.axial_stiffness_n;
        let mut w = DVector::zeros(self.lines.n_nodes());
        for l in 0..n {
            let yl = self.lines.node_y(l);
            let v = if length_mm > 1e-9 {
                let (t1, t2) = (y_mm - 0.5 * length_mm - yl, y_mm + 0.5 * length_mm - yl);
                (ramp_integral(t2, dy) - ramp_integral(t1, dy)) / length_mm
            } else {
                (-(y_mm - yl) / dy).clamp(-0.5, 0.5)
            };
            w[fiber * n + l] = v / ea;
        }
        w
    }

    /// The adjoint of a reading: the vector r with r · u0 = w · F for every u0, so a
    /// grating's reading for any load is one dot product with that load's u0.
    pub fn adjoint(&self, weights: &DVector<f64>) -> DVector<f64> {
        let nn = self.lines.n_nodes();
        let nf = self.lines.x_mm.len();
        let mut rhs = DVector::zeros(nn + nf);
        rhs.rows_mut(0, nn).copy_from(weights);
        let sol = self
            .lu_t
            .solve(&rhs)
            .unwrap_or_else(|| DVector::zeros(nn + nf));
        sol.rows(0, nn).into_owned()
    }
}
