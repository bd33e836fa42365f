//! Many configurations of one design solved as one batch ([`solve_configurations`]):
//! requests become units (the levels of a Richardson pair, or the only one), units of
//! one load case and one set of options share a mesh (a geometry), the geometries'
//! structures come from the caller's [`GeometryCache`], and units equal in geometry and
//! moduli share one numeric factorisation and solve (a task).

use super::cache::GeometryCache;
use super::element::ElasticConstants;
use super::{
    build_configuration, configuration_gratings, configuration_materials, module,
    richardson_levels, solve, solve_contact_configuration, Configuration, ConfigurationResult,
    FemOptions,
};
use crate::profile::GratingPlacement;
use crate::spec::Design;
use anyhow::{anyhow, Result};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// A geometry's structure, or why it could not be built (kept as text: shared by
/// every unit of the geometry).
type BuiltStructure = Result<Arc<solve::ProblemStructure>, String>;

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

/// A unit's materials and the gratings it reads.
struct Prepared {
    materials: Vec<ElasticConstants>,
    gratings: Vec<GratingPlacement>,
}

/// The distinct (geometry, materials) tasks of a batch, and each unit's task.
type Tasks<'a> = (Vec<(usize, &'a [ElasticConstants])>, Vec<Option<usize>>);

/// The batch: its units, their geometries and each request's plan.
#[derive(Default)]
struct Batch {
    units: Vec<Unit>,
    geometries: Vec<Geometry>,
    plans: Vec<Result<Plan>>,
}

impl Batch {
    /// Requests → units (levels) → geometries.
    fn plan(requests: &[(Configuration, FemOptions)]) -> Self {
        let mut b = Batch::default();
        for (config, opt) in requests {
            let plan = richardson_levels(opt).map(|levels| match levels {
                Some((plain, coarsened, factor)) => Plan::Richardson {
                    fine: b.add_unit(config, plain),
                    coarse: b.add_unit(config, coarsened),
                    factor,
                },
                None => Plan::Single(b.add_unit(config, *opt)),
            });
            b.plans.push(plan);
        }
        b
    }

    /// Add a unit on its geometry (a new one for a new case or options).
    fn add_unit(&mut self, config: &Configuration, opt: FemOptions) -> usize {
        let geometry = match self
            .geometries
            .iter()
            .position(|g| g.case == config.case && g.opt == opt)
        {
            Some(i) => i,
            None => {
                self.geometries.push(Geometry {
                    case: config.case,
                    opt,
                    model: Err(String::new()),
                    build_time_s: 0.0,
                });
                self.geometries.len() - 1
            }
        };
        self.units.push(Unit {
            config: config.clone(),
            opt,
            geometry,
        });
        self.units.len() - 1
    }

    /// One mesh per geometry, built for its first unit (in parallel).
    fn mesh(&mut self, design: &Design) {
        let firsts: Vec<usize> = (0..self.geometries.len())
            .map(|g| {
                self.units
                    .iter()
                    .position(|u| u.geometry == g)
                    .expect("used")
            })
            .collect();
        let units = &self.units;
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
        for (g, (model, t)) in self.geometries.iter_mut().zip(built) {
            g.model = model;
            g.build_time_s = t;
        }
    }

