//! Closed-form volumes of the module's parts: spherical zones, disc slices, a domed
//! cylinder and the ring a revolved profile sweeps (docs/geometry.md, "Exact volumes").

use crate::profile::ModuleProfile;
use std::f64::consts::PI;

/// Solid of revolution bounded by a cylinder of radius `r` from `z_base` up to `zj`, a
/// sphere of radius `rho` centred at `zc` above it, cut flat at `z_top`: its volume,
/// mm³ (the volume inside a [`domed_wall`]).
pub(super) fn capped_cylinder_volume(
    r: f64,
    z_base: f64,
    zj: f64,
    rho: f64,
    zc: f64,
    z_top: f64,
) -> f64 {
    PI * r * r * (zj - z_base) + zone_volume(rho, zj - zc, z_top - zc)
}

/// Volume of the part of a ball of radius rho between heights h1 < h2 above its
/// centre (a spherical zone), mm³.
pub fn zone_volume(rho: f64, h1: f64, h2: f64) -> f64 {
    PI * (rho * rho * (h2 - h1) - (h2.powi(3) - h1.powi(3)) / 3.0)
}

/// Area of the slice |t| < h of a disc of radius r, mm².
pub fn slice_area(r: f64, h: f64) -> f64 {
    h * (r * r - h * h).sqrt() + r * r * (h / r).asin()
}

pub(super) fn sphere_z(p: &ModuleProfile, rho: f64, r: f64) -> f64 {
    p.dome_center_z_mm + (rho * rho - r * r).sqrt()
}

/// Volume swept about the axis by the region between radius `r_out` and a chain of
/// straight (r, z) segments inside it, mm³ (Pappus, segment by segment).
pub(super) fn ring_volume(r_out: f64, chain: &[(f64, f64)]) -> f64 {
    chain
        .windows(2)
        .map(|w| {
            let ((r1, z1), (r2, z2)) = (w[0], w[1]);
            PI * (z2 - z1) * (r_out * r_out - (r1 * r1 + r1 * r2 + r2 * r2) / 3.0)
        })
        .sum()
}
