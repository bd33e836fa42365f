//! Scoring the table on the model policy: away from its anchor the search's K is an
//! estimate, so the choices are scored on the policy's own prediction (anchored on
//! each answer, with its readings) in order of estimated objective until no estimate
//! beats the best exact row; the winner's answer is walked by a trust region on the
//! policy. The best row of the table is then the policy's own, and so is what is
//! written.

use super::outcome::{ChoiceResult, Evaluation};
use super::problem::ModuleProblem;
use super::settings::ModuleSettings;
use super::ProblemInputs;
use crate::solvers::multi_start;

impl ProblemInputs<'_> {
    /// Score the table on the policy. Rows are taken in order of their (estimated)
    /// objective; each is scored exactly at its answer while its estimate exceeds the
    /// best exact row so far, and a row that becomes the best is refined by a trust
    /// region. Rows left with estimates lie below the best exact row. Returns the best
    /// row and its problem (anchored on its answer), or `None` when the policy finds no
    /// row feasible.
    pub(super) fn score_table(
        &self,
        choices: &mut [ChoiceResult],
        scale: f64,
    ) -> anyhow::Result<Option<(usize, ModuleProblem)>> {
        let mut order: Vec<usize> = (0..choices.len())
            .filter(|&i| choices[i].best.is_some())
            .collect();
        let est = |c: &ChoiceResult| c.best.as_ref().map_or(f64::NEG_INFINITY, |e| e.objective);
        order.sort_by(|&a, &b| est(&choices[b]).total_cmp(&est(&choices[a])));
        let mut best: Option<(usize, ModuleProblem, f64)> = None;
        for i in order {
            let estimate = est(&choices[i]);
            if best.as_ref().is_some_and(|b| estimate <= b.2) {
                break;
            }
            let found = choices[i].best.clone().expect("filtered");
            let mut p = self.problem(choices[i].choice.clone())?;
            p.set_scale(scale);
            let exact_p = p.anchored_at(&found.x)?;
            let exact = exact_p.evaluate(&found.x);
            let beats = |e: &Evaluation, best: &Option<(usize, ModuleProblem, f64)>| {
                e.feasible() && best.as_ref().is_none_or(|b| e.objective > b.2)
            };
            // The first row, and any row whose exact score beats the best, is refined.
            let refined = if best.is_none() || beats(&exact, &best) {
                policy_answer(exact_p.clone(), exact.clone(), self.settings, 24).ok()
            } else {
                None
            };
            let (rp, re) = refined.unwrap_or((exact_p, exact));
            if beats(&re, &best) {
                best = Some((i, rp, re.objective));
            }
            if re.feasible() {
                choices[i].best = Some(re);
                choices[i].least_violating = None;
            } else {
                choices[i].best = None;
                choices[i].least_violating = Some(re);
            }
        }
        Ok(best.map(|(i, p, _)| (i, p)))
    }

    /// The error when the policy finds no row of the table feasible.
    pub(super) fn infeasible_under_policy(&self, choices: &[ChoiceResult]) -> anyhow::Error {
        let why: Vec<String> = choices
            .iter()
            .filter_map(|c| {
                c.least_violating
                    .as_ref()
                    .filter(|e| e.exact)
                    .map(|e| (c, e))
            })
            .map(|(c, e)| {
                format!(
                    "{}: {}",
                    c.choice,
                    e.constraints
                        .iter()
                        .filter(|k| k.violation > 0.0)
                        .map(|k| format!("{}: {}", k.name, k.detail))
                        .collect::<Vec<_>>()
                        .join("; ")
                )
            })
            .collect();
        anyhow::anyhow!(
            "infeasible under the model policy's own prediction: {}",
            why.join(" | ")
        )
    }
}

/// The answer of one choice as the policy predicts it, walked by a trust region on
/// the policy itself: anchor on the current design with a first-order correction
/// (value and slope of the policy's nominal K there, one nominal anchoring per
/// variable; the readings' ratios to it held), search that estimate within a box
/// around it, score the step exactly (anchored on it with its readings); accept it when
/// the policy agrees it is better (and feasible), widen the box when the estimate was
/// right, shrink it when not (at most `max_steps` steps). `found` is the answer scored exactly; when the policy finds
/// it infeasible the choice's start is tried too.
pub(super) fn policy_answer(
    p: ModuleProblem,
    found: Evaluation,
    settings: &ModuleSettings,
    max_steps: u64,
) -> anyhow::Result<(ModuleProblem, Evaluation)> {
    let (lo, hi) = p.box_bounds();
    let exact = |x: &[f64]| -> anyhow::Result<(ModuleProblem, Evaluation)> {
        let q = p.anchored_at(x)?;
        let e = q.evaluate(x);
        Ok((q, e))
    };
    // Feasible beats infeasible; between feasible designs the objective decides,
    // between infeasible ones the smaller violation (so a start the policy finds
    // infeasible can be walked into the feasible region).
    let better = |a: &Evaluation, b: &Evaluation| match (a.feasible(), b.feasible()) {
        (true, false) => true,
        (false, true) => false,
        (true, true) => a.objective > b.objective,
        (false, false) => a.total_violation() < b.total_violation(),
    };
    let mut cur = (p.clone(), found);
    if !cur.1.feasible() {
        let s = exact(&p.start_point())?;
        if better(&s.1, &cur.1) {
            cur = s;
        }
    }
    let mut radius = 0.25;
    for k in 0..max_steps {
        let xc = cur.1.x.clone();
        let (tl, th): (Vec<f64>, Vec<f64>) = xc
            .iter()
            .zip(lo.iter().zip(&hi))
            .map(|(x, (l, h))| {
                let d = radius * (h - l);
                ((x - d).max(*l), (x + d).min(*h))
            })
            .unzip();
        let q = cur.0.corrected_at(&xc)?.within(tl, th);
        let runs = multi_start(
            &q,
            &settings.solvers,
            std::slice::from_ref(&xc),
            settings.seed.wrapping_add(1000 + k),
            &settings.run,
        )?;
        let evals: Vec<Evaluation> = runs.iter().map(|r| q.evaluate(&r.best_x)).collect();
        let step = q
            .best_feasible(&evals)
            .filter(|t| !cur.1.feasible() || t.objective > cur.1.objective * (1.0 + 1e-9))
            .cloned();
        match step {
            Some(t) => {
                let trial = exact(&t.x)?;
                if better(&trial.1, &cur.1) {
                    let predicted = t.objective - cur.1.objective;
                    let actual = trial.1.objective - cur.1.objective;
                    if cur.1.feasible() && actual > 0.75 * predicted {
                        radius = (2.0 * radius).min(0.5);
                    }
                    cur = trial;
                } else {
                    radius *= 0.5;
                }
            }
            None => radius *= 0.5,
        }
        if radius < 1e-4 {
            break;
        }
    }
    anyhow::ensure!(
        cur.1.feasible(),
        "infeasible: under the model policy's own prediction neither the optimised design nor the start meets every constraint ({})",
        cur.1
            .constraints
            .iter()
            .filter(|c| c.violation > 0.0)
            .map(|c| format!("{}: {}", c.name, c.detail))
            .collect::<Vec<_>>()
            .join("; ")
    );
    Ok(cur)
}
