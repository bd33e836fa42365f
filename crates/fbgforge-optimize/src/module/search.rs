//! The search: evaluate (and calibrate on) the start design, search every discrete
//! choice from several starts with every solver, score the table on the model policy
//! (`refine`) so that its best row is the policy's own, search the Pareto front
//! (`front`) and write the design the preference picks.

use super::choice::{choices, start_choice, Choice};
use super::front::{pareto_front, pick_written, tie_notes, tied_objectives, FrontCandidate};
use super::outcome::{infeasible_error, ChoiceResult, Evaluation, ModuleOutcome, RunSummary};
use super::predictor::Predictor;
use super::problem::ModuleProblem;
use super::refine::policy_answer;
use super::robust::UncertaintyRatios;
use super::settings::{check_settings, ModuleSettings, Objective};
use super::ProblemInputs;
use crate::materials::MaterialLibrary;
use crate::progress::Progress;
use crate::quality::{Calibration, MeasuredPrototype};
use crate::solvers::{multi_start, start_points, Run};
use crate::spec::Design;
use rayon::prelude::*;
use std::time::Instant;

/// Trust-region steps on the policy for the other case's row of the front.
const FRONT_REFINE_STEPS: u64 = 8;

impl ProblemInputs<'_> {
    /// The problem of one discrete choice, with the start's uncertainty ratios.
    pub(super) fn problem(&self, choice: Choice) -> anyhow::Result<ModuleProblem> {
        Ok(ModuleProblem::new(
            self.base,
            choice,
            self.lib,
            self.settings,
            self.cal,
            self.predictor.clone(),
        )?
        .with_uncertainty(&self.start_uncertainty))
    }

    /// The problem of one discrete choice with other settings (the front's force
    /// levels).
    pub(super) fn problem_with(
        &self,
        choice: Choice,
        settings: &ModuleSettings,
        uncertainty: &UncertaintyRatios,
    ) -> anyhow::Result<ModuleProblem> {
        Ok(ModuleProblem::new(
            self.base,
            choice,
            self.lib,
            settings,
            self.cal,
            self.predictor.clone(),
        )?
        .with_uncertainty(uncertainty))
    }

    /// Evaluate the start design on the policy with its readings, and calibrate the Q
    /// model on it when a verifier JSON of this design is given.
    fn evaluate_start(
        &mut self,
        start_ch: &Choice,
        measured: Option<&MeasuredPrototype>,
    ) -> anyhow::Result<Evaluation> {
        let probe = self.problem(start_ch.clone())?;
        let x0 = probe.start_point();
        let exact = probe.anchored_at(&x0)?;
        self.start_uncertainty = exact.uncertainty().clone();
        let start = exact.evaluate(&x0);
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
        if self.settings.rate_hz.is_some() {
            // An interrogator rate given on the command line outranks the measured one.
            self.cal.sample_period_s = quality.sample_period_s;
        }
        Ok(self
            .problem(start_ch.clone())?
            .anchored_at(&x0)?
            .evaluate(&x0))
    }

    /// Search one problem from several starts with every solver; its best feasible
    /// point (or the least violating one) and a summary of each run.
    pub(super) fn search(
        &self,
        p: &ModuleProblem,
        extra_starts: &[Vec<f64>],
        seed: u64,
    ) -> anyhow::Result<(Option<Evaluation>, Option<Evaluation>, Vec<RunSummary>)> {
        let settings = self.settings;
        let (lo, hi) = p.box_bounds();
        let mut starts = start_points(&p.start_point(), &lo, &hi, settings.extra_starts, seed);
        starts.extend(extra_starts.iter().cloned());
        let runs: Vec<Run> = multi_start(
            p,
            &settings.solvers,
            &starts,
            seed.wrapping_add(1),
            &settings.run,
        )?;
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
        Ok((best, least, summaries))
    }

    /// Search one choice; keep its best feasible point (or the least violating one).
    fn optimise_choice(&self, ci: usize, ch: &Choice, scale: f64) -> anyhow::Result<ChoiceResult> {
        let mut p = self.problem(ch.clone())?;
        p.set_scale(scale);
        let (best, least, runs) = self.search(&p, &[], self.settings.seed ^ ci as u64)?;
        Ok(ChoiceResult {
            choice: ch.clone(),
            best,
            least_violating: least,
            runs,
        })
    }
}

