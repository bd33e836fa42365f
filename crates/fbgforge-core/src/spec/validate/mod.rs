//! The checks on a design's fields that need no derived dimension, one file per
//! area: the printer, fiber and material table (`printer`), the module (`module`), the
//! array (`array`), and the rules they share (`rules`: ranges, the unique-name rule).
//! The first failing check is the error reported, so the order of the calls here is
//! the order a user meets the errors in.

mod array;
mod module;
mod printer;
mod rules;

use super::error::{err, SpecError};
use super::Design;
pub use module::MIN_UNDERCUT_PER_RESOLUTION;
pub use rules::{free_intervals, intervals_words, positive, range};

impl Design {
    /// Check every field against its allowed range and every cross-field constraint
    /// that needs no derived dimension; [`crate::design`] adds the checks on the
    /// derived profile (radial stack, pillar pitch, holes against the domes).
    pub(crate) fn validate_fields(&self) -> Result<(), SpecError> {
        self.validate_printer()?;
        self.validate_materials()?;
        if self.module.is_none() && self.array.is_none() {
            return Err(err(
                "module",
                "a design needs a [module] or an [array] section (or both)",
            ));
        }
        if let Some(m) = &self.module {
            self.validate_module(m)?;
        }
        if let Some(a) = &self.array {
            self.validate_array(a)?;
        }
        Ok(())
    }
}
