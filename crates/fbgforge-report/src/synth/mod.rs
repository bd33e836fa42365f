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

/// The K's a `--from-model` log follows, as one line that fits 80 columns for the
/// shipped designs: `K from the model (Case II): lambda_11 10.52, lambda_12 9.87 pm/N`.
///
/// ```
/// use fbgforge_report::synth::model_k_line;
/// let line = model_k_line(fbgforge_model::model::LoadCase::II, None, &[("lambda_11".into(), 10.523)]);
/// assert_eq!(line, "K from the model (Case II): lambda_11 10.52 pm/N");
/// ```
pub fn model_k_line(
    case: fbgforge_model::model::LoadCase,
    insert: Option<&str>,
    k: &[(String, f64)],
) -> String {
    let config = match insert {
        Some(i) => format!("Case {case}, {i}"),
        None => format!("Case {case}"),
    };
    let each: Vec<String> = k.iter().map(|(n, v)| format!("{n} {v:.2}")).collect();
    format!("K from the model ({config}): {} pm/N", each.join(", "))
}
