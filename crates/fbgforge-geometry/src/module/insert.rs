//! The insert (PSC-solid): a solid cylinder with a spherical top and a whole apex flat
//! (the force contact), an axial bore from its base for the reference fiber, a closed
//! chamber at the bore's top in which the reference grating hangs free, and a slot in
//! its base through which that fiber bends out.

use super::angles::Cuts;
use super::revolve::{domed_wall, revolve_chain, wall};
use super::section::{at, band_sides, disc, ring_ccw, ring_cw, S2};
use super::volume::{capped_cylinder_volume, slice_area, sphere_z};
use crate::brep::{Assembler, BrepError};
use crate::design_profile::DesignProfile;
use crate::part::{BuiltSolid, PartKind, Print, PrintablePart};
use crate::profile::{ModuleProfile, PartsProfile};
use crate::spec::{Design, Insert};
use crate::GeometryError;
use std::f64::consts::PI;
use truck_modeling::Vector3;

/// The insert: solid cylinder with a spherical top and a whole apex flat, an axial bore
/// for the reference fiber up to the reference chamber (see
/// [`ReferenceSpan`](crate::profile::ReferenceSpan)), and a slot in its base through
/// which that fiber bends out.
pub fn insert(p: &ModuleProfile, pp: &PartsProfile, part: &str) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new(part);
    let r = p.insert_radius_mm;
    let rb = pp.insert_bore_radius_mm;
    let hw = pp.insert_slot_half_width_mm;
    let th = pp.reference_exit_angle_rad;
    let (bo, bb) = ((hw / r).asin(), (hw / rb).asin());
    let cuts = Cuts::new(&[th - bo, th + bo, th - bb, th + bb]);
    let ang = &cuts.ang;
    let rho = p.insert_sphere_radius_mm;
    let zc = p.dome_center_z_mm;
    let zj = p.insert_junction_z_mm;
    let a = p.apex_flat_radius_mm;
    let hs = pp.insert_slot_top_mm;
    let (io0, io1, ib0, ib1) = (
        cuts.at(th - bo),
        cuts.at(th + bo),
        cuts.at(th - bb),
        cuts.at(th + bb),
    );
    // Keyhole cross-section below the slot roof: the outer circle outside the slot, the
    // slot's sides, the bore's far side.
    let mut key = ring_ccw(ang, r, io1, io0);
    key.push(S2::Line(
        (r * (th - bo).cos(), r * (th - bo).sin()),
        (rb * (th - bb).cos(), rb * (th - bb).sin()),
    ));
    key.extend(ring_cw(ang, rb, ib0, ib1));
    key.push(S2::Line(
        (rb * (th + bb).cos(), rb * (th + bb).sin()),
        (r * (th + bo).cos(), r * (th + bo).sin()),
    ));
    asm.plane("base", &[at(&key, 0.0)], -Vector3::unit_z())?;
    band_sides(&mut asm, std::slice::from_ref(&key), 0.0, hs)?;
    // Slot roof: between the bore's near side and the outer circle's slot arc.
    let mut roof = ring_ccw(ang, r, io0, io1);
    roof.push(S2::Line(
        (r * (th + bo).cos(), r * (th + bo).sin()),
        (rb * (th + bb).cos(), rb * (th + bb).sin()),
    ));
    roof.extend(ring_cw(ang, rb, ib1, ib0));
    roof.push(S2::Line(
        (rb * (th - bb).cos(), rb * (th - bb).sin()),
        (r * (th - bo).cos(), r * (th - bo).sin()),
    ));
    asm.plane("slot roof", &[at(&roof, hs)], -Vector3::unit_z())?;
    // Above the roof: cylinder, dome and a whole apex flat.
    let z_top = sphere_z(p, rho, a);
    let chain = domed_wall(r, hs, zj, rho, (a, z_top), true);
    revolve_chain(&mut asm, &chain, zc, ang)?;
    disc(&mut asm, ang, a, z_top, true)?;
    // Inside: the bore from the slot roof up to the reference chamber's floor (or, with
    // no reference grating, a blind bore ending one bore diameter under the apex), and
    // the closed chamber in which the grating hangs free.
    let (bore_top, chamber) = match pp.reference_chamber {
        Some(c) => (c.span.chamber_bottom_z_mm, Some(c)),
        None => (z_top - 4.0 * rb, None),
    };
    revolve_chain(&mut asm, &[wall(rb, bore_top, rb, hs, -1.0)], zc, ang)?;
    let mut cavity = PI * rb * rb * (bore_top - hs);
    match chamber {
        Some(c) => {
            let (rc, z0, z1) = (
                c.radius_mm,
                c.span.chamber_bottom_z_mm,
                c.span.chamber_top_z_mm,
            );
            let floor = [
                at(&ring_ccw(ang, rc, 0, 0), z0),
                at(&ring_cw(ang, rb, 0, 0), z0),
            ];
            asm.plane("chamber floor", &floor, Vector3::unit_z())?;
            revolve_chain(&mut asm, &[wall(rc, z1, rc, z0, -1.0)], zc, ang)?;
            disc(&mut asm, ang, rc, z1, false)?;
            cavity += PI * rc * rc * (z1 - z0);
        }
        None => disc(&mut asm, ang, rb, bore_top, false)?,
    }
    let slot_area = slice_area(r, hw) - slice_area(rb, hw);
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: capped_cylinder_volume(r, 0.0, zj, rho, zc, z_top)
            - PI * rb * rb * hs
            - cavity
            - slot_area * hs,
    })
}

/// The output name of an insert.
fn name_of(insert: &Insert) -> String {
    format!("insert-{}", insert.name)
}

/// The inserts, in the registry: `insert-<name>` for each listed insert, all printed
/// from one solid in their own materials.
pub(crate) struct InsertPart;

impl PrintablePart for InsertPart {
    fn kind(&self) -> PartKind {
        PartKind::Insert
    }

    fn names(&self, design: &Design) -> Vec<String> {
        design
            .module
            .iter()
            .flat_map(|m| m.inserts.iter().map(name_of))
            .collect()
    }

    fn solid(&self, profile: &DesignProfile, name: &str) -> Result<BuiltSolid, GeometryError> {
        let m = profile
            .module
            .as_ref()
            .expect("an insert only in a module design");
        Ok(insert(&m.profile, &m.parts, name)?)
    }

    fn materials(&self, design: &Design, name: &str) -> Vec<String> {
        design
            .module
            .iter()
            .flat_map(|m| &m.inserts)
            .filter(|i| name_of(i) == name)
            .map(|i| i.material.clone())
            .collect()
    }

    fn prints(&self, design: &Design, name: &str) -> Vec<Print> {
        design
            .module
            .iter()
            .flat_map(|m| &m.inserts)
            .filter(|i| name_of(i) == name)
            .map(|i| Print {
                label: name_of(i),
                material: Some(i.material.clone()),
            })
            .collect()
    }

    fn preview_colour(&self) -> &'static str {
        "#9467bd"
    }

    fn in_module(&self) -> bool {
        true
    }
}
