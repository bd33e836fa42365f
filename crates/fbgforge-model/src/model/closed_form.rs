//! The closed-form opto-mechanical model: axial strain of the core's cylinder per
//! newton of apex force, for Case I (solid insert) and Case II (hollow core).
//!
//! Every function here is pure, allocation-free and works on a
//! [`ModuleModelParams`]; the derivation and every assumption are in `docs/model.md`.
//! Units: moduli in MPa = N/mm², lengths in mm, areas in mm², compliances in mm/N,
//! strains dimensionless (positive in tension), forces in N.

use super::params::{Elastic, ModuleModelParams};
use super::LoadCase;
use serde::Serialize;
use std::f64::consts::PI;

/// Apex-to-rim compliance of a spherical dome carrying an axial load P spread over a
/// central patch of radius `patch_radius_mm`, from membrane theory, mm/N.
///
/// With N_φ = −P/(2πρ sin²φ) and N_θ = −N_φ, integrating the membrane strains along
/// the meridian gives the relative axial displacement of the patch edge (φ0) and the
/// rim (α): δ = P (1 + ν)/(2π E t) · ln(tan(α/2) / tan(φ0/2)).
pub(crate) fn dome_membrane_compliance_mm_per_n(
    material: Elastic,
    wall_mm: f64,
    sphere_radius_mm: f64,
    rim_radius_mm: f64,
    patch_radius_mm: f64,
) -> f64 {
    let phi0 = (patch_radius_mm / sphere_radius_mm).min(1.0).asin();
    let alpha = (rim_radius_mm / sphere_radius_mm).min(1.0).asin();
    let log_ratio = ((0.5 * alpha).tan() / (0.5 * phi0).tan()).ln().max(0.0);
    (1.0 + material.poisson_ratio) / (2.0 * PI * material.youngs_modulus_mpa * wall_mm) * log_ratio
}

/// Rim-to-apex compliance of a dome pulled down at its rim while resting on a
/// matching sphere (the insert's top) with uniform contact pressure, mm/N.
///
/// Uniform pressure on a sphere gives N_φ = N_θ = P/(2πρ): a uniform membrane strain
/// (1 − ν)N/(E t) that moves the apex by ρ·ε relative to the rim, independent of ρ:
/// δ = P (1 − ν)/(2π E t). No load concentration, hence no logarithm.
pub(crate) fn supported_dome_compliance_mm_per_n(material: Elastic, wall_mm: f64) -> f64 {
    (1.0 - material.poisson_ratio) / (2.0 * PI * material.youngs_modulus_mpa * wall_mm)
}

/// Axial compliance L/(EA) of a cylinder section in uniform membrane tension or
/// compression (N1' = P/(2πR) per unit circumference), mm/N.
pub(crate) fn cylinder_compliance_mm_per_n(
    material: Elastic,
    length_mm: f64,
    area_mm2: f64,
) -> f64 {
    length_mm / (material.youngs_modulus_mpa * area_mm2)
}

/// Indentation compliance of an elastic half-space under a rigid flat circular punch
/// of radius `a` (Boussinesq): δ = P (1 − ν²)/(2 a E), mm/N.
pub(crate) fn punch_compliance_mm_per_n(material: Elastic, radius_mm: f64) -> f64 {
    (1.0 - material.poisson_ratio.powi(2)) / (2.0 * radius_mm * material.youngs_modulus_mpa)
}

/// Through-thickness compliance of a thin layer squeezed over a patch of radius `a`,
/// with the confined (oedometric) modulus, mm/N.
pub(crate) fn layer_compliance_mm_per_n(
    material: Elastic,
    thickness_mm: f64,
    radius_mm: f64,
) -> f64 {
    thickness_mm / (material.confined_modulus_mpa() * PI * radius_mm * radius_mm)
}

/// How the apex force is shared in Case I, per newton of force.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CaseIShare {
    /// Compliance of the loop path (cap dome → cap cylinder in compression → base clip
    /// → core cylinder in tension → core dome → insert), mm/N.
    pub loop_compliance_mm_per_n: f64,
    /// Compliance of the direct path (apex patch: lower half of the cap wall, the core
    /// wall, the insert's indentation), mm/N.
    pub direct_compliance_mm_per_n: f64,
    /// Share of F carried by the loop, P/F (dimensionless, 0..1).
    pub loop_share: f64,
    /// Axial strain of the core's cylinder per newton (positive: tension, red shift).
    pub core_strain_per_n: f64,
    /// Axial strain of the cap's cylinder per newton (negative: compression).
    pub cap_strain_per_n: f64,
    /// Axial strain of the insert per newton (it carries all of F), negative.
    pub insert_strain_per_n: f64,
}

