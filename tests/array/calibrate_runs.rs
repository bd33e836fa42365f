//! Shared pieces of the calibration tests: the shipped array, its true matrix, a run
//! made by `synth::array_log` and analysed in memory as `calibrate-array` would.

use crate::common;
use fbgforge::array::calibrate::{self, analyse, AnalysisInputs, Calibration, Loading};
use fbgforge::array::kernel::model_matrix;
use fbgforge::array::SensingMatrix;
use fbgforge::synth::array_log::{self, ArrayRunSettings};

/// The paper's array as shipped.
pub fn design() -> fbgforge::spec::Design {
    common::shipped("tactile-array-60x80.toml")
}

/// The true matrix of the synthetic sheet: the power law fitted to Table 1.
pub fn truth() -> SensingMatrix {
    calibrate::power_law_matrix(&design()).unwrap()
}

/// `events` happen on a sheet whose matrix is `truth`; the lab's schedule says
/// `schedule`; analysed against the design's own prediction.
pub fn analysed(
    truth: &SensingMatrix,
    events: &[Loading],
    schedule: &[Loading],
    s: &ArrayRunSettings,
) -> Calibration {
    let d = design();
    let log = array_log::synth_array_run(&d, truth, events, s).unwrap();
    let data = array_log::run_data(&d, &log).unwrap();
    let p = model_matrix(&d, None).unwrap();
    analyse(&AnalysisInputs {
        gratings: &truth.gratings,
        cells: &truth.cells,
        data: &data,
        schedule,
        predicted: &p.matrix.sensitivity_pm_per_g,
        model: &p.description,
        resolution_pm: 0.5,
        tolerance: 0.4,
    })
    .unwrap()
}

/// The kinds of the faults found, in order.
pub fn kinds(c: &Calibration) -> Vec<&'static str> {
    c.faults.iter().map(|f| f.kind.name()).collect()
}

/// 200 g on each cell in turn, 10 s on, 10 s off, from 10 s.
pub fn cell_by_cell() -> Vec<Loading> {
    array_log::cell_by_cell(&[0, 1, 2, 3, 4, 5, 6, 7], 200.0, 10.0, 10.0, 10.0)
}

/// The paper's interrogator noise at 10 Hz.
pub fn lab() -> ArrayRunSettings {
    ArrayRunSettings {
        noise_pm: 0.5,
        sample_rate_hz: 10.0,
        ..Default::default()
    }
}
