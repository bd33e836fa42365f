//! The common meridian coordinate of the module's walls: every wall is an offset of
//! the cap's outer surface, so one station s (a height below the dome centre, a polar
//! angle above it) names facing points on all walls; the stations carry the break
//! points (clip band, pillar top, 45°, apex patch, top hole) as nodes.

use crate::profile::ModuleProfile;
use anyhow::{bail, Result};
use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

/// Station of the common meridian coordinate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Station {
    /// Height z ≤ z_c (cylinder section).
    Z(f64),
    /// Polar angle of a ray from the dome centre, radians (0 horizontal).
    Theta(f64),
}

/// A wall surface: cylinder radius and sphere radius (∞ for a pure cylinder), mm.
#[derive(Debug, Clone, Copy)]
pub(super) struct Surface {
    pub(super) r: f64,
    pub(super) rho: f64,
}

pub(super) fn lerp_surface(a: Surface, b: Surface, t: f64) -> Surface {
    let rho = if t == 0.0 {
        a.rho
    } else if t == 1.0 {
        b.rho
    } else if a.rho.is_infinite() || b.rho.is_infinite() {
        f64::INFINITY
    } else {
        a.rho + (b.rho - a.rho) * t
    };
    Surface {
        r: a.r + (b.r - a.r) * t,
        rho,
    }
}

pub(super) fn point(s: Surface, st: Station, zc: f64) -> [f64; 2] {
    match st {
        Station::Z(z) => [s.r, z],
        Station::Theta(t) => {
            if (FRAC_PI_2 - t).abs() < 1e-12 {
                return [0.0, zc + s.rho];
            }
            let (sn, c) = t.sin_cos();
            let len = (s.r / c).min(s.rho);
            [len * c, zc + len * sn]
        }
    }
}

/// Doubled meridian stations and the doubled indices of the break points.
pub(super) struct Stations {
    pub(super) st: Vec<Station>,
    pub(super) j_seam: usize,
    pub(super) j_pillar_top: usize,
    pub(super) j_45: usize,
    pub(super) j_hole: usize,
    pub(super) j_patch: usize,
    pub(super) j_axis: usize,
    /// Heights of the element boundaries below the seam (for strain integration).
    pub(super) z_breaks: Vec<f64>,
    /// Doubled index of every break point, in increasing order (0 and j_axis included).
    pub(super) breaks: Vec<usize>,
}

impl Stations {
    /// Stations twice as far apart between the same break points (a window with an odd
    /// number of elements keeps one element of the original length at its end), and
    /// for each of them its doubled index in `self`. Every station of the result is a
    /// station of `self`: a part meshed on them (the insert) meets the walls node on
    /// node at every one of its nodes.
    pub(super) fn halved(&self) -> (Stations, Vec<usize>) {
        let mut of: Vec<usize> = vec![0];
        for w in self.breaks.windows(2) {
            let (b0, b1) = (w[0], w[1]);
            let mut c = b0;
            while c < b1 {
                let span = if b1 - c >= 4 { 4 } else { b1 - c };
                of.push(c + span / 2);
                of.push(c + span);
                c += span;
            }
        }
        let at = |j: usize| of.iter().position(|&k| k == j).expect("a break is kept");
        let st: Vec<Station> = of.iter().map(|&j| self.st[j]).collect();
        let z_breaks = of
            .iter()
            .step_by(2)
            .filter(|&&j| j <= self.j_seam)
            .filter_map(|&j| match self.st[j] {
                Station::Z(z) => Some(z),
                Station::Theta(_) => None,
            })
            .collect();
        let halved = Stations {
            j_seam: at(self.j_seam),
            j_pillar_top: at(self.j_pillar_top),
            j_45: at(self.j_45),
            j_hole: at(self.j_hole),
            j_patch: at(self.j_patch),
            j_axis: at(self.j_axis),
            breaks: self.breaks.iter().map(|&b| at(b)).collect(),
            st,
            z_breaks,
        };
        (halved, of)
    }
}

/// The stations along the cylinders, from the base up to the dome centre `zc`: element
/// boundaries uniform at about `h`, with one on the clip band's top edge when there
/// is one, so the bonded band ends on a node and K varies continuously with every
/// dimension (a band edge between nodes jumps from node to node as the module
/// changes). Returns the stations (boundaries and midpoints), the boundaries, and the
/// doubled index of every break point (the ends of the windows meshed uniformly).
fn cylinder_stations(
    zc: f64,
    h: f64,
    clip_mm: Option<f64>,
) -> (Vec<Station>, Vec<f64>, Vec<usize>) {
    let mut z_breaks: Vec<f64> = Vec::new();
    let mut segment = |z0: f64, z1: f64, min: usize| {
        let n = (((z1 - z0) / h).ceil() as usize).max(min);
        for k in 0..n {
            z_breaks.push(z0 + (z1 - z0) * k as f64 / n as f64);
        }
        n
    };
    let mut break_indices = vec![0];
    match clip_mm.filter(|c| *c > 0.0 && *c < zc) {
        Some(c) => {
            let below = segment(0.0, c, 1);
            break_indices.push(2 * below);
            segment(c, zc, 1);
        }
        None => {
            segment(0.0, zc, 2);
        }
    }
    z_breaks.push(zc);
    let mut st: Vec<Station> = Vec::with_capacity(2 * z_breaks.len());
    for w in z_breaks.windows(2) {
        st.push(Station::Z(w[0]));
        st.push(Station::Z(0.5 * (w[0] + w[1])));
    }
    st.push(Station::Z(zc));
    break_indices.push(st.len() - 1);
    (st, z_breaks, break_indices)
}

