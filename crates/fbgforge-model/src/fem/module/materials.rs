//! The elastic constants of the module's element regions: cap, core and insert from
//! the design's materials, and the pillar rings, whose modulus smears the pillars over
//! the circumference by their share of it.

use crate::fem::element::ElasticConstants;
use crate::profile::ModuleProfile;
use crate::spec::Material;
use std::f64::consts::PI;

pub(super) fn constants(m: &Material) -> ElasticConstants {
    ElasticConstants {
        youngs_modulus_mpa: m.youngs_modulus_mpa,
        poisson_ratio: m.poisson_ratio,
    }
}

/// Smear materials with angular fill fractions into one ring (Voigt sum of moduli,
/// Poisson's ratio weighted by stiffness share).
fn smeared(parts: &[(ElasticConstants, f64)]) -> ElasticConstants {
    let e: f64 = parts.iter().map(|(m, f)| m.youngs_modulus_mpa * f).sum();
    let nu = parts
        .iter()
        .map(|(m, f)| m.poisson_ratio * m.youngs_modulus_mpa * f)
        .sum::<f64>()
        / e;
    ElasticConstants {
        youngs_modulus_mpa: e,
        poisson_ratio: nu,
    }
}

/// The element materials: 0 cap, 1 clearance ring, 2 groove ring, 3 web ring, 4 core,
/// 5 insert (Case I). The pillar rings smear the pillars over the circumference by
/// their share of it.
pub(super) fn smeared_materials(
    m: &crate::spec::Module,
    p: &ModuleProfile,
    cap: ElasticConstants,
    core: ElasticConstants,
    insert: Option<ElasticConstants>,
    sliding: bool,
) -> Vec<ElasticConstants> {
    let pl = &m.pillars;
    let n = pl.count as f64;
    let fill = |width: f64, r0: f64, r1: f64| (n * width / (PI * (r0 + r1))).min(1.0);
    let flanks = (
        core,
        fill(
            pl.width_mm - pl.groove_width_mm,
            p.groove_bottom_radius_mm,
            p.pillar_outer_radius_mm,
        ),
    );
    let (ring_clear, ring_groove) = if sliding {
        // The cap's ribs slide in the grooves with the cap, so their axial stiffness
        // must sit on the cap's side of the sliding face: the clearance ring gets the
        // ribs' whole E·A (rib section n · width · groove depth over the ring's
        // section), the groove ring the core's flanks only. Without a clearance ring the
        // ribs' share of the cap's section (≈ 1.5 % in the paper's module) is dropped.
        let ring_area = PI * (p.cap_inner_radius_mm.powi(2) - p.pillar_outer_radius_mm.powi(2));
        let rib_area = n * p.cap_pillar_width_mm * pl.groove_depth_mm;
        let clear = ElasticConstants {
            youngs_modulus_mpa: cap.youngs_modulus_mpa * rib_area / ring_area.max(1e-12),
            poisson_ratio: cap.poisson_ratio,
        };
        (clear, smeared(&[flanks]))
    } else {
        let clear = smeared(&[(
            cap,
            fill(
                p.cap_pillar_width_mm,
                p.pillar_outer_radius_mm,
                p.cap_inner_radius_mm,
            ),
        )]);
        let groove = smeared(&[
            flanks,
            (
                cap,
                fill(
                    p.cap_pillar_width_mm,
                    p.groove_bottom_radius_mm,
                    p.pillar_outer_radius_mm,
                ),
            ),
        ]);
        (clear, groove)
    };
    let ring_web = smeared(&[(
        core,
        fill(
            pl.width_mm,
            p.core_outer_radius_mm,
            p.groove_bottom_radius_mm,
        ),
    )]);
    let mut materials = vec![cap, ring_clear, ring_groove, ring_web, core];
    materials.extend(insert);
    materials
}
