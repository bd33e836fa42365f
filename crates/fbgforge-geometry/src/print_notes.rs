//! Print notes for the small passages the fibers need: every hole, bore, chamber and
//! slot of the parts with its size, and what the printing process needs done to clear
//! it (support gel in PolyJet passages, strings and sag in FDM ones). The manifest
//! lists them; the README says the same in prose.

use super::design_profile::{DesignProfile, ModuleDims};
use crate::spec::PrintProcess;
use serde::Serialize;

/// Narrowest passage a lab can clear by a plain rinse, mm: anything narrower needs a
/// wire or a needle pushed through.
pub(crate) const SMALL_PASSAGE_MM: f64 = 1.0;

/// One passage to clear after printing.
#[derive(Debug, Clone, Serialize)]
pub struct PrintNote {
    /// Part it is in.
    pub part: String,
    /// The passage, in words.
    pub feature: String,
    /// Width (diameter of a hole or bore, width of a slot), mm.
    pub width_mm: f64,
    /// Length along the passage, mm.
    pub length_mm: f64,
    /// How many of them.
    pub count: usize,
    /// Whether it is a small passage (≤ [`SMALL_PASSAGE_MM`]): not cleared by rinsing.
    pub small: bool,
    /// What to do.
    pub note: String,
}

/// How to clear a passage `w` mm wide (`blind`: closed at one end) after printing
/// with the design's process, checked with its coated fiber (`coated` mm).
fn how_to_clear(w: f64, blind: bool, polyjet: bool, coated: f64) -> String {
    let wire = (w - 0.1).max(coated);
    if polyjet {
        if blind {
            format!(
                "support gel fills it and drains only through the bore: soak the part in the support's cleaning solution (e.g. 2 % NaOH for SUP706), then flush through the bore with a syringe and a blunt needle until clear water comes back; check by passing the fiber ({coated} mm)"
            )
        } else if w <= SMALL_PASSAGE_MM {
            format!(
                "support gel fills it and a water jet does not reach it: soak in the support's cleaning solution, then push a wire of at most {wire:.2} mm through from end to end (repeat soaking until it slides); check by passing the fiber ({coated} mm)"
            )
        } else {
            "support gel fills it: water jet and soak as for the rest of the part".into()
        }
    } else if w <= SMALL_PASSAGE_MM {
        format!(
            "print without support inside it (the slicer bridges it); clear strings and sag with a drill or needle of at most {wire:.2} mm; check by passing the fiber ({coated} mm)"
        )
    } else {
        "print without support inside it; clear strings by hand".into()
    }
}

/// The notes as they are written, with what every note needs to know of the design.
struct Notes {
    polyjet: bool,
    coated: f64,
    out: Vec<PrintNote>,
}

impl Notes {
    fn note(&mut self, part: &str, feature: &str, (w, l): (f64, f64), count: usize, blind: bool) {
        self.out.push(PrintNote {
            part: part.into(),
            feature: feature.into(),
            width_mm: w,
            length_mm: l,
            count,
            small: w <= SMALL_PASSAGE_MM,
            note: how_to_clear(w, blind, self.polyjet, self.coated),
        })
    }

    /// The module's passages: the core's holes and slot, the cap's slots, the insert's
    /// bore, chamber and slot.
    fn module(&mut self, md: &ModuleDims) {
        let (m, p, pp) = (md.spec, &md.profile, &md.parts);
        let w = pp.channel_width_mm;
        let pillars = p.pillar_angles_rad.len();
        self.note(
            "core",
            "fiber hole through each pillar",
            (
                m.pillars.fiber_hole_diameter_mm,
                p.pillar_top_mm - pp.pillar_bottom_mm,
            ),
            pillars,
            false,
        );
        self.note(
            "core",
            "top hole through the dome",
            (m.top_hole_diameter_mm, m.core_wall_mm),
            1,
            false,
        );
        self.note(
            "core",
            "slot in the wall's base (reference fiber)",
            (w, pp.core_slot_top_mm),
            1,
            false,
        );
        self.note(
            "cap",
            "fiber slot open to the base",
            (w, pp.cap_slot_top_mm),
            pillars + 1,
            false,
        );
        if m.inserts.is_empty() {
            return;
        }
        let bore_top = pp
            .reference_chamber
            .map_or(pp.insert_slot_top_mm, |c| c.span.chamber_bottom_z_mm);
        self.note(
            "insert",
            "bore for the reference fiber, from the base slot up",
            (
                2.0 * pp.insert_bore_radius_mm,
                bore_top - pp.insert_slot_top_mm,
            ),
            1,
            false,
        );
        if let Some(c) = &pp.reference_chamber {
            self.note(
                "insert",
                "reference chamber at the bore's top (closed above)",
                (
                    2.0 * c.radius_mm,
                    c.span.chamber_top_z_mm - c.span.chamber_bottom_z_mm,
                ),
                1,
                true,
            );
        }
        self.note(
            "insert",
            "slot in the base (reference fiber)",
            (w, pp.insert_slot_top_mm),
            1,
            false,
        );
    }
}

/// The notes for every fiber passage of the design's parts.
pub fn print_notes(profile: &DesignProfile) -> Vec<PrintNote> {
    let design = profile.design;
    let mut notes = Notes {
        polyjet: design.printer.process == PrintProcess::Polyjet,
        coated: design.fiber_routing.coated_diameter_mm,
        out: Vec::new(),
    };
    if let Some(md) = &profile.module {
        notes.module(md);
    }
    if let Some(a) = &profile.array {
        let l = &a.layout;
        let seat_h = a.pocket.map_or(l.mold_outer_mm.2, |q| q.bottom_z_mm) - l.slit_bottom_z_mm;
        notes.note(
            "mold",
            "fiber seat at each slit's bottom",
            (a.spec.mold.slit_width_mm, seat_h),
            2 * a.spec.fiber_x_mm.len(),
            false,
        );
    }
    notes.out
}
