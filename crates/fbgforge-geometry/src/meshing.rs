//! Meshing the parts of a build: each distinct solid once, at the requested chord
//! tolerance, finer on the surfaces that face a designed gap ([`crate::gaps`]); halved
//! where the volume bound needs it; then every gap measured on the meshes and its
//! surfaces refined again until the meshes keep [`gaps::KEPT_FRACTION`] of it, or the
//! build refused naming the gap.

use super::design_profile::DesignProfile;
use super::gaps::{self, GapSpec, MeshedGap};
use super::refine::{mesh_solid_graded, SurfaceNeed};
use super::registry::first_of_each_kind;
use super::{BuiltPart, GeometryError, PartKind, PartSolid};
use crate::mesh::MeshError;
use rayon::prelude::*;

/// Largest allowed relative difference between mesh and exact volume at the printer's
/// default tolerance (0.5 %). A coarser tolerance scales it in proportion, since the
/// chord error of a tessellation grows linearly with the tolerance.
pub const VOLUME_TOLERANCE_AT_DEFAULT: f64 = 0.005;

/// The volume bound applied at tolerance `tol_mm` for a printer whose default is
/// `default_mm` (see [`VOLUME_TOLERANCE_AT_DEFAULT`]).
pub(crate) fn volume_bound(tol_mm: f64, default_mm: f64) -> f64 {
    VOLUME_TOLERANCE_AT_DEFAULT * (tol_mm / default_mm).max(1.0)
}

/// How many times [`mesh_part`] may halve the tolerance to meet the volume bound.
pub(crate) const MAX_REFINEMENTS: u32 = 3;

/// How many times a gap's surfaces may be refined again after the first measurement.
pub(crate) const MAX_GAP_REFINEMENTS: u32 = 4;

/// A requested tolerance at which a part does not mesh into a closed solid.
#[derive(Debug, thiserror::Error)]
#[error("field `BuildRequest.tolerance_mm`: {requested_mm} mm is too coarse for part `{part}` ({detail}); allowed 0.001 to {largest_mm} mm for this design (the largest of the requested tolerance halved that meshes the part; the printer's default is {default_mm} mm)")]
pub struct ToleranceTooCoarse {
    /// The requested tolerance, mm.
    pub requested_mm: f64,
    /// The part that failed.
    pub part: String,
    /// The failed check, in words.
    pub detail: String,
    /// The largest tolerance found that meshes it, mm.
    pub largest_mm: f64,
    /// The printer's default, mm.
    pub default_mm: f64,
}

/// A designed gap the meshes cannot keep.
#[derive(Debug, thiserror::Error)]
#[error("field `{field}`: the {what} ({designed_mm:.4} mm designed) keeps only {meshed_mm:.4} mm ({kept_percent:.1} %) between the written meshes of the {outer} and the {inner} at a surface tolerance of {tolerance_mm} mm, under the {least_percent:.0} % a build must keep; widen the gap: allowed {least_gap_mm:.4} mm and wider (the meshes take {eaten_mm:.4} mm of it)", eaten_mm = .designed_mm - .meshed_mm)]
pub struct GapEaten {
    /// Which surfaces.
    pub what: String,
    /// The field that sets the gap.
    pub field: String,
    /// The outer part.
    pub outer: String,
    /// The other side (a part, or `fiber`).
    pub inner: String,
    /// Designed gap, mm.
    pub designed_mm: f64,
    /// Meshed gap, mm.
    pub meshed_mm: f64,
    /// Meshed over designed, percent.
    pub kept_percent: f64,
    /// The finest surface tolerance tried, mm.
    pub tolerance_mm: f64,
    /// The least share a build keeps, percent.
    pub least_percent: f64,
    /// The least designed gap that keeps that share when the meshes take as much of it
    /// as they take of this one, mm.
    pub least_gap_mm: f64,
}