/// The settings with the interrogator rate resolved: `--rate-hz`, else the design's
/// `interrogator_rate_hz` (2 Hz when absent); a measured prototype's rate replaces the
/// design's in [`ProblemInputs::evaluate_start`].
fn resolved_settings(base: &Design, settings: &ModuleSettings) -> ModuleSettings {
    let mut s = settings.clone();
    let rate = settings.rate_hz.unwrap_or_else(|| {
        base.module
            .as_ref()
            .map_or(crate::spec::Module::DEFAULT_INTERROGATOR_RATE_HZ, |m| {
                m.interrogator_rate_hz()
            })
    });
    s.quality.sample_period_s = 1.0 / rate;
    s
}

/// The optimised design at `x` of `p`, named and described after its start (why it was
/// written, what its contact rests on, the paper's statements it fails), rated for the
/// force and strain limit it was held to, and validated.
fn optimised_design(
    base: &Design,
    settings: &ModuleSettings,
    (p, best, win): (&ModuleProblem, &Evaluation, &Choice),
    (start_objective, failed): (f64, &[String]),
    why: &str,
) -> anyhow::Result<Design> {
    let mut design = p.design_at(&best.x);
    design.name = format!("{}-optimised", base.name.trim_end_matches("-optimised"));
    if let Some(m) = design.module.as_mut() {
        m.limits = Some(crate::spec::Limits {
            max_force_n: settings.max_force_n,
            max_grating_strain_microstrain: settings.max_grating_strain * 1e6,
        });
    }
    let statements = if failed.is_empty() {
        "The paper's statements that predict checks hold on this design (paper_statements_failed: none)".to_string()
    } else {
        format!(
            "It fails the paper's statement(s) that predict checks: paper_statements_failed: {}",
            failed.join(", ")
        )
    };
    let margins = best.margins.map_or(String::new(), |m| {
        format!(
            "; margins at {} N at the far end of the design interval: strain {:.0} µε ({:.1} %), wavelength window {:.3} nm{}",
            settings.max_force_n,
            m.grating_strain_microstrain,
            m.grating_strain_percent,
            m.wavelength_window_nm,
            m.snap_strain_percent
                .map_or(String::new(), |s| format!(", snap strain {s:.2} %"))
        )
    });
    let (name, short) = match settings.objective {
        Objective::Q => ("Q", "Q"),
        Objective::Sensitivity => ("sensitivity", "|K|"),
        Objective::ForceRange => ("force range", "force range"),
    };
    design.description = Some(format!(
        "Optimised by fbgforge optimize from `{}` for {name} ({win}; {why}): {short} = {:.4} {} scored {}, nominal {:.4} (start {:.4}){margins}. {}. {statements}.",
        base.name,
        best.objective,
        settings.objective.unit(),
        settings.robustness.describe(),
        best.nominal_objective,
        start_objective,
        super::statements::contact_basis(&p.design_at(&best.x), win),
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
    let settings = &resolved_settings(base, settings);
    let start_ch = start_choice(base)?;
    let mut inputs = ProblemInputs {
        base,
        lib,
        settings,
        predictor,
        cal: Calibration::identity(&settings.quality),
        start_uncertainty: UncertaintyRatios::default(),
    };
    let start = inputs.evaluate_start(&start_ch, measured)?;
    let scale = if start.feasible() && start.objective > 0.0 {
        start.objective
    } else {
        1.0
    };
    let mut choices_done = inputs.search_choices(scale, progress)?;
    // Away from its anchor the search's K is an estimate (closed-form trend, FE level
    // and readings at an anchor); the table is scored on the policy itself until no
    // estimate beats its best exact row, so its best row is the policy's own.
    let scored = inputs.score_table(&mut choices_done, scale)?;
    let Some((bi, win_problem)) = scored else {
        return Err(inputs.infeasible_under_policy(&choices_done));
    };
    let (candidates, problems) =
        inputs.front_candidates(&mut choices_done, (bi, win_problem), scale)?;
    let (bi, win_problem) = inputs.table_best(&choices_done, &problems)?;
    let best_eval = choices_done[bi]
        .best
        .clone()
        .expect("the best row is feasible");
    let mut front = pareto_front(candidates, &win_problem.variables);
    for f in front.iter_mut() {
        let c = inputs.written_checks(&f.choice, &f.evaluation.x)?;
        f.paper_statements_failed = c.paper_statements_failed;
        f.model_error_over_max = c.model_error_over_max;
    }
    let best_checks = inputs.written_checks(&choices_done[bi].choice, &best_eval.x)?;
    let (written, why) = pick_written(
        &front,
        settings,
        (
            &choices_done[bi].choice,
            &best_eval,
            &best_checks.paper_statements_failed,
            &best_checks.model_error_over_max,
        ),
    );
    let (failed, over) = match written {
        Some(i) => (
            front[i].paper_statements_failed.clone(),
            front[i].model_error_over_max.clone(),
        ),
        None => (
            best_checks.paper_statements_failed,
            best_checks.model_error_over_max,
        ),
    };
    let (problem, eval, choice) = match written {
        Some(i) => {
            let f = &front[i];
            let p = inputs
                .problem(f.choice.clone())?
                .anchored_at(&f.evaluation.x)?;
            (p, f.evaluation.clone(), f.choice.clone())
        }
        None => (
            win_problem.clone(),
            best_eval.clone(),
            choices_done[bi].choice.clone(),
        ),
    };
    let design = optimised_design(
        base,
        settings,
        (&problem, &eval, &choice),
        (start.objective, &failed),
        &why,
    )?;
    let ties = tie_notes(&choices_done, &front, settings);
    let mut warnings = written_warnings(&choice, &design, &eval);
    // A warning, not a constraint: the search varies walls and materials, not the
    // gratings' length or modulation, and the check costs an FE solve per
    // configuration; it is run once, on the written design.
    warnings.extend(crate::prediction::spectrum::design_warnings(
        &design,
        &crate::fem::GeometryCache::default(),
    )?);
    if !failed.is_empty() {
        warnings.push(format!(
            "the written design fails the paper's statement(s) {} (predict names the numbers)",
            failed.join(", ")
        ));
    }
    if !over.is_empty() {
        warnings.push(format!(
            "the written design states a model error over 15 % on {} (every design found does; predict names why)",
            over.join(", ")
        ));
    }
    let front_dropped_objectives = tied_objectives(&front, settings);
    Ok(ModuleOutcome {
        objective: settings.objective,
        objective_unit: settings.objective.unit(),
        robustness: settings.robustness.describe(),
        rate_hz: 1.0 / inputs.cal.sample_period_s,
        variables: win_problem.variables.clone(),
        lower_bounds: win_problem.box_bounds().0,
        upper_bounds: win_problem.box_bounds().1,
        start_choice: start_ch,
        start,
        model: problem.model_description().to_string(),
        best_choice: bi,
        choices: choices_done,
        pareto_front: front,
        prefer: settings.prefer,
        written_front_index: written,
        written_choice: choice,
        written: eval,
        written_because: why,
        paper_statements_failed: failed,
        paper_statements: settings.paper_statements,
        front_dropped_objectives,
        ties,
        warnings,
        design,
        time_s: t0.elapsed().as_secs_f64(),
        calibration: inputs.cal,
    })
}

/// What a lab should know before printing the written design: that its Case I K rests
/// on the shipped default contact, and every grating whose nominal K breaks its
/// bounding readings.
fn written_warnings(choice: &Choice, design: &Design, eval: &Evaluation) -> Vec<String> {
    let mut warnings = Vec::new();
    if choice.insert_material.is_some()
        && design
            .module
            .as_ref()
            .is_some_and(|m| m.contact_radius_is_default())
    {
        warnings.push(format!(
            "Case I: {}",
            crate::prediction::DEFAULT_CONTACT_WARNING
        ));
    }
    for r in &eval.readings {
        let (v, why) = r.band_violation();
        if v > 0.0 {
            warnings.push(why);
        }
    }
    warnings
}

/// Index of the row with the largest objective among those `keep` lets through.
fn best_row(choices: &[ChoiceResult], keep: impl Fn(&ChoiceResult) -> bool) -> Option<usize> {
    (0..choices.len())
        .filter(|&i| keep(&choices[i]))
        .max_by(|&a, &b| {
            let o = |i: usize| choices[i].best.as_ref().map_or(0.0, |e| e.objective);
            o(a).total_cmp(&o(b))
        })
}

impl ProblemInputs<'_> {
    /// Search every material choice (in parallel), one progress step each; an error
    /// naming the constraint no design meets when none is feasible.
    fn search_choices(
        &self,
        scale: f64,
        progress: &dyn Progress,
    ) -> anyhow::Result<Vec<ChoiceResult>> {
        let list = choices(self.base, self.lib, self.settings)?;
        progress.begin("optimise", list.len() as u64);
        let results: Vec<anyhow::Result<ChoiceResult>> = list
            .par_iter()
            .enumerate()
            .map(|(ci, ch)| {
                let r = self.optimise_choice(ci, ch, scale)?;
                progress.advance(1);
                Ok(r)
            })
            .collect();
        progress.end();
        let done: Vec<ChoiceResult> = results.into_iter().collect::<anyhow::Result<_>>()?;
        if done.iter().all(|c| c.best.is_none()) {
            return Err(infeasible_error(&done, self.settings));
        }
        Ok(done)
    }

    /// The Pareto front's candidates: every exact row of the table, and the winner's
    /// choice and the best choice of the other case (insert or hollow), each searched
    /// from its table answer to the widest force range it reaches and at levels
    /// between, every design scored on the policy. Returns them with the problems
    /// anchored on the rows scored here (the winner's first).
    #[allow(clippy::type_complexity)]
    fn front_candidates(
        &self,
        choices_done: &mut [ChoiceResult],
        (bi, win_problem): (usize, ModuleProblem),
        scale: f64,
    ) -> anyhow::Result<(Vec<FrontCandidate>, Vec<(usize, ModuleProblem)>)> {
        let mut front_choices = vec![bi];
        let winner_hollow = choices_done[bi].choice.insert_material.is_none();
        if let Some(oi) = best_row(choices_done, |c| {
            c.best.is_some() && c.choice.insert_material.is_none() != winner_hollow
        }) {
            front_choices.push(oi);
        }
        // Every exact row of the table may enter the front too.
        let mut candidates: Vec<FrontCandidate> = choices_done
            .iter()
            .enumerate()
            .filter(|(i, _)| !front_choices.contains(i))
            .filter_map(|(_, c)| {
                c.best
                    .as_ref()
                    .filter(|e| e.exact && e.feasible())
                    .map(|e| FrontCandidate::new(c.choice.clone(), e.clone()))
            })
            .collect();
        let mut problems: Vec<(usize, ModuleProblem)> = vec![(bi, win_problem)];
        for &ci in &front_choices {
            let p = match problems.iter().find(|(i, _)| *i == ci) {
                Some((_, p)) => p.clone(),
                None => match self.score_front_row(&mut choices_done[ci], scale)? {
                    Some(p) => {
                        problems.push((ci, p.clone()));
                        p
                    }
                    None => continue,
                },
            };
            let row = choices_done[ci].best.clone().expect("feasible");
            candidates.push(FrontCandidate::new(
                choices_done[ci].choice.clone(),
                row.clone(),
            ));
            candidates.extend(self.front_levels(&choices_done[ci].choice, &p, &row)?);
        }
        Ok((candidates, problems))
    }

    /// Score a row for the front on the policy, walked a few trust-region steps on it
    /// (a design the policy refuses is moved away by the constraints' magnitudes): the
    /// row keeps its exact value; its problem, anchored on it, or `None` when the
    /// policy finds it infeasible (the row then holds it as its least violating).
    fn score_front_row(
        &self,
        row: &mut ChoiceResult,
        scale: f64,
    ) -> anyhow::Result<Option<ModuleProblem>> {
        let found = row.best.clone().expect("feasible rows only");
        let mut p = self.problem(row.choice.clone())?;
        p.set_scale(scale);
        let p = p.anchored_at(&found.x)?;
        let e = p.evaluate(&found.x);
        let (p, e) = policy_answer(p.clone(), e.clone(), self.settings, FRONT_REFINE_STEPS)
            .unwrap_or((p, e));
        if !e.feasible() {
            row.best = None;
            row.least_violating = Some(e);
            return Ok(None);
        }
        row.best = Some(e);
        Ok(Some(p))
    }

    /// The best of the table: its best exact row (a row scored for the front may beat
    /// the refined winner; every estimate lies below the winner), with its problem.
    fn table_best(
        &self,
        choices_done: &[ChoiceResult],
        problems: &[(usize, ModuleProblem)],
    ) -> anyhow::Result<(usize, ModuleProblem)> {
        let bi = best_row(choices_done, |c| c.best.as_ref().is_some_and(|e| e.exact))
            .expect("the refined winner is an exact row");
        let p = match problems.iter().find(|(i, _)| *i == bi) {
            Some((_, p)) => p.clone(),
            None => {
                let x = choices_done[bi].best.as_ref().expect("feasible").x.clone();
                self.problem(choices_done[bi].choice.clone())?
                    .anchored_at(&x)?
            }
        };
        Ok((bi, p))
    }
}

impl ProblemInputs<'_> {
    /// One choice's searches for the front: the widest force range it reaches (the
    /// force range maximised, with the user's limits as constraints), then the best
    /// objective with the limits held at `front_levels` forces evenly between the
    /// user's largest force and that range. Each search runs on the estimate with the
    /// readings of `exact` (the choice anchored on its table answer `row`); each answer
    /// is scored on the policy at the user's force.
    fn front_levels(
        &self,
        choice: &Choice,
        exact: &ModuleProblem,
        row: &Evaluation,
    ) -> anyhow::Result<Vec<FrontCandidate>> {
        let f = self.settings.max_force_n;
        let seed = self.settings.seed.wrapping_add(7919);
        let score = |x: &[f64]| -> anyhow::Result<Option<FrontCandidate>> {
            let e = exact.anchored_at(x)?.evaluate(x);
            Ok(e.feasible().then(|| FrontCandidate::new(choice.clone(), e)))
        };
        let wide_settings = ModuleSettings {
            objective: Objective::ForceRange,
            ..self.settings.clone()
        };
        let mut p = self.problem_with(choice.clone(), &wide_settings, exact.uncertainty())?;
        p.set_scale(f);
        let (wide, _, _) = self.search(&p, std::slice::from_ref(&row.x), seed)?;
        let Some(wide) = wide else {
            return Ok(Vec::new());
        };
        let mut out: Vec<FrontCandidate> = score(&wide.x)?.into_iter().collect();
        let widest = out
            .first()
            .and_then(|c| c.objectives())
            .map_or(wide.objective, |o| o.force_range_n);
        let n = self.settings.front_levels;
        let levels: Vec<f64> = (1..=n)
            .map(|j| f + (widest - f) * j as f64 / (n + 1) as f64)
            .filter(|&l| l > f * 1.01)
            .collect();
        let found: Vec<anyhow::Result<Option<Vec<f64>>>> = levels
            .par_iter()
            .enumerate()
            .map(|(li, &level)| {
                let s = ModuleSettings {
                    max_force_n: level,
                    ..self.settings.clone()
                };
                let mut p = self.problem_with(choice.clone(), &s, exact.uncertainty())?;
                p.set_scale(row.objective.max(1e-300));
                let seed = seed.wrapping_add(li as u64 + 1);
                let (b, _, _) = self.search(&p, &[row.x.clone(), wide.x.clone()], seed)?;
                Ok(b.map(|e| e.x))
            })
            .collect();
        for x in found {
            if let Some(x) = x? {
                out.extend(score(&x)?);
            }
        }
        Ok(out)
    }
}
