//! The small, copyable parameter set the closed-form model runs on.
//!
//! [`ModuleModelParams`] is built once from a design (through [`crate::profile`], the
//! single source of truth for every dimension) and then evaluated by the pure
//! functions of [`super::closed_form`]. Keeping it a flat `Copy` struct of `f64`s lets
//! an optimiser change a modulus or a wall and re-evaluate K millions of times
//! without touching the spec, the profile or the heap.

use super::ModelError;
use crate::profile::{sphere_height_at_radius, ModuleProfile};
use crate::spec::{Design, Module};
use serde::Serialize;

/// An isotropic linear-elastic material as the model needs it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Elastic {
    /// Young's modulus, MPa (= N/mm²).
    pub youngs_modulus_mpa: f64,
    /// Poisson's ratio, dimensionless.
    pub poisson_ratio: f64,
}

impl Elastic {
    /// Oedometric (laterally confined) modulus M = E(1 − ν)/((1 + ν)(1 − 2ν)), MPa: the
    /// through-thickness stiffness of a thin layer squeezed over a patch.
    pub(crate) fn confined_modulus_mpa(&self) -> f64 {
        let (e, nu) = (self.youngs_modulus_mpa, self.poisson_ratio);
        e * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu))
    }
}

/// Geometry the closed form needs, all read from [`ModuleProfile`] (mm, mm²).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModuleGeometry {
    /// Axial cross-section of the cap's cylinder: wall annulus plus its alignment ribs, mm².
    pub cap_area_mm2: f64,
    /// Axial cross-section of the core's cylinder: wall annulus plus the grooved pillars
    /// (less grooves and fiber holes), mm².
    pub core_area_mm2: f64,
    /// Cap wall thickness, mm.
    pub cap_wall_mm: f64,
    /// Core wall thickness, mm.
    pub core_wall_mm: f64,
    /// Mid-surface radius of the cap's cylinder, mm.
    pub cap_mid_radius_mm: f64,
    /// Mid-surface radius of the core's cylinder, mm.
    pub core_mid_radius_mm: f64,
    /// Length of the cap's cylinder from the base to its mid-surface dome junction, mm.
    pub cap_cylinder_length_mm: f64,
    /// Length of the core's cylinder from the base to its mid-surface dome junction, mm.
    pub core_cylinder_length_mm: f64,
    /// Mid-surface sphere radius of the cap's dome, mm.
    pub cap_dome_mid_sphere_radius_mm: f64,
    /// Mid-surface sphere radius of the core's dome, mm.
    pub core_dome_mid_sphere_radius_mm: f64,
    /// Radius of the apex flat where the force is applied, mm.
    pub apex_flat_radius_mm: f64,
    /// Insert radius, mm.
    pub insert_radius_mm: f64,
    /// Radial gap between the cap's inner dome and the core's outer dome as printed
    /// (one cap/core clearance), mm. The model assumes it closed (paper assumption 3);
    /// it closes at F = gap / c_L, a fraction of a newton (docs/model.md §5.3).
    pub dome_gap_mm: f64,
}

