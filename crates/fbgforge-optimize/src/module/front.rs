//! The Pareto front instead of a tied scalar: the non-dominated designs over
//! sensitivity |K| (up), force range (up), lag Δt_max (down) and R² (up), each scored
//! on the model policy; the design a preference picks (by default the knee); and the
//! notes that say where the objectives tie and why.

use super::choice::Choice;
use super::outcome::{ChoiceResult, Evaluation, FrontDesign};
use super::robust::FrontObjectives;
use super::settings::PaperStatementsPolicy;
use super::settings::{ModuleSettings, Preference};
use super::variables::Variable;

/// Below this prominence the front is called nearly straight in the report.
const KNEE_PROMINENCE_MIN: f64 = 0.05;

/// A scored design that may enter the front.
#[derive(Debug, Clone)]
pub struct FrontCandidate {
    choice: Choice,
    evaluation: Evaluation,
}

impl FrontCandidate {
    /// A candidate (its evaluation must carry the front's objectives).
    pub fn new(choice: Choice, evaluation: Evaluation) -> Self {
        FrontCandidate { choice, evaluation }
    }

    /// Its front objectives.
    pub fn objectives(&self) -> Option<FrontObjectives> {
        self.evaluation.objectives
    }
}

/// `a` dominates `b`: at least as good in every objective, better in one.
fn dominates(a: &FrontObjectives, b: &FrontObjectives) -> bool {
    let ge = |x: f64, y: f64| x >= y * (1.0 - 1e-9);
    let gt = |x: f64, y: f64| x > y * (1.0 + 1e-9);
    let no_worse = ge(a.sensitivity_pm_per_n, b.sensitivity_pm_per_n)
        && ge(a.force_range_n, b.force_range_n)
        && ge(b.max_lag_s, a.max_lag_s)
        && ge(a.r_squared, b.r_squared);
    let better = gt(a.sensitivity_pm_per_n, b.sensitivity_pm_per_n)
        || gt(a.force_range_n, b.force_range_n)
        || gt(b.max_lag_s, a.max_lag_s)
        || gt(a.r_squared, b.r_squared);
    no_worse && better
}

/// The non-dominated candidates (duplicates once), by force range, with the knee
/// marked when the front has one ([`knee_and_prominence`]: the design farthest beyond
/// the chord between the most sensitive and the widest-range designs, on log scales
/// normalised over the front; ties to the shorter lag, then the larger R²).
pub fn pareto_front(candidates: Vec<FrontCandidate>, variables: &[Variable]) -> Vec<FrontDesign> {
    let scored: Vec<(FrontCandidate, FrontObjectives)> = candidates
        .into_iter()
        .filter_map(|c| c.evaluation.objectives.map(|o| (c, o)))
        .filter(|(_, o)| o.sensitivity_pm_per_n.is_finite() && o.force_range_n.is_finite())
        .collect();
    let mut front: Vec<FrontDesign> = Vec::new();
    for (c, o) in &scored {
        if scored.iter().any(|(_, q)| dominates(q, o)) {
            continue;
        }
        let same = |f: &FrontDesign| {
            f.choice == c.choice
                && f.evaluation
                    .x
                    .iter()
                    .zip(&c.evaluation.x)
                    .all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(1.0))
        };
        if front.iter().any(same) {
            continue;
        }
        front.push(FrontDesign {
            choice: c.choice.clone(),
            variables: variables
                .iter()
                .zip(&c.evaluation.x)
                .map(|(v, x)| (v.name().to_string(), *x))
                .collect(),
            objectives: *o,
            readings: c.evaluation.readings.clone(),
            knee: false,
            paper_statements_failed: Vec::new(),
            model_error_over_max: Vec::new(),
            evaluation: c.evaluation.clone(),
        });
    }
    front.sort_by(|a, b| {
        a.objectives
            .force_range_n
            .total_cmp(&b.objectives.force_range_n)
    });
    if let Some(k) = knee(&front) {
        front[k].knee = true;
    }
    front
}

/// The knee's index (see [`pareto_front`]), when the front has one.
fn knee(front: &[FrontDesign]) -> Option<usize> {
    knee_and_prominence(front)
        .filter(|k| k.1 >= KNEE_PROMINENCE_MIN)
        .map(|k| k.0)
}

