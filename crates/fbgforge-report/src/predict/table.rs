//! A module's prediction as a table: one row per grating and configuration, the models
//! and the warnings as numbered notes below it, what the columns mean, and the paper's
//! Case I statements with their verdicts.

use super::Footnotes;
use anyhow::Result;
use fbgforge_core::fields::InWords;
use fbgforge_model::prediction::{
    self, FidelityChoice, ModelledPrediction, PaperStatements, PredictSink, Predicted,
};
use std::io::Write;

/// The prediction table, printed to a writer.
pub struct PredictTable<W: Write> {
    out: W,
    words: InWords,
}

impl<W: Write> PredictTable<W> {
    /// A table printed to `out`, naming options in `words`.
    pub fn new(out: W, words: InWords) -> Self {
        PredictTable { out, words }
    }
}

impl<W: Write> PredictSink for PredictTable<W> {
    fn predicted(&mut self, p: &Predicted) -> Result<()> {
        let mut text = Vec::new();
        let out = &mut text;
        writeln!(
            out,
            "{}: predicted sensitivity at F = {} N",
            p.design.name, p.request.force_n
        )?;
        let columns = (p.request.with_band(), p.request.delta_t_k != 0.0);
        let interval = p.rows.iter().any(|r| r.design_interval_pm_per_n.is_some());
        let mut notes = Footnotes::default();
        let mut models = Footnotes::default();
        header(out, columns, interval)?;
        for row in p.rows {
            write_row(out, row, (columns, interval), &mut notes, &mut models)?;
        }
        for (i, m) in models.0.iter().enumerate() {
            writeln!(out, "m{}: {m}", i + 1)?;
        }
        write!(out, "{}", legend(columns.0, p.request.fidelity))?;
        write!(out, "{}", error_legend(p, interval))?;
        for (i, n) in notes.0.iter().enumerate() {
            writeln!(out, "[{}] {n}", i + 1)?;
        }
        super::spectrum::write(out, p.rows)?;
        if let Some(s) = p.statements {
            statements(out, s)?;
        }
        let text = String::from_utf8(text)?;
        write!(self.out, "{}", (self.words)(&text))?;
        Ok(())
    }
}

/// The table's header line; `(band, temp)`: whether the band and the thermal columns
/// are shown, `interval`: whether the design interval and its strain are.
fn header(out: &mut impl Write, (band, temp): (bool, bool), interval: bool) -> Result<()> {
    write!(
        out,
        "{:<12} {:<6} {:<4} {:<12} {:<14} {:>8} {:>10} {:>11} {:>10} {:>8}",
        "grating",
        "core",
        "case",
        "insert",
        "model",
        "E1 MPa",
        "K pm/N",
        "shift pm",
        "strain µε",
        "share"
    )?;
    write!(out, " {:>6}", "err %")?;
    if band {
        write!(out, " {:>21}", "band pm/N")?;
    }
    if interval {
        write!(out, " {:>21} {:>10}", "design interval pm/N", "far µε")?;
    }
    if temp {
        write!(out, " {:>11} {:>12}", "raw pm", "compens. pm")?;
    }
    writeln!(out, "  warnings")?;
    Ok(())
}

/// One row of the table; its warnings and model become numbered notes.
fn write_row(
    out: &mut impl Write,
    row: &ModelledPrediction,
    ((band, temp), interval): ((bool, bool), bool),
    notes: &mut Footnotes,
    models: &mut Footnotes,
) -> Result<()> {
    let d = &row.detail;
    let p = &d.prediction;
    let refs: Vec<String> = p
        .warnings
        .iter()
        .map(|w| format!("[{}]", notes.index(w) + 1))
        .collect();
    let share = if d.core_load_share.is_finite() {
        format!("{:.4}", d.core_load_share)
    } else {
        "-".to_string()
    };
    let m = models.index(&row.model_description);
    write!(
        out,
        "{:<12} {:<6} {:<4} {:<12} {:<14} {:>8.3} {:>+10.3} {:>+11.2} {:>+10.1} {:>8}",
        p.grating,
        p.core,
        p.case.to_string(),
        p.insert.as_deref().unwrap_or("-"),
        format!("{} (m{})", row.model.name(), m + 1),
        d.core_modulus_mpa,
        p.sensitivity_pm_per_n,
        p.shift_pm,
        p.strain * 1e6,
        share
    )?;
    let err = row
        .model_error_fraction
        .map_or("-".to_string(), |f| format!("{:.1}", 100.0 * f));
    write!(out, " {err:>6}")?;
    if band {
        let b = row
            .band_pm_per_n
            .map_or("-".to_string(), |[lo, hi]| format!("{lo:+.1} … {hi:+.1}"));
        write!(out, " {b:>21}")?;
    }
    if interval {
        let iv = row
            .design_interval_pm_per_n
            .map_or("-".to_string(), |[lo, hi]| format!("{lo:+.1} … {hi:+.1}"));
        let far = row.limit_check.map_or("-".to_string(), |c| {
            format!("{:+.0}", c.far_end_strain_microstrain)
        });
        write!(out, " {iv:>21} {far:>10}")?;
    }
    if temp {
        let comp = d
            .compensated_shift_pm
            .map_or("-".to_string(), |c| format!("{c:+.2}"));
        write!(out, " {:>+11.2} {:>12}", d.raw_shift_pm, comp)?;
    }
    writeln!(out, "  {}", refs.join(""))?;
    Ok(())
}