/// The rays (angles above the dome centre's plane) the dome's stations break at: the
/// ring top (`theta_p`), 45°, the apex contact patch's edge (`theta_c`), the core's
/// top hole (`theta_h`), the axis, and every wall's cylinder-to-sphere corner below
/// the patch; sorted, with `(theta_p, theta_c, theta_h)`.
fn dome_breaks(
    p: &ModuleProfile,
    fiber_r: f64,
    (patch_r, more_r): (f64, &[Option<f64>]),
) -> (Vec<f64>, [f64; 3]) {
    let zc = p.dome_center_z_mm;
    // Ring top: the ray through the fiber radius at the pillar top.
    // Kept below the rays where the rings' bounding walls (cap inner, core outer) turn
    // onto their spheres, so the rings stay on the cylinders.
    let corner = |r: f64, rho: f64| if r < rho { (r / rho).acos() } else { 0.0 };
    let theta_p = if p.pillar_top_mm > zc + 1e-9 {
        ((p.pillar_top_mm - zc) / fiber_r)
            .atan()
            .min(corner(
                p.cap_inner_radius_mm,
                p.cap_dome_inner_sphere_radius_mm,
            ))
            .min(corner(
                p.core_outer_radius_mm,
                p.core_dome_outer_sphere_radius_mm,
            ))
    } else {
        0.0
    };
    // Core top hole: the ray through the hole edge at the core's mid-wall sphere.
    let rho_mid = 0.5 * (p.core_dome_outer_sphere_radius_mm + p.core_dome_inner_sphere_radius_mm);
    let theta_h = (p.top_hole_radius_mm / rho_mid).clamp(0.0, 1.0).acos();
    // Apex contact patch edge on the core's outer dome (kept below the hole's ray).
    let ray = |r: f64| {
        (r / p.core_dome_outer_sphere_radius_mm)
            .clamp(0.0, 1.0)
            .acos()
            .min(theta_h)
    };
    let theta_c = ray(patch_r);
    let mut breaks = vec![0.0, theta_p, FRAC_PI_4, theta_c, theta_h, FRAC_PI_2];
    // The other readings' contact radii, so that all of them mesh alike.
    let more: Vec<f64> = more_r.iter().flatten().map(|&r| ray(r)).collect();
    breaks.extend(more.iter().copied().filter(|&t| t > theta_p));
    // The corners below the widest contact zone get a station (every reading alike).
    let theta_low = more.iter().copied().fold(theta_c, f64::min);
    // For a dome flatter than a hemisphere each wall surface turns a corner where its
    // cylinder meets its sphere; a station on each corner's ray keeps quadratic
    // elements from spanning (and folding over) a corner.
    for (r, rho) in [
        (p.cap_outer_radius_mm, p.cap_dome_outer_sphere_radius_mm),
        (p.cap_inner_radius_mm, p.cap_dome_inner_sphere_radius_mm),
        (p.core_outer_radius_mm, p.core_dome_outer_sphere_radius_mm),
        (p.core_inner_radius_mm, p.core_dome_inner_sphere_radius_mm),
        (p.insert_radius_mm, p.insert_sphere_radius_mm),
    ] {
        if r < rho {
            let t = (r / rho).acos();
            if t > 1e-4 && t < theta_low {
                breaks.push(t);
            }
        }
    }
    breaks.sort_by(|a, b| a.total_cmp(b));
    breaks.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    (breaks, [theta_p, theta_c, theta_h])
}

pub(super) fn make_stations(
    p: &ModuleProfile,
    (h, h_dome): (f64, f64),
    fiber_r: f64,
    contact_r: (f64, &[Option<f64>]),
    clip_mm: Option<f64>,
) -> Result<Stations> {
    let zc = p.dome_center_z_mm;
    if zc <= 0.0 {
        bail!(
            "the finite-element mesher needs the dome centre above the base (dome centre at z = {zc:.3} mm): use a taller module or a higher dome"
        );
    }
    let (mut st, z_breaks, mut break_indices) = cylinder_stations(zc, h, clip_mm);
    let j_seam = st.len() - 1;
    let (breaks, [theta_p, theta_c, theta_h]) = dome_breaks(p, fiber_r, contact_r);
    let rho_ref = p.cap_dome_outer_sphere_radius_mm;
    let mut idx = HashMap::new();
    for w in breaks.windows(2) {
        let n = ((rho_ref * (w[1] - w[0]) / h_dome).ceil() as usize).max(1);
        for k in 1..=2 * n {
            st.push(Station::Theta(
                w[0] + (w[1] - w[0]) * k as f64 / (2 * n) as f64,
            ));
        }
        idx.insert((w[1] * 1e6).round() as i64, st.len() - 1);
        break_indices.push(st.len() - 1);
    }
    idx.insert(0, j_seam);
    let find = |t: f64| -> usize {
        breaks
            .iter()
            .find(|b| (**b - t).abs() < 1e-6)
            .and_then(|b| idx.get(&((b * 1e6).round() as i64)).copied())
            .unwrap_or(j_seam)
    };
    Ok(Stations {
        breaks: break_indices,
        j_patch: find(theta_c),
        j_seam,
        j_pillar_top: find(theta_p),
        j_45: find(FRAC_PI_4),
        j_hole: find(theta_h),
        j_axis: st.len() - 1,
        st,
        z_breaks,
    })
}
