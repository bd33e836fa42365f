//! A physical model of the flat array: the sensing matrix of a sheet not yet cast,
//! from its thickness, its silicone, its fibers' depth and positions, the indenter
//! and how the sheet rests on the table.
//!
//! A grating reads the axial strain of its fiber, and a glass fiber is some 10⁴ times
//! stiffer than the silicone: the fiber takes load from the sheet by shear along its
//! whole length, free at both ends, so its strain is one to two orders of magnitude
//! below the silicone's (docs/array.md §12). The model therefore has three parts:
//!
//! * [`layer`]: the sheet as an elastic layer on the table (bonded, frictionless, or
//!   gripping through a tangential interface stiffness), solved exactly for each
//!   horizontal wavenumber;
//! * [`hankel`]: transforms of those kernels to functions of distance: the silicone's
//!   horizontal displacement at the fibers' depth under the indenter (a disc of
//!   uniform pressure), and the layer's correction to Kelvin's point-force solution
//!   for forces on the fiber plane;
//! * [`fiber`]: every fiber as an embedded bar coupled to the silicone through that
//!   compliance (a boundary-integral form of shear lag), solved together, read as the
//!   axial strain averaged over each grating.
//!
//! Assumptions (each stated in docs/array.md §12): linear elasticity (a 250 g load on a
//! 20 mm disc strains a 1 MPa silicone by under 1 %); the sheet infinite in its plane
//! (its free edges are not modelled; the fibers end at the sheet's edges); the table
//! rigid, the sheet never lifting off; the fibers perfectly bonded at the coating's
//! outer radius (the coating lumped into the silicone), straight, without pre-strain,
//! and stiff only axially (a 125 µm fiber's bending stiffness is negligible); the
//! indenter a uniform pressure over its disc. Two constants are fitted to the paper's
//! Table 1 and stated as fitted: the composite's modulus and the table interface
//! ([`fit`]).

pub mod fiber;
pub mod fit;
pub mod hankel;
pub mod layer;
pub mod layouts;
pub mod spectrum;

use crate::profile::{cell_label, ArrayLayout};
use crate::spec::Design;
use anyhow::{anyhow, ensure, Result};
use fiber::{FiberBar, FiberLines, FiberSystem, SiliconeCompliance};
use hankel::{KGrid, Order, RadialTable, Transformable};
use layer::{BaseCondition, Layer};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Newtons per gram-force (standard gravity).
pub(crate) const NEWTONS_PER_GRAM: f64 = 9.80665e-3;

/// How finely the model is discretised: the speed–accuracy knob.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Resolution {
    /// Fiber segment length, mm (the fiber is cut into ⌈L/this⌉ segments).
    pub segment_mm: f64,
    /// Width of a wavenumber panel as a fraction of one Bessel period at the largest
    /// distance (smaller is finer).
    pub panel_fraction: f64,
    /// Step of the radial tables, mm.
    pub rho_step_mm: f64,
}

impl Resolution {
    /// The default: converged to 0.5 % on the paper's layout (docs/array.md §12.4).
    pub fn standard() -> Self {
        Resolution {
            segment_mm: 1.0,
            panel_fraction: 0.5,
            rho_step_mm: 0.25,
        }
    }

    /// Coarse and fast, for inner loops that need shapes rather than digits.
    pub fn coarse() -> Self {
        Resolution {
            segment_mm: 2.0,
            panel_fraction: 1.0,
            rho_step_mm: 0.5,
        }
    }

    /// Fine: the reference for convergence.
    pub fn fine() -> Self {
        Resolution {
            segment_mm: 0.5,
            panel_fraction: 0.25,
            rho_step_mm: 0.125,
        }
    }

    /// Each knob divided by `factor` (> 1 refines), for convergence studies.
    pub fn refined(&self, factor: f64) -> Self {
        Resolution {
            segment_mm: self.segment_mm / factor,
            panel_fraction: self.panel_fraction / factor,
            rho_step_mm: self.rho_step_mm / factor,
        }
    }
}

