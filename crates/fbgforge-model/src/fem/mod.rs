//! Axisymmetric finite-element reference model of the clip-on module.
//!
//! The closed-form model ([`crate::model`]) rests on thin-shell membrane theory and a
//! uniform strain across each wall. This module solves the same module, meshed from
//! the same [`crate::profile::ModuleProfile`], as a linear-elastic body of revolution
//! with quadratic mixed elements (no volumetric locking for the ν ≈ 0.49 rubber) and a
//! sparse Cholesky solve. It is the independent check of the closed form over the
//! design space (the `fem` study of the studies crate) and the slower, more general
//! prediction ([`predict`]) for designs outside the closed form's measured validity
//! region; which of the two answers a row is decided by the one model policy,
//! [`crate::prediction`].
//!
//! Submodules: [`element`] (Q9/P1 element), [`mesh`] (mesh data, edge loads),
//! [`mod@solve`] (dof map, assembly, the structure of a solve apart from its values),
//! [`linear`] (the sparse Cholesky solvers), [`cache`] (structures re-used across
//! solves that differ only in the moduli), [`contact`] (unilateral contact condensed on
//! its pairs), [`module`] (the module's mesh, contacts, supports and load).

pub mod cache;
pub mod contact;
pub mod element;
pub mod linear;
pub mod mesh;
pub mod module;
pub mod solve;

pub use module::{
    ContactReading, DomeContact, FemOptions, InsertContact, PillarCoupling, SolverKind,
};

use crate::model::GratingPrediction;
pub use crate::model::{configurations, Configuration};
use crate::profile::{module_gratings, GratingPlacement, ModuleProfile};
use crate::spec::{Design, GratingRole};
use anyhow::{anyhow, bail, Result};
use serde::Serialize;
use std::time::Instant;

/// Result of one finite-element solve of one configuration.
#[derive(Debug, Clone, Serialize)]
pub struct ConfigurationResult {
    /// The configuration.
    pub configuration: Configuration,
    /// Mean axial strain per newton on the fiber axis, for every strain grating of
    /// the configuration's core: (grating name, Bragg wavelength nm, strain per N).
    pub strain_per_n: Vec<(String, f64, f64)>,
    /// Unknowns solved for.
    pub unknowns: usize,
    /// Elements in the mesh.
    pub elements: usize,
    /// Wall-clock time of mesh, assembly, factorisation and read-out, s.
    pub solve_time_s: f64,
}

/// With extrapolation asked for: the options of the fine and the coarse solve (both
/// without extrapolation) and the Richardson factor 1/(2^order − 1) that takes
/// fine + (fine − coarse)·factor; None without it.
fn richardson_levels(opt: &FemOptions) -> Result<Option<(FemOptions, FemOptions, f64)>> {
    let Some(order) = opt.richardson_order else {
        return Ok(None);
    };
    if !(order.is_finite() && order > 0.0) {
        bail!("Richardson order must be a positive number, got {order}");
    }
    let plain = FemOptions {
        richardson_order: None,
        ..*opt
    };
    Ok(Some((
        plain,
        opt.coarsened(),
        1.0 / (2f64.powf(order) - 1.0),
    )))
}

/// Solve one configuration with F = 1 N and read every grating of its core (the
/// structure of its problem comes from, and goes to, [`cache::GeometryCache::global`]).
pub fn solve_configuration(
    design: &Design,
    config: &Configuration,
    opt: &FemOptions,
) -> Result<ConfigurationResult> {
    solve_configurations(design, &[(config.clone(), *opt)])
        .pop()
        .expect("one result per request")
}

/// A geometry's structure, or why it could not be built (kept as text: shared by
/// every unit of the geometry).
type BuiltStructure = Result<std::sync::Arc<solve::ProblemStructure>, String>;

/// One solve of a batch: a level of one request (the fine or the coarse mesh of a
/// Richardson pair, or the only one).
struct Unit {
    config: Configuration,
    opt: FemOptions,
    /// Index into the batch's geometries.
    geometry: usize,
}

/// How a request's result is made from its units.
enum Plan {
    Single(usize),
    Richardson {
        fine: usize,
        coarse: usize,
        factor: f64,
    },
}

/// A mesh shared by the units of one load case and one set of options.
struct Geometry {
    case: crate::model::LoadCase,
    opt: FemOptions,
    /// The problem built for the first unit, with what is needed to read gratings.
    model: Result<module::ModuleModel, String>,
    build_time_s: f64,
}

