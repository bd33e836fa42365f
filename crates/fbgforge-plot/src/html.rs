//! Self-contained HTML reports: a small document builder for the reports of
//! `verify`, `optimize` and `place`.
//!
//! A report is one file that opens anywhere, offline: its style sheet is inline, its
//! charts are inline SVG ([`crate::Chart::to_svg_inline`]), it loads nothing
//! (no script, font, image or style sheet from elsewhere) and needs no JavaScript.
//! The builder knows sections, paragraphs, lists of facts, a verdict banner with its
//! reasons, tables and figures; every text it is given is escaped.

use crate::output::write_atomic;
use crate::svg::escape;
use crate::Chart;
use anyhow::Result;
use std::fmt::Write as _;
use std::path::Path;

/// How a verdict or a table cell reads: good, bad, to be looked at, or plain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tone {
    /// Met what it was judged against.
    Pass,
    /// Did not.
    Fail,
    /// Neither: judged with a caveat, or not judged.
    Warn,
    /// Plain information.
    Neutral,
}

impl Tone {
    fn class(self) -> &'static str {
        match self {
            Tone::Pass => "pass",
            Tone::Fail => "fail",
            Tone::Warn => "warn",
            Tone::Neutral => "neutral",
        }
    }
}

/// A table cell: its text and, optionally, a tone.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Text (escaped when written).
    pub text: String,
    /// Colouring, if any.
    pub tone: Option<Tone>,
}

impl<T: Into<String>> From<T> for Cell {
    fn from(t: T) -> Self {
        Cell {
            text: t.into(),
            tone: None,
        }
    }
}

impl Cell {
    /// A cell with a tone.
    pub fn toned(text: impl Into<String>, tone: Tone) -> Self {
        Cell {
            text: text.into(),
            tone: Some(tone),
        }
    }
}

/// A table: header and rows of cells.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// Column headings (with units).
    pub header: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<Cell>>,
}

impl Table {
    /// A table with these headings and no rows.
    pub fn new<S: Into<String>>(header: impl IntoIterator<Item = S>) -> Self {
        Table {
            header: header.into_iter().map(Into::into).collect(),
            rows: Vec::new(),
        }
    }

    /// Add a row.
    pub fn row<C: Into<Cell>>(&mut self, cells: impl IntoIterator<Item = C>) {
        self.rows.push(cells.into_iter().map(Into::into).collect());
    }
}

