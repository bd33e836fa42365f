//! What a module optimisation reports: each run, each choice, the whole outcome, and
//! the error that names the constraint no design could meet.

use super::choice::Choice;
use super::robust::FrontObjectives;
use super::settings::{ModuleSettings, Objective, Preference};
use super::variables::Variable;
use crate::prediction::KReadings;
use crate::quality::{Calibration, QualityBreakdown};
use crate::solvers::SolverKind;
use crate::spec::Design;
use serde::Serialize;
use std::collections::BTreeMap;

/// One constraint's value at a design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConstraintValue {
    /// Constraint name (stable, used in errors).
    pub name: String,
    /// What it requires, in words with units.
    pub requirement: String,
    /// Normalised violation, 0 when met.
    pub violation: f64,
    /// The measured value, in words with units.
    pub detail: String,
}

/// A design evaluated: objective, Q breakdown and constraints.
#[derive(Debug, Clone, Serialize)]
pub struct Evaluation {
    /// Variable values, in `ModuleProblem::variables` order.
    pub x: Vec<f64>,
    /// Objective value (worst strain grating) as scored under the robustness setting,
    /// or 0 when the model failed.
    pub objective: f64,
    /// The objective with the nominal K.
    pub nominal_objective: f64,
    /// Whether the numbers are the model policy's own at this design (anchored on it),
    /// not the search's estimate carried from an anchor elsewhere.
    pub exact: bool,
    /// Q breakdown per strain grating (nominal K).
    pub gratings: Vec<QualityBreakdown>,
    /// Per strain grating: the nominal K, the contact window's ends and the bounding
    /// readings, pm/N.
    pub readings: Vec<KReadings>,
    /// The Pareto front's objectives, when the model predicted the design.
    pub objectives: Option<FrontObjectives>,
    /// What the physical limits leave to spare at the far end of the design interval,
    /// when the model predicted the design.
    pub margins: Option<Margins>,
    /// Every constraint.
    pub constraints: Vec<ConstraintValue>,
}

/// The margins a design keeps on its physical limits, each in its own units, with
/// every grating at the far end of its design interval (its largest |K| under the
/// model's stated error); negative when the limit is broken.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Margins {
    /// The strain limit less the largest |grating strain| at the largest force, µε.
    pub grating_strain_microstrain: f64,
    /// That margin as a share of the limit, percent.
    pub grating_strain_percent: f64,
    /// The share of the limit a design must keep (`ModuleSettings.strain_margin_fraction`),
    /// percent.
    pub required_strain_margin_percent: f64,
    /// The smallest distance of any grating's range (at the largest force, ± the
    /// temperature span) to the edges of its wavelength window, nm.
    pub wavelength_window_nm: f64,
    /// The cap material's permissible strain less the snap-fit's strain, percent
    /// (`None` without a snap-fit).
    pub snap_strain_percent: Option<f64>,
}

impl Evaluation {
    /// Sum of normalised violations.
    pub(crate) fn total_violation(&self) -> f64 {
        self.constraints.iter().map(|c| c.violation).sum()
    }
    /// How far from feasible, for ranking infeasible designs: designs whose geometry,
    /// spec or model fails rank behind designs that only break a physics constraint
    /// (strain, wavelength window), since only the latter were checked in full.
    pub(crate) fn infeasibility_rank(&self) -> (u8, f64) {
        let geometric = self
            .constraints
            .iter()
            .any(|c| c.violation > 0.0 && !PHYSICS_CONSTRAINTS.contains(&c.name.as_str()));
        (u8::from(geometric), self.total_violation())
    }

    /// True when every constraint is met.
    pub fn feasible(&self) -> bool {
        self.constraints.iter().all(|c| c.violation <= 0.0)
    }
}

/// Constraints checked on the model's prediction (only once the geometry is valid).
pub const PHYSICS_CONSTRAINTS: [&str; 3] = ["grating_strain", "wavelength_window", "contact_band"];

