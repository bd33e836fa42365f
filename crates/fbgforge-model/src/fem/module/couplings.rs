//! How the meshed parts of the module hold together and are held and loaded: the
//! base clip between cap and core, the domes' contact, the insert's ties to the core,
//! and the apex load of 1 N.

use super::insert::mesh_insert;
use super::options::{DomeContact, FemOptions, InsertContact, PillarCoupling};
use super::stations::Station;
use super::walls::{WallMesh, Walls};
use super::DomePair;
use crate::fem::contact::ContactPair;
use crate::fem::mesh::{edge_forces, edge_param_at_radius};
use crate::fem::solve::{Interpolation, R, Z};
use crate::profile::ModuleProfile;
use anyhow::{bail, Result};
use std::f64::consts::PI;

/// Supports and couplings: fixed components, ties and unilateral contact pairs.
#[derive(Default)]
pub(super) struct Couplings {
    pub(super) fixed: Vec<(usize, usize)>,
    pub(super) ties: Vec<(usize, usize, usize)>,
    pub(super) interpolations: Vec<Interpolation>,
    pub(super) contact_pairs: Vec<ContactPair>,
}

/// Couple the cap side to the core side of the pillars' outer face (d-lines `dl`,
/// `dl + 1`): bonded in the clip band at the base, and above it either tied radially
/// or in unilateral contact across the printed clearance.
pub(super) fn clip_band_coupling(
    wm: &mut WallMesh,
    dl: usize,
    m: &crate::spec::Module,
    opt: &FemOptions,
    c: &mut Couplings,
) -> Result<()> {
    let clip = opt.clip_height_mm.unwrap_or(m.cap_wall_mm);
    if !(clip.is_finite() && clip > 0.0) {
        bail!("the clip band's height must be a positive number of mm, got {clip}");
    }
    // Bonded only in the clip band at the base, so the cap slides axially over the
    // core above it.
    for j in 0..=wm.stations.j_pillar_top {
        let (a, b) = (wm.node(dl, j), wm.node(dl + 1, j));
        let in_clip = wm.mesh.nodes[a][1] <= clip + 1e-9;
        if in_clip {
            c.ties.push((a, b, R));
            c.ties.push((a, b, Z));
        } else if opt.pillar_coupling == PillarCoupling::BaseClipContact {
            // The cap side lies outside: the normal from it to the core points inwards.
            c.contact_pairs.push(ContactPair {
                a,
                b: Some(b),
                normal: [-1.0, 0.0],
                gap_mm: m.cap_core_clearance_mm,
            });
        } else {
            c.ties.push((a, b, R));
        }
    }
    Ok(())
}

/// Couple the cap's dome to the core's dome above the pillars as `opt.dome_contact`
/// says: a gap, unilateral contact, or ties over the whole dome or the apex patch.
/// Returns every facing pair of dome nodes, tied or not.
pub(super) fn dome_coupling(
    wm: &mut WallMesh,
    walls: &Walls,
    opt: &FemOptions,
    c: &mut Couplings,
) -> Vec<DomePair> {
    let s = wm.stations;
    let tie_from = match opt.dome_contact {
        DomeContact::Gap | DomeContact::Unilateral => None,
        DomeContact::Tied => Some(s.j_pillar_top + 1),
        DomeContact::ApexPatch => Some(s.j_patch.max(s.j_pillar_top + 1)),
    };
    if opt.dome_contact == DomeContact::Unilateral {
        for j in s.j_pillar_top + 1..=s.j_hole {
            let a = wm.node(walls.cap_inner, j);
            let b = wm.node(walls.core_outer, j);
            // Facing nodes lie on one ray from the dome centre (or one horizontal line
            // below it): the normal points along it, inwards, from the cap to the core.
            let normal = match s.st[j] {
                Station::Z(_) => [-1.0, 0.0],
                Station::Theta(t) => [-t.cos(), -t.sin()],
            };
            let (xa, xb) = (wm.mesh.nodes[a], wm.mesh.nodes[b]);
            let gap = normal[0] * (xb[0] - xa[0]) + normal[1] * (xb[1] - xa[1]);
            c.contact_pairs.push(ContactPair {
                a,
                b: Some(b),
                normal,
                gap_mm: gap.max(0.0),
            });
        }
    }
    let mut pairs = Vec::new();
    for j in s.j_pillar_top + 1..=s.j_hole {
        let a = wm.node(walls.cap_inner, j);
        let b = wm.node(walls.core_outer, j);
        let tied = tie_from.is_some_and(|j0| j >= j0);
        if tied {
            c.ties.push((a, b, R));
            c.ties.push((a, b, Z));
        }
        pairs.push(DomePair {
            cap: a,
            core: b,
            radius_mm: wm.mesh.nodes[b][0],
            tied,
        });
    }
    pairs
}