/// The candidate knee and its prominence. Among the designs not dominated in
/// sensitivity and force range alone (the others are on the front by lag or R²), with
/// both objectives on log scales normalised to 0…1 over them (sensitivity and range
/// trade in ratios: at the strain limit |K|·range is a constant, a straight line
/// here), the design farthest beyond the chord from the most sensitive to the
/// widest-range design, toward larger values of both; the prominence is that distance
/// (0: no design beyond the chord, a front without a knee).
fn knee_and_prominence(front: &[FrontDesign]) -> Option<(usize, f64)> {
    let two_d: Vec<usize> = (0..front.len())
        .filter(|&i| {
            let a = &front[i].objectives;
            !front.iter().any(|d| {
                let b = &d.objectives;
                b.sensitivity_pm_per_n >= a.sensitivity_pm_per_n
                    && b.force_range_n >= a.force_range_n
                    && (b.sensitivity_pm_per_n > a.sensitivity_pm_per_n * (1.0 + 1e-9)
                        || b.force_range_n > a.force_range_n * (1.0 + 1e-9))
            })
        })
        .collect();
    let ln = |v: f64| v.max(1e-300).ln();
    let span = |f: &dyn Fn(&FrontObjectives) -> f64| {
        let v = two_d.iter().map(|&i| ln(f(&front[i].objectives)));
        (
            v.clone().fold(f64::INFINITY, f64::min),
            v.fold(f64::NEG_INFINITY, f64::max),
        )
    };
    let (s0, s1) = span(&|o| o.sensitivity_pm_per_n);
    let (f0, f1) = span(&|o| o.force_range_n);
    if two_d.len() < 3 || s1 <= s0 || f1 <= f0 {
        return two_d.first().map(|&i| (i, 0.0));
    }
    // The chord runs from (s, f) = (1, 0) to (0, 1): distance beyond it (s + f − 1)/√2.
    let beyond = |i: usize| {
        let o = &front[i].objectives;
        let s = (ln(o.sensitivity_pm_per_n) - s0) / (s1 - s0);
        let f = (ln(o.force_range_n) - f0) / (f1 - f0);
        (s + f - 1.0) / 2f64.sqrt()
    };
    let k = two_d.iter().copied().max_by(|&a, &b| {
        let (da, db) = (&front[a], &front[b]);
        beyond(a)
            .total_cmp(&beyond(b))
            .then(db.objectives.max_lag_s.total_cmp(&da.objectives.max_lag_s))
            .then(da.objectives.r_squared.total_cmp(&db.objectives.r_squared))
    })?;
    Some((k, beyond(k).max(0.0)))
}

/// The front's design `prefer` picks (`None`: the table's best, which is not on the
/// front or was asked for by `objective`), and why, in words.
pub fn pick(
    front: &[FrontDesign],
    prefer: Preference,
    best_choice: &Choice,
    best: &Evaluation,
) -> (Option<usize>, String) {
    let by = |f: &dyn Fn(&FrontObjectives) -> f64| {
        (0..front.len())
            .max_by(|&a, &b| f(&front[a].objectives).total_cmp(&f(&front[b].objectives)))
    };
    let on_front = front.iter().position(|f| {
        &f.choice == best_choice
            && f.evaluation
                .x
                .iter()
                .zip(&best.x)
                .all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(1.0))
    });
    match prefer {
        Preference::Objective => (on_front, "ModuleSettings.prefer objective: the best of the table".into()),
        Preference::Knee => match knee_and_prominence(front) {
            Some((i, prominence)) if prominence >= KNEE_PROMINENCE_MIN => (
                Some(i),
                format!(
                    "ModuleSettings.prefer knee: the knee of the Pareto front, {prominence:.3} beyond the chord of sensitivity against force range (log scales, in units of the front's spans)"
                ),
            ),
            Some((_, prominence)) => (
                on_front,
                format!(
                    "ModuleSettings.prefer knee: the front has no knee (no design lies more than {KNEE_PROMINENCE_MIN} beyond the chord of sensitivity against force range on log scales; the most lies {prominence:.3}): its designs trade |K| for range at about one rate, as the strain limit makes |K|·range constant, so the best of the table is written, the most sensitive design that holds the required force"
                ),
            ),
            None => (on_front, "the front is empty: the best of the table".into()),
        },
        Preference::Sensitivity => (
            by(&|o| o.sensitivity_pm_per_n),
            "ModuleSettings.prefer sensitivity: the front's most sensitive design".into(),
        ),
        Preference::ForceRange => (
            by(&|o| o.force_range_n),
            "ModuleSettings.prefer force-range: the front's widest force range".into(),
        ),
        Preference::Lag => (
            by(&|o| -o.max_lag_s + 1e-9 * o.sensitivity_pm_per_n),
            "ModuleSettings.prefer lag: the front's shortest lag".into(),
        ),
        Preference::RSquared => (
            by(&|o| o.r_squared),
            "ModuleSettings.prefer r-squared: the front's largest R²".into(),
        ),
    }
}