impl ModuleGeometry {
    /// Read every dimension from the profile (plus the pillar sizes of the spec, which
    /// the profile does not restate).
    pub(crate) fn from_profile(m: &Module, p: &ModuleProfile) -> Self {
        let pl = &m.pillars;
        let n = pl.count as f64;
        let annulus = |ro: f64, ri: f64| std::f64::consts::PI * (ro * ro - ri * ri);
        // The cap's alignment ribs reach from the cap's inner wall down to
        // `cap_pillar_inner_radius_mm`; they belong to the cap's axial section.
        let cap_rib_area =
            n * p.cap_pillar_width_mm * (p.cap_inner_radius_mm - p.cap_pillar_inner_radius_mm);
        let hole_area = std::f64::consts::PI * pl.fiber_hole_diameter_mm.powi(2) / 4.0;
        let pillar_area =
            n * (pl.width_mm * pl.height_mm - pl.groove_width_mm * pl.groove_depth_mm - hole_area);
        let cap_mid = 0.5 * (p.cap_outer_radius_mm + p.cap_inner_radius_mm);
        let core_mid = 0.5 * (p.core_outer_radius_mm + p.core_inner_radius_mm);
        let cap_rho = 0.5 * (p.cap_dome_outer_sphere_radius_mm + p.cap_dome_inner_sphere_radius_mm);
        let core_rho =
            0.5 * (p.core_dome_outer_sphere_radius_mm + p.core_dome_inner_sphere_radius_mm);
        ModuleGeometry {
            cap_area_mm2: annulus(p.cap_outer_radius_mm, p.cap_inner_radius_mm) + cap_rib_area,
            core_area_mm2: annulus(p.core_outer_radius_mm, p.core_inner_radius_mm) + pillar_area,
            cap_wall_mm: m.cap_wall_mm,
            core_wall_mm: m.core_wall_mm,
            cap_mid_radius_mm: cap_mid,
            core_mid_radius_mm: core_mid,
            cap_cylinder_length_mm: p.dome_center_z_mm + sphere_height_at_radius(cap_rho, cap_mid),
            core_cylinder_length_mm: p.dome_center_z_mm
                + sphere_height_at_radius(core_rho, core_mid),
            cap_dome_mid_sphere_radius_mm: cap_rho,
            core_dome_mid_sphere_radius_mm: core_rho,
            apex_flat_radius_mm: p.apex_flat_radius_mm,
            insert_radius_mm: p.insert_radius_mm,
            dome_gap_mm: p.cap_dome_inner_sphere_radius_mm - p.core_dome_outer_sphere_radius_mm,
        }
    }

    /// Insert cross-section, mm².
    pub fn insert_area_mm2(&self) -> f64 {
        std::f64::consts::PI * self.insert_radius_mm * self.insert_radius_mm
    }

    /// Radius of the patch over which the apex force reaches the domes' neutral
    /// surfaces: the apex flat widened at 45° through half the cap wall (the paper's
    /// assumption 2 puts the force on the neutral surface), mm.
    pub(crate) fn contact_patch_radius_mm(&self) -> f64 {
        self.apex_flat_radius_mm + 0.5 * self.cap_wall_mm
    }
}

/// Everything the closed form needs for one core (and one insert in Case I).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModuleModelParams {
    /// Dimensions from the profile.
    pub geometry: ModuleGeometry,
    /// Cap material (E2).
    pub cap: Elastic,
    /// Core material (E1).
    pub core: Elastic,
    /// Insert material (Es); `None` for a hollow core.
    pub insert: Option<Elastic>,
    /// Multiplier on the derived compliance of Case I's direct (apex contact) path,
    /// dimensionless; 1 = the estimate of `docs/model.md`. It is the one quantity the
    /// stated assumptions do not fix; a measured Case I sensitivity calibrates it
    /// (see [`super::closed_form::fit_direct_path_factor`]).
    pub direct_path_factor: f64,
}

impl ModuleModelParams {
    /// Build the parameters for `core` (by name) and optionally `insert` (by name).
    pub fn from_design(
        design: &Design,
        core: &str,
        insert: Option<&str>,
    ) -> Result<Self, ModelError> {
        let m = design.module.as_ref().ok_or(ModelError::NoModule)?;
        let profile = ModuleProfile::from_module(m);
        Self::from_parts(design, m, &profile, core, insert)
    }

