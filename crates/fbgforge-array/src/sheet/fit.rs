//! The sheet model against measurements: the paper's Tables 1 and 2, the fit of its two
//! free constants (the composite's modulus and the table interface), and the fit of the
//! modulus to a measured sensing matrix (`calibrate-array --fit-modulus`).
//!
//! Table 1 gives six gratings' sensitivities to a load at the array's centre; mirror
//! pairs (1/6, 2/5, 3/4) sit at the same distance yet differ by up to 1.8× (the paper
//! blames placement), so a symmetric model is compared with the geometric mean of each
//! pair after one common scale. Table 2's 0.371 pm/g (a grating loaded right above it)
//! is compared with the same constants, without a scale.

use super::{gratings_of, pm_per_strain, GratingOnFiber, SheetModel, NEWTONS_PER_GRAM};
use crate::kernel::{TABLE1, TABLE2_DIRECT_PM_PER_G};
use crate::profile::ArrayLayout;
use crate::spec::{BaseCondition, Design};
use crate::SensingMatrix;
use anyhow::{anyhow, ensure, Result};
use serde::Serialize;

/// One grating of Table 1: measured against the model.
#[derive(Debug, Clone, Serialize)]
pub struct Table1Row {
    /// Grating name.
    pub grating: String,
    /// Distance from the load (the array's centre), mm.
    pub distance_mm: f64,
    /// Table 1, pm/g.
    pub measured_pm_per_g: f64,
    /// The model, pm/g.
    pub model_pm_per_g: f64,
    /// (model − measured)/measured, %.
    pub error_pct: f64,
}

/// One mirror pair of Table 1: geometric means, and the model after the common scale.
#[derive(Debug, Clone, Serialize)]
pub struct MirrorPair {
    /// Distance from the load, mm.
    pub distance_mm: f64,
    /// Geometric mean of the pair in Table 1, pm/g.
    pub measured_pm_per_g: f64,
    /// Geometric mean of the pair by the model, pm/g.
    pub model_pm_per_g: f64,
    /// The model times the common scale, pm/g.
    pub scaled_model_pm_per_g: f64,
    /// (scaled model − measured)/measured, %.
    pub shape_error_pct: f64,
}

/// The model against the paper's Tables 1 and 2.
#[derive(Debug, Clone, Serialize)]
pub struct PaperComparison {
    /// What was compared: the model's constants.
    pub model: SheetModel,
    /// Each raw grating of Table 1.
    pub table1: Vec<Table1Row>,
    /// Root mean square of ln(model/measured) over Table 1's six gratings.
    pub table1_rms_log: f64,
    /// The mirror-averaged shape.
    pub pairs: Vec<MirrorPair>,
    /// The common scale that best matches the pairs in log space (measured/model).
    pub common_scale: f64,
    /// Largest |shape error| of a pair, %.
    pub worst_shape_error_pct: f64,
    /// Table 2: a grating loaded right above it, pm/g.
    pub table2_measured_pm_per_g: f64,
    /// The model's direct sensitivity of each grating (the indenter centred on it), pm/g.
    pub table2_model_pm_per_g: Vec<f64>,
    /// Their mean, pm/g.
    pub table2_model_mean_pm_per_g: f64,
    /// (mean − measured)/measured, %.
    pub table2_error_pct: f64,
    /// What the grating would read under the direct load if the fiber simply followed
    /// the silicone (mean over the gratings), pm/g.
    pub table2_silicone_pm_per_g: f64,
}

/// The sensitivity (pm/g) of each grating to the indenter at each load point.
fn sensitivities(
    model: &SheetModel,
    gratings: &[GratingOnFiber],
    scale: &[f64],
    loads: &[(f64, f64)],
) -> Result<nalgebra::DMatrix<f64>> {
    let sol = model.solve()?;
    let mut m = sol.strain_per_n(gratings, loads);
    for (i, s) in scale.iter().enumerate() {
        m.row_mut(i).scale_mut(s * NEWTONS_PER_GRAM);
    }
    Ok(m)
}

