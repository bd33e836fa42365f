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
        let widths = Widths::of(p.rows);
        let mut notes = Footnotes::default();
        let mut models = Footnotes::default();
        header(out, columns, widths)?;
        for row in p.rows {
            write_row(out, row, (columns, widths), &mut notes, &mut models)?;
        }
        for (i, m) in models.0.iter().enumerate() {
            writeln!(out, "m{}: {m}", i + 1)?;
        }
        write!(out, "{}", legend(columns, p.request.fidelity))?;
        write!(out, "{}", error_legend(p, interval))?;
        for (i, n) in notes.0.iter().enumerate() {
            writeln!(out, "[{}] {n}", i + 1)?;
        }
        super::spectrum::write(out, p.rows)?;
        if let Some(s) = p.statements {
            statements(out, s)?;
        }
        let text = String::from_utf8(text)?;
        write!(self.out, "{}", crate::terminal::fit(&(self.words)(&text)))?;
        Ok(())
    }
}

/// Widths of the name columns: the longest grating name and configuration (`II`,
/// `I light_green`), at least the header's, so the table fits 80 columns with the
/// paper's names.
#[derive(Clone, Copy)]
struct Widths {
    grating: usize,
    case: usize,
}

/// `II` or `I blue`: the loading case and its insert.
fn case_label(p: &fbgforge_model::model::GratingPrediction) -> String {
    match &p.insert {
        Some(i) => format!("{} {i}", p.case),
        None => p.case.to_string(),
    }
}

impl Widths {
    fn of(rows: &[ModelledPrediction]) -> Self {
        let longest = |f: &dyn Fn(&ModelledPrediction) -> usize, min: usize| {
            rows.iter().map(f).max().unwrap_or(0).max(min)
        };
        Widths {
            grating: longest(&|r| r.detail.prediction.grating.chars().count(), 7),
            case: longest(&|r| case_label(&r.detail.prediction).chars().count(), 4),
        }
    }
}

/// The table's header, names then units; `(band, temp)`: whether the band and the
/// thermal columns are shown (the thermal columns take the band's place: the band
/// stays in the JSON). The shift at F (K·F), E1, the load share, the design interval
/// and its far-end strain are in the JSON, so the table keeps to 80 columns.
fn header(out: &mut impl Write, (band, temp): (bool, bool), w: Widths) -> Result<()> {
    let row = |out: &mut dyn Write, names: [&str; 10]| -> Result<()> {
        write!(
            out,
            "{:<gw$} {:<4} {:<cw$} {:<5} {:>8} {:>7} {:>5}",
            names[0],
            names[1],
            names[2],
            names[3],
            names[4],
            names[5],
            names[6],
            gw = w.grating,
            cw = w.case,
        )?;
        if temp {
            write!(out, " {:>8} {:>8}", names[7], names[8])?;
        } else if band {
            write!(out, " {:>13}", names[7])?;
        }
        if names[9].is_empty() {
            writeln!(out)?;
        } else {
            writeln!(out, " {}", names[9])?;
        }
        Ok(())
    };
    row(
        out,
        [
            "grating",
            "core",
            "case",
            "model",
            "K",
            "strain",
            "err",
            if temp { "raw" } else { "band" },
            "comp.",
            "notes",
        ],
    )?;
    row(
        out,
        [
            "",
            "",
            "",
            "",
            "pm/N",
            "µε",
            "%",
            if temp { "pm" } else { "pm/N" },
            "pm",
            "",
        ],
    )
}

/// One row of the table; its warnings and model become numbered notes.
fn write_row(
    out: &mut impl Write,
    row: &ModelledPrediction,
    ((band, temp), w): ((bool, bool), Widths),
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
    let m = models.index(&row.model_description);
    write!(
        out,
        "{:<gw$} {:<4} {:<cw$} {:<5} {:>+8.2} {:>+7.1}",
        p.grating,
        p.core,
        case_label(p),
        format!("m{}", m + 1),
        p.sensitivity_pm_per_n,
        p.strain * 1e6,
        gw = w.grating,
        cw = w.case,
    )?;
    let err = row
        .model_error_fraction
        .map_or("-".to_string(), |f| format!("{:.1}", 100.0 * f));
    write!(out, " {err:>5}")?;
    if temp {
        let comp = d
            .compensated_shift_pm
            .map_or("-".to_string(), |c| format!("{c:+.1}"));
        write!(out, " {:>+8.1} {:>8}", d.raw_shift_pm, comp)?;
    } else if band {
        let b = row
            .band_pm_per_n
            .map_or("-".to_string(), |[lo, hi]| format!("{lo:+.1}…{hi:+.1}"));
        write!(out, " {b:>13}")?;
    }
    writeln!(out, " {}", refs.join(""))?;
    Ok(())
}

/// What the columns and the model choice mean, in the library's words.
fn legend((band, temp): (bool, bool), choice: FidelityChoice) -> String {
    let mut s = String::from("K > 0: red shift (core cylinder in tension); K < 0: blue shift. strain: at F. The shift at F (K·F), E1, the load share, the design interval and its far-end strain: in the JSON document.\n");
    if temp {
        s.push_str("raw pm: the shift at F with the temperature change; comp. pm: after the reference grating's compensation (the band: in the JSON).\n");
    } else if band {
        s.push_str("band: K between the bounding contact readings (FE): pillars bonded to the cap (most coupled) and cylinders sliding with the domes touching over the apex patch only (least coupled); docs/model.md §5.6.\n");
    }
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
        s.push_str("design interval: every reading the spec implies (Case I: the nominal and the contact window's ends, 1.30–1.48 × the apex patch; Case II: the closed form and the FE reading of the stated cylinders), each widened by its own model error (in the JSON, with the strain at the largest force from its far end).\n");
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
        writeln!(out, "  {}: {v}; {}", c.statement, c.detail)?;
    }
    Ok(())
}