    /// Each geometry's structure from `cache` (none for contact models, solved one by
    /// one), largest first so the two halves of a 2-core machine end together, with
    /// the time it took.
    fn structures(&self, cache: &GeometryCache) -> Vec<Option<(BuiltStructure, f64)>> {
        let geometries = &self.geometries;
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
                let s = cache
                    .structure(&model.problem, geo.opt.solver.solver())
                    .map_err(|e| format!("{e:#}"));
                Some((g, s, start.elapsed().as_secs_f64()))
            })
            .collect();
        for (g, s, t) in made {
            structures[g] = Some((s, t));
        }
        structures
    }

    /// Each unit's materials and gratings.
    fn prepare(&self, design: &Design) -> Vec<Result<Prepared>> {
        self.units
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
            .collect()
    }

    /// Units equal in geometry and materials share one factorisation and solve: the
    /// distinct (geometry, materials) tasks, and each unit's task (none for a unit that
    /// failed or whose geometry has no structure).
    fn tasks<'a>(
        &self,
        prepared: &'a [Result<Prepared>],
        structures: &[Option<(BuiltStructure, f64)>],
    ) -> Tasks<'a> {
        let mut tasks: Vec<(usize, &[ElasticConstants])> = Vec::new();
        let task_of = self
            .units
            .iter()
            .zip(prepared)
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
        (tasks, task_of)
    }

    /// Factorise and solve every task (in parallel), with the time each took.
    fn solve_tasks(
        &self,
        tasks: &[(usize, &[ElasticConstants])],
        structures: &[Option<(BuiltStructure, f64)>],
    ) -> Vec<Result<(solve::Solution, f64), String>> {
        tasks
            .par_iter()
            .map(|&(g, materials)| {
                let start = Instant::now();
                let (s, _) = structures[g].as_ref().expect("a task has a structure");
                let s = s.as_ref().map_err(Clone::clone)?;
                let model = self.geometries[g].model.as_ref().map_err(Clone::clone)?;
                let sol = s
                    .factor(materials)
                    .and_then(|f| f.solve_loads(&model.problem.loads))
                    .map_err(|e| format!("{e:#}"))?;
                Ok((sol, start.elapsed().as_secs_f64()))
            })
            .collect()
    }

    /// Read every unit's gratings (contact units: their own solve, on `cache`).
    fn read(
        &self,
        design: &Design,
        solved: &Solved,
        cache: &GeometryCache,
    ) -> Vec<Result<ConfigurationResult>> {
        self.units
            .par_iter()
            .enumerate()
            .map(|(i, u)| {
                let prepared = solved.prepared[i].as_ref().map_err(|e| anyhow!("{e:#}"))?;
                let geo = &self.geometries[u.geometry];
                let model = geo.model.as_ref().map_err(|e| anyhow!("{e}"))?;
                if !model.contact_pairs.is_empty() {
                    return solve_contact_configuration(design, &u.config, &u.opt, cache);
                }
                let start = Instant::now();
                let task = solved.task_of[i].expect("a unit without contact pairs has a task");
                let (sol, solve_s) = solved.solutions[task]
                    .as_ref()
                    .map_err(|e| anyhow!("{e}"))?;
                let mut strain_per_n = Vec::new();
                for g in &prepared.gratings {
                    let e = model.mean_axial_strain(sol, g.z_start_mm, g.z_end_mm)?;
                    strain_per_n.push((g.name.clone(), g.bragg_wavelength_nm, e));
                }
                let structure_s = solved.structures[u.geometry]
                    .as_ref()
                    .map_or(0.0, |(_, t)| *t);
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
            .collect()
    }

    /// Each request's result from its units' (a Richardson pair extrapolated).
    fn combine(
        self,
        unit_results: Vec<Result<ConfigurationResult>>,
    ) -> Vec<Result<ConfigurationResult>> {
        let mut unit_results: Vec<Option<Result<ConfigurationResult>>> =
            unit_results.into_iter().map(Some).collect();
        let mut take = |i: usize| unit_results[i].take().expect("each unit used once");
        self.plans
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
}

/// What the batch solved, as its units read it.
struct Solved {
    prepared: Vec<Result<Prepared>>,
    structures: Vec<Option<(BuiltStructure, f64)>>,
    task_of: Vec<Option<usize>>,
    solutions: Vec<Result<(solve::Solution, f64), String>>,
}

/// Solve many configurations of one design, each with its own options, at F = 1 N:
/// the same results as [`super::solve_configuration`] on each, in order, for much less
/// work.
///
/// The configurations of one load case with one set of options share one mesh, built
/// once; problems of one mesh share one [`solve::ProblemStructure`] (numbering,
/// pattern, element stiffness per unit modulus, symbolic factorisation), built once
/// through the caller's `cache` (so later calls on the same geometry with the same
/// cache, e.g. the next step of a sweep over a modulus, skip it); problems equal in
/// mesh and moduli share one numeric factorisation and solve. Distinct structures are
/// built in parallel, largest first, then every factorisation in parallel. A
/// configuration's `solve_time_s` is the work its own solve needs, counting shared
/// work in full (what it would cost alone with a warm cache, plus the structure).
/// Contact readings with unilateral pairs are solved one by one
/// ([`super::solve_response`]).
pub fn solve_configurations(
    design: &Design,
    requests: &[(Configuration, FemOptions)],
    cache: &GeometryCache,
) -> Vec<Result<ConfigurationResult>> {
    let mut batch = Batch::plan(requests);
    batch.mesh(design);
    let structures = batch.structures(cache);
    let prepared = batch.prepare(design);
    let (tasks, task_of) = batch.tasks(&prepared, &structures);
    let solutions = batch.solve_tasks(&tasks, &structures);
    let solved = Solved {
        prepared,
        structures,
        task_of,
        solutions,
    };
    let results = batch.read(design, &solved, cache);
    batch.combine(results)
}
