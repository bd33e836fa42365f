//! Many configurations of one design solved as one batch ([`solve_configurations`]):
//! requests become units (the levels of a Richardson pair, or the only one), units of
//! one load case and one set of options share a mesh (a geometry), the geometries'
//! structures come from the caller's [`GeometryCache`], and units equal in geometry and
//! moduli share one numeric factorisation and solve (a task).
//!
//! Units whose options differ only in the domes' contact radius (the design's reading,
//! the contact window's ends, the apex patch) mesh alike (`FemOptions::dome_station_radii_mm`)
//! and share the geometry of the smallest radius: a wider contact zone is that
//! geometry with more facing dome nodes tied, and those ties are condensed on the one
//! factorisation (Lagrange multipliers on the pairs' unit loads, a dense system the
//! size of the extra ties), not refactorised.

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
use nalgebra::{DMatrix, DVector};
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
    /// The unit's contact radius when it is wider than its geometry's: the facing dome
    /// pairs out to it are tied by condensation, mm.
    wider_contact_mm: Option<f64>,
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

/// One factorisation of a batch: geometry, materials, and the widest contact radius
/// its units condense (mm; `None`: every unit is the geometry's own).
type Task<'a> = (usize, &'a [ElasticConstants], Option<f64>);

/// The distinct tasks of a batch, and each unit's task.
type Tasks<'a> = (Vec<Task<'a>>, Vec<Option<usize>>);

/// A task solved: the geometry's own solution, and its dome ties condensed.
struct TaskSolution {
    base: solve::Solution,
    ties: Option<CondensedTies>,
}

/// Ties of facing dome nodes beyond a geometry's own, condensed on its factorisation:
/// each tie row (a pair's radial or axial relative displacement) with its pair's
/// radius, the solution of a unit force pair on it (in the solver's numbering: a
/// column of `unit`, unknowns × rows), the flexibility W (row i's value under unit
/// force j), the rows' values in the geometry's own solution, and that solution in
/// the solver's numbering. Only the solution a unit reads is turned into nodal
/// displacements, once, after the columns are combined.
struct CondensedTies {
    radius_mm: Vec<f64>,
    unit: Vec<f64>,
    flexibility: DMatrix<f64>,
    free: Vec<f64>,
    base: Vec<f64>,
    structure: Arc<solve::ProblemStructure>,
    factor_nonzeros: usize,
}

/// A tie row's value in the solution `u` (solver's numbering) of `f`: the core node's
/// component less the cap node's.
fn tie_value(f: &solve::FactoredProblem, u: &[f64], row: &[(usize, usize); 2]) -> f64 {
    let [(cap, c), (core, _)] = *row;
    f.component_value(u, core, c) - f.component_value(u, cap, c)
}

/// Solve the geometry's own load on `f` and condense the ties of every untied facing
/// dome pair out to `radius_mm`: the geometry's own solution and the condensed ties.
fn condense_dome_ties(
    f: &solve::FactoredProblem,
    loads: &[(usize, usize, f64)],
    pairs: &[module::DomePair],
    radius_mm: f64,
) -> Result<(solve::Solution, CondensedTies)> {
    let mut rows = Vec::new();
    let mut radius = Vec::new();
    for p in pairs
        .iter()
        .filter(|p| !p.tied && p.radius_mm <= radius_mm * (1.0 + 1e-9))
    {
        for c in [solve::R, solve::Z] {
            rows.push([(p.cap, c), (p.core, c)]);
            radius.push(p.radius_mm);
        }
    }
    // The geometry's own load first, then a unit force pair on each tie row: +1 on
    // the core's component, −1 on the cap's; one blocked solve.
    let cases: Vec<Vec<(usize, usize, f64)>> = std::iter::once(loads.to_vec())
        .chain(
            rows.iter()
                .map(|&[(a, c), (b, _)]| vec![(b, c, 1.0), (a, c, -1.0)]),
        )
        .collect();
    let mut unit = f.solve_load_columns(&cases)?;
    let n = f.unknowns();
    let base: Vec<f64> = unit.drain(..n).collect();
    let m = rows.len();
    let flexibility = DMatrix::from_fn(m, m, |i, j| {
        tie_value(f, &unit[j * n..(j + 1) * n], &rows[i])
    });
    let free = rows.iter().map(|r| tie_value(f, &base, r)).collect();
    Ok((
        f.solution_from(&base)?,
        CondensedTies {
            radius_mm: radius,
            unit,
            flexibility,
            free,
            base,
            structure: Arc::clone(f.structure()),
            factor_nonzeros: f.factor_nonzeros(),
        },
    ))
}

