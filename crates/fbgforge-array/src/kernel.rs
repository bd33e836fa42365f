//! Forward model of the flat array: how much each grating shifts per gram on each cell.
//!
//! The paper measured the sensitivity of the six gratings to a load at the array centre
//! (Table 1) together with the load–grating distance, and the sensitivity of a grating
//! loaded right above it (Table 2, 0.371 pm/g). Sensitivity falls with distance roughly
//! as a power law s(d) = c · d^(−n); fitted in log space to Table 1 this gives
//! n ≈ 2.05 and c ≈ 44.7 pm·mm²/g (reference §2).
//!
//! A bare power law diverges as d → 0, yet the sheet is loaded through a 20 mm contact
//! disc and a grating under the load reads a finite 0.371 pm/g. We therefore use the
//! regularised kernel s(d) = c · (d² + d₀²)^(−n/2), whose core radius d₀ is fitted
//! together with c and n to Table 1 plus the Table 2 point at d = 0. For d ≫ d₀ it is
//! the power law; at d = 0 it is finite. A load on a cell is modelled as a point load
//! at the cell centre (the paper centres its contact disc on the cell).
//!
//! This file is also the one entry every caller of a model matrix goes through
//! ([`model_matrix`], [`matrix_from_design`]): it answers with the model a design names
//! (`array.model`, the physical [`super::sheet`] model by default) or the one asked for,
//! and names it.

use super::SensingMatrix;
use crate::profile::{cell_label, ArrayLayout};
use crate::spec::Design;
use anyhow::{anyhow, Result};
use nalgebra::DMatrix;
use serde::Serialize;

/// Table 1 of the paper: (sensitivity pm/g, load–grating distance mm) per grating.
pub const TABLE1: [(f64, f64); 6] = [
    (0.0327, 39.53),
    (0.0661, 25.74),
    (0.1958, 14.58),
    (0.1801, 14.58),
    (0.0455, 25.74),
    (0.0183, 39.53),
];

/// Table 2 of the paper: sensitivity of a grating loaded right above it, pm/g.
pub const TABLE2_DIRECT_PM_PER_G: f64 = 0.371;

/// Regularised power-law kernel s(d) = c · (d² + d₀²)^(−n/2), in pm/g.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DistanceKernel {
    /// Scale c, pm·mmⁿ/g.
    pub scale_pm_mm_n_per_g: f64,
    /// Exponent n (dimensionless).
    pub exponent: f64,
    /// Core radius d₀ that keeps the kernel finite at d = 0, mm (0 = bare power law).
    pub core_radius_mm: f64,
}

impl DistanceKernel {
    /// Sensitivity of a grating to a load at distance `d_mm`, pm/g.
    pub fn sensitivity_pm_per_g(&self, d_mm: f64) -> f64 {
        let r2 = d_mm * d_mm + self.core_radius_mm * self.core_radius_mm;
        if r2 <= 0.0 {
            // Bare power law at d = 0: no finite answer; callers use a core radius.
            return f64::INFINITY;
        }
        self.scale_pm_mm_n_per_g * r2.powf(-0.5 * self.exponent)
    }

    /// The kernel used by default: fitted to Table 1 and Table 2 (see [`fit_paper`]).
    pub fn paper() -> Self {
        fit_paper().kernel
    }

    /// Table 1's bare power law (c = 44.7 pm·mm^n/g, n = 2.05, [`fit_power_law`]) with a
    /// core radius `core_radius_mm` that keeps it finite under a grating. With 3 mm it
    /// is the kernel of the scaling study (the arrays of issue 14: a grating's
    /// sensitivity falls by half within 3 mm, so large arrays of 20 × 30 mm cells are
    /// far from the coherent limit the 16 mm core of [`Self::paper`] gives).
    pub fn table1_power_law(core_radius_mm: f64) -> Self {
        let k = fit_power_law(&TABLE1)
            .expect("Table 1 is valid fit data")
            .kernel;
        DistanceKernel {
            core_radius_mm,
            ..k
        }
    }
}