const STYLE: &str = "
body{font-family:'DejaVu Sans',Arial,Helvetica,sans-serif;margin:1.5em auto;max-width:1200px;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.25em;border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
.verdict{border-radius:6px;padding:.8em 1.1em;margin:1em 0;border:2px solid}
.verdict .headline{font-size:1.35em;font-weight:bold}
.verdict.pass{background:#e8f5e9;border-color:#2e7d32}.verdict.fail{background:#ffebee;border-color:#c62828}
.verdict.warn{background:#fff8e1;border-color:#f9a825}.verdict.neutral{background:#f5f5f5;border-color:#9e9e9e}
.verdict ul{margin:.4em 0 0 0}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}
th,td{border:1px solid #ccc;padding:.25em .55em;text-align:left;vertical-align:top}
th{background:#f0f0f0}td.pass{background:#e8f5e9}td.fail{background:#ffebee}td.warn{background:#fff8e1}
dl.facts{display:grid;grid-template-columns:max-content auto;gap:.2em 1em}dl.facts dt{font-weight:bold}dl.facts dd{margin:0}
figure{margin:1em 0}figure svg{max-width:100%;height:auto;border:1px solid #eee}figcaption{font-size:.9em;color:#555}
code{background:#f4f4f4;padding:0 .2em}.note{color:#555;font-size:.92em}
";

/// An HTML report being built.
#[derive(Debug, Clone)]
pub struct Document {
    title: String,
    body: String,
}

impl Document {
    /// An empty report with a title (also its first heading).
    pub fn new(title: impl Into<String>) -> Self {
        Document {
            title: title.into(),
            body: String::new(),
        }
    }

    /// A section heading.
    pub fn section(&mut self, heading: &str) {
        let _ = writeln!(self.body, "<h2>{}</h2>", escape(heading));
    }

    /// A paragraph in a quieter style (assumptions, how a number was made).
    pub fn note(&mut self, text: &str) {
        let _ = writeln!(self.body, r#"<p class="note">{}</p>"#, escape(text));
    }

    /// The verdict banner: a headline (`PASS`, `FAIL` …) in its tone, what it was
    /// judged against, and the reasons. One per report, `id="verdict"`.
    pub fn verdict(&mut self, tone: Tone, headline: &str, detail: &str, reasons: &[String]) {
        let _ = writeln!(
            self.body,
            r#"<section id="verdict" class="verdict {}" data-verdict="{}"><div class="headline">{}</div>"#,
            tone.class(),
            escape(headline),
            escape(headline)
        );
        if !detail.is_empty() {
            let _ = writeln!(self.body, "<div>{}</div>", escape(detail));
        }
        if !reasons.is_empty() {
            let _ = writeln!(self.body, r#"<ul class="reasons">"#);
            for r in reasons {
                let _ = writeln!(self.body, "<li>{}</li>", escape(r));
            }
            let _ = writeln!(self.body, "</ul>");
        }
        let _ = writeln!(self.body, "</section>");
    }

    /// Name–value pairs (inputs, settings).
    pub fn facts(&mut self, items: &[(&str, String)]) {
        let _ = writeln!(self.body, r#"<dl class="facts">"#);
        for (k, v) in items {
            let _ = writeln!(self.body, "<dt>{}</dt><dd>{}</dd>", escape(k), escape(v));
        }
        let _ = writeln!(self.body, "</dl>");
    }

    /// A bulleted list.
    pub fn list(&mut self, items: &[String]) {
        let _ = writeln!(self.body, "<ul>");
        for i in items {
            let _ = writeln!(self.body, "<li>{}</li>", escape(i));
        }
        let _ = writeln!(self.body, "</ul>");
    }

    /// A table, `class` naming it for readers and tests.
    pub fn table(&mut self, class: &str, t: &Table) {
        let _ = writeln!(self.body, r#"<table class="{}"><thead><tr>"#, escape(class));
        for h in &t.header {
            let _ = write!(self.body, "<th>{}</th>", escape(h));
        }
        let _ = writeln!(self.body, "</tr></thead><tbody>");
        for r in &t.rows {
            let _ = write!(self.body, "<tr>");
            for c in r {
                match c.tone {
                    Some(tone) => {
                        let _ = write!(
                            self.body,
                            r#"<td class="{}">{}</td>"#,
                            tone.class(),
                            escape(&c.text)
                        );
                    }
                    None => {
                        let _ = write!(self.body, "<td>{}</td>", escape(&c.text));
                    }
                }
            }
            let _ = writeln!(self.body, "</tr>");
        }
        let _ = writeln!(self.body, "</tbody></table>");
    }

    /// A chart, inline, with a caption; `file` names the SVG (and its CSV) beside.
    pub fn chart(&mut self, chart: &Chart, caption: &str) -> Result<()> {
        let svg = chart.to_svg_inline()?;
        self.svg_figure(&svg, caption);
        Ok(())
    }

    /// An inline SVG picture (an `<svg>` element without namespace URL) with a caption.
    pub fn svg_figure(&mut self, svg: &str, caption: &str) {
        let _ = writeln!(
            self.body,
            "<figure>\n{svg}<figcaption>{}</figcaption></figure>",
            escape(caption)
        );
    }

    /// The files written beside the report, as relative links.
    pub fn files(&mut self, names: &[&str]) {
        let _ = write!(self.body, r#"<p class="note">Files beside this report: "#);
        for (i, n) in names.iter().enumerate() {
            let sep = if i + 1 == names.len() { "" } else { ", " };
            let _ = write!(
                self.body,
                r#"<a href="{n}"><code>{n}</code></a>{sep}"#,
                n = escape(n)
            );
        }
        let _ = writeln!(self.body, ".</p>");
    }

    /// The whole document.
    pub fn to_html(&self) -> String {
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<meta name=\"generator\" content=\"fbgforge {}\">\n<title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{}</h1>\n{}</body>\n</html>\n",
            env!("CARGO_PKG_VERSION"),
            escape(&self.title),
            escape(&self.title),
            self.body
        )
    }

    /// Write the document atomically to `path`.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_atomic(path, self.to_html().as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Mark, Series};

    #[test]
    fn a_report_escapes_its_text_and_loads_nothing_from_elsewhere() {
        let mut d = Document::new("report of <design & co>");
        d.verdict(
            Tone::Fail,
            "FAIL",
            "K against the model",
            &["error 12 % > 8 %".into()],
        );
        let mut t = Table::new(["grating", "K pm/N"]);
        t.row(["fbg<1>", "1.0"]);
        t.rows
            .push(vec!["x".into(), Cell::toned("bad", Tone::Fail)]);
        d.table("figures", &t);
        d.chart(
            &Chart::new("c", "x", "y").with(Series::new(
                "s",
                vec![(0.0, 1.0), (1.0, 2.0)],
                Mark::Line,
            )),
            "a chart",
        )
        .unwrap();
        d.files(&["report.json"]);
        let html = d.to_html();
        assert!(html.contains("report of &lt;design &amp; co&gt;"));
        assert!(
            html.contains("<td>fbg&lt;1&gt;</td>") && html.contains(r#"<td class="fail">bad</td>"#)
        );
        assert!(html.contains(r#"id="verdict" class="verdict fail" data-verdict="FAIL""#));
        assert!(html.contains("<svg class=\"fbg-chart\""));
        for external in [
            "http:", "https:", "//", "<script", "<link", "@import", "src=",
        ] {
            assert!(!html.contains(external), "{external} in the report");
        }
    }
}