/// Mesh one solid at `tol_mm` (finer on the `needs` surfaces) and run every check. If
/// the mesh volume misses the exact volume by more than `volume_bound` (small parts: an
/// inscribed polygon of chord error s loses about 4/3 · s/r of a circle's area), the
/// tolerance is halved, up to [`MAX_REFINEMENTS`] times; the tolerance actually used is
/// recorded.
pub(crate) fn mesh_part(
    part: &PartSolid,
    tol_mm: f64,
    volume_bound: f64,
    needs: &[SurfaceNeed],
) -> Result<BuiltPart, GeometryError> {
    let mut tol = tol_mm;
    for attempt in 0..=MAX_REFINEMENTS {
        let mesh = mesh_solid_graded(&part.name, &part.solid, tol, needs)?;
        let v = mesh.volume_mm3();
        let rel = (v - part.exact_volume_mm3) / part.exact_volume_mm3;
        if rel.abs() <= volume_bound {
            return Ok(BuiltPart {
                name: part.name.clone(),
                kind: part.kind,
                solid: part.solid.clone(),
                mesh,
                exact_volume_mm3: part.exact_volume_mm3,
                mesh_volume_mm3: v,
                mesh_tolerance_mm: tol,
            });
        }
        if attempt == MAX_REFINEMENTS || rel.is_nan() {
            return Err(MeshError {
                part: part.name.clone(),
                check: "volume",
                detail: format!(
                    "mesh volume {v:.3} mm³ differs from the exact {:.3} mm³ by {:.3} % at tolerance {tol} mm (allowed {:.3} %)",
                    part.exact_volume_mm3,
                    rel * 100.0,
                    volume_bound * 100.0
                ),
            }
            .into());
        }
        tol /= 2.0;
    }
    unreachable!("the loop returns on its last attempt")
}

/// [`mesh_part`], turning a part that does not mesh at a tolerance coarser than the
/// printer's default into a refusal naming the option with the largest tolerance (the
/// requested one halved) at which it does.
fn mesh_part_or_refuse(
    part: &PartSolid,
    tol_mm: f64,
    (bound, default_mm): (f64, f64),
    needs: &[SurfaceNeed],
) -> Result<BuiltPart, GeometryError> {
    refuse_too_coarse(part, tol_mm, (bound, default_mm), |t, b| {
        mesh_part(part, t, b, needs)
    })
}

/// [`mesh_part_or_refuse`] with the mesher given (`mesh(tolerance, volume bound)`), so
/// that the refusal can be checked on a mesher whose failures are known.
fn refuse_too_coarse(
    part: &PartSolid,
    tol_mm: f64,
    (bound, default_mm): (f64, f64),
    mesh: impl Fn(f64, f64) -> Result<BuiltPart, GeometryError>,
) -> Result<BuiltPart, GeometryError> {
    match mesh(tol_mm, bound) {
        Err(GeometryError::Mesh(e)) if tol_mm > default_mm && e.check != "volume" => {
            let mut t = tol_mm;
            while t > default_mm {
                t /= 2.0;
                if mesh(t, volume_bound(t, default_mm)).is_ok() {
                    break;
                }
            }
            Err(GeometryError::TooCoarse(Box::new(ToleranceTooCoarse {
                requested_mm: tol_mm,
                part: part.name.clone(),
                detail: format!("mesh check `{}` failed: {}", e.check, e.detail),
                largest_mm: t.min(tol_mm),
                default_mm,
            })))
        }
        other => other,
    }
}

/// The surfaces of `kind` that face a gap, at each gap's current tolerance.
fn needs_of(kind: PartKind, specs: &[GapSpec], tols: &[f64]) -> Vec<SurfaceNeed> {
    specs
        .iter()
        .zip(tols)
        .filter(|(s, _)| s.outer == kind)
        .map(|(s, &t)| SurfaceNeed {
            surfaces: s.outer_surfaces.clone(),
            tolerance_mm: t,
        })
        .collect()
}

/// Mesh every distinct solid of `solids` (one per kind: the inserts share theirs), in
/// parallel, and measure every gap of the module on the meshes; refine the surfaces of
/// the gaps the meshes eat too much of (their tolerance halved) up to
/// [`MAX_GAP_REFINEMENTS`] times. Returns one built part per solid and every gap
/// measured (those whose parts were both built).
pub(crate) fn mesh_solids(
    profile: &DesignProfile,
    solids: &[PartSolid],
    tol: f64,
) -> Result<(Vec<BuiltPart>, Vec<MeshedGap>), GeometryError> {
    mesh_solids_within(profile, solids, tol, GapBudget::BUILD)
}

/// How hard [`mesh_solids_within`] tries to keep the gaps: the refinement rounds after
/// the first measurement, and the first surface tolerance as a fraction of
/// [`gaps::initial_tolerance_mm`] (1: the build's).
#[derive(Debug, Clone, Copy)]
pub(crate) struct GapBudget {
    rounds: u32,
    first_tolerance_scale: f64,
}