/// One data point of a kernel fit and how far the kernel misses it.
#[derive(Debug, Clone, Serialize)]
pub struct FitResidual {
    /// Load–grating distance, mm.
    pub distance_mm: f64,
    /// Measured sensitivity, pm/g.
    pub measured_pm_per_g: f64,
    /// Kernel sensitivity, pm/g.
    pub fitted_pm_per_g: f64,
    /// (fitted − measured) / measured, %.
    pub relative_error_pct: f64,
}

/// A fitted kernel with its residuals.
#[derive(Debug, Clone, Serialize)]
pub struct KernelFit {
    /// The fitted kernel.
    pub kernel: DistanceKernel,
    /// Residual per data point.
    pub residuals: Vec<FitResidual>,
    /// Root-mean-square of the log-space residuals (natural log).
    pub rms_log_residual: f64,
}

/// Least-squares line log s = a − b · t through (t, log s); returns (a, b, sum of squares).
fn log_line(t: &[f64], log_s: &[f64]) -> (f64, f64, f64) {
    let n = t.len() as f64;
    let mt = t.iter().sum::<f64>() / n;
    let ms = log_s.iter().sum::<f64>() / n;
    let (mut stt, mut sts) = (0.0, 0.0);
    for (&ti, &si) in t.iter().zip(log_s) {
        stt += (ti - mt) * (ti - mt);
        sts += (ti - mt) * (si - ms);
    }
    let slope = if stt > 0.0 { sts / stt } else { 0.0 };
    let a = ms - slope * mt;
    let ss = t
        .iter()
        .zip(log_s)
        .map(|(&ti, &si)| (a + slope * ti - si).powi(2))
        .sum();
    (a, -slope, ss)
}

fn residuals(kernel: &DistanceKernel, points: &[(f64, f64)]) -> (Vec<FitResidual>, f64) {
    let mut ss = 0.0;
    let res = points
        .iter()
        .map(|&(s, d)| {
            let f = kernel.sensitivity_pm_per_g(d);
            ss += (f.ln() - s.ln()).powi(2);
            FitResidual {
                distance_mm: d,
                measured_pm_per_g: s,
                fitted_pm_per_g: f,
                relative_error_pct: 100.0 * (f - s) / s,
            }
        })
        .collect();
    (res, (ss / points.len().max(1) as f64).sqrt())
}

/// Fit the bare power law s = c · d^(−n) in log space to (sensitivity pm/g, distance mm)
/// points with d > 0.
pub fn fit_power_law(points: &[(f64, f64)]) -> Result<KernelFit> {
    if points.len() < 2 || points.iter().any(|&(s, d)| !(s > 0.0 && d > 0.0)) {
        return Err(anyhow!(
            "a power-law fit needs at least two points with positive sensitivity and distance"
        ));
    }
    let t: Vec<f64> = points.iter().map(|&(_, d)| d.ln()).collect();
    let ls: Vec<f64> = points.iter().map(|&(s, _)| s.ln()).collect();
    let (a, n, _) = log_line(&t, &ls);
    let kernel = DistanceKernel {
        scale_pm_mm_n_per_g: a.exp(),
        exponent: n,
        core_radius_mm: 0.0,
    };
    let (residuals, rms) = residuals(&kernel, points);
    Ok(KernelFit {
        kernel,
        residuals,
        rms_log_residual: rms,
    })
}

