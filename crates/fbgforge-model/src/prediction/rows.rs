//! How [`predict`](super::predict) answers its rows: the FE solves every row needs (the
//! design's reading, the band's two bounding readings, the design interval's readings),
//! each once, in one batch; then each row's nominal, its stated error, its band, its
//! design interval, its strain margin and its warnings.

use super::error::{
    design_interval, ErrorSource, IntervalReadings, LimitCheck, ModelError, MAX_MODEL_ERROR,
};
use super::{
    apply_fem_strain, config_of, BandReadings, Fidelity, ModelledPrediction, PredictionRequest,
    DEFAULT_CONTACT_WARNING,
};
use crate::fem::{
    solve_configurations, AxialStrainProfile, ContactReading, FemOptions, GeometryCache,
};
use crate::model::{self, Configuration, DetailedPrediction, LoadCase, PredictOptions};
use crate::spec::{Design, Module};
use anyhow::{Context, Result};

/// One finite-element solve the policy needs.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct FeJob {
    pub(super) config: Configuration,
    pub(super) reading: ContactReading,
}

/// A grating's strain per newton in one job, and the step its Richardson extrapolation
/// took (`None` without extrapolation).
type JobStrain = (String, f64, Option<f64>);

/// A job's gratings' strain per newton sampled along them (empty for readings that
/// read means only).
type JobProfiles = Vec<AxialStrainProfile>;

/// Solve every job once (one batch, in parallel): per job, each grating's strain per
/// newton and extrapolation step, and its profile along the grating.
pub(super) fn solve_jobs(
    design: &Design,
    jobs: &[FeJob],
    fem_options: &FemOptions,
    cache: &GeometryCache,
) -> Result<Vec<(Vec<JobStrain>, JobProfiles)>> {
    let m = design
        .module
        .as_ref()
        .context("the design has no [module] section")?;
    // One batch: the jobs of one load case and reading share a mesh and a symbolic
    // factorisation, equal problems one numeric factorisation, and readings that
    // differ only in the contact radius one factorisation (`fem::solve_configurations`).
    let requests: Vec<(Configuration, FemOptions)> = jobs
        .iter()
        .map(|j| {
            (
                j.config.clone(),
                fem_options.with_reading(m, j.reading, j.config.case),
            )
        })
        .collect();
    jobs.iter()
        .zip(solve_configurations(design, &requests, cache))
        .map(|(j, r)| {
            let r = r.with_context(|| {
                format!(
                    "finite-element solve of {} ({})",
                    j.config.label(),
                    j.reading.describe(m, j.config.case)
                )
            })?;
            let steps = r.extrapolation_per_n.clone();
            let strains = r
                .strain_per_n
                .into_iter()
                .enumerate()
                .map(|(i, (name, _, e))| (name, e, steps.as_ref().map(|s| s[i])))
                .collect();
            Ok((strains, r.strain_profile_per_n))
        })
        .collect()
}

/// What the rows of one prediction need solved, and the answers.
pub(super) struct Readings<'a> {
    design: &'a Design,
    m: &'a Module,
    jobs: Vec<FeJob>,
    solved: Vec<Vec<JobStrain>>,
    profiles: Vec<JobProfiles>,
}

/// Which readings a row gets besides its nominal.
#[derive(Debug, Clone, Copy)]
pub(super) struct Wanted {
    pub(super) band: bool,
    pub(super) interval: bool,
}

/// Whether a Case I row's design interval spans the contact window: an FE row on the
/// shipped default radius (a calibrated radius was measured).
fn windowed(m: &Module, case: LoadCase, model: Fidelity) -> bool {
    case == LoadCase::I && model == Fidelity::Fem && m.contact_radius_is_default()
}

impl<'a> Readings<'a> {
    /// Plan and solve every FE reading the rows need, each once.
    pub(super) fn solve(
        design: &'a Design,
        rows: &[DetailedPrediction],
        models: &[Fidelity],
        want: Wanted,
        request: &PredictionRequest,
    ) -> Result<Self> {
        let m = design
            .module
            .as_ref()
            .context("the design has no [module] section")?;
        let mut jobs: Vec<FeJob> = Vec::new();
        let mut add = |config: &Configuration, reading: ContactReading| {
            let job = FeJob {
                config: config.clone(),
                reading,
            };
            if !jobs.contains(&job) {
                jobs.push(job);
            }
        };
        for (d, &model) in rows.iter().zip(models) {
            let c = config_of(&d.prediction);
            let case = c.case;
            if model == Fidelity::Fem || (want.interval && case == LoadCase::II) {
                add(&c, ContactReading::Design);
            }
            if want.band {
                add(&c, ContactReading::BondedPillars);
                add(&c, ContactReading::SlidingApexPatch);
            }
            if want.interval && windowed(m, case, model) {
                add(&c, ContactReading::WindowLow);
                add(&c, ContactReading::WindowHigh);
            }
        }
        let (solved, profiles) = solve_jobs(design, &jobs, &request.fem_options, &request.cache)?
            .into_iter()
            .unzip();
        Ok(Readings {
            design,
            m,
            jobs,
            solved,
            profiles,
        })
    }