/// Check that `design` is the paper's layout: six gratings whose distances to the
/// array centre are Table 1's (within 0.05 mm).
fn check_paper_layout(design: &Design) -> Result<Vec<(f64, f64)>> {
    let a = design
        .array
        .as_ref()
        .ok_or_else(|| anyhow!("design `{}` has no [array] section", design.name))?;
    let pos = ArrayLayout::from_array(a).grating_positions_mm;
    ensure!(
        pos.len() == TABLE1.len()
            && pos
                .iter()
                .zip(TABLE1.iter())
                .all(|(&(x, y), &(_, d))| (x.hypot(y) - d).abs() < 0.05),
        "design `{}` is not the paper's layout (six gratings at Table 1's distances from the centre)",
        design.name
    );
    Ok(pos)
}

/// Table 1's six values under `model` (pm/g, in grating order).
pub fn table1_model(model: &SheetModel, design: &Design) -> Result<Vec<f64>> {
    check_paper_layout(design)?;
    let g = gratings_of(design)?;
    let s = pm_per_strain(design)?;
    Ok(sensitivities(model, &g, &s, &[(0.0, 0.0)])?
        .column(0)
        .iter()
        .copied()
        .collect())
}

fn rms_log(model: &[f64], measured: &[f64]) -> f64 {
    let n = model.len().max(1) as f64;
    let ss: f64 = model
        .iter()
        .zip(measured)
        .map(|(m, t)| {
            if *m > 0.0 {
                (m / t).ln().powi(2)
            } else {
                // A non-positive prediction of a positive reading: as bad as a factor 100.
                (100f64).ln().powi(2)
            }
        })
        .sum();
    (ss / n).sqrt()
}

/// Compare `model` (of the paper's layout `design`) with Tables 1 and 2.
pub fn compare_with_paper(model: &SheetModel, design: &Design) -> Result<PaperComparison> {
    let pos = check_paper_layout(design)?;
    let a = design.array.as_ref().expect("checked");
    let g = gratings_of(design)?;
    let s = pm_per_strain(design)?;
    // Column 0: the centre load; then the indenter centred on each grating.
    let mut loads = vec![(0.0, 0.0)];
    loads.extend(pos.iter().copied());
    let sol = model.solve()?;
    let mut m = sol.strain_per_n(&g, &loads);
    for (i, sc) in s.iter().enumerate() {
        m.row_mut(i).scale_mut(sc * NEWTONS_PER_GRAM);
    }
    let measured: Vec<f64> = TABLE1.iter().map(|t| t.0).collect();
    let model_t1: Vec<f64> = m.column(0).iter().copied().collect();
    let table1 = a
        .gratings
        .iter()
        .zip(TABLE1.iter().zip(&model_t1))
        .map(|(gr, (&(meas, d), &mo))| Table1Row {
            grating: gr.name.clone(),
            distance_mm: d,
            measured_pm_per_g: meas,
            model_pm_per_g: mo,
            error_pct: 100.0 * (mo - meas) / meas,
        })
        .collect();
    // Pairs (1, 6), (2, 5), (3, 4) in Table 1's order.
    let pair_idx = [(0usize, 5usize), (1, 4), (2, 3)];
    let geo = |v: &[f64], (i, j): (usize, usize)| (v[i].max(1e-300) * v[j].max(1e-300)).sqrt();
    let meas_pairs: Vec<f64> = pair_idx.iter().map(|&p| geo(&measured, p)).collect();
    let model_pairs: Vec<f64> = pair_idx.iter().map(|&p| geo(&model_t1, p)).collect();
    let log_scale = meas_pairs
        .iter()
        .zip(&model_pairs)
        .map(|(t, m)| (t / m).ln())
        .sum::<f64>()
        / 3.0;
    let scale = log_scale.exp();
    let pairs: Vec<MirrorPair> = pair_idx
        .iter()
        .enumerate()
        .map(|(k, &(i, _))| {
            let scaled = model_pairs[k] * scale;
            MirrorPair {
                distance_mm: TABLE1[i].1,
                measured_pm_per_g: meas_pairs[k],
                model_pm_per_g: model_pairs[k],
                scaled_model_pm_per_g: scaled,
                shape_error_pct: 100.0 * (scaled - meas_pairs[k]) / meas_pairs[k],
            }
        })
        .collect();
    let worst = pairs
        .iter()
        .map(|p| p.shape_error_pct.abs())
        .fold(0.0, f64::max);
    let direct: Vec<f64> = (0..g.len()).map(|i| m[(i, i + 1)]).collect();
    let mean = direct.iter().sum::<f64>() / direct.len() as f64;
    let silicone = g
        .iter()
        .zip(&pos)
        .zip(&s)
        .map(|((gr, &(x, y)), sc)| sol.silicone_strain_per_n(gr, x, y) * sc * NEWTONS_PER_GRAM)
        .sum::<f64>()
        / g.len() as f64;
    Ok(PaperComparison {
        model: model.clone(),
        table1,
        table1_rms_log: rms_log(&model_t1, &measured),
        pairs,
        common_scale: scale,
        worst_shape_error_pct: worst,
        table2_measured_pm_per_g: TABLE2_DIRECT_PM_PER_G,
        table2_model_pm_per_g: direct,
        table2_model_mean_pm_per_g: mean,
        table2_error_pct: 100.0 * (mean - TABLE2_DIRECT_PM_PER_G) / TABLE2_DIRECT_PM_PER_G,
        table2_silicone_pm_per_g: silicone,
    })
}

