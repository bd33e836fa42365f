//! Sensing matrices of many layouts of one sheet, for placement: the layer's tables
//! are computed once; while the fibers stay where they are, the fiber system is solved
//! once for a load on every cell, and a grating anywhere along a fiber is then read by
//! one dot product per cell. Moving a fiber rebuilds only the fiber system.

use super::{
    gratings_of, pm_per_strain, GratingOnFiber, SheetModel, SheetSolution, SheetTables,
    NEWTONS_PER_GRAM,
};
use crate::profile::ArrayLayout;
use crate::spec::Design;
use anyhow::{anyhow, ensure, Result};
use nalgebra::DMatrix;

/// One sheet's model, ready to give the sensing matrix of any grating layout on it.
pub struct LayoutMatrices {
    model: SheetModel,
    tables: SheetTables,
    cells_mm: Vec<(f64, f64)>,
    fixed: SheetSolution,
    fixed_forces: DMatrix<f64>,
    pm_per_g: Vec<f64>,
}

impl LayoutMatrices {
    /// The sheet of `design`'s array, its cells and its gratings' pm per strain, at
    /// the model's standard resolution (`coarse` for inner loops that move fibers).
    pub fn from_design(design: &Design, coarse: bool) -> Result<Self> {
        let mut model = SheetModel::from_design(design)?;
        if coarse {
            model.resolution = super::Resolution::coarse();
        }
        let a = design
            .array
            .as_ref()
            .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
        let cells_mm = ArrayLayout::from_array(a).cell_centers_mm;
        let pm_per_g = pm_per_strain(design)?
            .iter()
            .map(|s| s * NEWTONS_PER_GRAM)
            .collect();
        let tables = model.tables()?;
        let fixed = SheetSolution::new(model.clone(), tables.clone())?;
        let fixed_forces = fixed.forces(&cells_mm);
        Ok(LayoutMatrices {
            model,
            tables,
            cells_mm,
            fixed,
            fixed_forces,
            pm_per_g,
        })
    }

    /// The design's gratings as the model reads them (their positions to be moved).
    pub fn gratings(design: &Design) -> Result<Vec<GratingOnFiber>> {
        gratings_of(design)
    }

    /// The model these matrices come from.
    pub fn model(&self) -> &SheetModel {
        &self.model
    }

    /// Sensing matrix (pm/g, gratings × cells) with the fibers at `fiber_x_mm` and the
    /// gratings at `gratings` (in the design's order, whose pm per strain they take).
    pub fn matrix(&self, fiber_x_mm: &[f64], gratings: &[GratingOnFiber]) -> Result<DMatrix<f64>> {
        ensure!(
            gratings.len() == self.pm_per_g.len(),
            "{} gratings given, the design has {}",
            gratings.len(),
            self.pm_per_g.len()
        );
        let mut m = if fiber_x_mm == self.model.fiber_x_mm.as_slice() {
            self.fixed.read(gratings, &self.fixed_forces)
        } else {
            let mut model = self.model.clone();
            model.fiber_x_mm = fiber_x_mm.to_vec();
            SheetSolution::new(model, self.tables.clone())?.strain_per_n(gratings, &self.cells_mm)
        };
        for (i, s) in self.pm_per_g.iter().enumerate() {
            m.row_mut(i).scale_mut(*s);
        }
        Ok(m)
    }
}