    /// The strain per newton along `grating` of `config` under the design's reading,
    /// from the solve that gave its nominal; `None` when no such solve ran (a
    /// closed-form row without a design interval) or it read means only.
    pub(super) fn design_profile(
        &self,
        config: &Configuration,
        grating: &str,
    ) -> Option<&AxialStrainProfile> {
        let i = self
            .jobs
            .iter()
            .position(|j| &j.config == config && j.reading == ContactReading::Design)?;
        let k = self.solved[i].iter().position(|(n, _, _)| n == grating)?;
        self.profiles[i].get(k)
    }

    /// The strain per newton of `d`'s grating under `reading`, with its step.
    fn strain(
        &self,
        d: &DetailedPrediction,
        reading: ContactReading,
    ) -> Result<(f64, Option<f64>)> {
        let p = &d.prediction;
        let config = config_of(p);
        let i = self
            .jobs
            .iter()
            .position(|j| j.config == config && j.reading == reading)
            .expect("every needed job was solved");
        self.solved[i]
            .iter()
            .find(|(name, _, _)| name == &p.grating)
            .map(|(_, e, s)| (*e, *s))
            .with_context(|| format!("the FE model gave no strain for grating `{}`", p.grating))
    }

    /// K of `d`'s grating under `reading` (pm/N) and its stated error.
    fn k(
        &self,
        d: &DetailedPrediction,
        reading: ContactReading,
    ) -> Result<(f64, Option<ModelError>)> {
        let (e, step) = self.strain(d, reading)?;
        let k = self.k_of(d, e);
        let source = match d.prediction.case {
            LoadCase::I => ErrorSource::FemCaseI,
            LoadCase::II => ErrorSource::FemCaseII,
        };
        Ok((k, ModelError::of(source, k, step.map(|s| self.k_of(d, s)))))
    }

    fn k_of(&self, d: &DetailedPrediction, strain: f64) -> f64 {
        self.design
            .fiber
            .shift_pm(d.bragg_wavelength_nm, strain, 0.0)
    }

    /// One row answered: its nominal by `model`, its error, band, design interval,
    /// strain margin and warnings.
    pub(super) fn row(
        &self,
        mut d: DetailedPrediction,
        model: Fidelity,
        want: Wanted,
        request: &PredictionRequest,
    ) -> Result<ModelledPrediction> {
        let m = self.m;
        let opts = PredictOptions {
            force_n: request.force_n,
            delta_t_k: request.delta_t_k,
        };
        let case = d.prediction.case;
        let closed_form_k = d.prediction.sensitivity_pm_per_n;
        let (description, error) = match model {
            Fidelity::ClosedForm => {
                let source = match case {
                    LoadCase::I => ErrorSource::ClosedFormCaseI,
                    LoadCase::II => ErrorSource::ClosedFormCaseII,
                };
                (
                    "closed form (membrane theory, docs/model.md)".to_string(),
                    ModelError::of(source, closed_form_k, None),
                )
            }
            Fidelity::Fem => {
                let (e, _) = self.strain(&d, ContactReading::Design)?;
                apply_fem_strain(&mut d, self.design, &opts, e);
                let (_, error) = self.k(&d, ContactReading::Design)?;
                (
                    format!("FE, {}", ContactReading::Design.describe(m, case)),
                    error,
                )
            }
        };
        let k = d.prediction.sensitivity_pm_per_n;
        let readings = if want.band {
            let (bonded, _) = self.k(&d, ContactReading::BondedPillars)?;
            let (sliding, _) = self.k(&d, ContactReading::SlidingApexPatch)?;
            Some(BandReadings {
                bonded_pillars_pm_per_n: bonded,
                sliding_apex_patch_pm_per_n: sliding,
            })
        } else {
            None
        };
        let band = readings.map(|b| {
            let (x, y) = (b.bonded_pillars_pm_per_n, b.sliding_apex_patch_pm_per_n);
            [x.min(y).min(k), x.max(y).max(k)]
        });
        let interval = if want.interval {
            Some(self.interval(&d, model, (k, error), closed_form_k)?)
        } else {
            None
        };
        let limit_check = interval.map(|(iv, _)| {
            let (force, from) = m
                .limits
                .map_or((request.force_n, "request"), |l| (l.max_force_n, "design"));
            let limit = m.limits.map_or(model::validity::GRATING_MAX_STRAIN, |l| {
                l.max_grating_strain_microstrain * 1e-6
            });
            let pm_per_strain = self.k_of(&d, 1.0);
            LimitCheck::new((force, from), limit, k, pm_per_strain, iv)
        });
        let fe_readings = model == Fidelity::Fem || want.band || want.interval;
        let mut row = ModelledPrediction {
            mesh_level: request.fem_options.policy_level().filter(|_| fe_readings),
            model,
            model_description: description,
            band_pm_per_n: band,
            band_readings: readings,
            model_error_fraction: error.map(|e| e.total_fraction),
            model_error: error,
            design_interval_pm_per_n: interval.map(|(iv, _)| iv),
            design_interval_readings: interval.map(|(_, r)| r),
            limit_check,
            spectrum: None,
            detail: d,
        };
        row_warnings(&mut row, m);
        Ok(row)
    }

