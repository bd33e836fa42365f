//! A candidate evaluated: every constraint (printer walls, fit clearances, the
//! profile's rules, the spec, the model, the grating strain, the wavelength windows,
//! the bounding contact readings) with how far it is broken, the margins left on the
//! physical limits in their own units, and the objective of the worst strain grating,
//! scored over the model's uncertainty about K (the design interval) beside its
//! nominal value. The strain and wavelength limits hold at the far end of each
//! grating's design interval, the strain with `ModuleSettings.strain_margin_fraction`
//! of the limit to spare.

use super::outcome::{ConstraintValue, Evaluation, Margins};
use super::problem::ModuleProblem;
use super::robust::FrontObjectives;
use super::settings::Objective;
use crate::model::GratingPrediction;
use crate::prediction::KReadings;
use crate::quality::{design_quality, QualityBreakdown};
use crate::spec::Design;

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

impl ModuleProblem {
    /// Evaluate the design at `x`: every constraint and the objective.
    pub fn evaluate(&self, x: &[f64]) -> Evaluation {
        let d = self.design_at(x);
        self.evaluate_design(x, &d)
    }

    /// The geometric constraints of a candidate: printer walls, fit clearances, the
    /// profile's rules and, when those hold, the spec's own validation.
    fn geometry_constraints(&self, d: &Design) -> Vec<ConstraintValue> {
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
        if cons.iter().all(|c| c.violation <= 0.0) {
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
        cons
    }

    /// The model's prediction of a valid candidate with its Q breakdown: the estimate
    /// with the trust region's correction, its trend without, and the per-grating
    /// quality; or why the model could not predict it.
    #[allow(clippy::type_complexity)]
    fn predicted(
        &self,
        x: &[f64],
        d: &Design,
    ) -> Result<
        (
            Vec<GratingPrediction>,
            Vec<GratingPrediction>,
            Vec<QualityBreakdown>,
        ),
        String,
    > {
        let (preds, trend) = (self.model)(d, self.settings.max_force_n)
            .map(|trend| {
                let mut preds = trend.clone();
                if let Some(c) = &self.correction {
                    c.apply(x, &mut preds);
                }
                (preds, trend)
            })
            .map_err(|e| format!("{e:#}"))?;
        let q = design_quality(
            d,
            &preds,
            &self.lib,
            &self.core_name,
            self.insert_name.as_deref(),
            &self.settings.quality,
            &self.calibration,
        )
        .map_err(|e| format!("{e:#}"))?;
        if q.is_empty() {
            return Err("no strain grating predicted".into());
        }
        Ok((preds, trend, q))
    }

    /// Evaluate a built candidate design.
    pub(crate) fn evaluate_design(&self, x: &[f64], d: &Design) -> Evaluation {
        let mut cons = self.geometry_constraints(d);
        let mut e = Evaluation {
            x: x.to_vec(),
            objective: 0.0,
            nominal_objective: 0.0,
            exact: self.is_exact_at(x),
            gratings: Vec::new(),
            readings: Vec::new(),
            objectives: None,
            margins: None,
            constraints: Vec::new(),
        };
        if cons.iter().all(|c| c.violation <= 0.0) {
            match self.predicted(x, d) {
                Err(why) => push(
                    &mut cons,
                    "model",
                    "the model predicts the design".into(),
                    1.0,
                    why,
                ),
                Ok((preds, trend, q)) => {
                    let scored = self.score(d, &preds, &trend, &q);
                    e.objective = scored.objective;
                    e.nominal_objective = scored.nominal_objective;
                    e.objectives = Some(scored.front);
                    e.margins = Some(self.physics_constraints(d, &scored.rows, &mut cons));
                    e.readings = scored.rows.into_iter().map(|r| r.readings).collect();
                    e.gratings = q;
                }
            }
        }
        e.constraints = cons;
        e
    }

    /// Each grating's room in its wavelength window for a shift of sign `sign`, pm
    /// (what is left once the thermal span is taken).
    fn window_room_pm(&self, d: &Design, name: &str, sign: f64) -> f64 {
        let m = d.module.as_ref().expect("candidate has a module");
        let (Some(g), Some((_, lo, hi))) = (
            m.gratings.iter().find(|g| g.name == name),
            self.windows_nm.iter().find(|w| w.0 == name),
        ) else {
            return f64::INFINITY;
        };
        let thermal_nm = d
            .fiber
            .temperature_sensitivity_pm_per_k(g.bragg_wavelength_nm)
            * self.settings.temperature_span_k
            * 1e-3;
        let room_nm = if sign >= 0.0 {
            hi - g.bragg_wavelength_nm - thermal_nm
        } else {
            g.bragg_wavelength_nm - thermal_nm - lo
        };
        (room_nm * 1e3).max(0.0)
    }

    /// The objective over the model's uncertainty, beside the nominal, and the front's
    /// objectives, from the predictions and the Q breakdown of the optimised
    /// configuration's gratings.
    fn score(
        &self,
        d: &Design,
        preds: &[GratingPrediction],
        trend: &[GratingPrediction],
        q: &[QualityBreakdown],
    ) -> Scored {
        let f = self.settings.max_force_n;
        let lim = self.settings.held_strain_limit();
        let mut rows = Vec::new();
        let mut front = FrontObjectives {
            sensitivity_pm_per_n: f64::INFINITY,
            nominal_sensitivity_pm_per_n: f64::INFINITY,
            force_range_n: f64::INFINITY,
            force_range_limited_by: "grating_strain",
            max_lag_s: 0.0,
            r_squared: f64::INFINITY,
            quality_pm_per_n_s: f64::INFINITY,
        };
        let (mut objective, mut nominal_objective) = (f64::INFINITY, f64::INFINITY);
        for g in q {
            let Some(p) = preds.iter().find(|p| {
                p.grating == g.grating
                    && p.core == self.core_name
                    && p.insert.as_deref() == self.insert_name.as_deref()
            }) else {
                continue;
            };
            let t = trend
                .iter()
                .find(|t| t.grating == p.grating && t.case == p.case && t.insert == p.insert)
                .unwrap_or(p);
            let readings = self.uncertainty.readings_of(p, t);
            let (k_scored, k_limit) = readings.abs_k_range(self.settings.robustness);
            let k_nominal = p.sensitivity_pm_per_n.abs();
            let to_limit = if k_nominal > 0.0 {
                k_limit / k_nominal
            } else {
                1.0
            };
            let scored_q = if k_nominal > 0.0 {
                g.quality_pm_per_n_s * k_scored / k_nominal
            } else {
                0.0
            };
            let strain_per_n = p.strain.abs() / f * to_limit;
            let f_strain = if strain_per_n > 0.0 {
                lim / strain_per_n
            } else {
                f64::INFINITY
            };
            let f_window = if k_limit > 0.0 {
                self.window_room_pm(d, &p.grating, p.sensitivity_pm_per_n) / k_limit
            } else {
                f64::INFINITY
            };
            front.sensitivity_pm_per_n = front.sensitivity_pm_per_n.min(k_scored);
            front.nominal_sensitivity_pm_per_n = front.nominal_sensitivity_pm_per_n.min(k_nominal);
            if f_strain.min(f_window) < front.force_range_n {
                front.force_range_n = f_strain.min(f_window);
                front.force_range_limited_by = if f_strain <= f_window {
                    "grating_strain"
                } else {
                    "wavelength_window"
                };
            }
            front.max_lag_s = front.max_lag_s.max(g.dt_max_s);
            front.r_squared = front.r_squared.min(g.r_squared);
            front.quality_pm_per_n_s = front.quality_pm_per_n_s.min(scored_q);
            let nominal_range = if k_nominal > 0.0 {
                (lim / (p.strain.abs() / f))
                    .min(self.window_room_pm(d, &p.grating, p.sensitivity_pm_per_n) / k_nominal)
            } else {
                f64::INFINITY
            };
            let (v, nv) = match self.settings.objective {
                Objective::Q => (scored_q, g.quality_pm_per_n_s),
                Objective::Sensitivity => (k_scored, k_nominal),
                Objective::ForceRange => (f_strain.min(f_window), nominal_range),
            };
            objective = objective.min(v);
            nominal_objective = nominal_objective.min(nv);
            rows.push(RobustRow {
                readings,
                strain_at_max_force: p.strain,
                strain_limit_factor: to_limit,
                k_limit,
            });
        }
        let finite = |v: f64| if v.is_finite() { v } else { 0.0 };
        Scored {
            objective: finite(objective),
            nominal_objective: finite(nominal_objective),
            front,
            rows,
        }
    }

    /// The constraints on the model's prediction (grating strain, wavelength windows,
    /// bounding readings), each at the far end of the design interval, and the margins
    /// they leave.
    fn physics_constraints(
        &self,
        d: &Design,
        rows: &[RobustRow],
        cons: &mut Vec<ConstraintValue>,
    ) -> Margins {
        let m = d.module.as_ref().expect("candidate has a module");
        let f = self.settings.max_force_n;
        let lim = self.settings.max_grating_strain;
        let held = self.settings.held_strain_limit();
        let preds_strain = |name: &str| {
            rows.iter().find(|r| r.readings.grating == name).map(|r| {
                (
                    r.readings.nominal_pm_per_n,
                    r.k_limit,
                    r.strain_limit_factor,
                )
            })
        };
        let worst = rows
            .iter()
            .map(|r| {
                (
                    r.strain_at_max_force.abs() * r.strain_limit_factor,
                    r.readings.grating.as_str(),
                )
            })
            .fold((0.0, ""), |a, b| if b.0 > a.0 { b } else { a });
        push(
            cons,
            "grating_strain",
            format!(
                "|grating strain| at {f} N at the far end of the design interval ≤ {:.0} µε ({:.0} µε limit less a {:.0} % margin)",
                held * 1e6,
                lim * 1e6,
                100.0 * self.settings.strain_margin_fraction
            ),
            (worst.0 - held) / lim,
            format!(
                "{:.0} µε at grating `{}` at the far end of its design interval",
                worst.0 * 1e6,
                worst.1
            ),
        );
        let mut excess_nm: f64 = 0.0;
        let mut room_nm = f64::INFINITY;
        let mut detail = String::from("every grating inside its window");
        for (name, lo, hi) in &self.windows_nm {
            let Some(g) = m.gratings.iter().find(|g| &g.name == name) else {
                continue;
            };
            let shift_nm = preds_strain(name)
                .map(|(k, k_limit, _)| k.signum() * k_limit * f * 1e-3)
                .unwrap_or(0.0);
            let thermal_nm = d
                .fiber
                .temperature_sensitivity_pm_per_k(g.bragg_wavelength_nm)
                * self.settings.temperature_span_k
                * 1e-3;
            let low = g.bragg_wavelength_nm + shift_nm.min(0.0) - thermal_nm;
            let high = g.bragg_wavelength_nm + shift_nm.max(0.0) + thermal_nm;
            room_nm = room_nm.min((low - lo).min(hi - high));
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
                "each grating's range at {f} N (far end of its design interval) ± {} K inside its window (guard {} nm)",
                self.settings.temperature_span_k, self.settings.guard_band_nm
            ),
            excess_nm,
            detail,
        );
        let margins = Margins {
            grating_strain_microstrain: (lim - worst.0) * 1e6,
            grating_strain_percent: 100.0 * (lim - worst.0) / lim,
            required_strain_margin_percent: 100.0 * self.settings.strain_margin_fraction,
            wavelength_window_nm: room_nm,
            snap_strain_percent: snap_margin_percent(d),
        };
        // The nominal K must be one the physically bounding readings support, with one
        // sign across them (a magnitude, so the search can move away).
        let (v, why) = rows.iter().map(|r| r.readings.band_violation()).fold(
            (
                0.0,
                "every grating's nominal K within its bounding readings, one sign".to_string(),
            ),
            |a, b| {
                if b.0 > a.0 {
                    b
                } else {
                    a
                }
            },
        );
        push(
            cons,
            "contact_band",
            "each grating's nominal K between its bounding contact readings (pillars bonded; cylinders sliding, domes on the apex patch) widened by its model error, with one sign across them".into(),
            v,
            why,
        );
        margins
    }
}

/// The snap-fit's margin: the cap material's permissible strain less the strain the
/// snap imposes, percent (`None` without a snap or a permissible strain).
fn snap_margin_percent(d: &Design) -> Option<f64> {
    let (p, pp) = crate::profile::PartsProfile::of_design(d)?;
    let r = crate::profile::snap_report(d, &p, &pp)?;
    Some(r.permissible_strain_percent - r.cap_strain_percent)
}

/// One grating's robust numbers.
pub(super) struct RobustRow {
    /// Nominal, window and bounding readings.
    pub(super) readings: KReadings,
    /// The nominal strain at the largest force.
    pub(super) strain_at_max_force: f64,
    /// The largest |K| the limits hold for, over the nominal |K|.
    pub(super) strain_limit_factor: f64,
    /// That largest |K|, pm/N.
    pub(super) k_limit: f64,
}

/// What [`ModuleProblem::score`] gives.
struct Scored {
    objective: f64,
    nominal_objective: f64,
    front: FrontObjectives,
    rows: Vec<RobustRow>,
}