impl GapBudget {
    /// What a build spends: [`MAX_GAP_REFINEMENTS`] rounds from the gap's own start.
    pub(crate) const BUILD: GapBudget = GapBudget {
        rounds: MAX_GAP_REFINEMENTS,
        first_tolerance_scale: 1.0,
    };
}

/// [`mesh_solids`] within a refinement budget.
pub(crate) fn mesh_solids_within(
    profile: &DesignProfile,
    solids: &[PartSolid],
    tol: f64,
    budget: GapBudget,
) -> Result<(Vec<BuiltPart>, Vec<MeshedGap>), GeometryError> {
    let default = profile.design.printer.default_tolerance_mm();
    let bound = volume_bound(tol, default);
    let specs: Vec<GapSpec> = profile
        .module
        .as_ref()
        .map(super::fits::module_gap_specs)
        .unwrap_or_default();
    let mut tols: Vec<f64> = specs
        .iter()
        .map(|s| {
            (budget.first_tolerance_scale * gaps::initial_tolerance_mm(s.designed_gap_mm)).min(tol)
        })
        .collect();
    let distinct = first_of_each_kind(solids, |s| s.kind);
    let mut meshed: Vec<BuiltPart> = distinct
        .par_iter()
        .map(|s| mesh_part_or_refuse(s, tol, (bound, default), &needs_of(s.kind, &specs, &tols)))
        .collect::<Result<_, _>>()?;
    let mut results = Vec::new();
    for round in 0..=budget.rounds {
        results = measure_all(&specs, &tols, &meshed);
        let eaten: Vec<usize> = results
            .iter()
            .filter(|(_, g)| g.kept_percent < 100.0 * gaps::KEPT_FRACTION)
            .map(|(k, _)| *k)
            .collect();
        let Some(&first) = eaten.first() else {
            break;
        };
        if round == budget.rounds {
            let g = &results
                .iter()
                .find(|(k, _)| *k == first)
                .expect("measured")
                .1;
            return Err(GeometryError::GapEaten(Box::new(GapEaten {
                what: g.what.clone(),
                field: g.field.clone(),
                outer: g.outer.name().into(),
                inner: g.inner.map_or("fiber", PartKind::name).into(),
                designed_mm: g.designed_gap_mm,
                meshed_mm: g.meshed_gap_mm,
                kept_percent: g.kept_percent,
                tolerance_mm: g.surface_tolerance_mm,
                least_percent: 100.0 * gaps::KEPT_FRACTION,
                least_gap_mm: (g.designed_gap_mm - g.meshed_gap_mm) / (1.0 - gaps::KEPT_FRACTION),
            })));
        }
        let mut again: Vec<PartKind> = Vec::new();
        for k in eaten {
            tols[k] /= 2.0;
            if !again.contains(&specs[k].outer) {
                again.push(specs[k].outer);
            }
        }
        let redone: Vec<BuiltPart> = distinct
            .par_iter()
            .filter(|s| again.contains(&s.kind))
            .map(|s| mesh_part(s, tol, bound, &needs_of(s.kind, &specs, &tols)))
            .collect::<Result<_, _>>()?;
        for r in redone {
            if let Some(slot) = meshed.iter_mut().find(|m| m.kind == r.kind) {
                *slot = r;
            }
        }
    }
    Ok((meshed, results.into_iter().map(|(_, g)| g).collect()))
}