    /// The design interval of a row with nominal `(k, error)` and closed-form K
    /// `closed_form_k`, with the readings that make it.
    fn interval(
        &self,
        d: &DetailedPrediction,
        model: Fidelity,
        (k, error): (f64, Option<ModelError>),
        closed_form_k: f64,
    ) -> Result<([f64; 2], IntervalReadings)> {
        let case = d.prediction.case;
        let mut parts = vec![(k, error)];
        let mut readings = IntervalReadings {
            contact_window_pm_per_n: None,
            stated_cylinders_pm_per_n: None,
            closed_form_pm_per_n: None,
        };
        if windowed(self.m, case, model) {
            let lo = self.k(d, ContactReading::WindowLow)?;
            let hi = self.k(d, ContactReading::WindowHigh)?;
            readings.contact_window_pm_per_n = Some([lo.0, hi.0]);
            parts.extend([lo, hi]);
        }
        if case == LoadCase::II {
            let stated = self.k(d, ContactReading::Design)?;
            let closed = ModelError::of(ErrorSource::ClosedFormCaseII, closed_form_k, None);
            readings.stated_cylinders_pm_per_n = Some(stated.0);
            readings.closed_form_pm_per_n = Some(closed_form_k);
            parts.extend([stated, (closed_form_k, closed)]);
        }
        Ok((design_interval(&parts), readings))
    }
}

/// Answer again, one policy mesh level finer at a time up to
/// `request.refine_to_level`, the configurations whose FE rows state a model error above
/// [`MAX_MODEL_ERROR`]: each row gets the cheapest mesh that states the policy's
/// accuracy (every reading of a configuration, its band and design interval included,
/// is solved at one level). `rows` and `models` are what `answered` was answered from.
pub(super) fn refine(
    design: &Design,
    rows: &[DetailedPrediction],
    models: &[Fidelity],
    want: Wanted,
    request: &PredictionRequest,
    answered: &mut [ModelledPrediction],
) -> Result<()> {
    let (Some(finest), Some(mut level)) =
        (request.refine_to_level, request.fem_options.policy_level())
    else {
        return Ok(());
    };
    while level < finest.min(FemOptions::MAX_MESH_LEVEL) {
        let mut over: Vec<Configuration> = Vec::new();
        for r in answered.iter() {
            let coarse = r.model == Fidelity::Fem
                && r.model_error_fraction.is_some_and(|f| f > MAX_MODEL_ERROR);
            let c = config_of(&r.detail.prediction);
            if coarse && !over.contains(&c) {
                over.push(c);
            }
        }
        if over.is_empty() {
            break;
        }
        level += 1;
        let finer = PredictionRequest {
            fem_options: request.fem_options.at_level(level),
            ..request.clone()
        };
        let which: Vec<usize> = (0..rows.len())
            .filter(|&i| over.contains(&config_of(&rows[i].prediction)))
            .collect();
        let sub: Vec<DetailedPrediction> = which.iter().map(|&i| rows[i].clone()).collect();
        let sub_models: Vec<Fidelity> = which.iter().map(|&i| models[i]).collect();
        let readings = Readings::solve(design, &sub, &sub_models, want, &finer)?;
        for ((&i, d), model) in which.iter().zip(sub).zip(sub_models) {
            answered[i] = readings.row(d, model, want, &finer)?;
        }
    }
    Ok(())
}

