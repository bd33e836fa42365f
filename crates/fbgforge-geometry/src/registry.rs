//! The printable parts, one entry each: what a part is called in a design, how its
//! solid is built, what it is printed in and how the previews draw it.
//!
//! Everything else in `geometry` (building, meshing, the manifest, the previews, the
//! assembly check) walks [`PARTS`] or looks a part up by its [`PartKind`], so a new
//! printable part is a file with its builder and a [`PrintablePart`] impl, its
//! `PartKind` variant and one entry in [`PARTS`].

use super::design_profile::DesignProfile;
use super::module::{cap::CapPart, core::CorePart, insert::InsertPart};
use super::mold::MoldPart;
use super::mold_plug::MoldPlugPart;
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

/// Every printable part, in build order (the order of `part_names` and the manifest).
pub const PARTS: &[&dyn PrintablePart] =
    &[&CapPart, &CorePart, &InsertPart, &MoldPart, &MoldPlugPart];

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

    /// The registry entry of this kind.
    pub fn part(self) -> &'static dyn PrintablePart {
        *PARTS
            .iter()
            .find(|p| p.kind() == self)
            .expect("every PartKind has one entry in PARTS (tested below)")
    }
}

/// Names of the printable parts of a design, in build order.
pub fn part_names(design: &Design) -> Vec<String> {
    PARTS.iter().flat_map(|p| p.names(design)).collect()
}

/// The first item of each kind, in order: parts of one kind share one solid, so one
/// of them stands for all (meshing, the overlap check, the fiber trace, the preview).
pub fn first_of_each_kind<T>(items: &[T], kind: impl Fn(&T) -> PartKind) -> Vec<&T> {
    let mut seen = Vec::new();
    items
        .iter()
        .filter(|t| {
            let k = kind(t);
            let first = !seen.contains(&k);
            seen.push(k);
            first
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_has_exactly_one_entry() {
        let kinds = [
            PartKind::Cap,
            PartKind::Core,
            PartKind::Insert,
            PartKind::Mold,
            PartKind::MoldPlug,
        ];
        assert_eq!(PARTS.len(), kinds.len());
        for k in kinds {
            let n = PARTS.iter().filter(|p| p.kind() == k).count();
            assert_eq!(n, 1, "{k:?} has {n} entries in PARTS");
            assert_eq!(k.part().kind(), k);
        }
    }

    #[test]
    fn first_of_each_kind_keeps_the_first_in_order() {
        let items = [
            (PartKind::Cap, 0),
            (PartKind::Insert, 1),
            (PartKind::Insert, 2),
            (PartKind::Core, 3),
            (PartKind::Cap, 4),
        ];
        let kept: Vec<i32> = first_of_each_kind(&items, |t| t.0)
            .iter()
            .map(|t| t.1)
            .collect();
        assert_eq!(kept, [0, 1, 3]);
    }
}
