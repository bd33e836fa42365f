//! What a terminal shows: every printed table and note keeps to [`WIDTH`] columns
//! (a terminal's default), the wide detail going to the JSON and the report folders.
//!
//! The tables are laid out to fit; the prose around them (notes, warnings, legends)
//! is wrapped here, at spaces, with continuation lines indented under the line's
//! own text. A word longer than a line (a path) is kept whole: a path cut is a path
//! that cannot be copied.

use std::io::{self, Write};

/// Columns the terminal output keeps to.
pub const WIDTH: usize = 80;

/// Columns `s` takes on a terminal: one per character (the printers' characters,
/// µ, ε, ², …, box drawing and block elements, are all one column wide).
pub fn width(s: &str) -> usize {
    s.chars().count()
}

/// How a printer breaks a line longer than its width: the one wrapping rule of every
/// terminal printer (the tables' notes, optimize's and place's reports, live's view),
/// which differ only in these settings.
///
/// Every rule breaks at spaces, keeps the first line's leading spaces and the runs of
/// spaces inside a line (a wrapped table row keeps its alignment up to the break), and
/// trims the spaces at a break.
///
/// ```
/// use fbgforge_report::terminal::{width, Wrap};
/// let line = "fiber x mm (mold slits): 10.0, 20.0, 30.0, 40.0, 50.0";
/// let text = Wrap::TERMINAL.width(30).indent(4).text(line);
/// assert_eq!(text, "fiber x mm (mold slits): 10.0,\n    20.0, 30.0, 40.0, 50.0");
/// let cut = Wrap::TERMINAL.width(10).indent(4).cut_long_words().text(&"x".repeat(30));
/// assert_eq!((width(&cut), cut.ends_with('…')), (6, true));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wrap {
    /// Columns a line keeps to.
    pub columns: usize,
    /// The continuation lines' indent; `None` hangs them under the line's text.
    pub continuation: Option<usize>,
    /// Whether a word longer than a line is cut with `…` (a status line redrawn in
    /// place must fit) rather than kept whole (a path cut cannot be copied).
    pub cut: bool,
}

impl Wrap {
    /// The default: [`WIDTH`] columns, continuation hung under the text, words whole.
    pub const TERMINAL: Wrap = Wrap {
        columns: WIDTH,
        continuation: None,
        cut: false,
    };

    /// This rule at `columns` columns.
    #[must_use]
    pub const fn width(self, columns: usize) -> Wrap {
        Wrap { columns, ..self }
    }

    /// This rule with continuation lines indented by `spaces`.
    #[must_use]
    pub const fn indent(self, spaces: usize) -> Wrap {
        Wrap {
            continuation: Some(spaces),
            ..self
        }
    }

    /// This rule cutting a word longer than a line with `…`.
    #[must_use]
    pub const fn cut_long_words(self) -> Wrap {
        Wrap { cut: true, ..self }
    }

    /// `text` with every line longer than the width wrapped; the text after the last
    /// newline (usually none) stays unterminated.
    pub fn text(&self, text: &str) -> String {
        let mut out = String::with_capacity(text.len() + text.len() / 40);
        let mut lines = text.split('\n').peekable();
        while let Some(line) = lines.next() {
            if lines.peek().is_none() {
                if !line.is_empty() {
                    let mut last = String::new();
                    self.line(&mut last, line);
                    last.pop();
                    out.push_str(&last);
                }
                break;
            }
            self.line(&mut out, line);
        }
        out
    }

    /// `line` (no newline) wrapped, each piece pushed to `out` with a newline.
    pub fn line(&self, out: &mut String, line: &str) {
        if width(line) <= self.columns {
            out.push_str(line);
            out.push('\n');
            return;
        }
        let indent = self.continuation.unwrap_or_else(|| hanging_indent(line));
        let lead = line.len() - line.trim_start_matches(' ').len();
        let mut cur = " ".repeat(lead.min(self.columns / 2));
        let mut fresh = true;
        for (gap, word) in spaced_words(line) {
            let word = self.whole_or_cut(word);
            if !fresh && width(&cur) + width(gap) + width(&word) > self.columns {
                out.push_str(cur.trim_end());
                out.push('\n');
                cur = " ".repeat(indent.min(self.columns / 2));
                fresh = true;
            }
            if !fresh {
                cur.push_str(gap);
            }
            cur.push_str(&word);
            fresh = false;
        }
        out.push_str(&cur);
        out.push('\n');
    }

    /// `word`, or (when this rule cuts) its first columns and `…` if it is longer
    /// than a continuation line holds.
    fn whole_or_cut<'a>(&self, word: &'a str) -> std::borrow::Cow<'a, str> {
        let room = self.columns.saturating_sub(4).max(1);
        if self.cut && width(word) > room {
            word.chars()
                .take(room - 1)
                .chain(['…'])
                .collect::<String>()
                .into()
        } else {
            word.into()
        }
    }
}