    /// Build the parameters from an already derived profile (saves re-deriving it when
    /// several cores, inserts and gratings are evaluated for one design).
    pub(crate) fn from_parts(
        design: &Design,
        m: &Module,
        profile: &ModuleProfile,
        core: &str,
        insert: Option<&str>,
    ) -> Result<Self, ModelError> {
        let elastic = |key: &str, field: String| -> Result<Elastic, ModelError> {
            let mat = design
                .materials
                .get(key)
                .ok_or_else(|| ModelError::UnknownMaterial {
                    field: field.clone(),
                    key: key.to_string(),
                })?;
            Ok(Elastic {
                youngs_modulus_mpa: mat.youngs_modulus_mpa,
                poisson_ratio: mat.poisson_ratio,
            })
        };
        let (ci, c) = m
            .cores
            .iter()
            .enumerate()
            .find(|(_, c)| c.name == core)
            .ok_or_else(|| ModelError::UnknownCore {
                name: core.to_string(),
                known: m.cores.iter().map(|c| c.name.clone()).collect(),
            })?;
        let insert = match insert {
            None => None,
            Some(name) => {
                if m.inserts.is_empty() {
                    return Err(ModelError::NoInsert);
                }
                let (ii, ins) = m
                    .inserts
                    .iter()
                    .enumerate()
                    .find(|(_, i)| i.name == name)
                    .ok_or_else(|| ModelError::UnknownInsert {
                        name: name.to_string(),
                        known: m.inserts.iter().map(|i| i.name.clone()).collect(),
                    })?;
                Some(elastic(
                    &ins.material,
                    format!("module.inserts[{ii}].material"),
                )?)
            }
        };
        let p = ModuleModelParams {
            geometry: ModuleGeometry::from_profile(m, profile),
            cap: elastic(&m.cap_material, "module.cap_material".into())?,
            core: elastic(&c.material, format!("module.cores[{ci}].material"))?,
            insert,
            direct_path_factor: 1.0,
        };
        p.check()?;
        Ok(p)
    }

    /// Reject parameters the closed form cannot evaluate: zero, negative or non-finite
    /// moduli, areas or lengths. Cheap enough to run before every evaluation.
    pub fn check(&self) -> Result<(), ModelError> {
        let mut moduli = vec![("E2 (cap)", self.cap), ("E1 (core)", self.core)];
        if let Some(i) = self.insert {
            moduli.push(("Es (insert)", i));
        }
        for (what, e) in moduli {
            if !(e.youngs_modulus_mpa.is_finite() && e.youngs_modulus_mpa > 0.0) {
                return Err(ModelError::BadModulus {
                    what: what.to_string(),
                    value_mpa: e.youngs_modulus_mpa,
                });
            }
            if !(e.poisson_ratio.is_finite() && (0.0..0.5).contains(&e.poisson_ratio)) {
                return Err(ModelError::BadGeometry {
                    what: format!("Poisson's ratio of {what}"),
                    value: e.poisson_ratio,
                });
            }
        }
        if !(self.direct_path_factor.is_finite() && self.direct_path_factor > 0.0) {
            return Err(ModelError::BadGeometry {
                what: "direct-path factor".into(),
                value: self.direct_path_factor,
            });
        }
        let g = &self.geometry;
        for (what, v) in [
            ("cap cross-section (mm²)", g.cap_area_mm2),
            ("core cross-section (mm²)", g.core_area_mm2),
            ("cap wall (mm)", g.cap_wall_mm),
            ("core wall (mm)", g.core_wall_mm),
            ("cap cylinder length (mm)", g.cap_cylinder_length_mm),
            ("core cylinder length (mm)", g.core_cylinder_length_mm),
            ("cap dome radius (mm)", g.cap_dome_mid_sphere_radius_mm),
            ("core dome radius (mm)", g.core_dome_mid_sphere_radius_mm),
            ("apex flat radius (mm)", g.apex_flat_radius_mm),
            ("insert radius (mm)", g.insert_radius_mm),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ModelError::BadGeometry {
                    what: what.to_string(),
                    value: v,
                });
            }
        }
        if g.contact_patch_radius_mm() >= g.core_dome_mid_sphere_radius_mm {
            return Err(ModelError::BadGeometry {
                what: "contact patch radius (apex flat + half cap wall) against the core dome radius (mm)".into(),
                value: g.contact_patch_radius_mm(),
            });
        }
        Ok(())
    }
}
