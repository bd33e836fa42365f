//! Refining the winner on the model policy: away from its anchor the optimiser's K is
//! an estimate, so the best choices are tried in order of merit and each answer is
//! walked by a trust region on the policy's own prediction until one holds.

use super::choice::Choice;
use super::evaluate::Evaluation;
use super::outcome::ChoiceResult;
use super::problem::ModuleProblem;
use super::search::ProblemInputs;
use super::settings::ModuleSettings;
use crate::solvers::multi_start;

impl ProblemInputs<'_> {
    /// Refine the answer on the policy: try the choices of `order` (the best by
    /// estimated merit, `bi`, first) until one holds under the policy's own prediction.
    pub(super) fn policy_refined(
        &self,
        choices: &[ChoiceResult],
        order: &[usize],
        bi: usize,
    ) -> anyhow::Result<(usize, ModuleProblem, Evaluation)> {
        let mut why = Vec::new();
        for &i in order
            .iter()
            .filter(|&&i| i == bi)
            .chain(order.iter().filter(|&&i| i != bi))
        {
            let p = self.problem(choices[i].choice.clone())?;
            let found = choices[i]
                .best
                .clone()
                .unwrap_or_else(|| p.evaluate(&p.start_point()));
            match policy_answer(p, found, self.settings) {
                Ok((p, e)) => return Ok((i, p, e)),
                Err(e) => why.push(format!("{}: {e:#}", choices[i].choice)),
            }
        }
        anyhow::bail!(
            "infeasible under the model policy's own prediction: {}",
            why.join("; ")
        )
    }
}

/// The feasible choices in the order the policy tries them: by estimated merit (at
/// most four), then the start's own choice. Every choice shares the start point and
/// the box, so merits compare across choices too.
pub(super) fn policy_order(
    choices: &[ChoiceResult],
    ranker: &ModuleProblem,
    start_ch: &Choice,
) -> Vec<usize> {
    let mut order: Vec<usize> = choices
        .iter()
        .enumerate()
        .filter(|(_, c)| c.best.is_some())
        .map(|(i, _)| i)
        .collect();
    order.sort_by(|&a, &b| {
        let m = |i: usize| ranker.merit(choices[i].best.as_ref().expect("filtered"));
        m(b).total_cmp(&m(a))
    });
    order.truncate(4);
    if let Some(si) = choices.iter().position(|c| &c.choice == start_ch) {
        if !order.contains(&si) {
            order.push(si);
        }
    }
    order
}

/// The winning choice's answer as the policy predicts it. Away from its anchor the
/// optimiser's model is an estimate (closed-form trend, FE level at the anchor), and in
/// Case I the closed form's trend can be far off the FE's. So the answer is refined by
/// a trust region on the policy itself: anchor on the current design with a
/// first-order correction (value and slope of the policy's K there, one anchoring per
/// variable), search that estimate within a box around it, score the step by the
/// policy anchored on the step; accept it when the policy agrees it is better (and
/// feasible), widen the box when the estimate was right, shrink it when not. Each
/// anchoring costs one FE solve per configuration. The global search's answer is a
/// candidate too.
fn policy_answer(
    p: ModuleProblem,
    found: Evaluation,
    settings: &ModuleSettings,
) -> anyhow::Result<(ModuleProblem, Evaluation)> {
    let (lo, hi) = p.box_bounds();
    let exact = |x: &[f64]| -> anyhow::Result<(ModuleProblem, Evaluation)> {
        let q = p.anchored_at(x)?;
        let e = q.evaluate(x);
        Ok((q, e))
    };
    // The problem is anchored on its start, so the start is scored exactly.
    let x0 = p.start_point();
    let mut cur = (p.clone(), p.evaluate(&x0));
    // Feasible beats infeasible; between feasible designs the objective decides,
    // between infeasible ones the smaller violation (so a start the policy finds
    // infeasible can be walked into the feasible region).
    let better = |a: &Evaluation, b: &Evaluation| match (a.feasible(), b.feasible()) {
        (true, false) => true,
        (false, true) => false,
        (true, true) => a.objective > b.objective,
        (false, false) => a.total_violation() < b.total_violation(),
    };
    let cand = exact(&found.x)?;
    if better(&cand.1, &cur.1) {
        cur = cand;
    }
    let mut radius = 0.25;
    for k in 0..24u64 {
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
