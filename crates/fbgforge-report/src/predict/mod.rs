//! How predictions are shown: the implementations of
//! [`fbgforge_model::prediction::PredictSink`] ([`PredictTable`], [`PredictJson`]) and
//! of [`fbgforge_model::prediction::SweepSink`] ([`SweepFiles`], [`PaperFigureFiles`]),
//! and the printers of an array's predicted sensing matrix ([`array`]).
//!
//! Text that names an option names it as the library does
//! (`PredictionRequest.fidelity`); every printer renders it through the front end's
//! words (`fbgforge_core::fields::InWords`).

pub mod array;
mod spectrum;
mod sweep;
mod table;

pub use sweep::{sweep_chart, sweep_csv, PaperFigureFiles, SweepFiles};
pub use table::PredictTable;

use anyhow::Result;
use fbgforge_core::fields::InWords;
use fbgforge_model::prediction::{PredictSink, Predicted};
use std::io::Write;

/// A module's prediction as pretty JSON: the design, the force, the temperature
/// change, the model choice, every row and the paper's statements.
pub struct PredictJson<W: Write> {
    out: W,
    words: InWords,
}

impl<W: Write> PredictJson<W> {
    /// JSON printed to `out`, naming options in `words`.
    pub fn new(out: W, words: InWords) -> Self {
        PredictJson { out, words }
    }
}

impl<W: Write> PredictSink for PredictJson<W> {
    fn predicted(&mut self, p: &Predicted) -> Result<()> {
        let doc = serde_json::json!({
            "design": p.design.name,
            "force_n": p.request.force_n,
            "delta_t_k": p.request.delta_t_k,
            "fidelity": p.request.fidelity,
            // The level the policy started from; rows the policy refined were answered
            // finer, so the levels actually used are listed apart (each row names its own).
            "starting_mesh_level": p.request.fem_options.policy_level(),
            "mesh_levels_used": mesh_levels_used(p),
            "predictions": p.rows,
            "paper_statements": p.statements,
        });
        let text = (self.words)(&serde_json::to_string_pretty(&doc)?);
        writeln!(self.out, "{text}")?;
        Ok(())
    }
}

/// The distinct policy mesh levels the rows' FE readings were solved at, ascending
/// (empty when no row has FE readings on a policy mesh).
fn mesh_levels_used(p: &Predicted) -> Vec<u32> {
    let mut levels: Vec<u32> = p.rows.iter().filter_map(|r| r.mesh_level).collect();
    levels.sort_unstable();
    levels.dedup();
    levels
}

/// Numbered footnotes: each distinct text once, in order of first use.
#[derive(Default)]
struct Footnotes(Vec<String>);

impl Footnotes {
    /// The index of `text`, added if new.
    fn index(&mut self, text: &str) -> usize {
        self.0.iter().position(|n| n == text).unwrap_or_else(|| {
            self.0.push(text.to_string());
            self.0.len() - 1
        })
    }
}
