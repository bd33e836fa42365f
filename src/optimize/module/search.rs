//! The search: evaluate (and calibrate on) the start design, search every discrete
//! choice from several starts with every solver, rank the choices, refine the winner
//! on the model policy (`refine`) and write the optimised design.

use super::choice::{choices, start_choice, Choice};
use super::evaluate::Evaluation;
use super::outcome::{infeasible_error, ChoiceResult, ModuleOutcome, RunSummary};
use super::predictor::Predictor;
use super::problem::ModuleProblem;
use super::refine::policy_order;
use super::settings::{check_settings, ModuleSettings, Objective};
use crate::optimize::materials::MaterialLibrary;
use crate::optimize::quality::{Calibration, MeasuredPrototype};
use crate::progress::Progress;
use crate::solvers::{multi_start, start_points, Run};
use crate::spec::Design;
use rayon::prelude::*;
use std::time::Instant;

/// What every choice's problem is built from.
pub(super) struct ProblemInputs<'a> {
    base: &'a Design,
    lib: &'a MaterialLibrary,
    pub(super) settings: &'a ModuleSettings,
    predictor: Predictor,
    /// Calibration of the Q model (identity unless a prototype was measured).
    cal: Calibration,
}

impl ProblemInputs<'_> {
    /// The problem of one discrete choice.
    pub(super) fn problem(&self, choice: Choice) -> anyhow::Result<ModuleProblem> {
        ModuleProblem::new(
            self.base,
            choice,
            self.lib,
            self.settings,
            self.cal,
            self.predictor.clone(),
        )
    }

    /// Evaluate the start design, and calibrate the Q model on it when a verifier JSON
    /// of this design is given.
    fn evaluate_start(
        &mut self,
        start_ch: &Choice,
        measured: Option<&MeasuredPrototype>,
    ) -> anyhow::Result<Evaluation> {
        let probe = self.problem(start_ch.clone())?;
        let x0 = probe.start_point();
        let start = probe.evaluate(&x0);
        let (Some(meas), false) = (measured, start.gratings.is_empty()) else {
            return Ok(start);
        };
        // The lag is the same for every grating of a core; stiffening differs a little,
        // so the verifier's mean R² is matched against the mean model value.
        let n = start.gratings.len() as f64;
        let lin = start
            .gratings
            .iter()
            .map(|g| g.r_squared_linearity)
            .sum::<f64>()
            / n;
        let quality = &self.settings.quality;
        self.cal = meas.calibrate(start.gratings[0].lag_s, lin, quality);
        Ok(self.problem(start_ch.clone())?.evaluate(&x0))
    }

    /// Search one choice from several starts with every solver; keep its best feasible
    /// point (or the least violating one) and a summary of each run.
    fn optimise_choice(&self, ci: usize, ch: &Choice, scale: f64) -> anyhow::Result<ChoiceResult> {
        let settings = self.settings;
        let mut p = self.problem(ch.clone())?;
        p.set_scale(scale);
        let (lo, hi) = p.box_bounds();
        let seed = settings.seed ^ ci as u64;
        let starts = start_points(&p.start_point(), &lo, &hi, settings.extra_starts, seed);
        let seed = settings.seed.wrapping_add(ci as u64);
        let runs: Vec<Run> = multi_start(&p, &settings.solvers, &starts, seed, &settings.run)?;
        // The best point of each run comes from argmin's state; the start point
        // is a candidate too (every Nelder–Mead run starts there).
        let evals: Vec<Evaluation> = std::iter::once(p.evaluate(&p.start_point()))
            .chain(runs.iter().map(|r| p.evaluate(&r.best_x)))
            .collect();
        let summaries = runs
            .into_iter()
            .zip(&evals[1..])
            .map(|(r, e)| RunSummary {
                solver: r.solver,
                start: r.start,
                iterations: r.iterations,
                evaluations: r.evaluations,
                time_s: r.time_s,
                objective: if e.feasible() { e.objective } else { 0.0 },
                feasible: e.feasible(),
                termination: r.termination,
                history: r.history,
            })
            .collect();
        let best = p.best_feasible(&evals).cloned();
        let least = if best.is_none() {
            p.least_violating(&evals).cloned()
        } else {
            None
        };
        Ok(ChoiceResult {
            choice: ch.clone(),
            best,
            least_violating: least,
            runs: summaries,
        })
    }
}

