//! Errors of a design spec: a [`SpecError`] names the file, the dotted field and what
//! was expected; a TOML syntax error becomes one with its line and the table it sits in.

use std::fmt;
use std::path::PathBuf;

/// An error in a design spec, naming the file and the field at fault.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecError {
    /// The file the spec came from, if any.
    pub file: Option<PathBuf>,
    /// Dotted path of the offending field, e.g. `module.cap_wall_mm`.
    pub field: String,
    /// What is wrong and what was expected.
    pub message: String,
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(p) = &self.file {
            write!(f, "{}: ", p.display())?;
        }
        // File-level errors (unreadable file, TOML syntax at the top level) name no field.
        if !self.field.is_empty() {
            write!(f, "field `{}`: ", self.field)?;
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for SpecError {}

/// Build a [`SpecError`] without a file (the loader adds it).
pub fn err(field: &str, message: impl Into<String>) -> SpecError {
    SpecError {
        file: None,
        field: field.to_string(),
        message: message.into(),
    }
}

/// A TOML error as a [`SpecError`]: its line in the message, and the table the line
/// sits in as the field.
pub(super) fn toml_error(text: &str, e: toml::de::Error) -> SpecError {
    let mut message = e.message().to_string();
    let mut field = String::new();
    if let Some(span) = e.span() {
        let before = &text[..span.start.min(text.len())];
        let line = before.matches('\n').count() + 1;
        message = format!("line {line}: {message}");
        // toml names no key path; the table the line sits in is the next best thing.
        field = before
            .lines()
            .rev()
            .find_map(table_header)
            .unwrap_or_default();
    }
    SpecError {
        file: None,
        field,
        message,
    }
}

/// The table a TOML header line opens (`[module.pillars]`, `[[module.cores]]`).
fn table_header(line: &str) -> Option<String> {
    let t = line.trim();
    let inner = t
        .strip_prefix("[[")
        .and_then(|r| r.strip_suffix("]]"))
        .or_else(|| t.strip_prefix('[').and_then(|r| r.strip_suffix(']')))?;
    Some(inner.trim().to_string())
}