impl CondensedTies {
    /// The solution with every pair out to `radius_mm` tied: the forces λ on the rows
    /// that close them (W λ = −q on those rows), added to the geometry's own solution.
    fn tied_to(&self, radius_mm: f64) -> Result<solve::Solution> {
        let sel: Vec<usize> = (0..self.radius_mm.len())
            .filter(|&i| self.radius_mm[i] <= radius_mm * (1.0 + 1e-9))
            .collect();
        let w = DMatrix::from_fn(sel.len(), sel.len(), |i, j| {
            self.flexibility[(sel[i], sel[j])]
        });
        let q = DVector::from_iterator(sel.len(), sel.iter().map(|&i| -self.free[i]));
        let lambda = w
            .cholesky()
            .ok_or_else(|| anyhow!("the dome ties' flexibility is not positive definite"))?
            .solve(&q);
        let n = self.base.len();
        let mut u = self.base.clone();
        for (k, &i) in sel.iter().enumerate() {
            for (x, y) in u.iter_mut().zip(&self.unit[i * n..(i + 1) * n]) {
                *x += lambda[k] * y;
            }
        }
        self.structure.solution_from(&u, self.factor_nonzeros)
    }
}

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
        for (config, opt) in requests.iter() {
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

    /// Add a unit (its geometry is assigned by [`Batch::assign_geometries`]).
    fn add_unit(&mut self, config: &Configuration, opt: FemOptions) -> usize {
        self.units.push(Unit {
            config: config.clone(),
            opt,
            geometry: usize::MAX,
            wider_contact_mm: None,
        });
        self.units.len() - 1
    }

    /// Units of one load case and one set of options share a geometry; units whose
    /// options differ only in the domes' contact radius (apex-patch ties) share the
    /// geometry of the smallest radius, and the wider ones are marked.
    fn assign_geometries(&mut self, design: &Design) {
        let patch = design
            .module
            .as_ref()
            .map_or(f64::NAN, crate::spec::Module::apex_patch_radius_mm);
        let family = |o: &FemOptions| {
            if o.dome_contact == module::DomeContact::ApexPatch {
                FemOptions {
                    dome_contact_radius_mm: None,
                    ..*o
                }
            } else {
                *o
            }
        };
        let radius = |o: &FemOptions| o.dome_contact_radius_mm.unwrap_or(patch);
        let mut families: Vec<(crate::model::LoadCase, FemOptions, usize)> = Vec::new();
        for i in 0..self.units.len() {
            let (case, opt) = (self.units[i].config.case, self.units[i].opt);
            let key = family(&opt);
            match families.iter().position(|f| f.0 == case && f.1 == key) {
                Some(k) => {
                    if radius(&opt) < radius(&self.units[families[k].2].opt) {
                        families[k].2 = i;
                    }
                }
                None => families.push((case, key, i)),
            }
        }
        for (_, _, base) in &families {
            self.geometries.push(Geometry {
                opt: self.units[*base].opt,
                model: Err(String::new()),
                build_time_s: 0.0,
            });
        }
        for u in &mut self.units {
            let key = family(&u.opt);
            let g = families
                .iter()
                .position(|f| f.0 == u.config.case && f.1 == key)
                .expect("every unit has a family");
            let base = radius(&self.geometries[g].opt);
            u.geometry = g;
            let r = radius(&u.opt);
            u.wider_contact_mm = (u.opt.dome_contact == module::DomeContact::ApexPatch
                && r > base * (1.0 + 1e-12))
                .then_some(r);
        }
    }

    /// One mesh per geometry, built for its first unit (in parallel).
    fn mesh(&mut self, design: &Design) {
        let firsts: Vec<usize> = (0..self.geometries.len())
            .map(|g| {
                self.units
                    .iter()
                    .position(|u| u.geometry == g && u.wider_contact_mm.is_none())
                    .expect("every geometry is some unit's own")
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
    /// distinct (geometry, materials) tasks with the widest contact radius their units
    /// condense, and each unit's task (none for a unit that failed or whose geometry
    /// has no structure).
    fn tasks<'a>(
        &self,
        prepared: &'a [Result<Prepared>],
        structures: &[Option<(BuiltStructure, f64)>],
    ) -> Tasks<'a> {
        let mut tasks: Vec<Task<'a>> = Vec::new();
        let task_of = self
            .units
            .iter()
            .zip(prepared)
            .map(|(u, p)| {
                let p = p.as_ref().ok()?;
                structures[u.geometry].as_ref()?;
                let key = (u.geometry, p.materials.as_slice());
                let i = match tasks.iter().position(|t| (t.0, t.1) == key) {
                    Some(i) => i,
                    None => {
                        tasks.push((key.0, key.1, None));
                        tasks.len() - 1
                    }
                };
                if let Some(r) = u.wider_contact_mm {
                    tasks[i].2 = Some(tasks[i].2.map_or(r, |w: f64| w.max(r)));
                }
                Some(i)
            })
            .collect();
        (tasks, task_of)
    }

    /// Factorise and solve every task (in parallel), with the ties of its widest
    /// contact condensed, and the time each took.
    fn solve_tasks(
        &self,
        tasks: &[Task<'_>],
        structures: &[Option<(BuiltStructure, f64)>],
    ) -> Vec<Result<(TaskSolution, f64), String>> {
        tasks
            .par_iter()
            .map(|&(g, materials, widest)| {
                let start = Instant::now();
                let (s, _) = structures[g].as_ref().expect("a task has a structure");
                let s = s.as_ref().map_err(Clone::clone)?;
                let model = self.geometries[g].model.as_ref().map_err(Clone::clone)?;
                let solved = s.factor(materials).and_then(|f| {
                    let loads = &model.problem.loads;
                    Ok(match widest {
                        Some(r) => {
                            let (base, ties) = condense_dome_ties(&f, loads, &model.dome_pairs, r)?;
                            TaskSolution {
                                base,
                                ties: Some(ties),
                            }
                        }
                        None => TaskSolution {
                            base: f.solve_loads(loads)?,
                            ties: None,
                        },
                    })
                });
                let sol = solved.map_err(|e| format!("{e:#}"))?;
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
                let (task_sol, solve_s) = solved.solutions[task]
                    .as_ref()
                    .map_err(|e| anyhow!("{e}"))?;
                let wider;
                let sol = match (u.wider_contact_mm, &task_sol.ties) {
                    (Some(r), Some(t)) => {
                        wider = t.tied_to(r)?;
                        &wider
                    }
                    _ => &task_sol.base,
                };
                let mut strain_per_n = Vec::new();
                let mut strain_profile_per_n = Vec::new();
                for g in &prepared.gratings {
                    // The mean is the profile's own quadrature: one read-out for both.
                    let profile = model.axial_strain_profile(sol, g.z_start_mm, g.z_end_mm)?;
                    strain_per_n.push((g.name.clone(), g.bragg_wavelength_nm, profile.mean()));
                    strain_profile_per_n.push(profile);
                }
                let structure_s = solved.structures[u.geometry]
                    .as_ref()
                    .map_or(0.0, |(_, t)| *t);
                Ok(ConfigurationResult {
                    configuration: u.config.clone(),
                    strain_per_n,
                    extrapolation_per_n: None,
                    strain_profile_per_n,
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
                    let step: Vec<f64> = fine
                        .strain_per_n
                        .iter()
                        .zip(&coarse.strain_per_n)
                        .map(|((_, _, ef), (_, _, ec))| (ef - ec) * factor)
                        .collect();
                    let strain_per_n = fine
                        .strain_per_n
                        .iter()
                        .zip(&step)
                        .map(|((name, lambda, ef), d)| (name.clone(), *lambda, ef + d))
                        .collect();
                    let strain_profile_per_n = fine
                        .strain_profile_per_n
                        .iter()
                        .zip(&step)
                        .map(|(p, d)| p.shifted(*d))
                        .collect();
                    Ok(ConfigurationResult {
                        strain_per_n,
                        extrapolation_per_n: Some(step),
                        strain_profile_per_n,
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
    solutions: Vec<Result<(TaskSolution, f64), String>>,
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
    batch.assign_geometries(design);
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