/// The optimised design at the winner's point, named and described after its start,
/// and validated.
fn optimised_design(
    base: &Design,
    settings: &ModuleSettings,
    (p, best, win): (&ModuleProblem, &Evaluation, &Choice),
    start_objective: f64,
) -> anyhow::Result<Design> {
    let mut design = p.design_at(&best.x);
    design.name = format!("{}-optimised", base.name.trim_end_matches("-optimised"));
    design.description = Some(format!(
        "Optimised by fbgforge optimize from `{}` for {} ({}): {} = {:.4} {} (start {:.4})",
        base.name,
        match settings.objective {
            Objective::Q => "Q",
            Objective::Sensitivity => "sensitivity",
        },
        win,
        match settings.objective {
            Objective::Q => "Q",
            Objective::Sensitivity => "|K|",
        },
        best.objective,
        settings.objective.unit(),
        start_objective
    ));
    design
        .validate()
        .map_err(|e| anyhow::anyhow!("internal: the optimised design does not validate: {e}"))?;
    Ok(design)
}

/// Optimise a module design. `progress` hears one stage with one step per choice.
pub fn optimise_module(
    base: &Design,
    lib: &MaterialLibrary,
    settings: &ModuleSettings,
    measured: Option<&MeasuredPrototype>,
    predictor: Predictor,
    progress: &dyn Progress,
) -> anyhow::Result<ModuleOutcome> {
    let t0 = Instant::now();
    check_settings(lib, settings)?;
    let start_ch = start_choice(base)?;
    let mut inputs = ProblemInputs {
        base,
        lib,
        settings,
        predictor,
        cal: Calibration::identity(&settings.quality),
    };
    let start = inputs.evaluate_start(&start_ch, measured)?;
    let scale = if start.feasible() && start.objective > 0.0 {
        start.objective
    } else {
        1.0
    };
    let list = choices(base, lib, settings)?;
    progress.begin("optimise", list.len() as u64);
    let results: Vec<anyhow::Result<ChoiceResult>> = list
        .par_iter()
        .enumerate()
        .map(|(ci, ch)| {
            let r = inputs.optimise_choice(ci, ch, scale)?;
            progress.advance(1);
            Ok(r)
        })
        .collect();
    progress.end();
    let mut choices_done: Vec<ChoiceResult> = results.into_iter().collect::<anyhow::Result<_>>()?;
    // Near-ties of merit go to the least change from the start.
    let mut ranker = inputs.problem(start_ch.clone())?;
    ranker.set_scale(scale);
    let best_choice = choices_done
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.best.as_ref().map(|b| (i, ranker.merit(b))))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i);
    let Some(bi) = best_choice else {
        return Err(infeasible_error(&choices_done, settings));
    };
    // Away from its anchor the optimiser's K is an estimate (closed-form trend, FE level
    // at the anchor); the answer is refined on the policy itself, so what is reported
    // and written is the policy's own prediction of the design.
    let order = policy_order(&choices_done, &ranker, &start_ch);
    let (bi, p, best_eval) = inputs.policy_refined(&choices_done, &order, bi)?;
    // The other choices keep their estimated answers; the winner's is the policy's.
    choices_done[bi].best = Some(best_eval.clone());
    let winner = (&p, &best_eval, &choices_done[bi].choice);
    let design = optimised_design(base, settings, winner, start.objective)?;
    Ok(ModuleOutcome {
        objective: settings.objective,
        objective_unit: settings.objective.unit(),
        variables: p.variables.clone(),
        lower_bounds: p.lo.clone(),
        upper_bounds: p.hi.clone(),
        start_choice: start_ch,
        start,
        model: p.model_description().to_string(),
        best_choice: bi,
        choices: choices_done,
        design,
        time_s: t0.elapsed().as_secs_f64(),
        calibration: inputs.cal,
    })
}
