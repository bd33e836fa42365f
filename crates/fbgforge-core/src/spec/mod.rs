//! The design spec: the TOML file that describes one fbgforge design.
//!
//! A spec holds the printer, a material table, and optionally a clip-on module
//! (cap, cores, inserts, gratings) and a flat tactile array with its casting mold.
//! Every length is in mm, every modulus in MPa, every wavelength in nm; the unit is
//! part of each field name. Unknown fields are rejected, and [`Design::validate`]
//! checks every number against its allowed range so that geometry, model, verifier
//! and optimiser can trust a loaded design.
//!
//! Derived dimensions (radii, heights, slit positions) are not stored here: they are
//! computed once in [`crate::profile`], the single source of truth that both the solid
//! geometry and the opto-mechanical model read. Loading a design file goes through
//! [`crate::design`], which adds the checks that need those derived dimensions.
//!
//! One file per area: the whole design and its parsing (`design`), the printer, the
//! material table and the fiber routing (`printer`), the clip-on module (`module`) and
//! its contact reading (`contact`), the flat array and its mold (`array`); the checks
//! per area live in `validate/`, the errors in `error`.

mod array;
mod contact;
mod design;
mod error;
mod module;
mod printer;
mod validate;

pub use array::{
    derived_slit_depth_mm, mold_slot_width_mm, seat_z_mm, ArrayGrating, ArrayModelKind,
    BaseCondition, Mold, TactileArray, PAPER_TANGENTIAL_STIFFNESS_N_PER_MM3,
};
pub use contact::{Contact, ContactRatios, CylinderCoupling};
pub use design::{parse_unvalidated, Design};
pub use error::{err, SpecError};
pub use module::{
    Core, GratingRole, Insert, Limits, Module, ModuleGrating, Pillars, Snap,
    DEFAULT_REFERENCE_TAIL_MM, GRATING_END_GAP_MM,
};
pub use printer::{
    FiberRouting, Material, PrintProcess, Printer, DEFAULT_FDM_LAYER_MM, DEFAULT_FDM_NOZZLE_MM,
    DEFAULT_POLYJET_LAYER_MM,
};
pub use validate::{free_intervals, intervals_words, positive, range, MIN_UNDERCUT_PER_RESOLUTION};
