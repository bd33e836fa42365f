//! The sheet model against measurements: the paper's Tables 1 and 2, the fit of its two
//! free constants (the composite's modulus and the table interface), and the fit of a
//! cast sheet's unknowns to its measured sensing matrix (`calibrate-array --fit-sheet`).
//!
//! Table 1 gives six gratings' sensitivities to a load at the array's centre; mirror
//! pairs (1/6, 2/5, 3/4) sit at the same distance yet differ by up to 1.8× (the paper
//! blames placement), so a symmetric model is compared with the geometric mean of each
//! pair after one common scale. Table 2's 0.371 pm/g (a grating loaded right above it)
//! is compared with the same constants, without a scale.
//!
//! A lab's own sheet: [`SheetGrid`] and [`fit_sheet`] fit its modulus, thickness and
//! table interface to a measured matrix and say which of them the data pin down.

use super::{gratings_of, pm_per_strain, GratingOnFiber, SheetModel, NEWTONS_PER_GRAM};
use crate::kernel::{TABLE1, TABLE2_DIRECT_PM_PER_G};
use crate::profile::ArrayLayout;
use crate::spec::{BaseCondition, Design};
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

/// The sheet model's error on the paper's own sheet: rms of ln(model/measured) over
/// Table 1 with the shipped constants (0.25, §12.3; test
/// `sheet_paper::the_model_error_the_sheet_fit_allows_is_its_error_on_the_papers_sheet`).
/// Parameter values whose prediction misses a measured matrix by no more are as good
/// as the model can tell apart.
pub const MODEL_RMS_LOG: f64 = 0.25;

/// Table interfaces the fit tries, N/mm³ (0 = frictionless, ∞ = bonded).
const INTERFACES_N_PER_MM3: [f64; 8] = [0.0, 0.0025, 0.005, 0.01, 0.02, 0.04, 0.08, f64::INFINITY];

/// The interface as a base condition.
fn base_of(k: f64) -> BaseCondition {
    if k <= 0.0 {
        BaseCondition::Frictionless
    } else if k.is_infinite() {
        BaseCondition::Bonded
    } else {
        BaseCondition::Gripping {
            tangential_stiffness_n_per_mm3: k,
        }
    }
}

/// An interface in words.
fn interface_words(k: f64) -> String {
    if k <= 0.0 {
        "frictionless".into()
    } else if k.is_infinite() {
        "bonded".into()
    } else {
        format!("gripping {k} N/mm³")
    }
}

/// One measured entry the fit reads.
#[derive(Debug, Clone, Copy)]
pub struct FitEntry {
    /// Row (grating, in the design's order).
    pub grating: usize,
    /// Column (cell).
    pub cell: usize,
    /// Measured, pm/g.
    pub measured_pm_per_g: f64,
    /// Its standard deviation, pm/g.
    pub sd_pm_per_g: f64,
}

/// The model's matrix over a grid of the sheet's unknowns: modulus (¼ to 4 × the
/// design's, 9 values), thickness (0.6 to 1.5 × the design's, 9 values, the fibers at
/// the design's fraction of it) and table interface (frictionless, gripping 0.0025 to
/// 0.08 N/mm³, bonded), at the coarse resolution (0.2 % from the standard one). Built
/// once per design (648 solves, a few seconds on two cores); held by the caller.
pub struct SheetGrid {
    modulus_mpa: Vec<f64>,
    thickness_mm: Vec<f64>,
    interface: Vec<f64>,
    design_at: [usize; 3],
    matrices: Vec<nalgebra::DMatrix<f64>>,
}

/// Insert `v` into the sorted axis `axis` unless present; its index.
fn with_value(axis: &mut Vec<f64>, v: f64) -> usize {
    if let Some(i) = axis
        .iter()
        .position(|x| (x - v).abs() <= 1e-9 * v.abs().max(1e-12) || *x == v)
    {
        return i;
    }
    axis.push(v);
    axis.sort_by(f64::total_cmp);
    axis.iter().position(|x| *x == v).expect("inserted")
}

