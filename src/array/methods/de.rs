//! `de`: the paper's replica, ‖Âz − y‖² + σ Σ z_jᵖ with p = 0.01, by differential
//! evolution (DE/rand/1/bin, 150 individuals, ≤ 1500 generations).

use super::*;
use crate::array::de::{DifferentialEvolution, PenalisedCost};
use argmin::core::{Executor, State, TerminationReason};

/// The registry entry of `de`.
pub(super) const ENTRY: MethodEntry = MethodEntry {
    name: "de",
    default_penalty: 4.0,
    has_penalty: true,
    penalty_grid: doubling_grid,
    build: |common, s| {
        Ok(Box::new(De {
            common,
            settings: *s,
        }))
    },
};

pub(super) struct De {
    pub(super) common: Common,
    pub(super) settings: MethodSettings,
}

/// FNV-1a over the bits of a frame, mixed into the seed so that equal frames give
/// equal answers whatever order or thread they are reconstructed in.
fn frame_seed(seed: u64, y: &[f64]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64 ^ seed;
    for v in y {
        for byte in v.to_bits().to_le_bytes() {
            h ^= byte as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

impl Reconstructor for De {
    fn method(&self) -> Method {
        Method::De
    }

    fn reconstruct(&self, y: &[f64]) -> Reconstruction {
        if self.common.problem.check_shifts(y).is_err() {
            return self.common.unusable();
        }
        let p = &self.common.problem;
        let cost = PenalisedCost::new(
            &p.working,
            &DVector::from_column_slice(y),
            self.settings.penalty,
            0.01,
        );
        let lower = vec![0.0; p.n_cells()];
        let upper: Vec<f64> = p.upper.iter().copied().collect();
        let solver =
            match DifferentialEvolution::new(lower, upper, frame_seed(self.settings.seed, y)) {
                Ok(s) => s.with_population(self.settings.de_population),
                Err(_) => return self.common.unusable(),
            };
        let generations = self.settings.de_generations;
        match Executor::new(cost, solver)
            .configure(|s| s.max_iters(generations))
            .run()
        {
            Ok(res) => {
                let st = res.state();
                let converged = matches!(
                    st.get_termination_reason(),
                    Some(TerminationReason::SolverConverged)
                );
                let iterations = st.get_iter();
                match st.get_best_param() {
                    Some(z) => self.common.finish(z, y, converged, iterations),
                    None => self.common.unusable(),
                }
            }
            Err(_) => self.common.unusable(),
        }
    }
}