/// Compliance of Case I's loop path, mm/N: the cap's dome (apex patch to rim,
/// membrane), the cap's cylinder in compression, the core's cylinder in tension and
/// the core's dome resting on the insert's matching top.
pub fn loop_compliance_mm_per_n(p: &ModuleModelParams) -> f64 {
    let g = &p.geometry;
    dome_membrane_compliance_mm_per_n(
        p.cap,
        g.cap_wall_mm,
        g.cap_dome_mid_sphere_radius_mm,
        g.cap_mid_radius_mm,
        g.contact_patch_radius_mm(),
    ) + cylinder_compliance_mm_per_n(p.cap, g.cap_cylinder_length_mm, g.cap_area_mm2)
        + cylinder_compliance_mm_per_n(p.core, g.core_cylinder_length_mm, g.core_area_mm2)
        + supported_dome_compliance_mm_per_n(p.core, g.core_wall_mm)
}

/// Derived compliance of Case I's direct path (before `direct_path_factor`), mm/N:
/// the lower half of the cap wall and the core wall squeezed over the contact patch,
/// and the insert indented by it.
pub(crate) fn direct_path_compliance_mm_per_n(p: &ModuleModelParams, insert: Elastic) -> f64 {
    let g = &p.geometry;
    let a = g.contact_patch_radius_mm();
    layer_compliance_mm_per_n(p.cap, 0.5 * g.cap_wall_mm, a)
        + layer_compliance_mm_per_n(p.core, g.core_wall_mm, a)
        + punch_compliance_mm_per_n(insert, a)
}

/// The `direct_path_factor` that makes Case I predict a measured sensitivity
/// `measured_pm_per_n` for a grating at `lambda_nm` (closed-form inversion of the load
/// share). `None` when the measurement is not a red shift the model can reach
/// (K must lie between 0 and the all-loop limit λ(1 − p_e)/(E1·A1)).
pub fn fit_direct_path_factor(
    p: &ModuleModelParams,
    measured_pm_per_n: f64,
    lambda_nm: f64,
    optics: &crate::grating::FiberOptics,
) -> Option<f64> {
    let insert = p.insert?;
    let per_strain = optics.shift_pm(lambda_nm, 1.0, 0.0);
    let share =
        measured_pm_per_n * p.core.youngs_modulus_mpa * p.geometry.core_area_mm2 / per_strain;
    if !(share > 0.0 && share < 1.0) {
        return None;
    }
    let direct = share * loop_compliance_mm_per_n(p) / (1.0 - share);
    Some(direct / direct_path_compliance_mm_per_n(p, insert))
}

/// Case I: core with a solid insert standing on the table, the module free to move
/// along it. Returns the load share and the strains per newton.
pub fn case_i_share(p: &ModuleModelParams, insert: Elastic) -> CaseIShare {
    let g = &p.geometry;
    let loop_c = loop_compliance_mm_per_n(p);
    let direct_c = p.direct_path_factor * direct_path_compliance_mm_per_n(p, insert);
    // Both paths start at the apex and end on the insert's top, so they share the apex
    // displacement: the force divides in inverse proportion to the compliances.
    let share = direct_c / (direct_c + loop_c);
    CaseIShare {
        loop_compliance_mm_per_n: loop_c,
        direct_compliance_mm_per_n: direct_c,
        loop_share: share,
        core_strain_per_n: share / (p.core.youngs_modulus_mpa * g.core_area_mm2),
        cap_strain_per_n: -share / (p.cap.youngs_modulus_mpa * g.cap_area_mm2),
        insert_strain_per_n: -1.0 / (insert.youngs_modulus_mpa * g.insert_area_mm2()),
    }
}

