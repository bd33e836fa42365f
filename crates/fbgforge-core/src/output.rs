//! Safe output files: everything fbgforge writes goes through here.
//!
//! A file is written to a temporary sibling and renamed into place, so a failure (a
//! full disk, a bad part, Ctrl-C) never leaves a half-written STL, CSV or report that
//! a slicer or a script could mistake for a good one.

use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Create `dir` (and its parents), with an error that names it.
pub fn ensure_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create output folder {}", dir.display()))
}

/// Write `bytes` to `path` atomically: temporary file in the same folder, then rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes).map_err(Into::into))
}

/// Write through a callback to `path` atomically. The callback gets a buffered writer;
/// if it fails, the temporary file is removed and `path` is left untouched.
pub fn write_atomic_with<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut dyn Write) -> Result<()>,
{
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    ensure_dir(&dir)?;
    let mut tmp = tempfile::Builder::new()
        .prefix(".fbgforge-")
        .suffix(".tmp")
        .tempfile_in(&dir)
        .with_context(|| format!("cannot write in output folder {}", dir.display()))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w).with_context(|| format!("while writing {}", path.display()))?;
        w.flush()
            .with_context(|| format!("while writing {}", path.display()))?;
    }
    // tempfile creates files readable by the owner only; a finished output is an
    // ordinary file that a slicer or a colleague should be able to read.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = tmp
            .as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644));
    }
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("cannot move the finished file to {}", path.display()))?;
    Ok(())
}

/// Serialise `value` as pretty JSON into `path`, atomically.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    write_atomic(path, text.as_bytes())
}

/// Write rows as CSV with a header into `path`, atomically.
pub fn write_csv(path: &Path, header: &[&str], rows: &[Vec<String>]) -> Result<()> {
    write_atomic_with(path, |w| {
        let mut c = csv::Writer::from_writer(w);
        c.write_record(header)?;
        for r in rows {
            c.write_record(r)?;
        }
        c.flush()?;
        Ok(())
    })
}

/// Fill the folder `dir` whole or not at all: `fill` writes into a fresh temporary
/// folder beside it, which then replaces `dir` (a previous `dir` is moved aside and
/// removed once the new one is in place). If `fill` fails, the temporary folder is
/// removed and `dir` is left as it was.
pub fn write_dir_atomic<F>(dir: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&Path) -> Result<()>,
{
    let parent = match dir.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    ensure_dir(&parent)?;
    let name = dir
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    let staged = |suffix: &str| {
        tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .suffix(suffix)
            .tempdir_in(&parent)
            .with_context(|| format!("cannot write in output folder {}", parent.display()))
    };
    let tmp = staged(".tmp")?;
    fill(tmp.path()).with_context(|| format!("while writing {}", dir.display()))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o755));
    }
    // The previous folder goes aside (inside a fresh temporary folder, so the move
    // never lands on an existing name) and is removed once the new one is in place.
    let aside = if dir.exists() {
        let holder = staged(".old")?;
        let to = holder.path().join(&name);
        std::fs::rename(dir, &to).with_context(|| {
            format!(
                "cannot move the previous {} aside to replace it",
                dir.display()
            )
        })?;
        Some((holder, to))
    } else {
        None
    };
    let tmp = tmp.keep();
    if let Err(e) = std::fs::rename(&tmp, dir) {
        // Put the previous folder back; the new one is dropped.
        if let Some((_, to)) = &aside {
            let _ = std::fs::rename(to, dir);
        }
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e)
            .with_context(|| format!("cannot move the finished folder to {}", dir.display()));
    }
    drop(aside);
    Ok(())
}