impl SheetGrid {
    /// Solve the model of `design` over the grid.
    pub fn new(design: &Design) -> Result<Self> {
        use rayon::prelude::*;
        let mut base = SheetModel::from_design(design)?;
        base.resolution = super::Resolution::coarse();
        let a = design.array.as_ref().expect("checked by from_design");
        let g = gratings_of(design)?;
        let s = pm_per_strain(design)?;
        let cells = ArrayLayout::from_array(a).cell_centers_mm;
        let depth_fraction = base.fiber_depth_mm / base.thickness_mm;
        let modulus_mpa: Vec<f64> = (-4..=4)
            .map(|k| base.youngs_modulus_mpa * 2f64.powf(f64::from(k) / 2.0))
            .collect();
        let thickness_mm: Vec<f64> = [0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.35, 1.5]
            .iter()
            .map(|f| f * base.thickness_mm)
            .collect();
        let mut interface = INTERFACES_N_PER_MM3.to_vec();
        let k_design = match base.base {
            BaseCondition::Frictionless => 0.0,
            BaseCondition::Bonded => f64::INFINITY,
            BaseCondition::Gripping {
                tangential_stiffness_n_per_mm3: k,
            } => k,
        };
        let ki = with_value(&mut interface, k_design);
        let (nj, nk) = (thickness_mm.len(), interface.len());
        let points: Vec<(usize, usize, usize)> = (0..modulus_mpa.len())
            .flat_map(|i| (0..nj).flat_map(move |j| (0..nk).map(move |k| (i, j, k))))
            .collect();
        let matrices = points
            .par_iter()
            .map(|&(i, j, k)| {
                let mut m = base.clone();
                m.youngs_modulus_mpa = modulus_mpa[i];
                m.thickness_mm = thickness_mm[j];
                m.fiber_depth_mm = depth_fraction * thickness_mm[j];
                m.base = base_of(interface[k]);
                sensitivities(&m, &g, &s, &cells)
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(SheetGrid {
            design_at: [4, 4, ki],
            modulus_mpa,
            thickness_mm,
            interface,
            matrices,
        })
    }

    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (i * self.thickness_mm.len() + j) * self.interface.len() + k
    }

    /// Model solves the grid took.
    pub fn solves(&self) -> usize {
        self.matrices.len()
    }

    /// The predicted matrix at the design's own values (coarse resolution).
    pub fn at_design(&self) -> &nalgebra::DMatrix<f64> {
        let [i, j, k] = self.design_at;
        &self.matrices[self.index(i, j, k)]
    }
}

/// One unknown of the sheet as the data fix it.
#[derive(Debug, Clone, Serialize)]
pub struct FitParameter {
    /// `youngs_modulus_mpa`, `thickness_mm` or `table_interface_n_per_mm3`.
    pub name: String,
    /// The design's value (∞ = bonded: null in JSON).
    pub design_value: f64,
    /// The best value, only when the data pin it down.
    pub value: Option<f64>,
    /// Every value that fits within the model's error, the others free (None when no
    /// value does).
    pub range: Option<[f64; 2]>,
    /// The same with the other two at the design's values.
    pub range_given_design: Option<[f64; 2]>,
    /// The searched range.
    pub searched: [f64; 2],
    /// The fitting values stop short of both ends of the searched range.
    pub identifiable: bool,
    /// The outcome in words.
    pub words: String,
}

/// The sheet's unknowns fitted to a measured matrix.
#[derive(Debug, Clone, Serialize)]
pub struct SheetFit {
    /// rms of ln(measured/model) a fit may have and still count ([`MODEL_RMS_LOG`]).
    pub model_rms_log: f64,
    /// rms log misfit at the design's own values.
    pub design_rms_log: f64,
    /// The smallest rms log misfit on the grid.
    pub best_rms_log: f64,
    /// The design's values fit within the model's error.
    pub design_consistent: bool,
    /// Entries read (the comparison's judged entries).
    pub entries_used: usize,
    /// Modulus, thickness, interface.
    pub parameters: Vec<FitParameter>,
    /// Model solves spent.
    pub solves: usize,
    /// The outcome in words.
    pub summary: String,
}

/// Fit `design`'s sheet to the measured entries (a fresh grid).
pub fn fit_sheet(design: &Design, entries: &[FitEntry]) -> Result<SheetFit> {
    Ok(SheetGrid::new(design)?.fit(entries))
}

/// rms of ln((measured + f)/(model + f)) over the entries, f = max(3 sd, 2 % of the
/// largest measured entry) so noise-level entries weigh little.
fn rms_log_misfit(m: &nalgebra::DMatrix<f64>, entries: &[FitEntry]) -> f64 {
    let top = entries
        .iter()
        .map(|e| e.measured_pm_per_g)
        .fold(0.0f64, f64::max);
    let ss: f64 = entries
        .iter()
        .map(|e| {
            let f = (3.0 * e.sd_pm_per_g).max(0.02 * top).max(1e-12);
            let p = m[(e.grating, e.cell)].max(0.0);
            ((e.measured_pm_per_g.max(0.0) + f) / (p + f)).ln().powi(2)
        })
        .sum();
    (ss / entries.len().max(1) as f64).sqrt()
}

impl SheetGrid {
    /// Fit the grid to `entries`: every grid point whose prediction misses them by no
    /// more than [`MODEL_RMS_LOG`] is consistent with the data; a parameter is
    /// identifiable when its consistent values stop short of both ends of its searched
    /// range. When no point fits that well, no parameter is read from the data.
    pub fn fit(&self, entries: &[FitEntry]) -> SheetFit {
        let misfit: Vec<f64> = self
            .matrices
            .iter()
            .map(|m| rms_log_misfit(m, entries))
            .collect();
        let [di, dj, dk] = self.design_at;
        let design = misfit[self.index(di, dj, dk)];
        let best_at = (0..misfit.len())
            .min_by(|a, b| misfit[*a].total_cmp(&misfit[*b]))
            .unwrap_or(0);
        let best = misfit[best_at];
        let fits = entries.len() >= 3 && best <= MODEL_RMS_LOG;
        let axes: [(&str, &[f64]); 3] = [
            ("youngs_modulus_mpa", &self.modulus_mpa),
            ("thickness_mm", &self.thickness_mm),
            ("table_interface_n_per_mm3", &self.interface),
        ];
        let coords = |idx: usize| -> [usize; 3] {
            let nk = self.interface.len();
            let nj = self.thickness_mm.len();
            [idx / (nj * nk), (idx / nk) % nj, idx % nk]
        };
        let parameters = axes
            .iter()
            .enumerate()
            .map(|(a, (name, values))| {
                let range_where = |keep: &dyn Fn([usize; 3]) -> bool| -> Option<[usize; 2]> {
                    let on: Vec<usize> = (0..misfit.len())
                        .filter(|&x| fits && misfit[x] <= MODEL_RMS_LOG && keep(coords(x)))
                        .map(|x| coords(x)[a])
                        .collect();
                    Some([*on.iter().min()?, *on.iter().max()?])
                };
                let joint = range_where(&|_| true);
                let given = range_where(&|c| (0..3).all(|b| b == a || c[b] == self.design_at[b]));
                parameter(
                    name,
                    values,
                    self.design_at[a],
                    coords(best_at)[a],
                    joint,
                    given,
                )
            })
            .collect::<Vec<_>>();
        let summary = if entries.len() < 3 {
            format!(
                "{} entries to fit: too few to read the sheet's unknowns",
                entries.len()
            )
        } else if !fits {
            format!("the sheet model misses this matrix by rms log {best:.2} at best over the grid, more than its {MODEL_RMS_LOG} error on the paper's sheet: no unknown can be read from it (the sheet, or the model, is not what the design says)")
        } else if design <= MODEL_RMS_LOG {
            format!("the design's values fit (rms log {design:.2} ≤ {MODEL_RMS_LOG})")
        } else {
            format!("the design's values do not fit (rms log {design:.2} > {MODEL_RMS_LOG}; best {best:.2}): the cast sheet differs from its description")
        };
        SheetFit {
            model_rms_log: MODEL_RMS_LOG,
            design_rms_log: design,
            best_rms_log: best,
            design_consistent: design <= MODEL_RMS_LOG,
            entries_used: entries.len(),
            parameters,
            solves: self.solves(),
            summary,
        }
    }
}

/// A value of a parameter in words.
fn value_words(name: &str, v: f64) -> String {
    match name {
        "table_interface_n_per_mm3" => interface_words(v),
        "youngs_modulus_mpa" => format!("{v:.3} MPa"),
        _ => format!("{v:.2} mm"),
    }
}

/// One parameter's outcome from the index ranges of its consistent values.
fn parameter(
    name: &str,
    values: &[f64],
    design: usize,
    best: usize,
    joint: Option<[usize; 2]>,
    given: Option<[usize; 2]>,
) -> FitParameter {
    let last = values.len() - 1;
    let identifiable = joint.is_some_and(|[lo, hi]| lo > 0 && hi < last);
    let span = |r: [usize; 2]| {
        format!(
            "{} to {}",
            value_words(name, values[r[0]]),
            value_words(name, values[r[1]])
        )
    };
    let words = match (joint, identifiable) {
        (None, _) => "not identifiable: no value fits within the model's error".to_string(),
        (Some(r), true) => format!(
            "{} (values from {} fit, the other unknowns free)",
            value_words(name, values[best]),
            span(r)
        ),
        (Some(r), false) => format!(
            "not identifiable: {} all fit within the model's error with the other unknowns free (searched {}){}",
            span(r),
            span([0, last]),
            given.map_or_else(
                || "; none fits with the others at the design's values".to_string(),
                |g| format!("; with the others at the design's values: {}", span(g))
            )
        ),
    };
    FitParameter {
        name: name.to_string(),
        design_value: values[design],
        value: identifiable.then(|| values[best]),
        range: joint.map(|r| [values[r[0]], values[r[1]]]),
        range_given_design: given.map(|r| [values[r[0]], values[r[1]]]),
        searched: [values[0], values[last]],
        identifiable,
        words,
    }
}