/// Where the objectives tie over the table's feasible rows scored on the policy, and
/// why: the lag on the sample-period floor, |K| at the strain or wavelength limit, the
/// scalar objective within a fraction of a per cent.
pub(crate) fn tie_notes(
    choices: &[ChoiceResult],
    front: &[FrontDesign],
    settings: &ModuleSettings,
) -> Vec<String> {
    let rows: Vec<(&ChoiceResult, &Evaluation, FrontObjectives)> = choices
        .iter()
        .filter_map(|c| {
            c.best
                .as_ref()
                .filter(|e| e.exact)
                .and_then(|e| e.objectives.map(|o| (c, e, o)))
        })
        .collect();
    let mut notes = Vec::new();
    if rows.is_empty() {
        return notes;
    }
    let range = |f: &dyn Fn(&FrontObjectives) -> f64| {
        let v = rows.iter().map(|r| f(&r.2));
        (
            v.clone().fold(f64::INFINITY, f64::min),
            v.fold(f64::NEG_INFINITY, f64::max),
        )
    };
    let spread = |(lo, hi): (f64, f64)| if hi > 0.0 { (hi - lo) / hi } else { 0.0 };
    let n = rows.len();
    let period = settings.quality.sample_period_s;
    // Lag.
    let lags: Vec<f64> = rows
        .iter()
        .flat_map(|r| r.1.gratings.iter().map(|g| g.lag_s))
        .collect();
    let on_floor = rows
        .iter()
        .filter(|r| (r.2.max_lag_s - period).abs() <= 1e-12 * period)
        .count();
    if on_floor == n {
        notes.push(format!(
            "max_lag_s ties: all {n} choices scored on the policy sit on the {period:.3} s floor of a {:.3} Hz interrogator (the model's lag T is {:.3}–{:.3} s, below one sample period), so lag does not separate them; a faster interrogator (ModuleSettings.rate_hz) would",
            1.0 / period,
            lags.iter().copied().fold(f64::INFINITY, f64::min),
            lags.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        ));
    }
    // Sensitivity at a limit.
    let f = settings.max_force_n;
    let at_limit: Vec<&str> = rows
        .iter()
        .filter(|r| r.2.force_range_n <= f * 1.005)
        .map(|r| r.2.force_range_limited_by)
        .collect();
    let (k0, k1) = range(&|o| o.sensitivity_pm_per_n);
    if !at_limit.is_empty() {
        let strain = at_limit.iter().filter(|l| **l == "grating_strain").count();
        notes.push(format!(
            "sensitivity_pm_per_n: {} of {n} choices take their whole force range ({f} N) to the limit ({strain} by the grating strain, {} µε; {} by the wavelength window), so |K| is capped there: scored |K| {k0:.3}–{k1:.3} pm/N (spread {:.2} %)",
            at_limit.len(),
            settings.max_grating_strain * 1e6,
            at_limit.len() - strain,
            100.0 * spread((k0, k1))
        ));
    }
    let (r0, r1) = range(&|o| o.r_squared);
    let (q0, q1) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, r| {
            (a.0.min(r.1.objective), a.1.max(r.1.objective))
        });
    let name = settings.objective.symbol();
    if spread((q0, q1)) < 0.005 && n > 1 {
        notes.push(format!(
            "{name} ties: the {n} choices scored on the policy span {q0:.4}–{q1:.4} {} ({:.2} %), within half a per cent; R² ({r0:.5}–{r1:.5}) is what separates them, so the Pareto front, not {name}, is the choice to make",
            settings.objective.unit(),
            100.0 * spread((q0, q1))
        ));
    } else if n > 1 {
        notes.push(format!(
            "{name} over the {n} choices scored on the policy: {q0:.4}–{q1:.4} {} (spread {:.2} %); R² {r0:.5}–{r1:.5}",
            settings.objective.unit(),
            100.0 * spread((q0, q1))
        ));
    }
    if front.len() > 1 {
        let same_lag = front
            .windows(2)
            .all(|w| (w[0].objectives.max_lag_s - w[1].objectives.max_lag_s).abs() < 1e-12);
        if same_lag {
            notes.push(format!(
                "the front's {} designs share one lag ({:.3} s): they trade sensitivity against force range only",
                front.len(),
                front[0].objectives.max_lag_s
            ));
        }
    }
    notes
}

