//! How a synthetic log set is announced: the files written, in one line
//! (`fbgforge synth-log`).

use fbgforge_synth::files::SynthLogFiles;

/// `wrote <log>, <force> and <truth>` for a module run, `wrote <log> and <matrix
/// truth>` for an array calibration run.
pub fn written(files: &SynthLogFiles) -> String {
    match &files.matrix_truth {
        Some(truth) => format!("wrote {} and {}", files.log.display(), truth.display()),
        None => format!(
            "wrote {}, {} and {}",
            files.log.display(),
            files.force.clone().unwrap_or_default().display(),
            files.truth.clone().unwrap_or_default().display()
        ),
    }
}
