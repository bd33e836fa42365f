//! Flat tactile array: from the layout to a sensing matrix, and from grating shifts
//! back to cell loads.
//!
//! The array of reference §2 has more cells (8) than gratings (6), so y = A x is
//! under-determined and the loads x are recovered by exploiting their sparsity and the
//! bounds 0 ≤ x ≤ ulimit. This module is organised the argmin way:
//!
//! * [`kernel`]: the one entry for a design's model matrix ([`kernel::model_matrix`]),
//!   the distance kernel fitted to the paper's Table 1 and the sensing matrix it
//!   predicts for any layout (plus cheap layout-quality proxies);
//! * [`sheet`]: the physical model of the sheet, its fibers and its table (the default
//!   model of a design's matrix);
//! * [`mod@predict`]: a design's predicted response by one named model: the matrix, one
//!   load anywhere, the sensitivity map over the sheet;
//! * [`io`]: measured sensing matrices and shift streams as CSV, reconstructions out;
//! * [`problem`]: the problem — matrix, bounds, column normalisation — kept apart from
//!   the methods that solve it;
//! * [`methods`]: interchangeable reconstruction methods behind one trait
//!   ([`methods::Reconstructor`]), one file each, registered by name
//!   ([`methods::Method::ALL`]), with one result type ([`methods::Reconstruction`]);
//! * [`choice`]: the default method — the most accurate one within a per-frame time
//!   budget for the array's size ([`choice::choose_method`]);
//! * [`mod@reconstruct`]: the one place a method is picked (named, or the default
//!   choice) and frames are reconstructed, in memory: [`fn@reconstruct`] and
//!   [`reconstruct::prepare`] (the live mode's);
//! * [`trust`]: whether a frame's answer can be trusted — the per-frame flags
//!   (`inconsistent` by a χ² test, `ceiling`, `overload`, `ambiguous`, …);
//! * [`faults`]: faults seen across frames (dead or stuck gratings) and the
//!   temperature weights of the common-mode term;
//! * [`run`]: the file use case, [`reconstruct_file`];
//! * [`protocol`]: the paper's 84-test protocol simulated with a seeded noise model,
//!   and the metrics of Table 3 (SNR, SEM, relative error, RR).
//!
//! Units: sensitivities in pm/g, shifts in pm, loads in g, distances in mm.

// Sibling crates under the names the modules used inside one crate.
#[allow(unused_imports)]
use fbgforge_core::{design, family, grating, logs, output, profile, progress, spec};
#[allow(unused_imports)]
use fbgforge_model::{fem, model, prediction, solvers};

pub mod calibrate;
pub mod choice;
pub mod faults;
pub mod io;
pub mod kernel;
pub mod methods;
pub mod predict;
pub mod problem;
pub mod protocol;
pub mod reconstruct;
pub mod run;
pub mod sheet;
pub mod trust;

use nalgebra::DMatrix;
use serde::Serialize;

/// A sensing matrix with the names of its rows (gratings) and columns (cells).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SensingMatrix {
    /// Grating names, one per row.
    pub gratings: Vec<String>,
    /// Cell labels, one per column.
    pub cells: Vec<String>,
    /// Sensitivity of each grating (row) to a load on each cell (column), pm/g.
    #[serde(serialize_with = "serialize_rows")]
    pub sensitivity_pm_per_g: DMatrix<f64>,
}

fn serialize_rows<S: serde::Serializer>(m: &DMatrix<f64>, s: S) -> Result<S::Ok, S::Error> {
    let rows: Vec<Vec<f64>> = (0..m.nrows())
        .map(|i| m.row(i).iter().copied().collect())
        .collect();
    rows.serialize(s)
}

impl SensingMatrix {
    /// Number of gratings (rows).
    pub fn n_gratings(&self) -> usize {
        self.sensitivity_pm_per_g.nrows()
    }
    /// Number of cells (columns).
    pub fn n_cells(&self) -> usize {
        self.sensitivity_pm_per_g.ncols()
    }
}

/// Errors of the array area that a user can cause (bad files, bad options).
#[derive(Debug, thiserror::Error)]
pub enum ArrayError {
    /// A file or value that does not have the expected shape or content.
    #[error("{0}")]
    Input(String),
    /// A method name that does not exist.
    #[error("unknown method `{name}`; the methods are: {known}")]
    UnknownMethod {
        /// The name given.
        name: String,
        /// The names that exist, comma-separated.
        known: String,
    },
}
pub use reconstruct::{reconstruct, Frames, MethodRequest};
pub use run::reconstruct_file;