/// Solve many configurations of one design, each with its own options, at F = 1 N:
/// the same results as [`solve_configuration`] on each, in order, for much less work.
///
/// The configurations of one load case with one set of options share one mesh, built
/// once; problems of one mesh share one [`solve::ProblemStructure`] (numbering,
/// pattern, element stiffness per unit modulus, symbolic factorisation), built once
/// through [`cache::GeometryCache::global`] (so later calls on the same geometry, e.g.
/// the next step of a sweep over a modulus, skip it); problems equal in mesh and
/// moduli share one numeric factorisation and solve. Distinct structures are built
/// in parallel, largest first, then every factorisation in parallel. A
/// configuration's `solve_time_s` is the work its own solve needs, counting shared
/// work in full (what it would cost alone with a warm cache, plus the structure).
/// Contact readings with unilateral pairs are solved one by one ([`solve_response`]).
pub fn solve_configurations(
    design: &Design,
    requests: &[(Configuration, FemOptions)],
) -> Vec<Result<ConfigurationResult>> {
    use rayon::prelude::*;
    // Requests → units (levels) → geometries.
    let mut units: Vec<Unit> = Vec::new();
    let mut geometries: Vec<Geometry> = Vec::new();
    let mut plans: Vec<Result<Plan>> = Vec::with_capacity(requests.len());
    let mut add_unit = |config: &Configuration, opt: FemOptions, units: &mut Vec<Unit>| {
        let geometry = match geometries
            .iter()
            .position(|g| g.case == config.case && g.opt == opt)
        {
            Some(i) => i,
            None => {
                geometries.push(Geometry {
                    case: config.case,
                    opt,
                    model: Err(String::new()),
                    build_time_s: 0.0,
                });
                geometries.len() - 1
            }
        };
        units.push(Unit {
            config: config.clone(),
            opt,
            geometry,
        });
        units.len() - 1
    };
    for (config, opt) in requests {
        plans.push(richardson_levels(opt).map(|levels| match levels {
            Some((plain, coarsened, factor)) => Plan::Richardson {
                fine: add_unit(config, plain, &mut units),
                coarse: add_unit(config, coarsened, &mut units),
                factor,
            },
            None => Plan::Single(add_unit(config, *opt, &mut units)),
        }));
    }
    // One mesh per geometry, built for its first unit.
    let firsts: Vec<usize> = (0..geometries.len())
        .map(|g| units.iter().position(|u| u.geometry == g).expect("used"))
        .collect();
    let built: Vec<(Result<module::ModuleModel, String>, f64)> = firsts
        .par_iter()
        .map(|&u| {
            let start = Instant::now();
            let unit = &units[u];
            let model = build_configuration(design, &unit.config, &unit.opt)
                .map(|(model, _)| model)
                .map_err(|e| format!("{e:#}"));
            (model, start.elapsed().as_secs_f64())
        })
        .collect();
    for (g, (model, t)) in geometries.iter_mut().zip(built) {
        g.model = model;
        g.build_time_s = t;
    }
    // Structures, largest first so the two halves of a 2-core machine end together.
    let mut order: Vec<usize> = (0..geometries.len()).collect();
    let size = |g: &Geometry| {
        g.model
            .as_ref()
            .map_or(0, |m| m.problem.mesh.elements.len())
    };
    order.sort_by_key(|&g| std::cmp::Reverse(size(&geometries[g])));
    let mut structures: Vec<Option<(BuiltStructure, f64)>> =
        (0..geometries.len()).map(|_| None).collect();
    let made: Vec<(usize, BuiltStructure, f64)> = order
        .par_iter()
        .filter_map(|&g| {
            let geo = &geometries[g];
            let model = geo.model.as_ref().ok()?;
            if !model.contact_pairs.is_empty() {
                return None;
            }
            let start = Instant::now();
            let s = cache::GeometryCache::global()
                .structure(&model.problem, geo.opt.solver.solver())
                .map_err(|e| format!("{e:#}"));
            Some((g, s, start.elapsed().as_secs_f64()))
        })
        .collect();
    for (g, s, t) in made {
        structures[g] = Some((s, t));
    }
    // Each unit's materials and gratings; units equal in geometry and materials share
    // one factorisation and solve (a task).
    struct Prepared {
        materials: Vec<element::ElasticConstants>,
        gratings: Vec<GratingPlacement>,
    }
    let prepared: Vec<Result<Prepared>> = units
        .iter()
        .map(|u| {
            let (core_material, insert_material) = configuration_materials(design, &u.config)?;
            let m = design
                .module
                .as_ref()
                .expect("checked by configuration_materials");
            Ok(Prepared {
                materials: module::materials(
                    design,
                    &core_material,
                    insert_material.as_deref(),
                    u.config.case,
                    &u.opt,
                )?,
                gratings: configuration_gratings(m, &u.config),
            })
        })
        .collect();
    let mut tasks: Vec<(usize, &[element::ElasticConstants])> = Vec::new();
    let task_of: Vec<Option<usize>> = units
        .iter()
        .zip(&prepared)
        .map(|(u, p)| {
            let p = p.as_ref().ok()?;
            structures[u.geometry].as_ref()?;
            let key = (u.geometry, p.materials.as_slice());
            Some(match tasks.iter().position(|t| *t == key) {
                Some(i) => i,
                None => {
                    tasks.push(key);
                    tasks.len() - 1
                }
            })
        })
        .collect();
    let solved: Vec<Result<(solve::Solution, f64), String>> = tasks
        .par_iter()
        .map(|&(g, materials)| {
            let start = Instant::now();
            let (s, _) = structures[g].as_ref().expect("a task has a structure");
            let s = s.as_ref().map_err(Clone::clone)?;
            let model = geometries[g].model.as_ref().map_err(Clone::clone)?;
            let sol = s
                .factor(materials)
                .and_then(|f| f.solve_loads(&model.problem.loads))
                .map_err(|e| format!("{e:#}"))?;
            Ok((sol, start.elapsed().as_secs_f64()))
        })
        .collect();
    // Read every unit's gratings (contact units: their own solve).
    let unit_results: Vec<Result<ConfigurationResult>> = units
        .par_iter()
        .enumerate()
        .map(|(i, u)| {
            let prepared = prepared[i].as_ref().map_err(|e| anyhow!("{e:#}"))?;
            let geo = &geometries[u.geometry];
            let model = geo.model.as_ref().map_err(|e| anyhow!("{e}"))?;
            if !model.contact_pairs.is_empty() {
                return solve_contact_configuration(design, &u.config, &u.opt);
            }
            let start = Instant::now();
            let task = task_of[i].expect("a unit without contact pairs has a task");
            let (sol, solve_s) = solved[task].as_ref().map_err(|e| anyhow!("{e}"))?;
            let mut strain_per_n = Vec::new();
            for g in &prepared.gratings {
                let e = model.mean_axial_strain(sol, g.z_start_mm, g.z_end_mm)?;
                strain_per_n.push((g.name.clone(), g.bragg_wavelength_nm, e));
            }
            let structure_s = structures[u.geometry].as_ref().map_or(0.0, |(_, t)| *t);
            Ok(ConfigurationResult {
                configuration: u.config.clone(),
                strain_per_n,
                unknowns: sol.unknowns,
                elements: model.problem.mesh.elements.len(),
                solve_time_s: geo.build_time_s
                    + structure_s
                    + solve_s
                    + start.elapsed().as_secs_f64(),
            })
        })
        .collect();
    let mut unit_results: Vec<Option<Result<ConfigurationResult>>> =
        unit_results.into_iter().map(Some).collect();
    let mut take = |i: usize| unit_results[i].take().expect("each unit used once");
    plans
        .into_iter()
        .map(|plan| match plan? {
            Plan::Single(u) => take(u),
            Plan::Richardson {
                fine,
                coarse,
                factor,
            } => {
                let (fine, coarse) = (take(fine)?, take(coarse)?);
                let strain_per_n = fine
                    .strain_per_n
                    .iter()
                    .zip(&coarse.strain_per_n)
                    .map(|((name, lambda, ef), (_, _, ec))| {
                        (name.clone(), *lambda, ef + (ef - ec) * factor)
                    })
                    .collect();
                Ok(ConfigurationResult {
                    strain_per_n,
                    solve_time_s: fine.solve_time_s + coarse.solve_time_s,
                    ..fine
                })
            }
        })
        .collect()
}

