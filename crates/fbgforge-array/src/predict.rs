//! The array's model policy and its predictions: which model answers (the one asked
//! for, else the one the design names in `array.model`, else the physical sheet model),
//! named in every answer; the sensing matrix (gratings × cells), the response of every
//! grating to one load anywhere on the sheet, and the map of each grating's
//! sensitivity over the sheet. `fbgforge predict ARRAY.toml` asks here (as
//! [`crate::prediction`] is the module's policy); reconstruction, placement, `live`
//! and Python reach the same models through [`super::kernel::model_matrix`].
//!
//! Both models answer the same question, "pm per gram on the indenter centred at
//! (x, y)": the sheet model ([`super::sheet`], by reciprocity: one adjoint solve per
//! grating, then one dot product per point) and the empirical kernel
//! ([`super::kernel::DistanceKernel::paper`], a function of the grating–load
//! distance only).

use super::kernel::{describe_kernel, describe_sheet, ArrayModelKind, DistanceKernel};
use super::sheet::{gratings_of, pm_per_strain, SheetModel, SheetSolution, NEWTONS_PER_GRAM};
use super::SensingMatrix;
use crate::profile::{cell_label, ArrayLayout};
use crate::spec::Design;
use anyhow::{anyhow, ensure, Result};
use nalgebra::DMatrix;
use serde::Serialize;

/// A model ready to answer loads on one design's array.
pub struct ArrayPredictor {
    kind: ArrayModelKind,
    description: String,
    gratings: Vec<String>,
    grating_xy_mm: Vec<(f64, f64)>,
    cells: Vec<String>,
    cell_xy_mm: Vec<(f64, f64)>,
    sheet_mm: (f64, f64),
    engine: Engine,
}

enum Engine {
    Kernel(DistanceKernel),
    Sheet {
        solution: Box<SheetSolution>,
        adjoints: Vec<nalgebra::DVector<f64>>,
        pm_per_g_per_strain: Vec<f64>,
    },
}

/// The response of every grating to one load.
#[derive(Debug, Clone, Serialize)]
pub struct LoadResponse {
    /// Where the indenter is centred, mm from the sheet centre.
    pub load_at_mm: [f64; 2],
    /// Grating names.
    pub gratings: Vec<String>,
    /// Each grating's shift per gram on the indenter, pm/g.
    pub sensitivity_pm_per_g: Vec<f64>,
}

/// Each grating's sensitivity over a grid of load positions on the sheet.
#[derive(Debug, Clone, Serialize)]
pub struct SensitivityMap {
    /// Grid x values, mm (cell centres of the map's grid).
    pub x_mm: Vec<f64>,
    /// Grid y values, mm.
    pub y_mm: Vec<f64>,
    /// Grating names.
    pub gratings: Vec<String>,
    /// Grating centres, mm.
    pub grating_xy_mm: Vec<(f64, f64)>,
    /// One matrix per grating, rows y and columns x, pm/g.
    #[serde(skip)]
    pub values_pm_per_g: Vec<DMatrix<f64>>,
}

impl ArrayPredictor {
    /// The predictor of `design`'s array by `kind`, or by the model the design names.
    pub fn new(design: &Design, kind: Option<ArrayModelKind>) -> Result<Self> {
        let a = design
            .array
            .as_ref()
            .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
        let kind = kind.unwrap_or_else(|| a.model_kind());
        let layout = ArrayLayout::from_array(a);
        let (engine, description) = match kind {
            ArrayModelKind::Kernel => {
                let k = DistanceKernel::paper();
                (Engine::Kernel(k), describe_kernel(&k))
            }
            ArrayModelKind::Sheet => {
                let model = SheetModel::from_design(design)?;
                let solution = model.solve()?;
                let adjoints = gratings_of(design)?
                    .iter()
                    .map(|g| {
                        let s = solution.system();
                        s.adjoint(&s.strain_weights(g.fiber, g.y_mm, g.length_mm))
                    })
                    .collect();
                let description = describe_sheet(&solution.model);
                (
                    Engine::Sheet {
                        solution: Box::new(solution),
                        adjoints,
                        pm_per_g_per_strain: pm_per_strain(design)?
                            .iter()
                            .map(|s| s * NEWTONS_PER_GRAM)
                            .collect(),
                    },
                    description,
                )
            }
        };
        Ok(ArrayPredictor {
            kind,
            description,
            gratings: a.gratings.iter().map(|g| g.name.clone()).collect(),
            grating_xy_mm: layout.grating_positions_mm.clone(),
            cells: (0..layout.cell_centers_mm.len()).map(cell_label).collect(),
            cell_xy_mm: layout.cell_centers_mm.clone(),
            sheet_mm: (a.size_x_mm, a.size_y_mm),
            engine,
        })
    }

    /// Which model answers.
    pub fn kind(&self) -> ArrayModelKind {
        self.kind
    }

