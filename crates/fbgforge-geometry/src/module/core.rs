//! The core (PSC): a hollow cylinder with a domed top and a top hole, outer pillars
//! with a groove and a fiber through-hole each, and a radial slot in the wall's base
//! for the reference fiber.

use super::angles::Cuts;
use super::revolve::{domed_wall, revolve_chain_above, Prof};
use super::section::{at, band_sides, ring_ccw, ring_cw, sector, O, S2};
use super::volume::{capped_cylinder_volume, slice_area, sphere_z};
use crate::brep::{Assembler, BrepError};
use crate::design_profile::DesignProfile;
use crate::part::{BuiltSolid, PartKind, Print, PrintablePart};
use crate::profile::{ModuleProfile, PartsProfile};
use crate::spec::Design;
use crate::GeometryError;
use std::f64::consts::{FRAC_PI_2, PI};
use truck_modeling::Vector3;

/// The core (PSC): hollow cylinder with a domed top and a top hole; outer pillars from
/// the pillar bottom to the pillar top, each with an axial groove in its outer face and
/// a fiber through-hole; a radial slot in the wall's base for the reference fiber.
pub fn core(
    p: &ModuleProfile,
    pp: &PartsProfile,
    pillar_width_mm: f64,
    fiber_hole_diameter_mm: f64,
    groove_width_mm: f64,
) -> Result<BuiltSolid, BrepError> {
    let mut asm = Assembler::new("core");
    let f = CoreFrame::new(
        p,
        pp,
        pillar_width_mm,
        fiber_hole_diameter_mm,
        groove_width_mm,
    );
    f.slotted_base(&mut asm)?;
    f.pillars(&mut asm)?;
    let upper = f.dome(&mut asm)?;
    Ok(BuiltSolid {
        solid: asm.solid()?,
        exact_volume_mm3: f.band_volume_mm3() + upper,
    })
}

/// The core's radii, heights and cut angles, shared by the steps that build it.
struct CoreFrame<'a> {
    p: &'a ModuleProfile,
    cuts: Cuts,
    r_co: f64,
    r_ci: f64,
    r_po: f64,
    r_gb: f64,
    /// Half widths of a pillar and of its groove, mm.
    hw: f64,
    hg: f64,
    /// Fiber hole radius, mm.
    rh: f64,
    r_fh: f64,
    top: f64,
    bottom: f64,
    /// Half angle of a pillar on the core wall.
    beta: f64,
    /// Reference fiber slot: angle, half angle, roof height.
    th: f64,
    phi: f64,
    hs: f64,
}

impl<'a> CoreFrame<'a> {
    /// Read the dimensions and cut every circle at the pillar and slot edges.
    fn new(
        p: &'a ModuleProfile,
        pp: &PartsProfile,
        pillar_width_mm: f64,
        fiber_hole_diameter_mm: f64,
        groove_width_mm: f64,
    ) -> Self {
        let (r_co, r_ci) = (p.core_outer_radius_mm, p.core_inner_radius_mm);
        let (r_po, r_gb) = (p.pillar_outer_radius_mm, p.groove_bottom_radius_mm);
        let (hw, hg) = (pillar_width_mm / 2.0, groove_width_mm / 2.0);
        let beta = (hw / r_co).asin();
        let (th, phi, hs) = (
            pp.reference_exit_angle_rad,
            pp.core_slot_half_angle_rad,
            pp.core_slot_top_mm,
        );
        let mut special: Vec<f64> = p
            .pillar_angles_rad
            .iter()
            .flat_map(|&t| [t - beta, t + beta])
            .collect();
        special.extend([th - phi, th + phi]);
        CoreFrame {
            p,
            cuts: Cuts::new(&special),
            r_co,
            r_ci,
            r_po,
            r_gb,
            hw,
            hg,
            rh: fiber_hole_diameter_mm / 2.0,
            r_fh: p.fiber_hole_center_radius_mm,
            top: p.pillar_top_mm,
            bottom: pp.pillar_bottom_mm,
            beta,
            th,
            phi,
            hs,
        }
    }

