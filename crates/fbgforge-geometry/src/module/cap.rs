//! The cap (CC): a hollow cylinder with a domed top and apex flats, inner alignment
//! pillars that fit the core's grooves, the snap bead ring below them and a radial
//! slot open to the base for every fiber.

use super::angles::Cuts;
use super::revolve::{domed_wall, revolve_chain, revolve_chain_above, wall, Prof};
use super::section::{at, band_sides, disc, ring_ccw, ring_cw, sector, O, S2};
use super::volume::{capped_cylinder_volume, ring_volume, slice_area, sphere_z};
use crate::brep::{Assembler, BrepError, Seg};
use crate::design_profile::DesignProfile;
use crate::part::{BuiltSolid, PartKind, Print, PrintablePart};
use crate::profile::{ModuleProfile, PartsProfile};
use crate::spec::Design;
use crate::GeometryError;
use std::f64::consts::PI;
use truck_modeling::Vector3;

/// The cap (CC): hollow cylinder with a domed top and apex flats; inner alignment
/// pillars from the core's pillar bottom up, fitting the core's grooves; the snap bead
/// ring just below them; and a radial slot open to the base for every fiber.
pub fn cap(p: &ModuleProfile, pp: &PartsProfile) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new("cap");
    let f = CapFrame::new(p, pp);
    f.slotted_base(&mut asm)?;
    let inner_chain = f.inner_wall(&mut asm, pp)?;
    f.pillars(&mut asm)?;
    let upper = f.dome(&mut asm)?;
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: f.band_volume_mm3(&inner_chain) + upper,
    })
}

/// The cap's radii, heights, slots and cut angles, shared by the steps that build it.
struct CapFrame<'a> {
    p: &'a ModuleProfile,
    cuts: Cuts,
    r_o: f64,
    r_ci: f64,
    r_pi: f64,
    /// Half width of an alignment pillar, mm.
    hc: f64,
    top: f64,
    bottom: f64,
    /// Half angle of an alignment pillar on the inner wall.
    beta: f64,
    /// Slot half angle and roof height.
    phi: f64,
    hs: f64,
    /// Slot angles: one per pillar, then the reference fiber's.
    slots: Vec<f64>,
}

impl<'a> CapFrame<'a> {
    /// Read the dimensions and cut every circle at the pillar and slot edges.
    fn new(p: &'a ModuleProfile, pp: &PartsProfile) -> Self {
        let hc = p.cap_pillar_width_mm / 2.0;
        let r_ci = p.cap_inner_radius_mm;
        let beta = (hc / r_ci).asin();
        let phi = pp.cap_slot_half_angle_rad;
        let mut slots: Vec<f64> = p.pillar_angles_rad.clone();
        slots.push(pp.reference_exit_angle_rad);
        let mut special: Vec<f64> = p
            .pillar_angles_rad
            .iter()
            .flat_map(|&t| [t - beta, t + beta])
            .collect();
        special.extend(slots.iter().flat_map(|&t| [t - phi, t + phi]));
        CapFrame {
            p,
            cuts: Cuts::new(&special),
            r_o: p.cap_outer_radius_mm,
            r_ci,
            r_pi: p.cap_pillar_inner_radius_mm,
            hc,
            top: p.pillar_top_mm,
            bottom: pp.pillar_bottom_mm,
            beta,
            phi,
            hs: pp.cap_slot_top_mm,
            slots,
        }
    }