/// Everything the physical model reads: the sheet, its table, the fibers, the indenter.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SheetModel {
    /// Sheet thickness, mm.
    pub thickness_mm: f64,
    /// Young's modulus of the cast composite, MPa.
    pub youngs_modulus_mpa: f64,
    /// Poisson's ratio of the composite.
    pub poisson_ratio: f64,
    /// Depth of the fibers' axes below the loaded face, mm.
    pub fiber_depth_mm: f64,
    /// How the sheet rests on the table.
    pub base: BaseCondition,
    /// Diameter of the indenter disc, mm (uniform pressure over it).
    pub indenter_diameter_mm: f64,
    /// Sheet size along x and y, mm (the fibers run along y across it).
    pub sheet_mm: (f64, f64),
    /// x of each fiber, mm from the sheet centre.
    pub fiber_x_mm: Vec<f64>,
    /// The fibers as bars.
    pub fiber: FiberBar,
    /// Discretisation.
    pub resolution: Resolution,
}

impl SheetModel {
    /// The model of a design's `[array]`: sheet, material, fiber depth, base and
    /// indenter as the design states them.
    pub fn from_design(design: &Design) -> Result<Self> {
        let a = design
            .array
            .as_ref()
            .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
        let m = design
            .material(&a.material, "array.material")
            .map_err(|e| anyhow!("{e}"))?;
        Ok(SheetModel {
            thickness_mm: a.thickness_mm,
            youngs_modulus_mpa: m.youngs_modulus_mpa,
            poisson_ratio: m.poisson_ratio,
            fiber_depth_mm: a.fiber_depth(),
            base: a.base_condition(),
            indenter_diameter_mm: a.indenter_diameter(),
            sheet_mm: (a.size_x_mm, a.size_y_mm),
            fiber_x_mm: a.fiber_x_mm.clone(),
            fiber: FiberBar::standard(design.fiber_routing.coated_diameter_mm),
            resolution: Resolution::standard(),
        })
    }

    /// The layer of this sheet.
    pub fn layer(&self) -> Layer {
        Layer {
            thickness_mm: self.thickness_mm,
            shear_modulus_mpa: self.youngs_modulus_mpa / (2.0 * (1.0 + self.poisson_ratio)),
            poisson_ratio: self.poisson_ratio,
            base: self.base,
        }
    }

    /// The fibers' lines: along y across the sheet, cut at the resolution's segment.
    pub(crate) fn fiber_lines(&self) -> FiberLines {
        let len = self.sheet_mm.1;
        FiberLines {
            x_mm: self.fiber_x_mm.clone(),
            span_mm: (-len / 2.0, len / 2.0),
            segments: ((len / self.resolution.segment_mm).ceil() as usize).max(2),
        }
    }