    /// Pillar outline from its −t edge to its +t edge on the core wall.
    fn rib(&self, t: f64) -> Vec<S2> {
        let (r_co, r_po, r_gb, hw, hg) = (self.r_co, self.r_po, self.r_gb, self.hw, self.hg);
        let (rh_, th_) = ((t.cos(), t.sin()), (-t.sin(), t.cos()));
        let e = |s: f64, q: f64| (s * rh_.0 + q * th_.0, s * rh_.1 + q * th_.1);
        let s1 = (r_co * r_co - hw * hw).sqrt();
        let s2 = (r_po * r_po - hw * hw).sqrt();
        let s3 = (r_po * r_po - hg * hg).sqrt();
        let s4 = (r_gb * r_gb - hg * hg).sqrt();
        let (aw, ag, gb) = ((hw / r_po).asin(), (hg / r_po).asin(), (hg / r_gb).asin());
        vec![
            S2::Line(e(s1, -hw), e(s2, -hw)),
            S2::Arc {
                c: O,
                r: r_po,
                a0: t - aw,
                a1: t - ag,
            },
            S2::Line(e(s3, -hg), e(s4, -hg)),
            S2::Arc {
                c: O,
                r: r_gb,
                a0: t - gb,
                a1: t + gb,
            },
            S2::Line(e(s4, hg), e(s3, hg)),
            S2::Arc {
                c: O,
                r: r_po,
                a0: t + ag,
                a1: t + aw,
            },
            S2::Line(e(s2, hw), e(s1, hw)),
        ]
    }

    /// The fiber through-hole of the pillar at angle t, as four quarter arcs.
    fn hole(&self, t: f64) -> Vec<S2> {
        let c = (self.r_fh * t.cos(), self.r_fh * t.sin());
        (0..4)
            .map(|k| S2::Arc {
                c,
                r: self.rh,
                a0: t - k as f64 * FRAC_PI_2,
                a1: t - (k + 1) as f64 * FRAC_PI_2,
            })
            .collect()
    }

    /// Base band (the wall with the reference fiber's slot), then the plain wall up to
    /// the pillar bottoms (outside) and the pillar top (inside).
    fn slotted_base(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (r_co, r_ci, th, phi, hs) = (self.r_co, self.r_ci, self.th, self.phi, self.hs);
        let ang = &self.cuts.ang;
        let (s0, s1) = (self.cuts.at(th - phi), self.cuts.at(th + phi));
        let radial = |a: f64, r0: f64, r1: f64| {
            S2::Line((r0 * a.cos(), r0 * a.sin()), (r1 * a.cos(), r1 * a.sin()))
        };
        let mut c_loop = ring_ccw(ang, r_co, s1, s0);
        c_loop.push(radial(th - phi, r_co, r_ci));
        c_loop.extend(ring_cw(ang, r_ci, s0, s1));
        c_loop.push(radial(th + phi, r_ci, r_co));
        asm.plane("base", &[at(&c_loop, 0.0)], -Vector3::unit_z())?;
        band_sides(asm, std::slice::from_ref(&c_loop), 0.0, hs)?;
        sector(asm, ang, (r_ci, r_co), (s0, s1), hs, false)?;
        band_sides(asm, &[ring_ccw(ang, r_co, 0, 0)], hs, self.bottom)?;
        band_sides(asm, &[ring_cw(ang, r_ci, 0, 0)], hs, self.top)
    }

    /// Pillars: sides and holes, then each one's bottom and top faces.
    fn pillars(&self, asm: &mut Assembler) -> Result<(), BrepError> {
        let (ang, angles) = (&self.cuts.ang, &self.p.pillar_angles_rad);
        let (bottom, top) = (self.bottom, self.top);
        let n = angles.len();
        let pillar_edges: Vec<(usize, usize)> = angles
            .iter()
            .map(|&t| (self.cuts.at(t - self.beta), self.cuts.at(t + self.beta)))
            .collect();
        let mut outer = Vec::new();
        for i in 0..n {
            outer.extend(self.rib(angles[i]));
            outer.extend(ring_ccw(
                ang,
                self.r_co,
                pillar_edges[i].1,
                pillar_edges[(i + 1) % n].0,
            ));
        }
        let holes: Vec<Vec<S2>> = angles.iter().map(|&t| self.hole(t)).collect();
        let mut loops = vec![outer];
        loops.extend(holes.iter().cloned());
        band_sides(asm, &loops, bottom, top)?;
        for i in 0..n {
            let mut l = self.rib(angles[i]);
            l.extend(ring_cw(
                ang,
                self.r_co,
                pillar_edges[i].1,
                pillar_edges[i].0,
            ));
            asm.plane(
                "pillar bottom",
                &[at(&l, bottom), at(&holes[i], bottom)],
                -Vector3::unit_z(),
            )?;
            asm.plane(
                "pillar top",
                &[at(&l, top), at(&holes[i], top)],
                Vector3::unit_z(),
            )?;
        }
        Ok(())
    }

