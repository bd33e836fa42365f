//! The paper's statements on what `optimize` writes: every design of the front is
//! predicted as written (the policy, every configuration of the written design) and
//! checked on the statements `predict` checks (`prediction::check_paper_statements`);
//! by default a design that fails one is not written
//! (`ModuleSettings::paper_statements`). The same prediction names the rows whose
//! stated model error exceeds `prediction::MAX_MODEL_ERROR` at the finest mesh the
//! policy refines to: such a design is never written while another is (issue 38).
//! And what each design's Case I contact rests on, in words, for the written file's
//! description.

use super::choice::Choice;
use super::predictor::Predictor;
use super::ProblemInputs;
use crate::prediction::{
    check_paper_statements, predict, ModelledPrediction, PredictionRequest, MAX_MODEL_ERROR,
};
use crate::spec::Design;

/// What `predict` finds wrong with a front design as written: the paper's statements
/// it fails, and its rows whose stated model error exceeds [`MAX_MODEL_ERROR`].
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct WrittenChecks {
    pub(super) paper_statements_failed: Vec<String>,
    pub(super) model_error_over_max: Vec<String>,
}

/// The rows of `rows` whose stated model error exceeds [`MAX_MODEL_ERROR`], each named
/// with its grating, case, insert and error (e.g. `lambda_11 Case I light_green 17.2 %`).
pub(super) fn rows_over_max_model_error(rows: &[ModelledPrediction]) -> Vec<String> {
    rows.iter()
        .filter_map(|r| {
            let f = r.model_error_fraction.filter(|&f| f > MAX_MODEL_ERROR)?;
            let p = &r.detail.prediction;
            Some(format!(
                "{} Case {} {} {:.1} %",
                p.grating,
                p.case,
                p.insert.as_deref().unwrap_or("hollow"),
                100.0 * f
            ))
        })
        .collect()
}

impl ProblemInputs<'_> {
    /// What `predict` finds wrong with the design of `choice` at `x` (nothing when a
    /// synthetic predictor stands in: it states no FE rows, so nothing is checked).
    pub(super) fn written_checks(
        &self,
        choice: &Choice,
        x: &[f64],
    ) -> anyhow::Result<WrittenChecks> {
        let Predictor::Policy {
            fidelity,
            structures,
            ..
        } = &self.predictor
        else {
            return Ok(WrittenChecks::default());
        };
        let d = self.problem(choice.clone())?.design_at(x);
        let rows = predict(
            &d,
            &PredictionRequest {
                fidelity: *fidelity,
                cache: structures.clone(),
                ..PredictionRequest::default()
            },
        )?;
        Ok(WrittenChecks {
            paper_statements_failed: check_paper_statements(&d, &rows).map_or_else(Vec::new, |s| {
                s.failures()
                    .iter()
                    .map(|c| c.statement.to_string())
                    .collect()
            }),
            model_error_over_max: rows_over_max_model_error(&rows),
        })
    }
}

/// What the design's Case I contact rests on, in words (for its description): a
/// calibrated radius, or the family rule's default and why it is what it is; a hollow
/// core has no contact parameter.
pub fn contact_basis(design: &Design, choice: &Choice) -> String {
    let Some(m) = design.module.as_ref() else {
        return String::new();
    };
    if choice.insert_material.is_none() {
        return format!(
            "Case II (hollow core): no contact parameter; K by the model policy, held over the closed form and the FE reading of the stated cylinders (`{}`)",
            match m.contact.cylinders {
                crate::spec::CylinderCoupling::Sliding => "sliding",
                crate::spec::CylinderCoupling::Bonded => "bonded",
            }
        );
    }
    let patch = m.apex_patch_radius_mm();
    let r = m.dome_contact_radius_mm();
    if m.contact_radius_is_default() {
        let (lo, hi) = crate::spec::Contact::PAPER_WINDOW_TO_PATCH;
        format!(
            "Case I contact: the domes bear within {r:.3} mm, {:.3} × the apex patch, the family rule's default: chosen so that the FE model meets the paper's Case I statements on the 34 mm module (window {lo:.2}–{hi:.2} × the patch, docs/model.md §5.6), not measured; held over that window",
            r / patch
        )
    } else {
        format!(
            "Case I contact: the domes bear within {r:.3} mm ({:.3} × the apex patch), calibrated{}",
            r / patch,
            m.contact
                .note
                .as_deref()
                .map(|n| format!(" ({n})"))
                .unwrap_or_default()
        )
    }
}