    fn check(&self) -> Result<()> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        ensure!(
            ok(self.thickness_mm),
            "sheet thickness must be positive, got {} mm",
            self.thickness_mm
        );
        ensure!(
            ok(self.youngs_modulus_mpa),
            "the silicone's modulus must be positive, got {} MPa",
            self.youngs_modulus_mpa
        );
        ensure!(
            self.poisson_ratio.is_finite() && (0.0..0.4999).contains(&self.poisson_ratio),
            "Poisson's ratio must be in [0, 0.5), got {}",
            self.poisson_ratio
        );
        ensure!(
            self.fiber_depth_mm > 0.0 && self.fiber_depth_mm < self.thickness_mm,
            "fiber depth {} mm is not inside the {} mm sheet",
            self.fiber_depth_mm,
            self.thickness_mm
        );
        ensure!(
            self.indenter_diameter_mm.is_finite() && self.indenter_diameter_mm >= 0.0,
            "indenter diameter must be ≥ 0 mm, got {}",
            self.indenter_diameter_mm
        );
        if let BaseCondition::Gripping {
            tangential_stiffness_n_per_mm3: k,
        } = self.base
        {
            ensure!(
                ok(k),
                "the table interface's tangential stiffness must be positive, got {k} N/mm³"
            );
        }
        ensure!(
            ok(self.sheet_mm.0) && ok(self.sheet_mm.1),
            "sheet size must be positive"
        );
        ensure!(!self.fiber_x_mm.is_empty(), "the sheet has no fiber");
        ensure!(
            ok(self.resolution.segment_mm)
                && ok(self.resolution.panel_fraction)
                && ok(self.resolution.rho_step_mm),
            "resolution knobs must be positive"
        );
        Ok(())
    }

    /// Largest distance a table must cover: the sheet's diagonal plus a margin.
    fn rho_max_mm(&self) -> f64 {
        self.sheet_mm.0.hypot(self.sheet_mm.1) + 5.0
    }

    /// The layer's radial tables for this sheet (the expensive part, independent of
    /// the fibers' x positions).
    pub fn tables(&self) -> Result<SheetTables> {
        self.check()?;
        let layer = self.layer();
        let zf = self.fiber_depth_mm;
        let decay = zf.min(self.thickness_mm - zf);
        let rho_max = self.rho_max_mm();
        // The indenter's field at the fiber plane decays as e^{−k z_f}; the faces'
        // correction on that plane as e^{−2k·min(z_f, h − z_f)}: each stops at e⁻²⁵.
        let k_ur = 25.0 / zf;
        let k_corr = 25.0 / (2.0 * decay);
        let grid = KGrid::new(rho_max, k_ur.max(k_corr), self.resolution.panel_fraction);
        let radius = self.indenter_diameter_mm / 2.0;
        let mut ur_kernel = Vec::with_capacity(grid.len());
        let mut s_kernel = Vec::with_capacity(grid.len());
        let mut d_kernel = Vec::with_capacity(grid.len());
        for &k in &grid.k {
            let kn = layer.kernels(k, zf);
            let (ak, bk) = layer.kelvin_along_normal(k);
            // Uniform pressure over the disc, per newton: p̂ = 2 J₁(ka)/(ka) / 1 N.
            let disc = if radius > 0.0 {
                let x = k * radius;
                2.0 * libm::j1(x) / x
            } else {
                1.0
            };
            // u_r(ρ) = −(1/2π) ∫ U p̂ J₁ k dk.
            ur_kernel.push(-kn.pressure_u * disc);
            s_kernel.push(0.5 * (kn.along + kn.normal) - 0.5 * (ak + bk));
            d_kernel.push(0.5 * (kn.along - kn.normal) - 0.5 * (ak - bk));
        }
        let zero_order = match self.base {
            BaseCondition::Frictionless => Order::J0Relative,
            _ => Order::J0,
        };
        let mut t = hankel::transform(
            &grid,
            &[
                Transformable {
                    values: &ur_kernel,
                    order: Order::J1,
                    k_max: k_ur,
                },
                Transformable {
                    values: &s_kernel,
                    order: zero_order,
                    k_max: k_corr,
                },
                Transformable {
                    values: &d_kernel,
                    order: Order::J2,
                    k_max: k_corr,
                },
            ],
            self.resolution.rho_step_mm,
            rho_max,
        );
        let correction_2 = t.pop().expect("three tables");
        let correction_0 = t.pop().expect("three tables");
        let radial_displacement = t.pop().expect("three tables");
        Ok(SheetTables {
            layer,
            fiber_depth_mm: zf,
            radial_displacement,
            correction_0,
            correction_2,
            k_nodes: grid.len(),
        })
    }

    /// Build the tables and the fiber system: a solved model ready to answer loads.
    pub fn solve(&self) -> Result<SheetSolution> {
        let tables = self.tables()?;
        SheetSolution::new(self.clone(), tables)
    }
}

/// The layer's transforms for one sheet, indenter and fiber depth.
#[derive(Debug, Clone)]
pub struct SheetTables {
    /// The layer.
    pub layer: Layer,
    /// Depth of the fiber plane, mm.
    pub fiber_depth_mm: f64,
    /// Radial displacement of the silicone at the fiber depth under the indenter,
    /// per newton, as a function of the distance from the indenter's centre, mm/N.
    pub radial_displacement: RadialTable,
    /// Layer correction to Kelvin for a y-force on the fiber plane, axisymmetric part.
    pub correction_0: RadialTable,
    /// The same, cos 2θ part.
    pub correction_2: RadialTable,
    /// Wavenumber nodes used.
    pub k_nodes: usize,
}

/// A grating as the model reads it: its fiber, its centre along y and its length.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GratingOnFiber {
    /// Index of its fiber.
    pub fiber: usize,
    /// Centre along y, mm.
    pub y_mm: f64,
    /// Length, mm.
    pub length_mm: f64,
}

/// A solved sheet: tables plus the factorised fiber system.
pub struct SheetSolution {
    /// The model solved.
    pub model: SheetModel,
    /// Its tables.
    pub tables: SheetTables,
    system: FiberSystem,
}