/// The two fitted constants and how well they fit.
#[derive(Debug, Clone, Serialize)]
pub struct ConstantsFit {
    /// Fitted Young's modulus of the composite, MPa.
    pub youngs_modulus_mpa: f64,
    /// Fitted tangential stiffness of the table interface, N/mm³.
    pub tangential_stiffness_n_per_mm3: f64,
    /// RMS of ln(model/measured) over Table 1 at the fit.
    pub table1_rms_log: f64,
    /// Model solves spent.
    pub evaluations: usize,
}

/// Golden-section minimum of `f` on [lo, hi] (`iters` steps); returns (x, f(x)).
fn golden(mut lo: f64, mut hi: f64, iters: usize, f: &mut dyn FnMut(f64) -> f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = hi - g * (hi - lo);
    let mut x2 = lo + g * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..iters {
        if f1 < f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        }
    }
    if f1 < f2 {
        (x1, f1)
    } else {
        (x2, f2)
    }
}

/// Fit the modulus and the table interface of `design`'s sheet (the paper's layout) to
/// Table 1's six gratings in log space: a scan of ln k_t, each with the best ln E by
/// golden section, then golden section on ln k_t around the best scan point.
pub fn fit_table1(design: &Design) -> Result<ConstantsFit> {
    check_paper_layout(design)?;
    let base_model = SheetModel::from_design(design)?;
    let g = gratings_of(design)?;
    let s = pm_per_strain(design)?;
    let measured: Vec<f64> = TABLE1.iter().map(|t| t.0).collect();
    let mut evals = 0usize;
    let mut misfit = |ln_e: f64, ln_kt: f64| -> f64 {
        evals += 1;
        let mut m = base_model.clone();
        m.youngs_modulus_mpa = ln_e.exp();
        m.base = BaseCondition::Gripping {
            tangential_stiffness_n_per_mm3: ln_kt.exp(),
        };
        match sensitivities(&m, &g, &s, &[(0.0, 0.0)]) {
            Ok(v) => rms_log(v.as_slice(), &measured),
            Err(_) => f64::INFINITY,
        }
    };
    // The best ln E for one ln k_t, by golden section over 0.05–20 MPa.
    fn best_e_for(ln_kt: f64, misfit: &mut dyn FnMut(f64, f64) -> f64) -> (f64, f64) {
        golden(0.05f64.ln(), 20f64.ln(), 14, &mut |ln_e| {
            misfit(ln_e, ln_kt)
        })
    }
    let mut scan = Vec::new();
    let n = 9;
    for i in 0..n {
        let ln_kt = (1e-3f64).ln() + (1.0f64.ln() - 1e-3f64.ln()) * i as f64 / (n - 1) as f64;
        let (ln_e, v) = best_e_for(ln_kt, &mut misfit);
        scan.push((ln_kt, ln_e, v));
    }
    let i_best = scan
        .iter()
        .enumerate()
        .min_by(|a, b| a.1 .2.total_cmp(&b.1 .2))
        .map(|(i, _)| i)
        .unwrap_or(0);
    let step = (1.0f64.ln() - 1e-3f64.ln()) / (n - 1) as f64;
    let lo = scan[i_best].0 - step;
    let hi = scan[i_best].0 + step;
    let mut best = (scan[i_best].0, scan[i_best].1, scan[i_best].2);
    let (ln_kt, _) = golden(lo, hi, 12, &mut |ln_kt| {
        let (ln_e, v) = best_e_for(ln_kt, &mut misfit);
        if v < best.2 {
            best = (ln_kt, ln_e, v);
        }
        v
    });
    let _ = ln_kt;
    Ok(ConstantsFit {
        youngs_modulus_mpa: best.1.exp(),
        tangential_stiffness_n_per_mm3: best.0.exp(),
        table1_rms_log: best.2,
        evaluations: evals,
    })
}