    /// The model and its constants in one line.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// Sensitivity (pm/g) of every grating (rows) to the indenter at each point
    /// (columns).
    pub fn response(&self, points_mm: &[(f64, f64)]) -> DMatrix<f64> {
        match &self.engine {
            Engine::Kernel(k) => DMatrix::from_fn(self.gratings.len(), points_mm.len(), |i, j| {
                let ((gx, gy), (x, y)) = (self.grating_xy_mm[i], points_mm[j]);
                k.sensitivity_pm_per_g((gx - x).hypot(gy - y))
            }),
            Engine::Sheet {
                solution,
                adjoints,
                pm_per_g_per_strain,
            } => {
                use rayon::prelude::*;
                let cols: Vec<Vec<f64>> = points_mm
                    .par_iter()
                    .map(|&(x, y)| {
                        let u = solution.silicone_displacement(x, y);
                        adjoints
                            .iter()
                            .zip(pm_per_g_per_strain)
                            .map(|(a, s)| a.dot(&u) * s)
                            .collect()
                    })
                    .collect();
                DMatrix::from_fn(self.gratings.len(), points_mm.len(), |i, j| cols[j][i])
            }
        }
    }

    /// The sensing matrix: the indenter centred on each cell.
    pub fn matrix(&self) -> SensingMatrix {
        SensingMatrix {
            gratings: self.gratings.clone(),
            cells: self.cells.clone(),
            sensitivity_pm_per_g: self.response(&self.cell_xy_mm),
        }
    }

    /// The response to the indenter at (x, y), which must lie on the sheet.
    pub fn load_at(&self, x_mm: f64, y_mm: f64) -> Result<LoadResponse> {
        let (hx, hy) = (self.sheet_mm.0 / 2.0, self.sheet_mm.1 / 2.0);
        ensure!(
            x_mm.is_finite() && y_mm.is_finite() && x_mm.abs() <= hx && y_mm.abs() <= hy,
            "the load at ({x_mm}, {y_mm}) mm is off the {} × {} mm sheet (x within ±{hx} mm, y within ±{hy} mm of its centre)",
            self.sheet_mm.0,
            self.sheet_mm.1
        );
        Ok(LoadResponse {
            load_at_mm: [x_mm, y_mm],
            gratings: self.gratings.clone(),
            sensitivity_pm_per_g: self
                .response(&[(x_mm, y_mm)])
                .column(0)
                .iter()
                .copied()
                .collect(),
        })
    }

    /// Each grating's sensitivity over the sheet on a grid of `step_mm` (cell-centred).
    pub fn map(&self, step_mm: f64) -> Result<SensitivityMap> {
        ensure!(
            step_mm.is_finite() && step_mm > 0.0,
            "the map step must be a positive number of mm, got {step_mm}"
        );
        let nx = ((self.sheet_mm.0 / step_mm).round() as usize).max(1);
        let ny = ((self.sheet_mm.1 / step_mm).round() as usize).max(1);
        let (dx, dy) = (self.sheet_mm.0 / nx as f64, self.sheet_mm.1 / ny as f64);
        let xs: Vec<f64> = (0..nx)
            .map(|i| -self.sheet_mm.0 / 2.0 + (i as f64 + 0.5) * dx)
            .collect();
        let ys: Vec<f64> = (0..ny)
            .map(|j| -self.sheet_mm.1 / 2.0 + (j as f64 + 0.5) * dy)
            .collect();
        let pts: Vec<(f64, f64)> = ys
            .iter()
            .flat_map(|&y| xs.iter().map(move |&x| (x, y)))
            .collect();
        let r = self.response(&pts);
        let values = (0..self.gratings.len())
            .map(|g| DMatrix::from_fn(ny, nx, |j, i| r[(g, j * nx + i)]))
            .collect();
        Ok(SensitivityMap {
            x_mm: xs,
            y_mm: ys,
            gratings: self.gratings.clone(),
            grating_xy_mm: self.grating_xy_mm.clone(),
            values_pm_per_g: values,
        })
    }

    /// The spectrum each grating makes under the indenter on each cell over the array's
    /// force range, with the warnings of those that chirp or split inside it
    /// ([`super::sheet::spectrum::array_spectra`], from the same solve as the matrix);
    /// `None` for the empirical kernel, which has no strain along a grating.
    pub fn spectra(&self, design: &Design) -> Result<Option<super::sheet::spectrum::ArraySpectra>> {
        match &self.engine {
            Engine::Kernel(_) => Ok(None),
            Engine::Sheet { solution, .. } => {
                super::sheet::spectrum::array_spectra(design, solution).map(Some)
            }
        }
    }

    /// Grating centres, mm.
    pub fn grating_xy_mm(&self) -> &[(f64, f64)] {
        &self.grating_xy_mm
    }

    /// Sheet size, mm.
    pub fn sheet_mm(&self) -> (f64, f64) {
        self.sheet_mm
    }
}

impl SensitivityMap {
    /// The map as CSV rows: `x_mm,y_mm,<grating…>` (pm/g).
    pub fn csv_rows(&self) -> (Vec<String>, Vec<Vec<String>>) {
        let mut header = vec!["x_mm".to_string(), "y_mm".to_string()];
        header.extend(self.gratings.iter().map(|g| format!("{g}_pm_per_g")));
        let mut rows = Vec::with_capacity(self.x_mm.len() * self.y_mm.len());
        for (j, y) in self.y_mm.iter().enumerate() {
            for (i, x) in self.x_mm.iter().enumerate() {
                let mut r = vec![format!("{x:.3}"), format!("{y:.3}")];
                r.extend(
                    self.values_pm_per_g
                        .iter()
                        .map(|m| format!("{:.6e}", m[(j, i)])),
                );
                rows.push(r);
            }
        }
        (header, rows)
    }
}