    /// The revolved body above the pillar top (walls, domes, top hole); its volume, mm³.
    fn dome(&self, asm: &mut Assembler) -> Result<f64, BrepError> {
        let (p, top) = (self.p, self.top);
        let zc = p.dome_center_z_mm;
        let tr = p.top_hole_radius_mm;
        let (rs_o, rs_i) = (
            p.core_dome_outer_sphere_radius_mm,
            p.core_dome_inner_sphere_radius_mm,
        );
        let (z_oj, z_ij) = (p.core_outer_junction_z_mm, p.core_inner_junction_z_mm);
        let (z_oh, z_ih) = (sphere_z(p, rs_o, tr), sphere_z(p, rs_i, tr));
        let [outer_wall, outer_dome] = domed_wall(self.r_co, top, z_oj, rs_o, (tr, z_oh), true);
        let [inner_dome, inner_wall] = domed_wall(self.r_ci, top, z_ij, rs_i, (tr, z_ih), false);
        let top_hole = Prof {
            a: (tr, z_oh),
            b: (tr, z_ih),
            sphere: None,
            out: -1.0,
        };
        let chain = [outer_wall, outer_dome, top_hole, inner_dome, inner_wall];
        revolve_chain_above(asm, &chain, zc, &self.cuts.ang, top)?;
        Ok(capped_cylinder_volume(self.r_co, top, z_oj, rs_o, zc, z_oh)
            - capped_cylinder_volume(self.r_ci, top, z_ij, rs_i, zc, z_ih)
            - PI * tr * tr * (z_oh - z_ih))
    }

    /// Exact volume of the band z ∈ [0, pillar top]: wall and pillars less holes and slot.
    fn band_volume_mm3(&self) -> f64 {
        let (r_co, r_ci, r_po, r_gb, hw, hg) =
            (self.r_co, self.r_ci, self.r_po, self.r_gb, self.hw, self.hg);
        let (top, bottom, rh) = (self.top, self.bottom, self.rh);
        let n = self.p.pillar_angles_rad.len();
        let rib_area = slice_area(r_po, hw)
            - slice_area(r_co, hw)
            - (slice_area(r_po, hg) - slice_area(r_gb, hg));
        top * PI * (r_co * r_co - r_ci * r_ci)
            + (top - bottom) * n as f64 * (rib_area - PI * rh * rh)
            - self.hs * self.phi * (r_co * r_co - r_ci * r_ci)
    }
}

/// The core, in the registry: `core` for every module design (every listed core is
/// printed from it).
pub(crate) struct CorePart;

impl PrintablePart for CorePart {
    fn kind(&self) -> PartKind {
        PartKind::Core
    }

    fn names(&self, design: &Design) -> Vec<String> {
        design.module.iter().map(|_| "core".to_string()).collect()
    }

    fn solid(&self, profile: &DesignProfile, _name: &str) -> Result<BuiltSolid, GeometryError> {
        let m = profile
            .module
            .as_ref()
            .expect("a core only in a module design");
        let pl = &m.spec.pillars;
        Ok(core(
            &m.profile,
            &m.parts,
            pl.width_mm,
            pl.fiber_hole_diameter_mm,
            pl.groove_width_mm,
        )?)
    }

    fn materials(&self, design: &Design, _name: &str) -> Vec<String> {
        design
            .module
            .iter()
            .flat_map(|m| &m.cores)
            .map(|c| format!("{} ({})", c.material, c.name))
            .collect()
    }

    fn prints(&self, design: &Design, _name: &str) -> Vec<Print> {
        design
            .module
            .iter()
            .flat_map(|m| &m.cores)
            .map(|c| Print {
                label: format!("core-{}", c.name),
                material: Some(c.material.clone()),
            })
            .collect()
    }

    fn preview_colour(&self) -> &'static str {
        "#2ca02c"
    }

    fn in_module(&self) -> bool {
        true
    }
}