/// A configuration with unilateral contact pairs: the secant K at 1 N.
fn solve_contact_configuration(
    design: &Design,
    config: &Configuration,
    opt: &FemOptions,
) -> Result<ConfigurationResult> {
    let start = Instant::now();
    let r = solve_response(design, config, opt, &[1.0])?;
    Ok(ConfigurationResult {
        configuration: config.clone(),
        strain_per_n: r
            .gratings
            .iter()
            .map(|g| (g.name.clone(), g.bragg_wavelength_nm, g.strain[0]))
            .collect(),
        unknowns: r.unknowns,
        elements: r.elements,
        solve_time_s: start.elapsed().as_secs_f64(),
    })
}

/// The material keys of a configuration's core and insert.
fn configuration_materials(
    design: &Design,
    config: &Configuration,
) -> Result<(String, Option<String>)> {
    let m = design
        .module
        .as_ref()
        .ok_or_else(|| anyhow!("the design has no [module] section"))?;
    let core = m
        .cores
        .iter()
        .find(|c| c.name == config.core)
        .ok_or_else(|| anyhow!("no core named `{}`", config.core))?;
    let insert_material = match &config.insert {
        Some(name) => Some(
            m.inserts
                .iter()
                .find(|i| &i.name == name)
                .ok_or_else(|| anyhow!("no insert named `{name}`"))?
                .material
                .clone(),
        ),
        None => None,
    };
    Ok((core.material.clone(), insert_material))
}

