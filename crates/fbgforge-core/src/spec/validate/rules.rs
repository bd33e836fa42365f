//! The rules every area's checks share: a number finite, in range, positive; a name
//! unique in its list. Each error names the field and the allowed range.

use crate::spec::error::{err, SpecError};

/// `name` (the `what` at `field`) must differ from every earlier name in its list.
pub(super) fn unique_name<'a>(
    earlier: impl IntoIterator<Item = &'a str>,
    name: &str,
    field: &str,
    what: &str,
) -> Result<(), SpecError> {
    if earlier.into_iter().any(|o| o == name) {
        return Err(err(field, format!("duplicate {what} name `{name}`")));
    }
    Ok(())
}

/// `v` must be finite.
pub(super) fn finite(field: &str, v: f64) -> Result<(), SpecError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(err(field, format!("expected a finite number, got {v}")))
    }
}

/// `v` must be finite and within [lo, hi].
pub fn range(field: &str, v: f64, lo: f64, hi: f64) -> Result<(), SpecError> {
    finite(field, v)?;
    if hi < lo {
        // The rest of the design leaves this field no room: say so rather than give
        // a range that ends below its start.
        return Err(err(
            field,
            format!("{v}: no value fits the rest of the design (it would need to be at least {lo:.4} and at most {hi:.4}); change the fields that bound it"),
        ));
    }
    if v < lo || v > hi {
        return Err(err(
            field,
            format!("{v} is out of range; allowed {lo:.4} to {hi:.4}"),
        ));
    }
    Ok(())
}

/// `v` must be finite, strictly positive and within [lo, hi].
pub fn positive(field: &str, v: f64, lo: f64, hi: f64) -> Result<(), SpecError> {
    finite(field, v)?;
    if v <= 0.0 {
        return Err(err(
            field,
            format!("{v} must be positive; allowed {lo:.4} to {hi:.4}"),
        ));
    }
    range(field, v, lo, hi)
}

/// The parts of `[lo, hi]` outside every `blocked` interval (open at their ends), in
/// order: where a value may go once the ranges its neighbours take are removed.
pub fn free_intervals(lo: f64, hi: f64, blocked: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut free = vec![(lo, hi)];
    for &(b0, b1) in blocked {
        free = free
            .into_iter()
            .flat_map(|(a0, a1)| {
                let mut out = Vec::new();
                if b0 > a0 {
                    out.push((a0, a1.min(b0)));
                }
                if b1 < a1 {
                    out.push((a0.max(b1), a1));
                }
                out
            })
            .filter(|(a0, a1)| a1 >= a0)
            .collect();
    }
    free
}

/// Intervals in words, `3.0000 to 23.0000 or 37.0000 to 45.0000 mm`; `none` when empty.
pub fn intervals_words(free: &[(f64, f64)]) -> String {
    if free.is_empty() {
        return "none".into();
    }
    let parts: Vec<String> = free
        .iter()
        .map(|(a, b)| format!("{a:.4} to {b:.4}"))
        .collect();
    format!("{} mm", parts.join(" or "))
}
