//! Library errors as the Python exceptions of `fbgforge.errors`: a design spec that
//! does not hold is a `DesignError` (a `ValueError`, with the file and the field), a
//! missing file a `MissingFileError` (a `FileNotFoundError`), another failed file
//! operation a `FileError` (an `OSError`), anything else a bad value (`InputError`,
//! a `ValueError`). Messages are the library's, with the command line's flags named
//! as the Python parameters are (`--force-n` → `force_n`).

use fbgforge::spec::SpecError;
use pyo3::prelude::*;
use std::path::Path;

/// Raise `fbgforge.errors.<class>(message, **extra)`.
fn raise(py: Python<'_>, class: &str, message: String, extra: &[(&str, Option<String>)]) -> PyErr {
    let made = py
        .import("fbgforge.errors")
        .and_then(|m| m.getattr(class))
        .and_then(|c| {
            let kwargs = pyo3::types::PyDict::new(py);
            for (k, v) in extra {
                kwargs.set_item(k, v)?;
            }
            c.call((message,), Some(&kwargs))
        });
    match made {
        Ok(exc) => PyErr::from_value(exc),
        Err(e) => e,
    }
}

/// Request fields whose Python parameter is named otherwise than the field
/// (`Type.field` → parameter); every other field is its own parameter name.
pub const PARAMS: &[(&str, &str)] = &[
    // verify
    ("AnalysisOptions.window_half_width_nm", "window_nm"),
    ("AnalysisOptions.max_clock_offset_s", "max_offset_s"),
    ("ForceReadOptions.time", "force_time_column"),
    ("ForceReadOptions.force", "force_force_column"),
    ("ForceReadOptions.scale_to_n", "force_scale_to_n"),
    ("ForceReadOptions.date_order", "force_date_order"),
    // synth_log
    ("TrainSettings.peaks_n", "pulses_n"),
    ("SynthConfig.sample_rate_hz", "rate_hz"),
    ("SynthConfig.sensitivity_pm_per_n", "k_pm_per_n"),
    ("LogStyle.metadata_lines", "metadata_lines"),
    // calibrate_array
    ("CalibrateRequest.window_half_width_nm", "window_nm"),
    // live
    ("InterpretOptions.window_half_width_nm", "window_nm"),
    ("LiveRequest.max_frames", "frames"),
    ("LiveRequest.queue_frames", "queue"),
    ("LiveRequest.source", "source"),
    // optimize
    ("ModuleSettings.min_fit_clearance_mm", "min_clearance_mm"),
];

/// A library text in the package's words ([`python_words`] with no renames): what
/// the result documents and report folders say.
pub fn py_words(text: &str) -> String {
    python_words(text, &[])
}

/// A library message in the Python package's words: every request field the library
/// names (`VerifyRequest.force_start`, see `fbgforge::fields`) as its parameter
/// (`force_start`, or its entry in [`PARAMS`]), then any command-line `--flag-name`
/// left as the parameter `flag_name` (`renames` maps flags whose parameter is named
/// otherwise, e.g. `from` → `start`).
pub fn python_words(message: &str, renames: &[(&str, &str)]) -> String {
    let names = fbgforge::fields::field_names(message);
    let words: Vec<(String, String)> = names
        .into_iter()
        .map(|name| {
            let param = PARAMS
                .iter()
                .find(|(f, _)| *f == name)
                .map(|(_, p)| p.to_string())
                .unwrap_or_else(|| name.rsplit('.').next().unwrap_or(&name).to_string());
            (name, param)
        })
        .collect();
    let pairs: Vec<(&str, &str)> = words
        .iter()
        .map(|(a, b)| (a.as_str(), b.as_str()))
        .collect();
    let message = fbgforge::fields::in_words(message, &pairs);
    let message = message.as_str();
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(i) = rest.find("--") {
        let after = &rest[i + 2..];
        let len = after
            .find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-'))
            .unwrap_or(after.len());
        let flag = after[..len].trim_end_matches('-');
        let starts_word = i == 0 || !rest[..i].ends_with(|c: char| c.is_alphanumeric());
        if flag.is_empty() || !starts_word || !flag.starts_with(|c: char| c.is_ascii_lowercase()) {
            out.push_str(&rest[..i + 2]);
            rest = after;
            continue;
        }
        out.push_str(&rest[..i]);
        match renames.iter().find(|(f, _)| *f == flag) {
            Some((_, p)) => out.push_str(p),
            None => out.push_str(&flag.replace('-', "_")),
        }
        rest = &after[flag.len()..];
    }
    out.push_str(rest);
    out
}

/// A library error as its Python exception (see the module doc).
pub fn err(py: Python<'_>, e: anyhow::Error) -> PyErr {
    err_named(py, e, &[])
}

/// [`err`] with flags renamed for this call's parameters.
pub fn err_named(py: Python<'_>, e: anyhow::Error, renames: &[(&str, &str)]) -> PyErr {
    let message = python_words(&format!("{e:#}"), renames);
    for cause in e.chain() {
        if let Some(s) = cause.downcast_ref::<SpecError>() {
            return spec_err(py, s.clone(), Some(message));
        }
        if let Some(io) = cause.downcast_ref::<std::io::Error>() {
            let class = if io.kind() == std::io::ErrorKind::NotFound {
                "MissingFileError"
            } else {
                "FileError"
            };
            return raise(py, class, message, &[]);
        }
    }
    raise(py, "InputError", message, &[])
}

/// A design spec error as a `DesignError` (message: `message`, or the error's own).
pub fn spec_err(py: Python<'_>, e: SpecError, message: Option<String>) -> PyErr {
    let file = e.file.as_ref().map(|p| p.display().to_string());
    let field = (!e.field.is_empty()).then(|| e.field.clone());
    let message = message.unwrap_or_else(|| e.to_string());
    raise(
        py,
        "DesignError",
        message,
        &[("file", file), ("field", field)],
    )
}

/// A bad value (`InputError`, a `ValueError`).
pub fn input(py: Python<'_>, message: impl Into<String>) -> PyErr {
    raise(py, "InputError", message.into(), &[])
}

/// Refuse a missing input file before the library reads it: `MissingFileError`
/// naming the parameter and the path.
pub fn must_exist(py: Python<'_>, path: &Path, what: &str) -> PyResult<()> {
    if path.exists() {
        return Ok(());
    }
    Err(raise(
        py,
        "MissingFileError",
        format!("{what} {}: no such file", path.display()),
        &[("filename", Some(path.display().to_string()))],
    ))
}
