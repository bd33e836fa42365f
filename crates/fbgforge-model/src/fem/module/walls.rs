//! The mesh of the module's walls: cap, the pillar rings and core laid out as layers
//! between shared d-lines (curves of constant offset from the cap's outer surface),
//! each meshed over the stations with one node per (d-line, station).

use super::options::{FemOptions, PillarCoupling};
use super::stations::{lerp_surface, point, Stations, Surface};
use crate::fem::mesh::Mesh;
use crate::profile::ModuleProfile;
use std::collections::HashMap;
use std::ops::Range;

/// One wall layer: its outer d-line, elements through it, last station, material.
#[derive(Debug, Clone, Copy)]
struct Layer {
    first: usize,
    n: usize,
    j_end: usize,
    material: usize,
}

/// The layered walls on shared "d-lines" (curves of constant offset), outside in.
pub(super) struct Walls {
    pub(super) dlines: Vec<Surface>,
    layers: Vec<Layer>,
    /// Element thickness through a wall, mm.
    t_el: f64,
    /// With a sliding pillar coupling: the cap side's d-line on the pillars' outer
    /// face (the core side's is the next one).
    pub(super) split: Option<usize>,
    web_layer: usize,
    pub(super) cap_inner: usize,
    pub(super) core_outer: usize,
    pub(super) core_inner: usize,
}

impl Walls {
    /// Add a layer from the innermost d-line to `inner`, `thk` mm thick; returns its
    /// inner d-line.
    fn add_layer(&mut self, inner: Surface, thk: f64, j_end: usize, material: usize) -> usize {
        let n = ((thk / self.t_el).round() as usize).max(1);
        let outer = *self.dlines.last().expect("at least one d-line");
        let first = self.dlines.len() - 1;
        for k in 1..=2 * n {
            self.dlines
                .push(lerp_surface(outer, inner, k as f64 / (2 * n) as f64));
        }
        self.layers.push(Layer {
            first,
            n,
            j_end,
            material,
        });
        self.dlines.len() - 1
    }
}

/// Lay out the walls: cap, clearance ring, groove ring, web ring, core (materials 0–4).
pub(super) fn wall_layers(
    m: &crate::spec::Module,
    p: &ModuleProfile,
    s: &Stations,
    opt: &FemOptions,
) -> Walls {
    let cyl = |r: f64| Surface {
        r,
        rho: f64::INFINITY,
    };
    let has_clearance = p.cap_inner_radius_mm - p.pillar_outer_radius_mm > 1e-9;
    let mut w = Walls {
        dlines: vec![Surface {
            r: p.cap_outer_radius_mm,
            rho: p.cap_dome_outer_sphere_radius_mm,
        }],
        layers: Vec::new(),
        t_el: m.cap_wall_mm.min(m.core_wall_mm) / opt.elements_through_wall as f64,
        split: None,
        web_layer: 2 + usize::from(has_clearance),
        cap_inner: 0,
        core_outer: 0,
        core_inner: 0,
    };
    let cap_inner = Surface {
        r: p.cap_inner_radius_mm,
        rho: p.cap_dome_inner_sphere_radius_mm,
    };
    w.cap_inner = w.add_layer(cap_inner, m.cap_wall_mm, s.j_axis, 0);
    if has_clearance {
        let clearance = m.cap_core_clearance_mm;
        w.add_layer(cyl(p.pillar_outer_radius_mm), clearance, s.j_pillar_top, 1);
    }
    // Base clip: the cap side (cap + its alignment pillars) and the core side (core
    // pillars) get separate nodes on the pillar's outer face, tied below.
    if opt.pillar_coupling != PillarCoupling::Bonded {
        let outer = *w.dlines.last().expect("d-lines");
        w.dlines.push(outer);
        w.split = Some(w.dlines.len() - 2);
    }
    let groove = m.pillars.groove_depth_mm;
    w.add_layer(cyl(p.groove_bottom_radius_mm), groove, s.j_pillar_top, 2);
    let core_outer = Surface {
        r: p.core_outer_radius_mm,
        rho: p.core_dome_outer_sphere_radius_mm,
    };
    let web = p.groove_bottom_radius_mm - p.core_outer_radius_mm;
    w.core_outer = w.add_layer(core_outer, web, s.j_pillar_top, 3);
    let core_inner = Surface {
        r: p.core_inner_radius_mm,
        rho: p.core_dome_inner_sphere_radius_mm,
    };
    w.core_inner = w.add_layer(core_inner, m.core_wall_mm, s.j_hole, 4);
    w
}

/// The mesh being built, with the node at each (d-line, station) made once.
pub(super) struct WallMesh<'a> {
    pub(super) mesh: Mesh,
    pub(super) node_of: HashMap<(usize, usize), usize>,
    pub(super) dlines: &'a [Surface],
    pub(super) stations: &'a Stations,
    pub(super) zc: f64,
}

impl WallMesh<'_> {
    /// The node on d-line `dl` at station `j`.
    pub(super) fn node(&mut self, dl: usize, j: usize) -> usize {
        let (mesh, q) = (
            &mut self.mesh,
            point(self.dlines[dl], self.stations.st[j], self.zc),
        );
        *self
            .node_of
            .entry((dl, j))
            .or_insert_with(|| mesh.add_node(q[0], q[1]))
    }

    /// Mesh every wall layer; returns the web ring's elements and the nodes on the base.
    pub(super) fn mesh_layers(&mut self, walls: &Walls) -> (Range<usize>, Vec<usize>) {
        let mut web_elements = 0..0;
        let mut base_nodes = Vec::new();
        for (li, l) in walls.layers.iter().enumerate() {
            let ids: Vec<Vec<usize>> = (0..=2 * l.n)
                .map(|i| (0..=l.j_end).map(|j| self.node(l.first + i, j)).collect())
                .collect();
            base_nodes.extend(ids.iter().map(|col| col[0]));
            let range = self.mesh.add_block(&ids, l.material);
            if li == walls.web_layer {
                web_elements = range;
            }
        }
        (web_elements, base_nodes)
    }
}