/// The warnings of the policy on one row: a Case I FE row that rests on the shipped
/// default contact radius says so; a row whose nominal K lies outside its bounding
/// readings widened by its model error, or whose sign is not fixed across them, says
/// the model is wrong there; a stated error above [`MAX_MODEL_ERROR`] says so; a
/// design interval whose far end breaks the strain limit says so.
fn row_warnings(row: &mut ModelledPrediction, m: &Module) {
    let model = row.model;
    let contained = row.nominal_contained();
    let widened = row.widened_readings();
    let p = &mut row.detail.prediction;
    let k = p.sensitivity_pm_per_n;
    if p.case == LoadCase::I && model == Fidelity::Fem && m.contact_radius_is_default() {
        p.warnings.push(DEFAULT_CONTACT_WARNING.to_string());
    }
    if let (Some(false), Some([lo, hi])) = (contained, widened) {
        p.warnings.push(format!(
            "the model is wrong here: nominal K {k:+.1} pm/N lies outside its bounding contact readings widened by its stated error ({lo:+.1} … {hi:+.1} pm/N)"
        ));
    }
    if let Some(b) = row.band_readings {
        let (x, y) = (b.bonded_pillars_pm_per_n, b.sliding_apex_patch_pm_per_n);
        if x * y <= 0.0 || x * k < 0.0 {
            p.warnings.push(format!(
                "the sign of K is not fixed across the bounding contact readings (nominal {k:+.1}, pillars bonded {x:+.1}, sliding apex patch {y:+.1} pm/N)"
            ));
        }
    }
    if let (Some(f), Some(e)) = (row.model_error_fraction, row.model_error) {
        if f > MAX_MODEL_ERROR {
            let level = row
                .mesh_level
                .map_or("a custom mesh".to_string(), |k| format!("mesh level {k}"));
            // Which term breaks it: the mesh alone, or the modelling term.
            let finest = row
                .mesh_level
                .is_some_and(|k| k >= FemOptions::AUTO_FINEST_MESH_LEVEL);
            let why = if e.discretisation_fraction > MAX_MODEL_ERROR - e.modelling_fraction {
                if finest {
                    // Issue 38's design (a 0.37 mm cap on a 34 mm module, K_I 14 pm/N):
                    // the step stays ~1.2 pm/N from level 2 to 4, so level 4 states
                    // the same; the absolute error is the other inserts', K is small.
                    format!(
                        "the discretisation estimate does not fall within what 15 % leaves at {level}, the finest the policy refines to by itself, and a finer mesh need not help (the FE step stopped shrinking between levels 3 and 4 on such a design, docs/fem.md §5.3): do not rely on this row"
                    )
                } else {
                    format!(
                        "the mesh is too coarse for this design at {level} (ask for a finer one: PredictionRequest.fem_options)"
                    )
                }
            } else {
                "the model does not hold here".to_string()
            };
            p.warnings.push(format!(
                "stated model error {:.1} % (discretisation {:.1} % at {level}, modelling {:.1} %) exceeds {:.0} %: {why}",
                100.0 * f,
                100.0 * e.discretisation_fraction,
                100.0 * e.modelling_fraction,
                100.0 * MAX_MODEL_ERROR
            ));
        }
    }
    if let Some(c) = row.limit_check {
        if !c.meets_margin {
            let verdict = if c.strain_margin_microstrain < 0.0 {
                format!("over the {:.0} µε limit", c.strain_limit_microstrain)
            } else {
                format!(
                    "{:.1} % under the {:.0} µε limit, less than the {:.0} % margin required",
                    c.strain_margin_percent,
                    c.strain_limit_microstrain,
                    100.0 * super::error::STRAIN_MARGIN_FRACTION
                )
            };
            p.warnings.push(format!(
                "at {} N the far end of the design interval ({:+.1} pm/N) strains the grating by {:+.0} µε: {verdict}",
                c.force_n, c.far_end_pm_per_n, c.far_end_strain_microstrain,
            ));
        }
    }
}