/// Case I: mesh the solid insert and tie the core's inner wall to it (on the cylinder
/// radially only when the insert contact slides).
///
/// The insert is meshed on every other station of the walls (`Stations::halved`):
/// it is a solid block whose O-grid would otherwise carry the dome's fine stations
/// through its whole interior (81 % of the elements of the paper's module at level 1).
/// Each insert node faces a node of the core's inner wall and is tied to it; the wall
/// nodes between (the middle of a wall element, at s = ±½ on the insert's quadratic
/// edge) follow the insert's edge ([`Interpolation`]: ⅜, ¾, −⅛), so core and insert
/// stay conforming across the 2:1 change of element size.
pub(super) fn insert_coupling(
    wm: &mut WallMesh,
    walls: &Walls,
    p: &ModuleProfile,
    h: f64,
    opt: &FemOptions,
    c: &mut Couplings,
) {
    let s = wm.stations;
    let (halved, wall_of) = s.halved();
    let surface = mesh_insert(&mut wm.mesh, &mut c.fixed, p, &halved, h, wm.zc);
    let tied_components = |b: usize, mesh: &crate::fem::mesh::Mesh| -> &'static [usize] {
        let on_cylinder = mesh.nodes[b][1] <= p.insert_junction_z_mm + 1e-9;
        if on_cylinder && opt.insert_contact == InsertContact::SlidingWall {
            &[R]
        } else {
            &[R, Z]
        }
    };
    let last = halved.j_hole;
    for (k, (&j, &b)) in wall_of.iter().zip(&surface).enumerate().take(last + 1) {
        let a = wm.node(walls.core_inner, j);
        for &comp in tied_components(b, &wm.mesh) {
            c.ties.push((a, b, comp));
        }
        // An insert element spanning two wall elements: its corners at k and k + 2,
        // its middle node at k + 1; the wall nodes at j + 1 and j + 3 hang on its edge.
        if k % 2 == 0 && k + 2 <= last && wall_of[k + 2] == j + 4 {
            let edge = [surface[k], surface[k + 1], surface[k + 2]];
            for (hang, w) in [
                (j + 1, [0.375, 0.75, -0.125]),
                (j + 3, [-0.125, 0.75, 0.375]),
            ] {
                let node = wm.node(walls.core_inner, hang);
                for &comp in tied_components(edge[1], &wm.mesh) {
                    c.interpolations.push(Interpolation {
                        node,
                        component: comp,
                        masters: [(edge[0], w[0]), (edge[1], w[1]), (edge[2], w[2])],
                    });
                }
            }
        }
    }
}

/// The apex load, 1 N downward, as uniform pressure on the projected apex patch of
/// the cap's outer surface.
pub(super) fn apex_load(wm: &mut WallMesh, p: &ModuleProfile) -> Vec<(usize, usize, f64)> {
    let a = p.apex_flat_radius_mm;
    let pressure = 1.0 / (PI * a * a);
    let mut loads = Vec::new();
    let mut j = wm.stations.j_axis;
    while j >= 2 {
        let ids = [wm.node(0, j - 2), wm.node(0, j - 1), wm.node(0, j)];
        let nodes = &wm.mesh.nodes;
        let xy = [nodes[ids[0]], nodes[ids[1]], nodes[ids[2]]];
        if xy[2][0] >= a {
            break;
        }
        let s0 = if xy[0][0] <= a {
            -1.0
        } else {
            edge_param_at_radius(xy, a)
        };
        let f = edge_forces(xy, s0, 1.0, |_, _, dr, _| [0.0, -pressure * dr.abs()]);
        for k in 0..3 {
            loads.push((ids[k], Z, f[k][1]));
        }
        if xy[0][0] > a {
            break;
        }
        j -= 2;
    }
    loads
}
