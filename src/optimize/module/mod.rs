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
//! point (`evaluate`), the search over every choice (`search`), the refinement of the
//! winner on the model policy (`refine`), the outcome types (`outcome`) and the
//! landscape plot's grid (`landscape`).

mod choice;
mod derive;
mod evaluate;
mod landscape;
mod outcome;
mod predictor;
mod problem;
mod refine;
mod search;
mod settings;
mod variables;

pub use choice::{choices, start_choice, Choice};
pub use evaluate::{wavelength_windows, ConstraintValue, Evaluation, PHYSICS_CONSTRAINTS};
pub use landscape::{landscape, LandscapePoint};
pub use outcome::{ChoiceResult, ModuleOutcome, RunSummary};
pub use predictor::{model_predictor, AnchorCache, PredictFn, Predictor};
pub use problem::{ModuleProblem, TIE_WEIGHT};
pub use search::optimise_module;
pub use settings::{ModuleSettings, Objective};
pub use variables::{parse_bounds, Variable};