/// Why a design is not written while another can be: the paper's statements it fails
/// (under [`PaperStatementsPolicy::Exclude`]) and its rows whose stated model error
/// exceeds 15 % (always), in words; empty when nothing excludes it.
fn exclusion(settings: &ModuleSettings, failed: &[String], over: &[String]) -> Vec<String> {
    let mut why = Vec::new();
    if settings.paper_statements == PaperStatementsPolicy::Exclude && !failed.is_empty() {
        why.push(format!("fails {}", failed.join(", ")));
    }
    if !over.is_empty() {
        why.push(format!(
            "states a model error over 15 % on {}",
            over.join(", ")
        ));
    }
    why
}

/// The design written under `settings`' preference: [`pick`] among the front's
/// designs that meet every paper statement (under [`PaperStatementsPolicy::Exclude`];
/// among all under `Report`) and state every row's model error within 15 %, the
/// table's best included when it does; with why, in words. `best_failed` names the
/// statements the table's best fails, `best_over` its rows over 15 %. When every
/// design is excluded, the preferred one is written and names why.
pub fn pick_written(
    front: &[FrontDesign],
    settings: &ModuleSettings,
    (best_choice, best, best_failed, best_over): (&Choice, &Evaluation, &[String], &[String]),
) -> (Option<usize>, String) {
    let (i, why) = pick(front, settings.prefer, best_choice, best);
    let excluded = |i: Option<usize>| match i {
        Some(k) => exclusion(
            settings,
            &front[k].paper_statements_failed,
            &front[k].model_error_over_max,
        ),
        None => exclusion(settings, best_failed, best_over),
    };
    let reasons = excluded(i);
    if reasons.is_empty() {
        return (i, why);
    }
    let passing: Vec<usize> = (0..front.len())
        .filter(|&k| excluded(Some(k)).is_empty())
        .collect();
    let best_ok = excluded(None).is_empty();
    let reasons = reasons.join("; ");
    if passing.is_empty() && !best_ok {
        return (
            i,
            format!("{why}; every design of the front and the table's best are excluded, so this one is written and names why ({reasons})"),
        );
    }
    let sub: Vec<FrontDesign> = passing.iter().map(|&k| front[k].clone()).collect();
    let (j, sub_why) = pick(&sub, settings.prefer, best_choice, best);
    let chosen = match j {
        Some(j) => Some(passing[j]),
        // The table's best is not on the front (or is excluded): the passing design of
        // the best objective.
        None if best_ok => None,
        None => passing.iter().copied().max_by(|&a, &b| {
            front[a]
                .evaluation
                .objective
                .total_cmp(&front[b].evaluation.objective)
        }),
    };
    (
        chosen,
        format!(
            "{sub_why}, among the designs that meet the paper's statements and state every row's model error within 15 % (the preferred design {reasons}; ModuleSettings.paper_statements {})",
            match settings.paper_statements {
                PaperStatementsPolicy::Exclude => "exclude",
                PaperStatementsPolicy::Report => "report",
            }
        ),
    )
}

