//! Solids of the clip-on module: cap (CC), core (PSC) and insert (PSC-solid), with
//! their exact volumes in closed form.
//!
//! Each part is an extruded band z ∈ [0, pillar top] (the cross-section with pillars,
//! grooves and fiber holes) joined to a revolved upper body (cylinder, dome, apex
//! flat or top hole). Every circle is cut at the same angles (the pillar edges, plus
//! extra cuts so no patch spans more than 90°), so the band's top edges are the upper
//! body's bottom edges and the faces share them through the
//! [`Assembler`](super::brep::Assembler).
//!
//! Loops and meridians run with the material on their left; the outward side of each
//! face is stated explicitly and checked against the surface normal.
//!
//! One file per part (`cap`, `core`, `insert`: its builder and its entry in the
//! [`registry`](super::registry)); the faces they share are built by
//! `section` (planar and extruded faces from cross-section loops) and `revolve`
//! (faces of revolution from (r, z) profiles), on the cut angles of `angles`; the
//! closed-form volumes are in `volume`.

mod angles;
pub mod cap;
pub mod core;
pub mod insert;
mod revolve;
mod section;
mod volume;

pub use volume::{slice_area, zone_volume};
