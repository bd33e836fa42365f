//! How a module optimisation is shown: the implementations of
//! [`fbgforge_optimize::run::ModuleSink`].
//!
//! - [`ModuleReportFolder`]: the report folder (`summary.json`, the convergence, Pareto
//!   front and landscape charts with their CSVs, `report.html`);
//! - [`ModuleTable`]: the table on a terminal, every line within [`WIDTH`] columns;
//! - [`ModuleJson`]: the outcome as JSON.
//!
//! The outcome names the options it was run with as the library does
//! (`ModuleSettings.prefer`, see `fbgforge_core::fields`); every printer here renders
//! its text through the front end's words ([`InWords`]: the command line's flags, the
//! Python package's parameters).

mod charts;
mod html;
mod table;

pub(crate) use charts::CONVERGENCE_CAPTION;
pub use charts::{convergence_chart, RunHistory};
pub(crate) use html::Figure;
pub use table::module_table;

use crate::output::write_atomic;
use anyhow::Result;
use fbgforge_optimize::run::{ModuleRun, ModuleSink};
use std::io::Write;

pub use fbgforge_core::fields::InWords;

/// Width the printed tables keep to, columns: the one terminal width.
pub use crate::terminal::WIDTH;

/// Append `text` wrapped to [`WIDTH`] columns by the terminal's one rule
/// ([`crate::terminal::Wrap`]), continuation lines indented by `indent` spaces.
pub(crate) fn wrapped(out: &mut String, text: &str, indent: usize) {
    let rule = crate::terminal::Wrap::TERMINAL.indent(indent);
    for line in text.split('\n') {
        rule.line(out, line);
    }
}

/// `value` as the pretty JSON the report folders and the JSON printers write, in the
/// front end's words.
pub(crate) fn json_text<T: serde::Serialize>(value: &T, words: InWords) -> Result<String> {
    Ok(words(&serde_json::to_string_pretty(value)?))
}

/// The report folder of a module optimisation, written into the run's `report_dir`.
pub struct ModuleReportFolder {
    words: InWords,
}

impl ModuleReportFolder {
    /// A report folder whose text names options in `words`.
    pub fn new(words: InWords) -> Self {
        ModuleReportFolder { words }
    }
}

impl ModuleSink for ModuleReportFolder {
    fn optimised(&mut self, run: &ModuleRun) -> Result<()> {
        let dir = &run.report_dir;
        let o = &run.outcome;
        write_atomic(
            &dir.join("summary.json"),
            json_text(&outcome_json(run)?, self.words)?.as_bytes(),
        )?;
        let win = &o.choices[o.best_choice];
        let convergence = charts::write_convergence(dir, win)?;
        let front = charts::write_front(dir, o, self.words)?;
        let mut landscape = None;
        if let Some(l) = &run.landscape {
            let chart = charts::landscape_chart(o, win, l)?;
            chart.write_svg(&dir.join("landscape.svg"))?;
            charts::write_landscape_csv(dir, l)?;
            landscape = Some(chart);
        }
        let mut figures: Vec<Figure> = vec![(&convergence, CONVERGENCE_CAPTION)];
        if let Some(c) = &landscape {
            figures.push((c, "The objective over the two landscape variables, the others at the optimum: slices of the second variable; points the constraints cut off drawn apart."));
        }
        let doc = html::module_document(o, front.as_ref(), &figures)?;
        write_atomic(
            &dir.join("report.html"),
            (self.words)(&doc.to_html()).as_bytes(),
        )
    }
}

/// The table of a module optimisation, then where the design and the report went.
pub struct ModuleTable<W: Write> {
    out: W,
    words: InWords,
}

impl<W: Write> ModuleTable<W> {
    /// A table printed to `out`, naming options in `words`.
    pub fn new(out: W, words: InWords) -> Self {
        ModuleTable { out, words }
    }
}

impl<W: Write> ModuleSink for ModuleTable<W> {
    fn optimised(&mut self, run: &ModuleRun) -> Result<()> {
        write!(self.out, "{}", module_table(&run.outcome, self.words))?;
        writeln!(self.out, "design: {}", run.design_path.display())?;
        writeln!(self.out, "report: {}", run.report_dir.display())?;
        Ok(())
    }
}

/// The outcome of a module optimisation as pretty JSON.
pub struct ModuleJson<W: Write> {
    out: W,
    words: InWords,
}

impl<W: Write> ModuleJson<W> {
    /// JSON printed to `out`, naming options in `words`.
    pub fn new(out: W, words: InWords) -> Self {
        ModuleJson { out, words }
    }
}

impl<W: Write> ModuleSink for ModuleJson<W> {
    fn optimised(&mut self, run: &ModuleRun) -> Result<()> {
        writeln!(self.out, "{}", json_text(&outcome_json(run)?, self.words)?)?;
        Ok(())
    }
}

/// The outcome as JSON with where the run wrote: `design_path` (the written design)
/// and `report_dir` beside its fields.
pub(crate) fn outcome_json(run: &ModuleRun) -> Result<serde_json::Value> {
    let mut doc = serde_json::Map::new();
    doc.insert(
        "design_path".into(),
        serde_json::Value::String(run.design_path.display().to_string()),
    );
    doc.insert(
        "report_dir".into(),
        serde_json::Value::String(run.report_dir.display().to_string()),
    );
    if let serde_json::Value::Object(o) = serde_json::to_value(&run.outcome)? {
        doc.extend(o);
    }
    Ok(serde_json::Value::Object(doc))
}
