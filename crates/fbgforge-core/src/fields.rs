//! The library's own words for the options it is given.
//!
//! The library never names a command-line flag or a Python parameter. An error about an
//! option names the field of the use case's request (or settings) that holds it, written
//! `Type.field`, e.g. `VerifyRequest.force_start`, and each front end maps those names
//! to its own words once: the binary's `cli::hiargs` to `--force-start`, the Python
//! package to `force_start` (ripgrep's `hiargs.rs` is the example: flags become the
//! library's configuration in one place, so the library never names a flag).
//!
//! ```
//! use fbgforge_core::fields::in_words;
//! let words = [("VerifyRequest.force_start", "--force-start")];
//! let message = "VerifyRequest.force_start `x`: expected a date and time";
//! assert_eq!(in_words(message, &words), "--force-start `x`: expected a date and time");
//! ```

/// `message` with every field name of `words` (`(field, word)` pairs, e.g.
/// `("VerifyRequest.force_start", "--force-start")`) replaced by its word. Longer names
/// are replaced first, so `Options.window` never eats the start of `Options.window_nm`;
/// a name only counts where it is not part of a longer identifier.
pub fn in_words(message: &str, words: &[(&str, &str)]) -> String {
    let mut order: Vec<&(&str, &str)> = words.iter().collect();
    order.sort_by_key(|(field, _)| std::cmp::Reverse(field.len()));
    let mut out = message.to_string();
    for (field, word) in order {
        out = replace_whole(&out, field, word);
    }
    out
}

/// A front end's words for the library's: the text with every field name the front end
/// knows written its way (the binary's flags, the Python package's parameters). A
/// printer takes one, so what it prints reads in the words its user typed.
pub type InWords = fn(&str) -> String;

/// The library's own words: the text unchanged.
pub fn own_words(text: &str) -> String {
    text.to_string()
}

/// Every `Type.field` name in `message` whose type name ends with one of the request
/// suffixes the library uses ([`REQUEST_SUFFIXES`]), in order of appearance. Front ends
/// test with it that their table covers every name the library can say.
pub fn field_names(message: &str) -> Vec<String> {
    let bytes = message.as_bytes();
    let mut found = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts = bytes[i].is_ascii_uppercase() && (i == 0 || !is_ident(bytes[i - 1]));
        if !starts {
            i += 1;
            continue;
        }
        let mut j = i;
        while j < bytes.len() && bytes[j].is_ascii_alphanumeric() {
            j += 1;
        }
        let ty = &message[i..j];
        if j + 1 < bytes.len()
            && bytes[j] == b'.'
            && bytes[j + 1].is_ascii_lowercase()
            && REQUEST_SUFFIXES.iter().any(|s| ty.ends_with(s))
        {
            let mut k = j + 1;
            while k < bytes.len()
                && (bytes[k].is_ascii_lowercase() || bytes[k].is_ascii_digit() || bytes[k] == b'_')
            {
                k += 1;
            }
            found.push(message[i..k].to_string());
            i = k;
        } else {
            i = j.max(i + 1);
        }
    }
    found
}

/// The endings of the type names whose fields an error may name: a use case's request,
/// and the options, settings and configurations it carries.
pub(crate) const REQUEST_SUFFIXES: [&str; 5] = ["Request", "Options", "Settings", "Config", "Args"];

fn is_ident(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}

fn replace_whole(text: &str, name: &str, word: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find(name) {
        let before_ok = at == 0 || !is_ident(rest.as_bytes()[at - 1]);
        let end = at + name.len();
        let after_ok = end == rest.len() || !is_ident(rest.as_bytes()[end]);
        out.push_str(&rest[..at]);
        out.push_str(if before_ok && after_ok { word } else { name });
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn longer_names_win_and_parts_of_identifiers_stay() {
        // A front end's words (here a keyword-argument style): any text will do.
        let words = [
            ("AnalysisOptions.window", "window="),
            ("AnalysisOptions.window_nm", "window_nm="),
        ];
        assert_eq!(
            in_words(
                "AnalysisOptions.window_nm and AnalysisOptions.window",
                &words
            ),
            "window_nm= and window="
        );
        assert_eq!(
            in_words("XAnalysisOptions.window_nm", &words),
            "XAnalysisOptions.window_nm"
        );
    }

    #[test]
    fn field_names_are_found_by_their_request_suffix() {
        let names = field_names(
            "give VerifyRequest.force_start or AnalysisOptions.clock_offset_s; Table 2.x is no field",
        );
        assert_eq!(
            names,
            [
                "VerifyRequest.force_start",
                "AnalysisOptions.clock_offset_s"
            ]
        );
    }
}
