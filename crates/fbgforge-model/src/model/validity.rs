//! Validity checks of the closed-form model: where its assumptions stop holding.
//!
//! The limits, and why each is used (details in `docs/model.md`):
//! - thin shell: membrane theory neglects bending and through-thickness stress, an
//!   error of order t/R; we warn above t/R = 1/10, the usual thin-shell bound;
//! - edge zones: within π/β of the base or of a dome junction (β⁴ = 3(1 − ν²)/(R t)²)
//!   the cylinder bends and the membrane strain is not uniform;
//! - elastomers (E < 100 MPa): a neo-Hookean solid's secant modulus falls 5 % below E
//!   at about 5 % strain, so the linear model is trusted up to 5 %;
//! - rigid photopolymers (E ≥ 100 MPa): proportional limit of about 1 % strain;
//! - grating: 3000 µε, one third of the 1 % proof-test strain of standard fiber,
//!   the usual limit for long-term reliable, linear operation.

use super::params::{Elastic, ModuleModelParams};
use super::{closed_form, LoadCase};
use crate::profile::GratingPlacement;

/// Largest wall thickness to mid-surface radius ratio accepted as a thin shell.
pub(crate) const THIN_SHELL_MAX_T_OVER_R: f64 = 0.1;
/// Modulus below which a material is treated as an elastomer, MPa.
pub(crate) const ELASTOMER_MAX_MODULUS_MPA: f64 = 100.0;
/// Linear-range strain limit of an elastomer (dimensionless).
pub(crate) const ELASTOMER_LINEAR_STRAIN: f64 = 0.05;
/// Linear-range strain limit of a rigid photopolymer (dimensionless).
pub(crate) const RIGID_LINEAR_STRAIN: f64 = 0.01;
/// Largest grating strain for reliable linear operation (dimensionless).
pub(crate) const GRATING_MAX_STRAIN: f64 = 3.0e-3;

/// Linear-range strain limit of a material.
pub(crate) fn material_strain_limit(e: Elastic) -> f64 {
    if e.youngs_modulus_mpa < ELASTOMER_MAX_MODULUS_MPA {
        ELASTOMER_LINEAR_STRAIN
    } else {
        RIGID_LINEAR_STRAIN
    }
}

/// Length of the bending boundary layer of a cylinder (π/β), mm.
pub(crate) fn edge_zone_mm(radius_mm: f64, wall_mm: f64, poisson: f64) -> f64 {
    let beta = (3.0 * (1.0 - poisson * poisson)).powf(0.25) / (radius_mm * wall_mm).sqrt();
    std::f64::consts::PI / beta
}

/// Warnings that depend on the geometry only (thin-shell ratios, grating in an edge zone).
pub(crate) fn geometry_warnings(
    p: &ModuleModelParams,
    grating: Option<&GratingPlacement>,
) -> Vec<String> {
    let g = &p.geometry;
    let mut w = Vec::new();
    for (part, t, r) in [
        ("cap", g.cap_wall_mm, g.cap_mid_radius_mm),
        ("core", g.core_wall_mm, g.core_mid_radius_mm),
    ] {
        if t / r > THIN_SHELL_MAX_T_OVER_R {
            w.push(format!(
                "thin-shell ratio of the {part} t/R = {:.3} exceeds {THIN_SHELL_MAX_T_OVER_R}: membrane theory errs by about t/R",
                t / r
            ));
        }
    }
    if let Some(gr) = grating {
        let zone = edge_zone_mm(g.core_mid_radius_mm, g.core_wall_mm, p.core.poisson_ratio);
        if gr.z_start_mm < zone {
            w.push(format!(
                "grating starts {:.2} mm above the base, inside the {zone:.2} mm bending zone of the core's free edge",
                gr.z_start_mm
            ));
        }
        if gr.z_end_mm > g.core_cylinder_length_mm - zone {
            w.push(format!(
                "grating ends {:.2} mm below the core's dome junction, inside its {zone:.2} mm bending zone",
                g.core_cylinder_length_mm - gr.z_end_mm
            ));
        }
    }
    w
}

/// Warnings that depend on the strains at a given force.
pub(crate) fn strain_warnings(
    core: Elastic,
    core_strain: f64,
    cap: Elastic,
    cap_strain: f64,
    insert: Option<(Elastic, f64)>,
) -> Vec<String> {
    let mut w = Vec::new();
    // The values themselves are in the prediction; the messages name the limit only,
    // so a table of many rows repeats one note instead of one per row.
    if core_strain.abs() > GRATING_MAX_STRAIN {
        w.push(format!(
            "grating strain beyond ±{:.0} µε (a third of the 1 % proof test): not reliably linear",
            GRATING_MAX_STRAIN * 1e6
        ));
    }
    let mut parts = vec![("core", core, core_strain), ("cap", cap, cap_strain)];
    if let Some((e, s)) = insert {
        parts.push(("insert", e, s));
    }
    for (part, e, s) in parts {
        let lim = material_strain_limit(e);
        if s.abs() > lim {
            w.push(format!(
                "{part} strain beyond the linear range of its material ({:.0} % for E = {} MPa)",
                lim * 100.0,
                e.youngs_modulus_mpa
            ));
        }
    }
    w
}

/// Warnings that depend on the force: a pull lifts the module off its support, and in
/// Case I the printed dome gap stays open below the force that closes it.
pub(crate) fn force_warnings(p: &ModuleModelParams, case: LoadCase, force_n: f64) -> Vec<String> {
    let mut w = Vec::new();
    if force_n < 0.0 {
        w.push(
            "a pulling force lifts the module off its support: both cases need F ≥ 0".to_string(),
        );
    }
    if case == LoadCase::I && force_n >= 0.0 && p.geometry.dome_gap_mm > 0.0 {
        // With the gap open all of F goes round the loop, and the cap's apex approaches
        // the core's dome by F·c_L (docs/model.md §5.3).
        let closing_n = p.geometry.dome_gap_mm / closed_form::loop_compliance_mm_per_n(p);
        if force_n < closing_n {
            w.push(format!(
                "the printed {:.2} mm dome gap closes only near {closing_n:.1} N; below it the cap does not bear on the core's dome, all of F goes round the loop and K ≈ λ(1 − p_e)/(E1·A1), far above the value shown",
                p.geometry.dome_gap_mm
            ));
        }
    }
    w
}