/// What the columns and the model choice mean, in the library's words.
fn legend(band: bool, choice: FidelityChoice) -> String {
    let mut s = String::from("K > 0: red shift (core cylinder in tension); K < 0: blue shift.\n");
    if band {
        s.push_str("band: K between the bounding contact readings (FE): pillars bonded to the cap (most coupled) and cylinders sliding with the domes touching over the apex patch only (least coupled); docs/model.md §5.6.\n");
    }
    s.push_str("share: Case I, share of F through the cap→core loop; Case II, share carried by the core (closed form only).\n");
    match choice {
        FidelityChoice::Auto => {
            let v = prediction::validity();
            s.push_str(&format!(
                "model (PredictionRequest.fidelity auto): closed form where measured within {:.0} % of the FE model (D {}–{} mm; Case II core t/R ≤ {}; Case I {}), FE with the design's [module.contact] elsewhere.\n",
                v.tolerance * 100.0,
                v.diameter_range_mm.0,
                v.diameter_range_mm.1,
                v.max_wall_to_radius_case_ii,
                if v.max_wall_to_radius_case_i > 0.0 {
                    format!("core t/R ≤ {}", v.max_wall_to_radius_case_i)
                } else {
                    "never".to_string()
                }
            ));
        }
        FidelityChoice::ClosedForm => s.push_str("model: closed form forced (PredictionRequest.fidelity closed-form): no finite-element solve, so no band (PredictionRequest.fidelity auto gives it).\n"),
        FidelityChoice::Fem => s.push_str("model: finite elements forced (PredictionRequest.fidelity fem).\n"),
    }
    s
}

/// What the error, the design interval and the far-end strain mean, the mesh and the
/// discretisation error it implies, and where the limits were checked.
fn error_legend(p: &Predicted, interval: bool) -> String {
    let mut s = String::from(
        "err %: the nominal K's stated model error, discretisation (the Richardson step of the FE mesh, at least 0.5 %) plus a modelling term from the comparison with independent solutions (closed form, Case II 8 %; FE, Case I 9 %, Case II 14 %); docs/model.md §5.8.\n",
    );
    let disc: Vec<f64> = p
        .rows
        .iter()
        .filter_map(|r| r.model_error)
        .filter(|e| e.discretisation_fraction > 0.0)
        .map(|e| e.discretisation_fraction)
        .collect();
    if !disc.is_empty() {
        let (lo, hi) = disc
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, &d| {
                (a.0.min(d), a.1.max(d))
            });
        // The levels the rows were answered at: the one asked for, or finer where the
        // policy refined a configuration to state its accuracy.
        let levels: Vec<u32> = p.rows.iter().filter_map(|r| r.mesh_level).collect();
        let level = match (levels.iter().min(), levels.iter().max()) {
            (Some(a), Some(b)) if a != b => format!("{a}–{b}"),
            (Some(a), _) => a.to_string(),
            _ => "custom".to_string(),
        };
        let how = match p.request.refine_to_level {
            Some(finest) => format!(
                "per configuration the cheapest level up to {finest} that states a model error of at most 15 %; PredictionRequest.fem_options fixes one"
            ),
            None => "PredictionRequest.fem_options".to_string(),
        };
        s.push_str(&format!(
            "mesh level {level} ({how}; element sizes relative to the 34 mm module, extrapolated with the level below): discretisation error {:.1}–{:.1} % over the FE rows.\n",
            100.0 * lo,
            100.0 * hi
        ));
    }
    if interval {
        s.push_str("design interval: every reading the spec implies (Case I: the nominal and the contact window's ends, 1.30–1.48 × the apex patch; Case II: the closed form and the FE reading of the stated cylinders), each widened by its own model error; far µε: the strain at the largest force from its far end.\n");
        if let Some(c) = p.rows.iter().find_map(|r| r.limit_check) {
            s.push_str(&format!(
                "limits: {} N ({}), strain limit {:.0} µε, each grating to keep {:.0} % of it free at the far end.\n",
                c.force_n,
                if c.force_from == "design" {
                    "the design's [module.limits]"
                } else {
                    "PredictionRequest.force_n"
                },
                c.strain_limit_microstrain,
                100.0 * prediction::STRAIN_MARGIN_FRACTION
            ));
        }
    }
    s
}

/// The paper's Case I statements on this design, each with its verdict.
fn statements(out: &mut impl Write, s: &PaperStatements) -> Result<()> {
    let failed = s.failures();
    writeln!(
        out,
        "paper's Case I statements (docs/model.md §7.2) on {}: {}",
        s.design,
        if failed.is_empty() {
            "every one checked holds".to_string()
        } else {
            format!(
                "{} FAIL{}",
                failed
                    .iter()
                    .map(|c| c.statement)
                    .collect::<Vec<_>>()
                    .join(", "),
                if failed.len() == 1 { "S" } else { "" }
            )
        }
    )?;
    for c in &s.checks {
        let v = match c.holds {
            Some(true) => "holds",
            Some(false) => "FAILS",
            None => "not checked",
        };
        writeln!(out, "  {:<34} {v:<12} {}", c.statement, c.detail)?;
    }
    Ok(())
}