/// One design of the Pareto front.
#[derive(Debug, Clone, Serialize)]
pub struct FrontDesign {
    /// Core material and insert.
    pub choice: Choice,
    /// The design's variables under their names (`outer_diameter_mm`, `cap_wall_mm`,
    /// `core_wall_mm`, `dome_height_ratio`, ...).
    pub variables: BTreeMap<String, f64>,
    /// Its objectives: `sensitivity_pm_per_n`, `force_range_n`, `max_lag_s`,
    /// `r_squared` (with the nominal |K| and Q beside them).
    pub objectives: FrontObjectives,
    /// Per grating: nominal K, the contact window's ends and the bounding readings.
    pub readings: Vec<KReadings>,
    /// Whether it is the knee of the front.
    pub knee: bool,
    /// The paper's statements `predict` finds failing on this design as written (empty
    /// when every one checked holds).
    pub paper_statements_failed: Vec<String>,
    /// Its rows whose stated model error exceeds 15 % (`prediction::MAX_MODEL_ERROR`)
    /// at the finest mesh the policy refines to, each named with its grating, case,
    /// insert and error: such a design is not written while another design of the
    /// front (or the table's best) states every row within 15 %.
    pub model_error_over_max: Vec<String>,
    /// The evaluation behind it.
    #[serde(skip)]
    pub evaluation: Evaluation,
}

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
    /// How K was scored over the model's uncertainty, in words.
    pub robustness: String,
    /// The interrogator's sample rate Δt_max was floored at, Hz.
    pub rate_hz: f64,
    /// Variables, in the order of every `x`.
    pub variables: Vec<Variable>,
    /// Search bounds.
    pub lower_bounds: Vec<f64>,
    /// Search bounds.
    pub upper_bounds: Vec<f64>,
    /// The start design's choice and evaluation.
    pub start_choice: Choice,
    /// The start design evaluated on the policy (its objective is the bar to beat).
    pub start: Evaluation,
    /// The model that scored the written design, in words (the policy anchored on it).
    pub model: String,
    /// Index of the table's best choice in `choices` (by the scalar objective, scored
    /// on the policy: no row's value exceeds it).
    pub best_choice: usize,
    /// Every choice: its best design, scored on the policy (`exact`) or, below the
    /// best, the search's estimate.
    pub choices: Vec<ChoiceResult>,
    /// The non-dominated designs over sensitivity, force range, lag and R², by force
    /// range, each scored on the policy.
    pub pareto_front: Vec<FrontDesign>,
    /// Which design was written.
    pub prefer: Preference,
    /// Its index in `pareto_front` (`None`: the table's best, not on the front).
    pub written_front_index: Option<usize>,
    /// Its choice.
    pub written_choice: Choice,
    /// Its evaluation.
    pub written: Evaluation,
    /// Why it was written, in words.
    pub written_because: String,
    /// The paper's statements `predict` finds failing on the written design (empty when
    /// every one checked holds).
    pub paper_statements_failed: Vec<String>,
    /// What was done with designs that fail a statement.
    pub paper_statements: super::settings::PaperStatementsPolicy,
    /// The front's objectives on which every design ties, each with why it was dropped
    /// from the front's comparison (the others are what the front trades).
    pub front_dropped_objectives: Vec<String>,
    /// Where the objectives tie and why.
    pub ties: Vec<String>,
    /// What a lab should know before printing the written design (e.g. that its Case I
    /// K rests on the shipped default contact, chosen, not measured).
    pub warnings: Vec<String>,
    /// The optimised design.
    #[serde(skip)]
    pub design: Design,
    /// Wall time of the whole optimisation, s.
    pub time_s: f64,
    /// Calibration used for the Q model.
    pub calibration: Calibration,
}

impl ModuleOutcome {
    /// How front design `i` is marked in tables: `knee`, `written`, both, or nothing.
    pub fn front_tag(&self, i: usize) -> &'static str {
        let knee = self.pareto_front.get(i).is_some_and(|f| f.knee);
        match (knee, self.written_front_index == Some(i)) {
            (true, true) => "knee, written",
            (true, false) => "knee",
            (false, true) => "written",
            (false, false) => "",
        }
    }
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