/// The front's objectives on which every design ties, each with why: such an
/// objective does not separate the designs, so the front trades the others only.
pub fn tied_objectives(front: &[FrontDesign], settings: &ModuleSettings) -> Vec<String> {
    if front.len() < 2 {
        return Vec::new();
    }
    let tie = |f: &dyn Fn(&FrontObjectives) -> f64| {
        let v: Vec<f64> = front.iter().map(|d| f(&d.objectives)).collect();
        let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &x| {
            (a.0.min(x), a.1.max(x))
        });
        (hi - lo <= 1e-9 * hi.abs().max(1e-300)).then_some(hi)
    };
    let n = front.len();
    let mut out = Vec::new();
    if let Some(lag) = tie(&|o| o.max_lag_s) {
        let period = settings.quality.sample_period_s;
        let why = if (lag - period).abs() <= 1e-9 * period {
            format!(
                "the sample-period floor of the {:.3} Hz interrogator (ModuleSettings.rate_hz or the design's interrogator_rate_hz): the model's lag is shorter than one sample",
                1.0 / period
            )
        } else {
            "one lag for every design".to_string()
        };
        out.push(format!(
            "max_lag_s: all {n} designs of the front have {lag:.3} s, {why}; dropped from the front, which trades the other objectives"
        ));
    }
    if let Some(r2) = tie(&|o| o.r_squared) {
        out.push(format!(
            "r_squared: all {n} designs of the front have {r2:.6}; dropped from the front"
        ));
    }
    if let Some(k) = tie(&|o| o.sensitivity_pm_per_n) {
        out.push(format!(
            "sensitivity_pm_per_n: all {n} designs of the front score {k:.3} pm/N; dropped from the front"
        ));
    }
    if let Some(f) = tie(&|o| o.force_range_n) {
        out.push(format!(
            "force_range_n: all {n} designs of the front reach {f:.3} N; dropped from the front"
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn design(k: f64, range: f64, objective: f64) -> FrontDesign {
        let evaluation = Evaluation {
            x: vec![k],
            objective,
            nominal_objective: objective,
            exact: true,
            gratings: Vec::new(),
            readings: Vec::new(),
            objectives: None,
            margins: None,
            constraints: Vec::new(),
        };
        FrontDesign {
            choice: Choice {
                core_material: "core".into(),
                insert_material: Some("insert".into()),
            },
            variables: Default::default(),
            objectives: FrontObjectives {
                sensitivity_pm_per_n: k,
                nominal_sensitivity_pm_per_n: k,
                force_range_n: range,
                force_range_limited_by: "grating_strain",
                max_lag_s: 0.5,
                r_squared: 1.0,
                quality_pm_per_n_s: objective,
            },
            readings: Vec::new(),
            knee: false,
            paper_statements_failed: Vec::new(),
            model_error_over_max: Vec::new(),
            evaluation,
        }
    }

    #[test]
    fn a_design_stating_over_15_percent_is_not_written_while_another_can_be() {
        let settings = ModuleSettings {
            prefer: Preference::Sensitivity,
            ..ModuleSettings::default()
        };
        let mut front = vec![design(50.0, 40.0, 2.0), design(80.0, 25.0, 3.0)];
        let best = front[1].clone();
        let choice = best.choice.clone();
        // Nothing excluded: the most sensitive design.
        let (i, _) = pick_written(&front, &settings, (&choice, &best.evaluation, &[], &[]));
        assert_eq!(i, Some(1));
        // Its rows state 17.2 %: the other design is written, and why says so.
        let over = vec!["lambda_11 Case I light_green 17.2 %".to_string()];
        front[1].model_error_over_max = over.clone();
        let (i, why) = pick_written(&front, &settings, (&choice, &best.evaluation, &[], &over));
        assert_eq!(i, Some(0), "{why}");
        assert!(
            why.contains("model error over 15 % on lambda_11 Case I light_green 17.2 %"),
            "{why}"
        );
        // Under `report` a paper-statement failure is written, an error over 15 % is not.
        let report = ModuleSettings {
            paper_statements: PaperStatementsPolicy::Report,
            ..settings.clone()
        };
        let (i, _) = pick_written(&front, &report, (&choice, &best.evaluation, &[], &over));
        assert_eq!(i, Some(0));
        front[1].model_error_over_max.clear();
        front[1].paper_statements_failed = vec!["case_i_red_shift".into()];
        let (i, _) = pick_written(&front, &report, (&choice, &best.evaluation, &[], &[]));
        assert_eq!(i, Some(1));
        // Every design excluded: the preferred one is written and names why.
        front[0].model_error_over_max = over.clone();
        front[1].model_error_over_max = over.clone();
        let (i, why) = pick_written(&front, &settings, (&choice, &best.evaluation, &[], &over));
        assert_eq!(i, Some(1));
        assert!(
            why.contains("every design of the front and the table's best are excluded"),
            "{why}"
        );
    }
}
