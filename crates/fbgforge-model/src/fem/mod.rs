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

mod batch;
pub mod cache;
pub mod contact;
pub mod element;
pub mod linear;
pub mod mesh;
pub mod module;
pub mod solve;

pub use module::{
    AxialStrainProfile, ContactReading, DomeContact, FemOptions, InsertContact, PillarCoupling,
    SolverKind,
};

use crate::model::GratingPrediction;
pub use crate::model::{configurations, Configuration};
use crate::profile::{module_gratings, GratingPlacement, ModuleProfile};
use crate::spec::{Design, GratingRole};
use anyhow::{anyhow, bail, Result};
pub use batch::solve_configurations;
pub use cache::GeometryCache;
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
    /// Per grating (in `strain_per_n`'s order): the step the Richardson extrapolation
    /// took from the fine mesh's strain, ε_R − ε_h, per newton: the mesh-convergence
    /// estimate the policy states as the discretisation error; `None` without
    /// extrapolation.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extrapolation_per_n: Option<Vec<f64>>,
    /// Per grating (in `strain_per_n`'s order): the axial strain per newton sampled
    /// along it, from the same solve (its weighted mean is the grating's strain per
    /// newton; under Richardson extrapolation the fine mesh's profile shifted by the
    /// step). Empty for contact readings with unilateral pairs, which read means only.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub strain_profile_per_n: Vec<AxialStrainProfile>,
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
/// structure of its problem comes from, and goes to, the caller's `cache`).
pub fn solve_configuration(
    design: &Design,
    config: &Configuration,
    opt: &FemOptions,
    cache: &GeometryCache,
) -> Result<ConfigurationResult> {
    solve_configurations(design, &[(config.clone(), *opt)], cache)
        .pop()
        .expect("one result per request")
}

/// A configuration with unilateral contact pairs: the secant K at 1 N.
fn solve_contact_configuration(
    design: &Design,
    config: &Configuration,
    opt: &FemOptions,
    cache: &GeometryCache,
) -> Result<ConfigurationResult> {
    let start = Instant::now();
    let r = solve_response(design, config, opt, &[1.0], cache)?;
    Ok(ConfigurationResult {
        configuration: config.clone(),
        strain_per_n: r
            .gratings
            .iter()
            .map(|g| (g.name.clone(), g.bragg_wavelength_nm, g.strain[0]))
            .collect(),
        extrapolation_per_n: None,
        strain_profile_per_n: Vec::new(),
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
/// stiffness is factorised once (on the structure `cache` holds or builds) and the
/// contact problem, when the options ask for one, is condensed on its pairs and
/// solved exactly at every force (`contact`).
pub fn solve_response(
    design: &Design,
    config: &Configuration,
    opt: &FemOptions,
    forces_n: &[f64],
    cache: &GeometryCache,
) -> Result<ConfigurationResponse> {
    if forces_n.iter().any(|f| !f.is_finite()) {
        bail!("forces must be finite numbers of newtons");
    }
    if let Some((plain, coarsened, factor)) = richardson_levels(opt)? {
        let fine = solve_response(design, config, &plain, forces_n, cache)?;
        let coarse = solve_response(design, config, &coarsened, forces_n, cache)?;
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
    let factored = cache.factor(&model.problem, opt.solver.solver())?;
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
pub(crate) const LINEAR_STRAIN_LIMIT: f64 = 0.01;

/// Finite-element prediction of every strain grating, for Case II and for Case I with
/// each insert, at `force_n` (same output type and order as [`crate::model::predict`]);
/// the solves' structures come from, and go to, `cache`.
pub fn predict(
    design: &Design,
    force_n: f64,
    opt: &FemOptions,
    cache: &GeometryCache,
) -> Result<Vec<GratingPrediction>> {
    if !force_n.is_finite() {
        bail!("force must be a finite number of newtons, got {force_n}");
    }
    let mut out = Vec::new();
    for config in configurations(design)? {
        let res = solve_configuration(design, &config, opt, cache)?;
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
