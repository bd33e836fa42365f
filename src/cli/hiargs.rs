//! The library's words to the command line's, in one place (ripgrep's `hiargs.rs`).
//!
//! The library names an option by the request field that holds it
//! (`VerifyRequest.force_start`, see `fbgforge::fields`); each subcommand's file lists
//! its fields beside the flags that fill them (`FLAGS`), and this module gathers those
//! lists, so an error the library raises reads in the words the user typed
//! (`--force-start`). A test checks that every field name the library's sources can
//! say has its flag here.

use super::{build, live, log_args, optimize, peaks, predict, reconstruct, verify};
use fbgforge::fields::in_words;

/// Every subcommand's `(field, flag)` pairs.
pub const FLAGS: &[&[(&str, &str)]] = &[
    build::FLAGS,
    predict::FLAGS,
    optimize::FLAGS,
    verify::FLAGS,
    reconstruct::FLAGS,
    live::FLAGS,
    peaks::FLAGS,
    log_args::FLAGS,
];

/// `message` with every request field named as its flag.
pub fn in_flag_words(message: &str) -> String {
    let all: Vec<(&str, &str)> = FLAGS.iter().flat_map(|t| t.iter().copied()).collect();
    in_words(message, &all)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;
    use std::path::Path;

    fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                rust_files(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }

    /// Every `Type.field` name written in the library's sources has a flag here, and
    /// no flag is listed twice for different fields.
    #[test]
    fn every_field_the_library_names_has_its_flag() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("crates");
        let mut files = Vec::new();
        rust_files(&root, &mut files);
        let listed: BTreeSet<&str> = FLAGS
            .iter()
            .flat_map(|t| t.iter().map(|(f, _)| *f))
            .collect();
        let mut missing = BTreeSet::new();
        // fields.rs names example fields in its own tests and docs.
        for f in files
            .iter()
            .filter(|f| !f.ends_with("fbgforge-core/src/fields.rs"))
        {
            let text = std::fs::read_to_string(f).unwrap();
            for line in text.lines() {
                let code = line.trim_start();
                if code.starts_with("//") {
                    continue;
                }
                for name in fbgforge::fields::field_names(code) {
                    if !listed.contains(name.as_str()) {
                        missing.insert(format!("{name} ({})", f.display()));
                    }
                }
            }
        }
        assert!(
            missing.is_empty(),
            "fields without a flag in cli::hiargs: {missing:#?}"
        );
    }
}