    /// Fingers between the slots from the base to the slot roofs, the slot roofs, and
    /// the outer wall above the slots.
    fn slotted_base(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (ang, r_o, r_ci, hs) = (&self.cuts.ang, self.r_o, self.r_ci, self.hs);
        // Slots as index ranges, sorted by angle; the fingers lie between them.
        let mut slot_idx: Vec<(usize, usize)> = self
            .slots
            .iter()
            .map(|&t| (self.cuts.at(t - self.phi), self.cuts.at(t + self.phi)))
            .collect();
        slot_idx.sort();
        let radial = |k: usize, r0: f64, r1: f64| {
            let a = ang.interval(k).0;
            S2::Line((r0 * a.cos(), r0 * a.sin()), (r1 * a.cos(), r1 * a.sin()))
        };
        let mut fingers = Vec::new();
        for j in 0..slot_idx.len() {
            let (from, to) = (slot_idx[j].1, slot_idx[(j + 1) % slot_idx.len()].0);
            let mut l = ring_ccw(ang, r_o, from, to);
            l.push(radial(to, r_o, r_ci));
            l.extend(ring_cw(ang, r_ci, to, from));
            l.push(radial(from, r_ci, r_o));
            fingers.push(l);
        }
        let bottoms: Vec<Vec<Seg>> = fingers.iter().map(|l| at(l, 0.0)).collect();
        for b in &bottoms {
            asm.plane("base", std::slice::from_ref(b), -Vector3::unit_z())?;
        }
        band_sides(asm, &fingers, 0.0, hs)?;
        for &(a, b) in &slot_idx {
            sector(asm, ang, (r_ci, r_o), (a, b), hs, false)?;
        }
        band_sides(asm, &[ring_ccw(ang, r_o, 0, 0)], hs, self.top)
    }

    /// Inner wall from the slot roofs to the pillar bottoms, with the snap bead; its
    /// (r, z) chain, for the volume.
    fn inner_wall(
        &self,
        asm: &mut Assembler,
        pp: &PartsProfile,
    ) -> Result<Vec<(f64, f64)>, BrepError> {
        let r_ci = self.r_ci;
        let mut inner_chain = vec![(r_ci, self.hs)];
        if let Some(s) = &pp.snap {
            let rc = s.crest_radius_mm;
            inner_chain.extend([
                (r_ci, s.lead_in_z_mm),
                (rc, s.crest_bottom_z_mm),
                (rc, s.crest_top_z_mm),
                (r_ci, s.retention_top_z_mm),
            ]);
        }
        inner_chain.push((r_ci, self.bottom));
        let profs: Vec<Prof> = inner_chain
            .windows(2)
            .map(|w| wall(w[0].0, w[0].1, w[1].0, w[1].1, -1.0))
            .collect();
        revolve_chain(asm, &profs, self.p.dome_center_z_mm, &self.cuts.ang)?;
        Ok(inner_chain)
    }

    /// Alignment pillar outline at angle t, from its +t edge to its −t edge.
    fn rib(&self, t: f64) -> Vec<S2> {
        let (r_ci, r_pi, hc) = (self.r_ci, self.r_pi, self.hc);
        let (rh_, th_) = ((t.cos(), t.sin()), (-t.sin(), t.cos()));
        let e = |s: f64, q: f64| (s * rh_.0 + q * th_.0, s * rh_.1 + q * th_.1);
        let s1 = (r_ci * r_ci - hc * hc).sqrt();
        let s2 = (r_pi * r_pi - hc * hc).sqrt();
        let b2 = (hc / r_pi).asin();
        vec![
            S2::Line(e(s1, hc), e(s2, hc)),
            S2::Arc {
                c: O,
                r: r_pi,
                a0: t + b2,
                a1: t - b2,
            },
            S2::Line(e(s2, -hc), e(s1, -hc)),
        ]
    }

    /// Alignment pillars from the pillar bottoms to the pillar top.
    fn pillars(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (ang, angles) = (&self.cuts.ang, &self.p.pillar_angles_rad);
        let (r_ci, bottom, top) = (self.r_ci, self.bottom, self.top);
        let n = angles.len();
        let rib_idx: Vec<(usize, usize)> = angles
            .iter()
            .map(|&t| (self.cuts.at(t - self.beta), self.cuts.at(t + self.beta)))
            .collect();
        let mut inner = Vec::new();
        for i in (0..n).rev() {
            inner.extend(self.rib(angles[i]));
            inner.extend(ring_cw(ang, r_ci, rib_idx[i].0, rib_idx[(i + n - 1) % n].1));
        }
        band_sides(asm, &[inner], bottom, top)?;
        for (&t, &(from, to)) in angles.iter().zip(&rib_idx) {
            let mut l = self.rib(t);
            l.extend(ring_ccw(ang, r_ci, from, to));
            asm.plane("pillar bottom", &[at(&l, bottom)], -Vector3::unit_z())?;
            asm.plane("pillar top", &[at(&l, top)], Vector3::unit_z())?;
        }
        Ok(())
    }

