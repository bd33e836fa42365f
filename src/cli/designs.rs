//! A design argument: a TOML file, or the name of a shipped design
//! (`fbgforge predict clip-on-34mm`), found where the library's default build finds
//! them (`fbgforge::design::designs_dir()`: `designs/` under the working directory,
//! else the repository's), the names Python's `fbgforge.shipped_design` takes.

use std::path::{Path, PathBuf};

/// The design file `arg` names: the file itself when it exists or names a folder
/// (`designs/x.toml`, `./x.toml`), else the shipped design of that name (with or
/// without `.toml`); an unknown name is refused with the shipped names.
pub fn design_arg(arg: &str) -> Result<PathBuf, String> {
    let given = PathBuf::from(arg);
    if given.exists() || given.components().count() > 1 {
        return Ok(given);
    }
    let dir = fbgforge::design::designs_dir();
    let name = arg.trim_end_matches(".toml");
    let shipped = dir.join(format!("{name}.toml"));
    if shipped.is_file() {
        return Ok(shipped);
    }
    Err(format!(
        "no design file `{arg}` and no shipped design of that name; the shipped designs: {}",
        shipped_names(&dir).join(", ")
    ))
}

/// The names of the shipped designs in `dir` (file stems, sorted).
fn shipped_names(dir: &Path) -> Vec<String> {
    fbgforge::design::design_files(dir)
        .unwrap_or_default()
        .iter()
        .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shipped_name_is_its_file_and_a_path_stays_a_path() {
        let p = design_arg("clip-on-34mm").unwrap();
        assert!(
            p.ends_with("designs/clip-on-34mm.toml") && p.is_file(),
            "{p:?}"
        );
        assert_eq!(design_arg("clip-on-34mm.toml").unwrap(), p);
        assert_eq!(
            design_arg("some/dir/x.toml").unwrap(),
            PathBuf::from("some/dir/x.toml")
        );
        let e = design_arg("clip-on-99mm").unwrap_err();
        assert!(
            e.contains("clip-on-34mm") && e.contains("tactile-array-60x80"),
            "{e}"
        );
    }
}