/// Case II: hollow core and cap both standing on the table; the domes bear on each
/// other, so both cylinders shorten equally and share F in proportion to E·A.
/// Returns (core strain per N, cap strain per N, share of F in the core = F10/F).
pub fn case_ii_strain_per_n(p: &ModuleModelParams) -> (f64, f64, f64) {
    let g = &p.geometry;
    let k_core = p.core.youngs_modulus_mpa * g.core_area_mm2;
    let k_cap = p.cap.youngs_modulus_mpa * g.cap_area_mm2;
    let strain = -1.0 / (k_core + k_cap);
    (strain, strain, k_core / (k_core + k_cap))
}

/// Axial strain of the core's cylinder per newton for a load case (signed; Case I
/// needs `p.insert`, otherwise `None`).
pub fn core_strain_per_n(p: &ModuleModelParams, case: LoadCase) -> Option<f64> {
    match case {
        LoadCase::I => p.insert.map(|i| case_i_share(p, i).core_strain_per_n),
        LoadCase::II => Some(case_ii_strain_per_n(p).0),
    }
}

/// Sensitivity K of a grating at `lambda_nm` bonded in the core's pillar, pm/N
/// (signed: positive = red shift). The membrane strain is uniform over the section
/// and along the cylinder, so the strain at the fiber's radius and its average over
/// the grating length equal the cylinder's strain.
pub fn sensitivity_pm_per_n(
    p: &ModuleModelParams,
    case: LoadCase,
    lambda_nm: f64,
    optics: &crate::grating::FiberOptics,
) -> Option<f64> {
    core_strain_per_n(p, case).map(|e| optics.shift_pm(lambda_nm, e, 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Apex-to-rim displacement of a loaded spherical membrane, integrated numerically
    /// from the strain–displacement relations (independent of the closed form).
    fn dome_by_quadrature(e: Elastic, t: f64, rho: f64, rim: f64, patch: f64) -> f64 {
        let (phi0, alpha) = ((patch / rho).asin(), (rim / rho).asin());
        // Unit apex load: N_φ = −1/(2πρ sin²φ), N_θ = −N_φ.
        let strains = |phi: f64| {
            let n = -1.0 / (2.0 * PI * rho * phi.sin().powi(2));
            let eps_phi = (n + e.poisson_ratio * n) / (e.youngs_modulus_mpa * t);
            (eps_phi, -eps_phi)
        };
        // v/sinφ from d(v/sinφ)/dφ = ρ(ε_φ − ε_θ)/sinφ, with v(α) = 0 (rigid-body datum).
        let n = 200_000;
        let h = (alpha - phi0) / n as f64;
        let mut w_over_sin = 0.0;
        for i in 0..n {
            // Midpoint rule from α down to φ0.
            let phi = alpha - (i as f64 + 0.5) * h;
            let (ep, et) = strains(phi);
            w_over_sin -= rho * (ep - et) / phi.sin() * h;
        }
        let z = |phi: f64, v_over_sin: f64| -v_over_sin + rho * strains(phi).1 * phi.cos();
        z(alpha, 0.0) - z(phi0, w_over_sin)
    }

    #[test]
    fn dome_membrane_compliance_matches_quadrature() {
        let e = Elastic {
            youngs_modulus_mpa: 44.0,
            poisson_ratio: 0.35,
        };
        for (rho, rim, patch) in [(16.25, 16.25, 1.25), (20.0, 15.0, 0.8), (8.0, 6.0, 0.3)] {
            let exact = dome_membrane_compliance_mm_per_n(e, 1.5, rho, rim, patch);
            let quad = dome_by_quadrature(e, 1.5, rho, rim, patch);
            assert!((exact / quad - 1.0).abs() < 1e-6, "{exact} vs {quad}");
        }
    }

    #[test]
    fn punch_and_layer_compliances_follow_their_textbook_forms() {
        let e = Elastic {
            youngs_modulus_mpa: 2.0,
            poisson_ratio: 0.0,
        };
        // ν = 0: confined modulus equals E, punch compliance 1/(2aE).
        assert!((layer_compliance_mm_per_n(e, 1.0, 1.0) - 1.0 / (2.0 * PI)).abs() < 1e-15);
        assert!((punch_compliance_mm_per_n(e, 0.5,) - 0.5).abs() < 1e-15);
        let rubber = Elastic {
            youngs_modulus_mpa: 1.0,
            poisson_ratio: 0.49,
        };
        assert!((rubber.confined_modulus_mpa() - 0.51 / (1.49 * 0.02)).abs() < 1e-12);
    }
}
