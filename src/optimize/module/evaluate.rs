//! A candidate evaluated: every constraint (printer walls, fit clearances, the
//! profile's rules, the spec, the model, the grating strain, the wavelength windows)
//! with how far it is broken, and the objective of the worst strain grating.

use super::problem::ModuleProblem;
use super::settings::Objective;
use crate::model::GratingPrediction;
use crate::optimize::quality::{design_quality, QualityBreakdown};
use crate::spec::{Design, Module};
use serde::Serialize;

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
    /// Objective value (worst strain grating), or 0 when the model failed.
    pub objective: f64,
    /// Q breakdown per strain grating.
    pub gratings: Vec<QualityBreakdown>,
    /// Every constraint.
    pub constraints: Vec<ConstraintValue>,
}

impl Evaluation {
    /// Sum of normalised violations.
    pub fn total_violation(&self) -> f64 {
        self.constraints.iter().map(|c| c.violation).sum()
    }
    /// How far from feasible, for ranking infeasible designs: designs whose geometry,
    /// spec or model fails rank behind designs that only break a physics constraint
    /// (strain, wavelength window), since only the latter were checked in full.
    pub fn infeasibility_rank(&self) -> (u8, f64) {
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
pub const PHYSICS_CONSTRAINTS: [&str; 2] = ["grating_strain", "wavelength_window"];

/// Add a constraint's value (a negative violation counts as met).
fn push(
    cons: &mut Vec<ConstraintValue>,
    name: &str,
    requirement: String,
    violation: f64,
    detail: String,
) {
    cons.push(ConstraintValue {
        name: name.into(),
        requirement,
        violation: violation.max(0.0),
        detail,
    })
}

/// Wavelength windows: each grating owns the band between the midpoints to its
/// neighbours, less half the guard band on each side; the outer gratings reach the
/// interrogator's band edges.
pub fn wavelength_windows(
    m: &Module,
    guard_nm: f64,
    band_nm: (f64, f64),
) -> Vec<(String, f64, f64)> {
    let mut g: Vec<(String, f64)> = m
        .gratings
        .iter()
        .map(|g| (g.name.clone(), g.bragg_wavelength_nm))
        .collect();
    g.sort_by(|a, b| a.1.total_cmp(&b.1));
    (0..g.len())
        .map(|i| {
            let lo = if i == 0 {
                band_nm.0
            } else {
                0.5 * (g[i - 1].1 + g[i].1) + guard_nm / 2.0
            };
            let hi = if i + 1 == g.len() {
                band_nm.1
            } else {
                0.5 * (g[i].1 + g[i + 1].1) - guard_nm / 2.0
            };
            (g[i].0.clone(), lo, hi)
        })
        .collect()
}

impl ModuleProblem {
    /// Evaluate the design at `x`: every constraint and the objective.
    pub fn evaluate(&self, x: &[f64]) -> Evaluation {
        let d = self.design_at(x);
        self.evaluate_design(x, &d)
    }

    /// Evaluate a built candidate design.
    pub fn evaluate_design(&self, x: &[f64], d: &Design) -> Evaluation {
        let m = d.module.as_ref().expect("candidate has a module");
        let min_wall = d.printer.min_wall_mm;
        let mut cons = Vec::new();
        let thinnest = m.cap_wall_mm.min(m.core_wall_mm);
        push(
            &mut cons,
            "printer_min_wall",
            format!("cap and core walls ≥ {min_wall} mm"),
            (min_wall - thinnest) / min_wall,
            format!("thinnest wall {thinnest:.3} mm"),
        );
        let fit = self.min_fit_clearance_mm();
        let tight = m.cap_core_clearance_mm.min(m.core_insert_clearance_mm);
        push(
            &mut cons,
            "fit_clearance",
            format!("fit clearances ≥ {fit} mm"),
            (fit - tight) / fit,
            format!("tightest clearance {tight:.3} mm"),
        );
        // The spec's rules on the derived profile, each with how far it is broken:
        // the same rules `design::load` enforces, as penalties.
        for v in crate::design::profile_violations(m, min_wall) {
            push(&mut cons, v.rule, v.requirement, v.excess, v.detail);
        }
        // Everything the spec itself checks (a design that fails here would not load).
        let spec_violation = cons.iter().all(|c| c.violation <= 0.0);
        if spec_violation {
            if let Err(e) = d.validate() {
                push(
                    &mut cons,
                    "spec_validation",
                    "the design validates".into(),
                    1.0,
                    e.to_string(),
                );
            }
        }
        let mut objective = 0.0;
        let mut gratings = Vec::new();
        if cons.iter().all(|c| c.violation <= 0.0) {
            let preds = (self.model)(d, self.settings.max_force_n).map(|mut preds| {
                if let Some(c) = &self.correction {
                    c.apply(x, &mut preds);
                }
                preds
            });
            match preds {
                Err(e) => push(
                    &mut cons,
                    "model",
                    "the model predicts the design".into(),
                    1.0,
                    format!("{e:#}"),
                ),
                Ok(preds) => {
                    match design_quality(
                        d,
                        &preds,
                        &self.lib,
                        &self.core_name,
                        self.insert_name.as_deref(),
                        &self.settings.quality,
                        &self.calibration,
                    ) {
                        Err(e) => push(
                            &mut cons,
                            "model",
                            "the model predicts the design".into(),
                            1.0,
                            format!("{e:#}"),
                        ),
                        Ok(q) if q.is_empty() => push(
                            &mut cons,
                            "model",
                            "the model predicts the design".into(),
                            1.0,
                            "no strain grating predicted".into(),
                        ),
                        Ok(q) => {
                            objective = q
                                .iter()
                                .map(|g| match self.settings.objective {
                                    Objective::Q => g.quality_pm_per_n_s,
                                    Objective::Sensitivity => g.sensitivity_pm_per_n.abs(),
                                })
                                .fold(f64::INFINITY, f64::min);
                            if !objective.is_finite() {
                                objective = 0.0;
                            }
                            self.physics_constraints(d, &preds, &mut cons);
                            gratings = q;
                        }
                    }
                }
            }
        }
        Evaluation {
            x: x.to_vec(),
            objective,
            gratings,
            constraints: cons,
        }
    }

    fn physics_constraints(
        &self,
        d: &Design,
        preds: &[GratingPrediction],
        cons: &mut Vec<ConstraintValue>,
    ) {
        let m = d.module.as_ref().expect("candidate has a module");
        let case_preds: Vec<&GratingPrediction> = preds
            .iter()
            .filter(|p| {
                p.core == self.core_name && p.insert.as_deref() == self.insert_name.as_deref()
            })
            .collect();
        let f = self.settings.max_force_n;
        let lim = self.settings.max_grating_strain;
        let worst = case_preds
            .iter()
            .map(|p| (p.strain.abs(), p.grating.as_str()))
            .fold((0.0, ""), |a, b| if b.0 > a.0 { b } else { a });
        push(
            cons,
            "grating_strain",
            format!("|grating strain| at {f} N ≤ {:.0} µε", lim * 1e6),
            (worst.0 - lim) / lim,
            format!("{:.0} µε at grating `{}`", worst.0 * 1e6, worst.1),
        );
        let mut excess_nm: f64 = 0.0;
        let mut detail = String::from("every grating inside its window");
        for (name, lo, hi) in &self.windows_nm {
            let Some(g) = m.gratings.iter().find(|g| &g.name == name) else {
                continue;
            };
            let shift_nm = case_preds
                .iter()
                .find(|p| &p.grating == name)
                .map(|p| p.sensitivity_pm_per_n * f * 1e-3)
                .unwrap_or(0.0);
            let thermal_nm = d
                .fiber
                .temperature_sensitivity_pm_per_k(g.bragg_wavelength_nm)
                * self.settings.temperature_span_k
                * 1e-3;
            let low = g.bragg_wavelength_nm + shift_nm.min(0.0) - thermal_nm;
            let high = g.bragg_wavelength_nm + shift_nm.max(0.0) + thermal_nm;
            let e = (lo - low).max(high - hi).max(0.0);
            if e > excess_nm {
                excess_nm = e;
                detail = format!(
                    "grating `{name}` spans {low:.3}–{high:.3} nm, its window is {lo:.3}–{hi:.3} nm"
                );
            }
        }
        push(
            cons,
            "wavelength_window",
            format!(
                "each grating's range at {f} N ± {} K inside its window (guard {} nm)",
                self.settings.temperature_span_k, self.settings.guard_band_nm
            ),
            excess_nm,
            detail,
        );
    }
}
