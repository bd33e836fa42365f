//! The printable parts, one entry each: what a part is called in a design, how its
//! solid is built, what it is printed in and how the previews draw it.
//!
//! Everything else in `geometry` (building, meshing, the manifest, the previews, the
//! assembly check) walks [`PARTS`] or looks a part up by its [`PartKind`], so a new
//! printable part is a file with its builder and a [`PrintablePart`] impl, its
//! `PartKind` variant and one entry in [`PARTS`].

use super::module::{cap::CapPart, core::CorePart, insert::InsertPart};
use super::mold::MoldPart;
use super::mold_plug::MoldPlugPart;
use super::part::{PartKind, PrintablePart};
use crate::spec::Design;

/// Every printable part, in build order (the order of `part_names` and the manifest).
pub(crate) const PARTS: &[&dyn PrintablePart] =
    &[&CapPart, &CorePart, &InsertPart, &MoldPart, &MoldPlugPart];

impl PartKind {
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