/// The indent of a line's continuation: under its text after any leading spaces and a
/// marker (`[3] `, `- `, `• `; otherwise four spaces in), at most half a line.
fn hanging_indent(line: &str) -> usize {
    let lead = line.len() - line.trim_start_matches(' ').len();
    let rest = &line[lead..];
    let marker = [
        rest.strip_prefix('[')
            .and_then(|r| r.find("] ").map(|i| i + 3)),
        ["- ", "• "]
            .iter()
            .find(|m| rest.starts_with(*m))
            .map(|m| m.chars().count()),
    ]
    .into_iter()
    .flatten()
    .next();
    match marker {
        Some(m) => lead + m,
        None => lead + 4,
    }
}

/// The words of `line` after its indent, each with the run of spaces before it (kept
/// inside a line, so a wrapped table row keeps its alignment up to the break).
fn spaced_words(line: &str) -> Vec<(&str, &str)> {
    let mut out = Vec::new();
    let mut rest = line.trim_start_matches(' ');
    let mut gap = "";
    while !rest.is_empty() {
        let end = rest.find(' ').unwrap_or(rest.len());
        out.push((gap, &rest[..end]));
        let after = &rest[end..];
        let next = after.trim_start_matches(' ');
        gap = &after[..after.len() - next.len()];
        rest = next;
    }
    out
}

/// `text` with every line longer than [`WIDTH`] columns wrapped at spaces
/// ([`Wrap::TERMINAL`]).
///
/// ```
/// use fbgforge_report::terminal::{fit, width, WIDTH};
/// let note = format!("[1] {}", "a long warning about the grating strain ".repeat(5));
/// let text = fit(&format!("grating  K pm/N\n{note}\n"));
/// assert!(text.lines().all(|l| width(l) <= WIDTH));
/// assert!(text.starts_with("grating  K pm/N\n[1] a long"));
/// assert!(text.lines().nth(2).unwrap().starts_with("    ")); // under the note's text
/// ```
pub fn fit(text: &str) -> String {
    Wrap::TERMINAL.text(text)
}

/// A writer that fits each line written through it to [`WIDTH`] columns ([`fit`]):
/// what a command's terminal printer writes into when it prints for a person (never
/// the JSON a script reads).
pub struct Fit<W: Write> {
    out: W,
    pending: Vec<u8>,
}

impl<W: Write> Fit<W> {
    /// Lines written to `out`, fitted.
    pub fn new(out: W) -> Self {
        Fit {
            out,
            pending: Vec::new(),
        }
    }

    /// Fit and write every complete line held.
    fn drain(&mut self) -> io::Result<()> {
        if let Some(end) = self.pending.iter().rposition(|&b| b == b'\n') {
            let lines: Vec<u8> = self.pending.drain(..=end).collect();
            let text = String::from_utf8_lossy(&lines);
            self.out.write_all(fit(&text).as_bytes())?;
        }
        Ok(())
    }
}

impl<W: Write> Write for Fit<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.pending.extend_from_slice(buf);
        self.drain()?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.drain()?;
        if !self.pending.is_empty() {
            let rest = std::mem::take(&mut self.pending);
            self.out
                .write_all(fit(&String::from_utf8_lossy(&rest)).as_bytes())?;
        }
        self.out.flush()
    }
}

impl<W: Write> Drop for Fit<W> {
    fn drop(&mut self) {
        let _ = self.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_lines_pass_untouched_and_long_ones_wrap_under_their_text() {
        let short = "grating    K pm/N   R²\nlambda_11  -165.5   0.94\n";
        assert_eq!(fit(short), short);
        let long = format!("  [12] {}\n", "word ".repeat(40).trim_end());
        let f = fit(&long);
        let lines: Vec<&str> = f.lines().collect();
        assert!(lines.len() > 2, "{f}");
        assert!(lines.iter().all(|l| width(l) <= WIDTH), "{f}");
        assert!(lines[0].starts_with("  [12] word"));
        assert!(lines[1].starts_with(&" ".repeat(7)) && !lines[1].starts_with(&" ".repeat(8)));
        // Nothing lost, nothing added but line breaks and indents.
        let words = |s: &str| s.split_whitespace().map(str::to_string).collect::<Vec<_>>();
        assert_eq!(words(&f), words(&long));
    }

    #[test]
    fn spaces_inside_a_wrapped_line_are_kept() {
        let row = format!("a    b {}", "c ".repeat(50));
        let f = fit(&row);
        assert!(f.starts_with("a    b c c"), "{f}");
    }

    #[test]
    fn a_word_longer_than_a_line_stays_whole() {
        let path = format!("wrote {}", "x/".repeat(60));
        let f = fit(&path);
        assert!(f.contains(&"x/".repeat(60)), "{f}");
    }

    #[test]
    fn the_writer_fits_lines_split_across_writes() {
        let mut buf = Vec::new();
        {
            let mut w = Fit::new(&mut buf);
            let text = format!("warning: {}\nnext", "abc ".repeat(30));
            for chunk in text.as_bytes().chunks(7) {
                w.write_all(chunk).unwrap();
            }
        }
        let s = String::from_utf8(buf).unwrap();
        assert!(s.lines().all(|l| width(l) <= WIDTH), "{s}");
        assert!(s.ends_with("\nnext"), "{s}");
        assert_eq!(
            fit(&format!("warning: {}\n", "abc ".repeat(30)))
                .lines()
                .count()
                + 1,
            s.lines().count()
        );
    }
}
