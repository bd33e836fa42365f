//! How a grating placement is shown: the implementations of
//! [`fbgforge_optimize::run::PlaceSink`].
//!
//! - [`PlaceReportFolder`]: the report folder (`summary.json`, the layout on the sheet
//!   as `layout.svg` and `layout.csv`, convergence, the proxy's agreement, and
//!   `report.html`);
//! - [`PlaceTable`]: the table on a terminal, every line within
//!   [`crate::optimize::WIDTH`] columns;
//! - [`PlaceJson`]: the outcome as JSON.

mod html;
pub mod sheet;
mod table;

pub use table::place_table;

use crate::optimize::{
    convergence_chart, json_text, Figure, InWords, RunHistory, CONVERGENCE_CAPTION,
};
use crate::output::{write_atomic, write_csv};
use crate::plot::{Chart, Mark, Series};
use anyhow::Result;
use fbgforge_optimize::place::PlaceOutcome;
use fbgforge_optimize::run::{PlaceRun, PlaceSink};
use std::io::Write;
use std::path::Path;

/// The report folder of a placement, written into the run's `report_dir`.
pub struct PlaceReportFolder {
    words: InWords,
}

impl PlaceReportFolder {
    /// A report folder whose text names options in `words`.
    pub fn new(words: InWords) -> Self {
        PlaceReportFolder { words }
    }
}

impl PlaceSink for PlaceReportFolder {
    fn placed(&mut self, run: &PlaceRun) -> Result<()> {
        let dir = &run.report_dir;
        let o = &run.outcome;
        write_atomic(
            &dir.join("summary.json"),
            json_text(o, self.words)?.as_bytes(),
        )?;
        let inline = write_layout(dir, &run.start, o)?;
        let convergence = write_convergence(dir, o)?;
        let agreement = write_agreement(dir, o)?;
        let mut figures: Vec<Figure> = vec![(&convergence, CONVERGENCE_CAPTION)];
        if let Some(c) = &agreement {
            figures.push((c, "Random layouts: the coherence proxy against the protocol score (lower coherence should score higher)."));
        }
        let doc = html::place_document(o, run.held_out_seeds, &inline, &figures)?;
        write_atomic(
            &dir.join("report.html"),
            (self.words)(&doc.to_html()).as_bytes(),
        )
    }
}

/// The layout on the sheet, start and chosen: `layout.svg` and `layout.csv`; returns
/// the picture for inlining in the HTML.
fn write_layout(
    dir: &Path,
    start: &fbgforge_core::spec::Design,
    o: &PlaceOutcome,
) -> Result<String> {
    let (Some(from), Some(to)) = (&start.array, &o.design.array) else {
        anyhow::bail!("internal: a placement without an [array] section");
    };
    // The start as the search saw it (clamped into the box), so start and chosen are
    // drawn on the same terms.
    let mut from = from.clone();
    for (g, &y) in from.gratings.iter_mut().zip(&o.start_x) {
        g.y_mm = y;
    }
    if o.start_x.len() == from.gratings.len() + from.fiber_x_mm.len() {
        let n = from.gratings.len();
        from.fiber_x_mm = o.start_x[n..].to_vec();
    }
    let title = format!("Layout of {}: start and chosen", o.design.name);
    let (svg, _, _) = sheet::layout_svg(&from, to, &title, true);
    write_atomic(&dir.join("layout.svg"), svg.as_bytes())?;
    let (inline, _, _) = sheet::layout_svg(&from, to, &title, false);
    write_csv(
        &dir.join("layout.csv"),
        &sheet::LAYOUT_HEADER,
        &sheet::layout_rows(&from, to),
    )?;
    Ok(inline)
}

/// Convergence of every solver's run: chart and CSV.
fn write_convergence(dir: &Path, o: &PlaceOutcome) -> Result<Chart> {
    let runs: Vec<RunHistory> = o
        .runs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            (
                r.solver.name().to_string(),
                r.solver,
                i,
                r.history.as_slice(),
            )
        })
        .collect();
    let (chart, gaps) = convergence_chart("Placement convergence", &runs);
    let mut rows = Vec::new();
    for (r, g) in o.runs.iter().zip(&gaps) {
        for (i, (c, gap)) in r.history.iter().zip(g).enumerate() {
            rows.push(vec![
                r.solver.name().to_string(),
                (i + 1).to_string(),
                c.to_string(),
                gap.to_string(),
            ]);
        }
    }
    chart.write_svg(&dir.join("convergence.svg"))?;
    write_csv(
        &dir.join("convergence.csv"),
        &["solver", "iteration", "best_cost", "above_lowest"],
        &rows,
    )?;
    Ok(chart)
}

/// The coherence proxy against the protocol over random layouts, when measured: chart
/// and CSV.
fn write_agreement(dir: &Path, o: &PlaceOutcome) -> Result<Option<Chart>> {
    let Some(ag) = &o.agreement else {
        return Ok(None);
    };
    let chart = Chart::new(
        "Coherence proxy against the protocol",
        "mutual coherence",
        "RR % + mean SNR dB",
    )
    .with(Series::new(
        "random layouts",
        ag.points.clone(),
        Mark::Points,
    ));
    chart.write_svg(&dir.join("proxy_agreement.svg"))?;
    let rows: Vec<Vec<String>> = ag
        .points
        .iter()
        .map(|p| vec![p.0.to_string(), p.1.to_string()])
        .collect();
    write_csv(
        &dir.join("proxy_agreement.csv"),
        &["mutual_coherence", "protocol_score"],
        &rows,
    )?;
    Ok(Some(chart))
}

/// The table of a placement, then where the design and the report went.
pub struct PlaceTable<W: Write> {
    out: W,
}

impl<W: Write> PlaceTable<W> {
    /// A table printed to `out`.
    pub fn new(out: W) -> Self {
        PlaceTable { out }
    }
}

impl<W: Write> PlaceSink for PlaceTable<W> {
    fn placed(&mut self, run: &PlaceRun) -> Result<()> {
        let o = &run.outcome;
        // The written layout is the search's best on its training seeds; when it does
        // not beat the start on the held-out ones the closing line says so, so the
        // path is not read as the result.
        let gain = o.best_test.score() - o.start_test.score();
        let verdict = if gain > 0.0 {
            String::new()
        } else {
            format!(
                " (written, but it does not beat the start on the held-out seeds: RR + SNR {gain:+.2}; keep the start design)"
            )
        };
        let text = format!(
            "{}design: {}{verdict}\nreport: {}\n",
            place_table(o),
            run.design_path.display(),
            run.report_dir.display()
        );
        write!(self.out, "{}", crate::terminal::fit(&text))?;
        Ok(())
    }
}

/// The outcome of a placement as pretty JSON.
pub struct PlaceJson<W: Write> {
    out: W,
    words: InWords,
}

impl<W: Write> PlaceJson<W> {
    /// JSON printed to `out`, naming options in `words`.
    pub fn new(out: W, words: InWords) -> Self {
        PlaceJson { out, words }
    }
}

impl<W: Write> PlaceSink for PlaceJson<W> {
    fn placed(&mut self, run: &PlaceRun) -> Result<()> {
        writeln!(self.out, "{}", json_text(&run.outcome, self.words)?)?;
        Ok(())
    }
}
