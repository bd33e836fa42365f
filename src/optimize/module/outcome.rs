//! What a module optimisation reports: each run, each choice, the whole outcome, and
//! the error that names the constraint no design could meet.

use super::choice::Choice;
use super::evaluate::Evaluation;
use super::settings::{ModuleSettings, Objective};
use super::variables::Variable;
use crate::optimize::quality::Calibration;
use crate::solvers::SolverKind;
use crate::spec::Design;
use serde::Serialize;

/// Summary of one run for the report.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// Solver.
    pub solver: SolverKind,
    /// Start index.
    pub start: usize,
    /// Iterations.
    pub iterations: u64,
    /// Cost evaluations.
    pub evaluations: u64,
    /// Wall time, s.
    pub time_s: f64,
    /// Objective at the run's best point (0 if infeasible).
    pub objective: f64,
    /// Whether the run's best point is feasible.
    pub feasible: bool,
    /// Termination reason.
    pub termination: String,
    /// Best penalised cost after each iteration.
    pub history: Vec<f64>,
}

/// Outcome of one discrete choice.
#[derive(Debug, Clone, Serialize)]
pub struct ChoiceResult {
    /// The choice.
    pub choice: Choice,
    /// Best feasible evaluation, if any.
    pub best: Option<Evaluation>,
    /// When nothing was feasible: the least violating evaluation.
    pub least_violating: Option<Evaluation>,
    /// Every run.
    pub runs: Vec<RunSummary>,
}

/// Outcome of a module optimisation.
#[derive(Debug, Clone, Serialize)]
pub struct ModuleOutcome {
    /// Objective.
    pub objective: Objective,
    /// Unit of the objective.
    pub objective_unit: &'static str,
    /// Variables, in the order of every `x`.
    pub variables: Vec<Variable>,
    /// Search bounds.
    pub lower_bounds: Vec<f64>,
    /// Search bounds.
    pub upper_bounds: Vec<f64>,
    /// The start design's choice and evaluation.
    pub start_choice: Choice,
    /// The start design evaluated (its objective is the bar to beat).
    pub start: Evaluation,
    /// The model that scored the answer, in words (the policy anchored on it).
    pub model: String,
    /// Index of the winning choice in `choices`.
    pub best_choice: usize,
    /// Every choice.
    pub choices: Vec<ChoiceResult>,
    /// The optimised design.
    #[serde(skip)]
    pub design: Design,
    /// Wall time of the whole optimisation, s.
    pub time_s: f64,
    /// Calibration used for the Q model.
    pub calibration: Calibration,
}

/// Name the constraint that cannot be met: across choices, the one violated at the
/// least violating design (by its largest share of the violation).
pub(super) fn infeasible_error(
    choices: &[ChoiceResult],
    settings: &ModuleSettings,
) -> anyhow::Error {
    let least = choices
        .iter()
        .filter_map(|c| c.least_violating.as_ref().map(|e| (c, e)))
        .min_by(|a, b| {
            let (ra, rb) = (a.1.infeasibility_rank(), b.1.infeasibility_rank());
            ra.0.cmp(&rb.0).then(ra.1.total_cmp(&rb.1))
        });
    match least {
        None => anyhow::anyhow!("infeasible: no candidate design could be evaluated"),
        Some((c, e)) => {
            let worst = e
                .constraints
                .iter()
                .filter(|c| c.violation > 0.0)
                .max_by(|a, b| a.violation.total_cmp(&b.violation))
                .expect("infeasible evaluations violate something");
            let vars: Vec<String> = settings
                .vary
                .iter()
                .zip(&e.x)
                .map(|(v, x)| format!("{} = {x:.3}", v.name()))
                .collect();
            anyhow::anyhow!(
                "infeasible: constraint `{}` cannot be met ({}); the closest design ({}, {}) has {}",
                worst.name,
                worst.requirement,
                c.choice,
                vars.join(", "),
                worst.detail
            )
        }
    }
}