impl SheetSolution {
    /// Assemble the fiber system of `model` on precomputed `tables` (of the same
    /// sheet; only the fibers' x may differ from the tables' model).
    pub fn new(model: SheetModel, tables: SheetTables) -> Result<Self> {
        let lines = model.fiber_lines();
        let g = SiliconeCompliance {
            shear_modulus_mpa: tables.layer.shear_modulus_mpa,
            poisson_ratio: tables.layer.poisson_ratio,
            correction_0: &tables.correction_0,
            correction_2: &tables.correction_2,
        }
        .matrix(&lines, model.fiber.coupling_radius_mm);
        let system = FiberSystem::with_compliance(lines, model.fiber, g)?;
        Ok(SheetSolution {
            model,
            tables,
            system,
        })
    }

    /// The fiber system.
    pub fn system(&self) -> &FiberSystem {
        &self.system
    }

    /// The silicone's displacement along y at every fiber node (no fibers), mm, for
    /// the indenter centred at (x, y) carrying 1 N.
    pub(crate) fn silicone_displacement(&self, x_mm: f64, y_mm: f64) -> DVector<f64> {
        let lines = self.system.lines();
        let n = lines.segments;
        let mut u = DVector::zeros(lines.n_nodes());
        for (f, &fx) in lines.x_mm.iter().enumerate() {
            for l in 0..n {
                let dy = lines.node_y(l) - y_mm;
                let rho = (fx - x_mm).hypot(dy);
                if rho > 1e-12 {
                    u[f * n + l] = self.tables.radial_displacement.at(rho) * dy / rho;
                }
            }
        }
        u
    }

    /// The silicone's own strain along y at a grating (averaged over its length), per
    /// newton on the indenter at (x, y): what the grating would read if the fiber
    /// simply followed the silicone.
    pub(crate) fn silicone_strain_per_n(&self, g: &GratingOnFiber, x_mm: f64, y_mm: f64) -> f64 {
        let fx = self.system.lines().x_mm[g.fiber];
        let uy = |y: f64| {
            let dy = y - y_mm;
            let rho = (fx - x_mm).hypot(dy);
            if rho > 1e-12 {
                self.tables.radial_displacement.at(rho) * dy / rho
            } else {
                0.0
            }
        };
        let h = (0.5 * g.length_mm).max(0.05);
        (uy(g.y_mm + h) - uy(g.y_mm - h)) / (2.0 * h)
    }

    /// Segment forces on the fibers for 1 N on the indenter at each of `loads_mm`
    /// (one column per load), N.
    pub fn forces(&self, loads_mm: &[(f64, f64)]) -> DMatrix<f64> {
        let nn = self.system.lines().n_nodes();
        let mut u0 = DMatrix::zeros(nn, loads_mm.len());
        for (c, &(x, y)) in loads_mm.iter().enumerate() {
            u0.set_column(c, &self.silicone_displacement(x, y));
        }
        self.system.forces(&u0)
    }

    /// Fiber strain (averaged over each grating) per newton on each load: one row per
    /// grating, one column per load.
    pub fn strain_per_n(
        &self,
        gratings: &[GratingOnFiber],
        loads_mm: &[(f64, f64)],
    ) -> DMatrix<f64> {
        let f = self.forces(loads_mm);
        self.read(gratings, &f)
    }

    /// Read gratings from segment forces (one column per load).
    pub fn read(&self, gratings: &[GratingOnFiber], forces: &DMatrix<f64>) -> DMatrix<f64> {
        let mut out = DMatrix::zeros(gratings.len(), forces.ncols());
        for (i, g) in gratings.iter().enumerate() {
            let w = self.system.strain_weights(g.fiber, g.y_mm, g.length_mm);
            for c in 0..forces.ncols() {
                out[(i, c)] = w.dot(&forces.column(c));
            }
        }
        out
    }