/// Measure every gap whose parts were meshed: (index into `specs`, the result).
fn measure_all(specs: &[GapSpec], tols: &[f64], meshed: &[BuiltPart]) -> Vec<(usize, MeshedGap)> {
    let mesh_of = |k: PartKind| meshed.iter().find(|m| m.kind == k).map(|m| &m.mesh);
    specs
        .par_iter()
        .enumerate()
        .filter_map(|(k, s)| {
            let outer = mesh_of(s.outer)?;
            let inner = match s.inner_kind() {
                Some(kind) => Some(mesh_of(kind)?),
                None => None,
            };
            let g = gaps::measure(s, outer, inner)?;
            Some((
                k,
                MeshedGap {
                    outer: s.outer,
                    inner: s.inner_kind(),
                    what: s.what.clone(),
                    field: s.field.clone(),
                    designed_gap_mm: s.designed_gap_mm,
                    meshed_gap_mm: g,
                    kept_percent: 100.0 * g / s.designed_gap_mm,
                    surface_tolerance_mm: tols[k].min(
                        meshed
                            .iter()
                            .find(|m| m.kind == s.outer)
                            .map_or(f64::INFINITY, |m| m.mesh_tolerance_mm),
                    ),
                },
            ))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped(name: &str) -> crate::spec::Design {
        fbgforge_core::design::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../designs/{name}")),
        )
        .unwrap()
    }

    /// No shipped or drawn design reaches the refusal (the gap surfaces refine until
    /// kept): with no refinement round and the gap surfaces at the chord tolerance of
    /// 1 mm, the meshes eat a gap, and the refusal names its field and the least gap
    /// that would be kept.
    #[test]
    fn a_gap_the_meshes_eat_is_refused_naming_its_field_and_the_least_gap_kept() {
        let d = shipped("clip-on-34mm.toml");
        let profile = DesignProfile::new(&d);
        let sel = ["cap".to_string(), "core".into()];
        let solids = crate::build_solids_for(&profile, Some(&sel)).unwrap();
        let coarse = GapBudget {
            rounds: 0,
            first_tolerance_scale: 1e9,
        };
        let Err(GeometryError::GapEaten(g)) = mesh_solids_within(&profile, &solids, 1.0, coarse)
        else {
            panic!("a coarse mesh keeps every gap");
        };
        let e = g.to_string();
        assert!(g.kept_percent < 80.0, "{e}");
        assert!(
            e.starts_with(&format!("field `{}`", g.field)) && g.field.contains('.'),
            "{e}"
        );
        assert!(e.contains(&g.what), "{e}");
        // The least gap that keeps 80 % when the meshes take as much: wider than the
        // designed one, and 80 % of it is left once the eaten share is taken.
        assert!(
            e.contains(&format!("allowed {:.4} mm and wider", g.least_gap_mm)),
            "{e}"
        );
        assert!(g.least_gap_mm > g.designed_mm, "{e}");
        let eaten = g.designed_mm - g.meshed_mm;
        assert!(((g.least_gap_mm - eaten) / g.least_gap_mm - 0.8).abs() < 1e-9);
        // The build's budget keeps the same gaps on the same meshes' tolerance.
        let (_, kept) = mesh_solids_within(&profile, &solids, 1.0, GapBudget::BUILD).unwrap();
        assert!(kept.iter().all(|k| k.kept_percent >= 80.0));
    }

    /// No shipped design fails to mesh at a coarse tolerance any more; on a mesher that
    /// fails above 0.15 mm, a request of 1 mm is refused naming the option and the
    /// largest tolerance found by halving (0.125 mm), which meshes.
    #[test]
    fn a_tolerance_too_coarse_is_refused_naming_the_option_and_the_range_that_meshes() {
        let d = shipped("clip-on-10mm.toml");
        let profile = DesignProfile::new(&d);
        let solids = crate::build_solids_for(&profile, Some(&["cap".to_string()])).unwrap();
        let part = &solids[0];
        let default = d.printer.default_tolerance_mm();
        let fails_above = 0.15;
        let mesher = |t: f64, b: f64| {
            if t > fails_above {
                Err(GeometryError::Mesh(MeshError {
                    part: part.name.clone(),
                    check: "closed",
                    detail: format!("open at {t} mm"),
                }))
            } else {
                mesh_part(part, t, b, &[])
            }
        };
        let Err(GeometryError::TooCoarse(r)) =
            refuse_too_coarse(part, 1.0, (volume_bound(1.0, default), default), mesher)
        else {
            panic!("refused");
        };
        let e = r.to_string();
        assert!(
            e.starts_with("field `BuildRequest.tolerance_mm`: 1 mm is too coarse for part `cap`"),
            "{e}"
        );
        assert!(e.contains("allowed 0.001 to 0.125 mm"), "{e}");
        assert!(e.contains("mesh check `closed` failed"), "{e}");
        // The largest it names meshes; twice it does not.
        assert!(mesher(r.largest_mm, volume_bound(r.largest_mm, default)).is_ok());
        assert!(mesher(2.0 * r.largest_mm, 1.0).is_err());
        // At or under the printer's default nothing is tried: the failure is the mesher's.
        assert!(matches!(
            refuse_too_coarse(part, default, (0.005, default), |_, _| Err(
                GeometryError::Mesh(MeshError {
                    part: "cap".into(),
                    check: "closed",
                    detail: String::new(),
                })
            )),
            Err(GeometryError::Mesh(_))
        ));
    }
}