/// Fit the regularised kernel c · (d² + d₀²)^(−n/2) in log space. For a fixed d₀ the
/// fit is a straight line in log(d² + d₀²); d₀ is found by a fine scan, then refined.
pub fn fit_regularised(points: &[(f64, f64)]) -> Result<KernelFit> {
    if points.len() < 3 || points.iter().any(|&(s, d)| !(s > 0.0 && d >= 0.0)) {
        return Err(anyhow!(
            "a regularised fit needs at least three points with positive sensitivity and distance ≥ 0"
        ));
    }
    let ls: Vec<f64> = points.iter().map(|&(s, _)| s.ln()).collect();
    let fit_at = |d0: f64| {
        let t: Vec<f64> = points
            .iter()
            .map(|&(_, d)| 0.5 * (d * d + d0 * d0).ln())
            .collect();
        log_line(&t, &ls)
    };
    let mut best = (f64::INFINITY, 0.0);
    let mut d0 = 0.05;
    while d0 <= 60.0 {
        let (_, _, ss) = fit_at(d0);
        if ss < best.0 {
            best = (ss, d0);
        }
        d0 += 0.05;
    }
    // Golden-section refinement around the best scan point.
    let (mut lo, mut hi) = ((best.1 - 0.05).max(1e-3), best.1 + 0.05);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..60 {
        let m1 = hi - g * (hi - lo);
        let m2 = lo + g * (hi - lo);
        if fit_at(m1).2 < fit_at(m2).2 {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    let d0 = 0.5 * (lo + hi);
    let (a, n, _) = fit_at(d0);
    let kernel = DistanceKernel {
        scale_pm_mm_n_per_g: a.exp(),
        exponent: n,
        core_radius_mm: d0,
    };
    let (residuals, rms) = residuals(&kernel, points);
    Ok(KernelFit {
        kernel,
        residuals,
        rms_log_residual: rms,
    })
}

/// The default kernel fit: Table 1 plus Table 2's direct-load point at d = 0.
pub fn fit_paper() -> KernelFit {
    let mut pts = TABLE1.to_vec();
    pts.push((TABLE2_DIRECT_PM_PER_G, 0.0));
    fit_regularised(&pts).expect("the paper's tables are valid fit data")
}

/// Sensing matrix (pm/g) of gratings at `grating_xy_mm` for point loads at
/// `cell_xy_mm`, by `kernel`. Rows are gratings, columns cells.
pub fn matrix_from_positions(
    cell_xy_mm: &[(f64, f64)],
    grating_xy_mm: &[(f64, f64)],
    kernel: &DistanceKernel,
) -> DMatrix<f64> {
    DMatrix::from_fn(grating_xy_mm.len(), cell_xy_mm.len(), |i, j| {
        let (gx, gy) = grating_xy_mm[i];
        let (cx, cy) = cell_xy_mm[j];
        kernel.sensitivity_pm_per_g((gx - cx).hypot(gy - cy))
    })
}

/// A point (x, y) in the sheet's plane, mm from the array centre.
pub(crate) type Point2Mm = (f64, f64);

/// The paper's layout (reference §2, as in `designs/tactile-array-60x80.toml`):
/// cell centres of the 4 × 2 cells of 20 × 30 mm (row-major from the −y row), and the
/// six grating centres at x = ±7.5, ±22.5, ±37.5 mm, y = ±12.5 mm alternating.
pub fn paper_layout() -> (Vec<Point2Mm>, Vec<Point2Mm>) {
    let cells = [-15.0, 15.0]
        .iter()
        .flat_map(|&y| [-30.0, -10.0, 10.0, 30.0].map(|x| (x, y)))
        .collect();
    let gratings = [-37.5, -22.5, -7.5, 7.5, 22.5, 37.5]
        .iter()
        .enumerate()
        .map(|(k, &x)| (x, if k % 2 == 0 { 12.5 } else { -12.5 }))
        .collect();
    (cells, gratings)
}

/// A grid array for any size (the scaling study): `cells_x` × `cells_y` cells of
/// 20 × 30 mm centred on the origin (row-major from the −y row), and `fibers`
/// parallel fibers along x, each carrying `gratings_per_fiber` gratings.
///
/// Fiber f runs at the centre of its band of cells_y / fibers rows; a band of one row
/// has its fiber 2.5 mm towards the array centre (the paper's 12.5 mm against 15),
/// a band of two or more rows has it 5 mm off the band's centre line, alternately
/// down and up, so that no two cells are mirror images about a fiber (a mirror pair is
/// seen identically by every grating on it). Gratings are spaced by the pitch
/// p = width / gratings_per_fiber, at 0.3·p from the left end of a pitch on even
/// fibers and 0.7·p on odd ones (staggered).
pub fn fiber_grid_layout(
    cells_x: usize,
    cells_y: usize,
    fibers: usize,
    gratings_per_fiber: usize,
) -> (Vec<Point2Mm>, Vec<Point2Mm>) {
    const CELL_X_MM: f64 = 20.0;
    const CELL_Y_MM: f64 = 30.0;
    let (w, h) = (cells_x as f64 * CELL_X_MM, cells_y as f64 * CELL_Y_MM);
    let cells = (0..cells_y)
        .flat_map(|j| {
            (0..cells_x).map(move |i| {
                (
                    -w / 2.0 + (i as f64 + 0.5) * CELL_X_MM,
                    -h / 2.0 + (j as f64 + 0.5) * CELL_Y_MM,
                )
            })
        })
        .collect();
    let fibers = fibers.max(1);
    let rows_per_fiber = cells_y / fibers;
    let pitch = w / gratings_per_fiber.max(1) as f64;
    let mut gratings = Vec::with_capacity(fibers * gratings_per_fiber);
    for f in 0..fibers {
        let centre = -h / 2.0 + (f as f64 + 0.5) * h / fibers as f64;
        let y = if rows_per_fiber <= 1 {
            centre - centre.signum() * 2.5
        } else if f % 2 == 1 {
            centre + 5.0
        } else {
            centre - 5.0
        };
        let offset = if f % 2 == 1 { 0.7 } else { 0.3 };
        for i in 0..gratings_per_fiber {
            gratings.push((-w / 2.0 + (i as f64 + offset) * pitch, y));
        }
    }
    (cells, gratings)
}

/// Named sensing matrix of a layout (cells labelled A.., gratings named `names`).
pub(crate) fn matrix_from_layout(
    layout: &ArrayLayout,
    grating_names: &[String],
    kernel: &DistanceKernel,
) -> SensingMatrix {
    SensingMatrix {
        gratings: grating_names.to_vec(),
        cells: (0..layout.cell_centers_mm.len()).map(cell_label).collect(),
        sensitivity_pm_per_g: matrix_from_positions(
            &layout.cell_centers_mm,
            &layout.grating_positions_mm,
            kernel,
        ),
    }
}

pub use crate::spec::ArrayModelKind;

/// A model sensing matrix of a design, with the model that produced it.
#[derive(Debug, Clone, Serialize)]
pub struct ModelMatrix {
    /// The matrix, pm/g.
    pub matrix: SensingMatrix,
    /// The array's ulimit, g.
    pub ulimit_g: f64,
    /// Which model.
    pub model: ArrayModelKind,
    /// The model and its constants in one line.
    pub description: String,
}

/// One line naming the sheet model and the constants it used.
pub(crate) fn describe_sheet(m: &super::sheet::SheetModel) -> String {
    format!(
        "sheet model: {} mm elastic sheet, E = {} MPa, ν = {}, {}; fibers at {} mm depth (bars, E·A = {:.0} N, gripped at r = {} mm); {} mm indenter (uniform pressure); docs/array.md §12",
        m.thickness_mm,
        m.youngs_modulus_mpa,
        m.poisson_ratio,
        m.base.describe(),
        m.fiber_depth_mm,
        m.fiber.axial_stiffness_n,
        m.fiber.coupling_radius_mm,
        m.indenter_diameter_mm
    )
}

/// One line naming the empirical kernel.
pub fn describe_kernel(k: &DistanceKernel) -> String {
    format!(
        "empirical kernel s(d) = c·(d² + d₀²)^(−n/2), c = {:.0} pm·mm^n/g, n = {:.3}, d₀ = {:.2} mm, fitted to the paper's Tables 1–2 (reads no sheet property); docs/array.md §1",
        k.scale_pm_mm_n_per_g, k.exponent, k.core_radius_mm
    )
}

/// The model sensing matrix of a design's array by `kind`, or by the model the design
/// names (`array.model`; the sheet model by default) when `kind` is `None`.
pub fn model_matrix(design: &Design, kind: Option<ArrayModelKind>) -> Result<ModelMatrix> {
    let a = design
        .array
        .as_ref()
        .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
    let kind = kind.unwrap_or_else(|| a.model_kind());
    let layout = ArrayLayout::from_array(a);
    let names: Vec<String> = a.gratings.iter().map(|g| g.name.clone()).collect();
    let (matrix, description) = match kind {
        ArrayModelKind::Kernel => {
            let k = DistanceKernel::paper();
            (matrix_from_layout(&layout, &names, &k), describe_kernel(&k))
        }
        ArrayModelKind::Sheet => {
            let (m, sol) = super::sheet::design_matrix(design)?;
            (
                SensingMatrix {
                    gratings: names,
                    cells: (0..layout.cell_centers_mm.len()).map(cell_label).collect(),
                    sensitivity_pm_per_g: m,
                },
                describe_sheet(&sol.model),
            )
        }
    };
    Ok(ModelMatrix {
        matrix,
        ulimit_g: a.ulimit_g,
        model: kind,
        description,
    })
}

/// Model sensing matrix of a design's array by the model the design names (the sheet
/// model unless `array.model = "kernel"`), and its ulimit (g). Every caller that needs
/// a design's model matrix (`reconstruct --design`, `live`, the Python binding, the
/// synthetic stream) comes here.
pub fn matrix_from_design(design: &Design) -> Result<(SensingMatrix, f64)> {
    let m = model_matrix(design, None)?;
    Ok((m.matrix, m.ulimit_g))
}

/// Cheap proxies of how well a matrix supports sparse recovery.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct MatrixQuality {
    /// Largest |cos| between two distinct columns (0 = orthogonal, 1 = parallel).
    pub mutual_coherence: f64,
    /// Ratio of the largest to the smallest of the min(m, n) singular values.
    pub condition_number: f64,
    /// Smallest column norm divided by the largest (a cell far from every grating
    /// gives a small value).
    pub column_norm_ratio: f64,
}

/// Mutual coherence: the largest |cos angle| between two distinct columns.
pub fn mutual_coherence(a: &DMatrix<f64>) -> f64 {
    let norms: Vec<f64> = (0..a.ncols()).map(|j| a.column(j).norm()).collect();
    let mut mu: f64 = 0.0;
    for i in 0..a.ncols() {
        for j in i + 1..a.ncols() {
            let d = norms[i] * norms[j];
            let c = if d > 0.0 {
                a.column(i).dot(&a.column(j)).abs() / d
            } else {
                1.0
            };
            mu = mu.max(c);
        }
    }
    mu
}

/// Condition number: largest over smallest of the min(m, n) singular values
/// (infinite when the matrix is rank deficient).
pub fn condition_number(a: &DMatrix<f64>) -> f64 {
    if a.is_empty() {
        return f64::INFINITY;
    }
    let sv = a.clone().svd(false, false).singular_values;
    let max = sv.iter().copied().fold(0.0, f64::max);
    let min = sv.iter().copied().fold(f64::INFINITY, f64::min);
    if min > 0.0 && min.is_finite() {
        max / min
    } else {
        f64::INFINITY
    }
}

/// All three proxies at once.
pub fn matrix_quality(a: &DMatrix<f64>) -> MatrixQuality {
    let norms: Vec<f64> = (0..a.ncols()).map(|j| a.column(j).norm()).collect();
    let max = norms.iter().copied().fold(0.0, f64::max);
    let min = norms.iter().copied().fold(f64::INFINITY, f64::min);
    MatrixQuality {
        mutual_coherence: mutual_coherence(a),
        condition_number: condition_number(a),
        column_norm_ratio: if max > 0.0 { min / max } else { 0.0 },
    }
}
