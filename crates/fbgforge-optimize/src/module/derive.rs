//! The derivation rules: the candidate design at a point. The overall height,
//! pillars, holes, contact lengths and grating heights follow the variables by fixed
//! rules (docs/optimize.md), floored at what the printer can make; the contact by the
//! family rule (`spec::ContactRatios`).

use super::problem::ModuleProblem;
use super::variables::Variable;
use crate::profile::ModuleProfile;
use crate::spec::Design;

impl ModuleProblem {
    /// Build the candidate design at `x` by the derivation rules.
    pub fn design_at(&self, x: &[f64]) -> Design {
        let b = self.base.module.as_ref().expect("checked in new");
        let get = |v: Variable| self.variables.iter().position(|&w| w == v).map(|i| x[i]);
        let mut d = self.template.clone();
        let min_wall = d.printer.min_wall_mm;
        let fit = self.min_fit_clearance_mm();
        let m = d.module.as_mut().expect("template has a module");
        let dia = get(Variable::OuterDiameterMm).unwrap_or(b.outer_diameter_mm);
        let s = dia / b.outer_diameter_mm;
        let r = dia / 2.0;
        m.outer_diameter_mm = dia;
        m.overall_height_mm = get(Variable::OverallHeightMm).unwrap_or(b.overall_height_mm * s);
        let ratio = get(Variable::DomeHeightRatio)
            .unwrap_or(b.dome_height_mm / (b.outer_diameter_mm / 2.0));
        m.dome_height_mm = ratio * r;
        m.cap_wall_mm = get(Variable::CapWallMm).unwrap_or((b.cap_wall_mm * s).max(min_wall));
        m.core_wall_mm = get(Variable::CoreWallMm).unwrap_or((b.core_wall_mm * s).max(min_wall));
        m.cap_core_clearance_mm = b.cap_core_clearance_mm.max(fit);
        m.core_insert_clearance_mm = b.core_insert_clearance_mm.max(fit);
        // Small features scale with the module but never below what prints and what a
        // coated fiber (250 µm) passes through.
        let p = &mut m.pillars;
        let bp = &b.pillars;
        p.fiber_hole_diameter_mm = (bp.fiber_hole_diameter_mm * s)
            .max(0.4)
            .min(bp.fiber_hole_diameter_mm.max(0.4));
        p.groove_depth_mm = (bp.groove_depth_mm * s).max(0.1);
        // EPS keeps the floors strictly inside the spec's limits despite rounding.
        const EPS: f64 = 1e-3;
        p.groove_width_mm =
            (bp.groove_width_mm * s).max(2.0 * m.cap_core_clearance_mm + min_wall + EPS);
        p.width_mm = (bp.width_mm * s).max(p.groove_width_mm + 2.0 * min_wall + EPS);
        p.height_mm = (bp.height_mm * s)
            .max(p.groove_depth_mm + p.fiber_hole_diameter_mm + 2.0 * min_wall + EPS);
        m.top_hole_diameter_mm = (b.top_hole_diameter_mm * s).max(0.4);
        m.apex_flat_diameter_mm = (b.apex_flat_diameter_mm * s).max(2.0 * d.printer.resolution_mm);
        // The contact reading follows by the family rule: the template states it
        // relative to its features (`Module::restate_contact_relative`), so the domes'
        // contact zone stays the same multiple of the apex patch, the clip band of the
        // cap wall, the dome clearance of the fit clearance.
        // Gratings keep their relative height, inside the cylindrical section.
        let prof = ModuleProfile::from_module_unchecked(m);
        let hs = m.overall_height_mm / b.overall_height_mm;
        for g in m.gratings.iter_mut() {
            if let Some(z) = g.center_height_mm {
                let lo = g.length_mm / 2.0;
                let hi = (prof.pillar_top_mm - g.length_mm / 2.0).max(lo);
                g.center_height_mm = Some((z * hs).clamp(lo, hi));
            }
        }
        d
    }
}