    /// The revolved body above the pillar top (walls, domes, apex flats); its volume, mm³.
    fn dome(&self, asm: &mut Assembler) -> Result<f64, BrepError> {
        let (p, top, ang) = (self.p, self.top, &self.cuts.ang);
        let zc = p.dome_center_z_mm;
        let a = p.apex_flat_radius_mm;
        let (rs_o, rs_i) = (
            p.cap_dome_outer_sphere_radius_mm,
            p.cap_dome_inner_sphere_radius_mm,
        );
        let (z_oj, z_ij) = (p.cap_outer_junction_z_mm, p.cap_inner_junction_z_mm);
        let (z_oa, z_ia) = (sphere_z(p, rs_o, a), sphere_z(p, rs_i, a));
        let outer_chain = domed_wall(self.r_o, top, z_oj, rs_o, (a, z_oa), true);
        let inner_dome = domed_wall(self.r_ci, top, z_ij, rs_i, (a, z_ia), false);
        revolve_chain_above(asm, &outer_chain, zc, ang, top)?;
        revolve_chain_above(asm, &inner_dome, zc, ang, top)?;
        let coarse = ang.coarse().0;
        disc(asm, &coarse, a, z_oa, true)?;
        disc(asm, &coarse, a, z_ia, false)?;
        Ok(capped_cylinder_volume(self.r_o, top, z_oj, rs_o, zc, z_oa)
            - capped_cylinder_volume(self.r_ci, top, z_ij, rs_i, zc, z_ia))
    }

    /// Exact volume of the band z ∈ [0, pillar top]: wall and pillars less the slots,
    /// plus the snap bead swept along `inner_chain`.
    fn band_volume_mm3(&self, inner_chain: &[(f64, f64)]) -> f64 {
        let (r_o, r_ci, phi) = (self.r_o, self.r_ci, self.phi);
        let n = self.p.pillar_angles_rad.len();
        let rib_area = slice_area(r_ci, self.hc) - slice_area(self.r_pi, self.hc);
        self.top * PI * (r_o * r_o - r_ci * r_ci) + (self.top - self.bottom) * n as f64 * rib_area
            - self.hs * self.slots.len() as f64 * phi * (r_o * r_o - r_ci * r_ci)
            + ring_volume(r_ci, inner_chain)
    }
}

/// The cap, in the registry: `cap` for every module design.
pub(crate) struct CapPart;

impl PrintablePart for CapPart {
    fn kind(&self) -> PartKind {
        PartKind::Cap
    }

    fn names(&self, design: &Design) -> Vec<String> {
        design.module.iter().map(|_| "cap".to_string()).collect()
    }

    fn solid(&self, profile: &DesignProfile, _name: &str) -> Result<BuiltSolid, GeometryError> {
        let m = profile
            .module
            .as_ref()
            .expect("a cap only in a module design");
        Ok(cap(&m.profile, &m.parts)?)
    }

    fn materials(&self, design: &Design, _name: &str) -> Vec<String> {
        design
            .module
            .iter()
            .map(|m| m.cap_material.clone())
            .collect()
    }

    fn prints(&self, design: &Design, _name: &str) -> Vec<Print> {
        design
            .module
            .iter()
            .map(|m| Print {
                label: "cap".into(),
                material: Some(m.cap_material.clone()),
            })
            .collect()
    }

    fn preview_colour(&self) -> &'static str {
        "#1f77b4"
    }

    fn in_module(&self) -> bool {
        true
    }
}