/// One point of the modulus profile: the best table interface for a given modulus.
#[derive(Debug, Clone, Serialize)]
pub struct ProfilePoint {
    /// The modulus held fixed, MPa.
    pub youngs_modulus_mpa: f64,
    /// The interface stiffness that fits Table 1 best with it, N/mm³.
    pub tangential_stiffness_n_per_mm3: f64,
    /// k_t/μ, 1/mm: what sets the fall-off with distance.
    pub stiffness_over_shear_modulus_per_mm: f64,
    /// RMS of ln(model/measured) over Table 1.
    pub table1_rms_log: f64,
}

/// For each modulus in `moduli_mpa`, the interface stiffness that fits Table 1 best
/// (golden section on ln k_t over 10⁻⁴–1 N/mm³): how well Table 1 pins the modulus
/// down once the interface is free.
pub fn modulus_profile(design: &Design, moduli_mpa: &[f64]) -> Result<Vec<ProfilePoint>> {
    check_paper_layout(design)?;
    let base_model = SheetModel::from_design(design)?;
    let g = gratings_of(design)?;
    let s = pm_per_strain(design)?;
    let measured: Vec<f64> = TABLE1.iter().map(|t| t.0).collect();
    moduli_mpa
        .iter()
        .map(|&e| {
            let mut m = base_model.clone();
            m.youngs_modulus_mpa = e;
            let mut misfit = |ln_kt: f64| {
                let mut mm = m.clone();
                mm.base = BaseCondition::Gripping {
                    tangential_stiffness_n_per_mm3: ln_kt.exp(),
                };
                sensitivities(&mm, &g, &s, &[(0.0, 0.0)])
                    .map(|v| rms_log(v.as_slice(), &measured))
                    .unwrap_or(f64::INFINITY)
            };
            let (ln_kt, rms) = golden(1e-4f64.ln(), 1f64.ln(), 16, &mut misfit);
            let kt = ln_kt.exp();
            Ok(ProfilePoint {
                youngs_modulus_mpa: e,
                tangential_stiffness_n_per_mm3: kt,
                stiffness_over_shear_modulus_per_mm: kt / m.layer().shear_modulus_mpa,
                table1_rms_log: rms,
            })
        })
        .collect()
}

/// One entry of a measured matrix against the model with the fitted modulus.
#[derive(Debug, Clone, Serialize)]
pub struct EntryMisfit {
    /// Grating (row).
    pub grating: String,
    /// Cell (column).
    pub cell: String,
    /// Measured, pm/g.
    pub measured_pm_per_g: f64,
    /// Model at the fitted modulus, pm/g.
    pub model_pm_per_g: f64,
    /// (model − measured)/|measured|, % (absent when the measured entry is 0).
    pub misfit_pct: Option<f64>,
}

