//! What a printable part is: its kind, the pieces printed from it, its solid, and the
//! trait each part's builder implements ([`PrintablePart`]). The parts' files and the
//! registry ([`crate::registry::PARTS`]) both stand on these.

use super::design_profile::DesignProfile;
use super::GeometryError;
use crate::spec::Design;
use truck_modeling::Solid;

/// What kind of part; every part of one kind is printed from one solid (all inserts
/// are alike). Serialised in the manifest in lower case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PartKind {
    /// Clip-on cap (CC).
    Cap,
    /// Plug-in sensor core (PSC); every listed core is printed from it.
    Core,
    /// Solid insert (PSC-solid).
    Insert,
    /// Casting mold of the flat array.
    Mold,
    /// Plug that closes a mold slit above its fiber (one file, printed once per slit).
    MoldPlug,
}

/// One printed piece of a part: its label and material key.
#[derive(Debug, Clone, PartialEq)]
pub struct Print {
    /// Label, e.g. `cap`, `core-psc1`, `insert-blue`.
    pub label: String,
    /// Key into the design's material table.
    pub material: Option<String>,
}

/// A solid with its exact volume.
pub struct BuiltSolid {
    /// The B-rep.
    pub solid: Solid,
    /// Exact volume from the closed form, mm³.
    pub exact_volume_mm3: f64,
}

/// One kind of printable part.
pub trait PrintablePart: Sync {
    /// Its kind.
    fn kind(&self) -> PartKind;

    /// Its output names in `design`, in build order; none when the design has no such
    /// part. All of them are printed from one solid.
    fn names(&self, design: &Design) -> Vec<String>;

    /// Its B-rep and exact volume, from the derived dimensions; `name` is the first
    /// of its names being built (errors name it). Called only when
    /// [`names`](Self::names) is not empty.
    fn solid(&self, profile: &DesignProfile, name: &str) -> Result<BuiltSolid, GeometryError>;

    /// The materials the part called `name` is printed in (one print per material).
    fn materials(&self, design: &Design, name: &str) -> Vec<String>;

    /// The pieces printed from the part called `name`, one per material: a label and
    /// the key of its material in the design's table (None when the design names
    /// none). The 3MF files hold one object per piece.
    fn prints(&self, design: &Design, name: &str) -> Vec<Print>;

    /// Stroke colour of its sections in the cut-away previews (SVG colour).
    fn preview_colour(&self) -> &'static str;

    /// Whether it belongs to the assembled module: checked for overlap, traced
    /// through by the fibers, drawn in the module preview.
    fn in_module(&self) -> bool {
        false
    }
}

impl PartKind {
    /// The kind's name in words and in the manifest (`cap`, `core`, `insert`, `mold`,
    /// `mold-plug`).
    pub fn name(self) -> &'static str {
        match self {
            PartKind::Cap => "cap",
            PartKind::Core => "core",
            PartKind::Insert => "insert",
            PartKind::Mold => "mold",
            PartKind::MoldPlug => "mold-plug",
        }
    }
}