    /// The fiber's axial strain per newton on the indenter at `load_mm`, sampled along
    /// grating `g` from its start (z = 0, at y − ℓ/2) to its end (z = ℓ): at both ends
    /// and at every segment edge between them. The bar's axial force is continuous and
    /// linear within a segment (uniform force density per segment), so the samples
    /// joined by straight lines *are* the model's strain along the grating, and their
    /// mean (trapezoids) is the grating's reading [`Self::strain_per_n`] of the same
    /// forces: one source of truth for the mean and the profile.
    pub fn strain_profile_per_n(
        &self,
        g: &GratingOnFiber,
        load_mm: (f64, f64),
    ) -> (Vec<f64>, Vec<f64>) {
        let f = self.forces(&[load_mm]);
        self.profile_from_forces(g, &f.column(0).into_owned())
    }

    /// [`Self::strain_profile_per_n`] from segment forces already solved (one load).
    pub fn profile_from_forces(
        &self,
        g: &GratingOnFiber,
        forces: &DVector<f64>,
    ) -> (Vec<f64>, Vec<f64>) {
        let lines = self.system.lines();
        let (y0, y1) = (g.y_mm - 0.5 * g.length_mm, g.y_mm + 0.5 * g.length_mm);
        let dy = lines.segment_mm();
        let mut y = vec![y0];
        y.extend(
            (0..=lines.segments)
                .map(|k| lines.span_mm.0 + k as f64 * dy)
                .filter(|&e| e > y0 + 1e-9 && e < y1 - 1e-9),
        );
        y.push(y1);
        let strain = y
            .iter()
            .map(|&yy| self.system.strain_weights(g.fiber, yy, 0.0).dot(forces))
            .collect();
        (y.iter().map(|yy| yy - y0).collect(), strain)
    }

    /// Each grating's strain per newton for the indenter at every point of `points`
    /// (by reciprocity: one adjoint solve per grating, one dot product per point).
    pub fn strain_map_per_n(
        &self,
        gratings: &[GratingOnFiber],
        points_mm: &[(f64, f64)],
    ) -> DMatrix<f64> {
        use rayon::prelude::*;
        let adj: Vec<DVector<f64>> = gratings
            .iter()
            .map(|g| {
                self.system
                    .adjoint(&self.system.strain_weights(g.fiber, g.y_mm, g.length_mm))
            })
            .collect();
        let cols: Vec<Vec<f64>> = points_mm
            .par_iter()
            .map(|&(x, y)| {
                let u = self.silicone_displacement(x, y);
                adj.iter().map(|a| a.dot(&u)).collect()
            })
            .collect();
        DMatrix::from_fn(gratings.len(), points_mm.len(), |i, j| cols[j][i])
    }
}

/// The gratings of a design's array as the model reads them.
pub fn gratings_of(design: &Design) -> Result<Vec<GratingOnFiber>> {
    let a = design
        .array
        .as_ref()
        .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
    Ok(a.gratings
        .iter()
        .map(|g| GratingOnFiber {
            fiber: g.fiber as usize,
            y_mm: g.y_mm,
            length_mm: g.length_mm,
        })
        .collect())
}

/// pm per unit strain of each grating of a design (its Bragg wavelength and the
/// design's fiber optics).
pub(crate) fn pm_per_strain(design: &Design) -> Result<Vec<f64>> {
    let a = design
        .array
        .as_ref()
        .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
    Ok(a.gratings
        .iter()
        .map(|g| design.fiber.shift_pm(g.bragg_wavelength_nm, 1.0, 0.0))
        .collect())
}

/// The sensing matrix (pm/g) of a design's array by the sheet model, gratings × cells,
/// with the solution it came from.
pub fn design_matrix(design: &Design) -> Result<(DMatrix<f64>, SheetSolution)> {
    let model = SheetModel::from_design(design)?;
    let sol = model.solve()?;
    let a = design.array.as_ref().expect("checked by from_design");
    let cells = ArrayLayout::from_array(a).cell_centers_mm;
    let gratings = gratings_of(design)?;
    let scale = pm_per_strain(design)?;
    let mut m = sol.strain_per_n(&gratings, &cells);
    for (i, s) in scale.iter().enumerate() {
        m.row_mut(i).scale_mut(s * NEWTONS_PER_GRAM);
    }
    Ok((m, sol))
}

/// Cell labels of a design's array.
pub fn cell_labels(design: &Design) -> Vec<String> {
    design
        .array
        .as_ref()
        .map(|a| (a.cells_x * a.cells_y) as usize)
        .map(|n| (0..n).map(cell_label).collect())
        .unwrap_or_default()
}
