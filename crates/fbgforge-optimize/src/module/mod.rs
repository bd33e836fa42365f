//! Module optimisation: for each discrete choice of core material and insert (or a
//! hollow core), search the continuous design variables (outer diameter, wall
//! thicknesses, dome height, overall height) for the largest Q (or sensitivity) that
//! meets every constraint.
//!
//! The problem ([`ModuleProblem`], a [`BoxProblem`](crate::solvers::BoxProblem)) is separate from the method
//! ([`SolverKind`](crate::solvers::SolverKind)). Bounds are a feasible parameterisation (the solvers work in the
//! box); the other constraints enter the cost as an exact (L1) penalty, and the problem
//! itself remembers the best *feasible* design it has evaluated, so the answer always
//! satisfies every constraint and, since the starting design is evaluated first, never
//! has a lower objective than the start.
//!
//! Derived dimensions follow the variables by fixed rules (documented in
//! docs/optimize.md): the overall height, pillars, holes and grating heights scale with
//! the diameter, floored at what the printer can make.
//!
//! One concern per file: the settings and what to maximise (`settings`), the
//! variables and their bounds (`variables`), the discrete material choices (`choice`),
//! the model the problem asks (`predictor`), the problem itself (`problem`: box, cost,
//! merit), the derivation rules (`derive`), the constraints and the objective at a
//! point (`evaluate`), the model's uncertainty carried through the search and the
//! front's objectives (`robust`), the search over every choice (`search`), the table
//! scored on the model policy and the winner's refinement (`refine`), the Pareto front
//! and the preference that picks the written design (`front`), the outcome types
//! (`outcome`) and the landscape plot's grid (`landscape`).
//!
//! K is scored over the model's own uncertainty (`ModuleSettings::robustness`: by
//! default the worst case over the design interval: Case I's contact window, Case II's
//! closed form and stated cylinders' reading, each widened by its model error) beside
//! its nominal value; the strain and wavelength limits hold at the interval's far end
//! with a margin; and a design whose nominal K lies outside its bounding contact
//! readings widened by its model error, or whose sign is not fixed across them, is
//! infeasible (`contact_band`).

mod choice;
mod derive;
mod evaluate;
mod front;
mod landscape;
mod outcome;
mod predictor;
mod problem;
mod refine;
mod robust;
mod search;
mod settings;
mod statements;
mod variables;

pub use choice::{choices, start_choice, Choice};
pub use front::{pareto_front, FrontCandidate};
pub use landscape::{landscape, LandscapePoint};
pub use outcome::{
    ChoiceResult, ConstraintValue, Evaluation, FrontDesign, Margins, ModuleOutcome, RunSummary,
    PHYSICS_CONSTRAINTS,
};
pub use predictor::{model_predictor, AnchorCache, PredictFn, Predictor, ReadingsCache};
pub use problem::{wavelength_windows, ModuleProblem, TIE_WEIGHT};
pub use robust::{FrontObjectives, UncertaintyRatios};
pub use search::optimise_module;
pub use settings::PaperStatementsPolicy;
pub use settings::{ModuleSettings, Objective, Preference};
pub use statements::contact_basis;
pub use variables::{parse_bounds, Variable};

use crate::materials::MaterialLibrary;
use crate::quality::Calibration;
use crate::spec::Design;

/// What every choice's problem is built from.
struct ProblemInputs<'a> {
    base: &'a Design,
    lib: &'a MaterialLibrary,
    settings: &'a ModuleSettings,
    predictor: Predictor,
    /// Calibration of the Q model (identity unless a prototype was measured).
    cal: Calibration,
    /// The model's uncertainty at the start, carried to every choice's search.
    start_uncertainty: UncertaintyRatios,
}