/// The modulus fitted to a measured matrix.
#[derive(Debug, Clone, Serialize)]
pub struct ModulusFit {
    /// The modulus the design states, MPa.
    pub design_modulus_mpa: f64,
    /// The fitted modulus, MPa.
    pub fitted_modulus_mpa: f64,
    /// The fit stopped at the end of the search range (0.05–50 MPa): the matrix's
    /// level cannot be reached by the modulus alone.
    pub at_search_limit: bool,
    /// Relative rms misfit ‖model − measured‖/‖measured‖ at the design's modulus.
    pub design_rel_rms: f64,
    /// The same at the fitted modulus.
    pub fitted_rel_rms: f64,
    /// The same at half and twice the fitted modulus (how well the data pin it down).
    pub rel_rms_at_half_and_double: (f64, f64),
    /// Every entry.
    pub entries: Vec<EntryMisfit>,
}

/// Fit the composite's modulus of `design`'s sheet model to `measured` (pm/g, rows and
/// columns named as the design's gratings and cells, any order): least absolute
/// deviations over the entries, Σ|model − measured| (dominated by the large,
/// well-measured entries, and not dragged by one bad entry as least squares is), by
/// golden section on ln E over 0.05–50 MPa.
pub fn fit_modulus(design: &Design, measured: &SensingMatrix) -> Result<ModulusFit> {
    let base_model = SheetModel::from_design(design)?;
    let a = design.array.as_ref().expect("checked by from_design");
    let g = gratings_of(design)?;
    let s = pm_per_strain(design)?;
    let cells = ArrayLayout::from_array(a).cell_centers_mm;
    let labels = super::cell_labels(design);
    // Map the measured matrix onto the design's order.
    let rows: Vec<usize> = a
        .gratings
        .iter()
        .map(|gr| {
            measured
                .gratings
                .iter()
                .position(|n| n == &gr.name)
                .ok_or_else(|| anyhow!("the measured matrix has no row for grating `{}`", gr.name))
        })
        .collect::<Result<_>>()?;
    let cols: Vec<usize> = labels
        .iter()
        .map(|c| {
            measured
                .cells
                .iter()
                .position(|n| n == c)
                .ok_or_else(|| anyhow!("the measured matrix has no column for cell `{c}`"))
        })
        .collect::<Result<_>>()?;
    let meas = nalgebra::DMatrix::from_fn(g.len(), cells.len(), |i, j| {
        measured.sensitivity_pm_per_g[(rows[i], cols[j])]
    });
    let norm = meas.norm();
    ensure!(
        norm > 0.0 && norm.is_finite(),
        "the measured matrix is all zero or not finite"
    );
    let at = |e: f64| -> Result<nalgebra::DMatrix<f64>> {
        let mut m = base_model.clone();
        m.youngs_modulus_mpa = e;
        sensitivities(&m, &g, &s, &cells)
    };
    let rel = |m: &nalgebra::DMatrix<f64>| (m - &meas).norm() / norm;
    let l1 = |m: &nalgebra::DMatrix<f64>| (m - &meas).abs().sum();
    let (lo, hi) = (0.05f64.ln(), 50f64.ln());
    let (ln_e, _) = golden(lo, hi, 24, &mut |x| {
        at(x.exp()).map(|m| l1(&m)).unwrap_or(f64::INFINITY)
    });
    let e = ln_e.exp();
    let fitted = at(e)?;
    let entries = (0..g.len())
        .flat_map(|i| (0..cells.len()).map(move |j| (i, j)))
        .map(|(i, j)| EntryMisfit {
            grating: a.gratings[i].name.clone(),
            cell: labels[j].clone(),
            measured_pm_per_g: meas[(i, j)],
            model_pm_per_g: fitted[(i, j)],
            misfit_pct: (meas[(i, j)] != 0.0)
                .then(|| 100.0 * (fitted[(i, j)] - meas[(i, j)]) / meas[(i, j)].abs()),
        })
        .collect();
    Ok(ModulusFit {
        design_modulus_mpa: base_model.youngs_modulus_mpa,
        fitted_modulus_mpa: e,
        at_search_limit: (ln_e - lo).abs() < 0.05 || (hi - ln_e).abs() < 0.05,
        design_rel_rms: rel(&at(base_model.youngs_modulus_mpa)?),
        fitted_rel_rms: rel(&fitted),
        rel_rms_at_half_and_double: (rel(&at(e / 2.0)?), rel(&at(e * 2.0)?)),
        entries,
    })
}