/// The strain gratings of a configuration's core.
fn configuration_gratings(
    m: &crate::spec::Module,
    config: &Configuration,
) -> Vec<GratingPlacement> {
    let profile = ModuleProfile::from_module(m);
    module_gratings(m, &profile)
        .into_iter()
        .filter(|g| {
            g.role == GratingRole::Strain && g.core.as_deref() == Some(config.core.as_str())
        })
        .collect()
}

/// The module problem of one configuration and the strain gratings of its core.
fn build_configuration(
    design: &Design,
    config: &Configuration,
    opt: &FemOptions,
) -> Result<(module::ModuleModel, Vec<GratingPlacement>)> {
    let (core_material, insert_material) = configuration_materials(design, config)?;
    let m = design.module.as_ref().expect("checked above");
    let model = module::build(
        design,
        &core_material,
        insert_material.as_deref(),
        config.case,
        opt,
    )?;
    Ok((model, configuration_gratings(m, config)))
}

/// One grating's response over a force range.
#[derive(Debug, Clone, Serialize)]
pub struct GratingResponse {
    /// Grating name.
    pub name: String,
    /// Bragg wavelength, nm.
    pub bragg_wavelength_nm: f64,
    /// Mean axial strain at the grating at each force (dimensionless).
    pub strain: Vec<f64>,
}

/// The response of one configuration over a range of apex forces: with unilateral
/// contact (a contact reading of [`FemOptions`]) it is not linear in the force.
#[derive(Debug, Clone, Serialize)]
pub struct ConfigurationResponse {
    /// The configuration.
    pub configuration: Configuration,
    /// Apex forces, N.
    pub force_n: Vec<f64>,
    /// Each strain grating of the configuration's core.
    pub gratings: Vec<GratingResponse>,
    /// Contact pairs touching at each force.
    pub active_pairs: Vec<usize>,
    /// Of those, the pairs along the cylinders (the rest are on the domes).
    pub active_cylinder_pairs: Vec<usize>,
    /// Contact pairs in the model.
    pub contact_pairs: usize,
    /// Force at which the first printed gap closes (the knee), N; `None` when the model
    /// has no contact pairs or no gap closes.
    pub knee_force_n: Option<f64>,
    /// Unknowns solved for.
    pub unknowns: usize,
    /// Elements in the mesh.
    pub elements: usize,
    /// Wall-clock time, s.
    pub solve_time_s: f64,
}

impl ConfigurationResponse {
    /// Bragg shift of grating `i` at each force, pm.
    pub fn shift_pm(&self, optics: &crate::grating::FiberOptics, i: usize) -> Vec<f64> {
        let g = &self.gratings[i];
        g.strain
            .iter()
            .map(|&e| optics.shift_pm(g.bragg_wavelength_nm, e, 0.0))
            .collect()
    }
}

/// Solve one configuration at each of `forces_n` (N, in increasing order): the
/// stiffness is factorised once and the contact problem, when the options ask for
/// one, is condensed on its pairs and solved exactly at every force (`contact`).
pub fn solve_response(
    design: &Design,
    config: &Configuration,
    opt: &FemOptions,
    forces_n: &[f64],
) -> Result<ConfigurationResponse> {
    if forces_n.iter().any(|f| !f.is_finite()) {
        bail!("forces must be finite numbers of newtons");
    }
    if let Some((plain, coarsened, factor)) = richardson_levels(opt)? {
        let fine = solve_response(design, config, &plain, forces_n)?;
        let coarse = solve_response(design, config, &coarsened, forces_n)?;
        let mut out = fine.clone();
        for (g, c) in out.gratings.iter_mut().zip(&coarse.gratings) {
            for (e, ec) in g.strain.iter_mut().zip(&c.strain) {
                *e += (*e - ec) * factor;
            }
        }
        out.knee_force_n = match (fine.knee_force_n, coarse.knee_force_n) {
            (Some(f), Some(c)) => Some(f + (f - c) * factor),
            (f, _) => f,
        };
        out.solve_time_s = fine.solve_time_s + coarse.solve_time_s;
        return Ok(out);
    }
    let start = Instant::now();
    let (model, gratings) = build_configuration(design, config, opt)?;
    let factored = cache::GeometryCache::global().factor(&model.problem, opt.solver.solver())?;
    let observe = |sol: &solve::Solution| -> Result<Vec<f64>> {
        gratings
            .iter()
            .map(|g| model.mean_axial_strain(sol, g.z_start_mm, g.z_end_mm))
            .collect()
    };
    let reduced = contact::reduce(
        &factored,
        &model.problem.loads,
        &model.contact_pairs,
        observe,
    )?;
    let mut strain = vec![Vec::with_capacity(forces_n.len()); gratings.len()];
    let mut active = Vec::with_capacity(forces_n.len());
    let mut active_cylinders = Vec::with_capacity(forces_n.len());
    for &f in forces_n {
        let state = reduced.solve(f, 0.0)?;
        for (s, v) in strain.iter_mut().zip(&state.observed) {
            s.push(*v);
        }
        active.push(state.active());
        active_cylinders.push(
            state
                .normal_force_n
                .iter()
                .zip(&model.pair_on_cylinders)
                .filter(|(l, on)| **l > 0.0 && **on)
                .count(),
        );
    }
    Ok(ConfigurationResponse {
        configuration: config.clone(),
        force_n: forces_n.to_vec(),
        gratings: gratings
            .into_iter()
            .zip(strain)
            .map(|(g, strain)| GratingResponse {
                name: g.name,
                bragg_wavelength_nm: g.bragg_wavelength_nm,
                strain,
            })
            .collect(),
        active_pairs: active,
        active_cylinder_pairs: active_cylinders,
        contact_pairs: model.contact_pairs.len(),
        knee_force_n: reduced.knee_load_factor(),
        unknowns: factored.unknowns(),
        elements: model.problem.mesh.elements.len(),
        solve_time_s: start.elapsed().as_secs_f64(),
    })
}

/// Largest grating strain the linear model is trusted with (1 %): beyond it the rubber
/// and the bond of the fiber leave the linear range.
pub const LINEAR_STRAIN_LIMIT: f64 = 0.01;

/// Finite-element prediction of every strain grating, for Case II and for Case I with
/// each insert, at `force_n` (same output type and order as [`crate::model::predict`]).
pub fn predict(design: &Design, force_n: f64, opt: &FemOptions) -> Result<Vec<GratingPrediction>> {
    if !force_n.is_finite() {
        bail!("force must be a finite number of newtons, got {force_n}");
    }
    let mut out = Vec::new();
    for config in configurations(design)? {
        let res = solve_configuration(design, &config, opt)?;
        for (name, lambda_nm, e) in res.strain_per_n {
            let k = design.fiber.shift_pm(lambda_nm, e, 0.0);
            let strain = e * force_n;
            let mut warnings = vec![];
            if strain.abs() > LINEAR_STRAIN_LIMIT {
                warnings.push(format!(
                    "strain {strain:.4} at {force_n} N exceeds the linear range (|ε| ≤ {LINEAR_STRAIN_LIMIT})"
                ));
            }
            out.push(GratingPrediction {
                grating: name,
                core: config.core.clone(),
                case: config.case,
                insert: config.insert.clone(),
                sensitivity_pm_per_n: k,
                shift_pm: k * force_n,
                strain,
                warnings,
            });
        }
    }
    Ok(out)
}
