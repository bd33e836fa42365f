//! The sheet model against the paper (Tables 1 and 2) and how its answer moves with
//! the design: thickness, fiber depth, modulus, table interface, direction to the load.
//! docs/array.md §12.3–11.5.

use crate::common;
use fbgforge::array::kernel::{model_matrix, ArrayModelKind, TABLE2_DIRECT_PM_PER_G};
use fbgforge::array::sheet::fit::compare_with_paper;
use fbgforge::array::sheet::{GratingOnFiber, SheetModel};
use fbgforge::spec::BaseCondition;

/// (near, mid, far) mirror-pair geometric means (14.58, 25.74, 39.53 mm) and the mean
/// direct sensitivity, pm/g.
fn shape(m: &SheetModel) -> ([f64; 3], f64) {
    let d = common::shipped("tactile-array-60x80.toml");
    let c = compare_with_paper(m, &d).unwrap();
    (
        [
            c.pairs[2].model_pm_per_g,
            c.pairs[1].model_pm_per_g,
            c.pairs[0].model_pm_per_g,
        ],
        c.table2_model_mean_pm_per_g,
    )
}

fn paper_model() -> SheetModel {
    SheetModel::from_design(&common::shipped("tactile-array-60x80.toml")).unwrap()
}

#[test]
fn the_shipped_sheet_meets_table1s_mirror_averaged_shape_and_states_table2() {
    let d = common::shipped("tactile-array-60x80.toml");
    let c = compare_with_paper(&paper_model(), &d).unwrap();
    // Each raw grating is reported, at Table 1's distances, with its error.
    assert_eq!(c.table1.len(), 6);
    for r in &c.table1 {
        assert!(r.model_pm_per_g > 0.0, "{r:?}");
        let e = 100.0 * (r.model_pm_per_g - r.measured_pm_per_g) / r.measured_pm_per_g;
        assert!((e - r.error_pct).abs() < 1e-9);
    }
    // The shape target: mirror-pair geometric means within 25 % after one common scale.
    let means = [0.0245, 0.0548, 0.1878];
    for (p, m) in c.pairs.iter().zip(means) {
        assert!((p.measured_pm_per_g - m).abs() < 5e-4, "{p:?}");
    }
    assert!(
        c.worst_shape_error_pct <= 25.0,
        "shape error {:.1} %: {:?}",
        c.worst_shape_error_pct,
        c.pairs
    );
    // The level follows without a scale: the common scale stays within a factor 1.5
    // (the modulus is assumed, only the interface was fitted).
    assert!(
        (1.0 / 1.5..1.5).contains(&c.common_scale),
        "scale {}",
        c.common_scale
    );
    // Table 2 with the same constants: the right order (a fiber that followed the
    // silicone would read ≥ 10× more), within a factor 2 of 0.371 pm/g.
    assert_eq!(c.table2_measured_pm_per_g, TABLE2_DIRECT_PM_PER_G);
    let ratio = c.table2_model_mean_pm_per_g / TABLE2_DIRECT_PM_PER_G;
    assert!((0.5..2.0).contains(&ratio), "direct {ratio}× Table 2");
    assert!(
        c.table2_silicone_pm_per_g > 10.0 * c.table2_model_mean_pm_per_g,
        "silicone {} vs fiber {}",
        c.table2_silicone_pm_per_g,
        c.table2_model_mean_pm_per_g
    );
    println!("{}", serde_json::to_string_pretty(&c).unwrap());
}

#[test]
fn a_3_mm_sheet_changes_the_shape_of_the_response_not_only_its_scale() {
    let d5 = common::shipped("tactile-array-60x80.toml");
    let mut d3 = d5.clone();
    let coated = d3.fiber_routing.coated_diameter_mm;
    let printer = d3.printer.clone();
    let a3 = d3.array.as_mut().unwrap();
    a3.thickness_mm = 3.0;
    // The slit depth was derived for 5 mm at load time; the 3 mm sheet's follows.
    a3.mold.slit_depth_mm = fbgforge::spec::derived_slit_depth_mm(a3, coated, &printer);
    d3.validate().unwrap();
    let m5 = model_matrix(&d5, Some(ArrayModelKind::Sheet))
        .unwrap()
        .matrix;
    let m3 = model_matrix(&d3, Some(ArrayModelKind::Sheet))
        .unwrap()
        .matrix;
    // Shape: a pure change of scale would multiply every entry by one factor; the
    // entry-wise ratios 3 mm / 5 mm spread by more than 1.3× instead.
    let ratios: Vec<f64> = m3
        .sensitivity_pm_per_g
        .iter()
        .zip(m5.sensitivity_pm_per_g.iter())
        .filter(|(a, b)| **a > 0.0 && **b > 0.0)
        .map(|(a, b)| a / b)
        .collect();
    assert!(ratios.len() > 24, "{} positive entries", ratios.len());
    let (lo, hi) = ratios
        .iter()
        .fold((f64::MAX, 0.0f64), |(l, h), &r| (l.min(r), h.max(r)));
    assert!(hi / lo > 1.3, "ratios 3 mm/5 mm span {lo:.3}–{hi:.3}");
    // And the fall-off is steeper in the thinner sheet (far/near of Table 1's pairs).
    let mut t3 = paper_model();
    t3.thickness_mm = 3.0;
    t3.fiber_depth_mm = 1.5;
    let (s5, _) = shape(&paper_model());
    let (s3, _) = shape(&t3);
    assert!(
        s3[2] / s3[0] < 0.9 * (s5[2] / s5[0]),
        "far/near: 3 mm {} vs 5 mm {}",
        s3[2] / s3[0],
        s5[2] / s5[0]
    );
    // The empirical kernel reads no thickness: the same matrix for both.
    let k5 = model_matrix(&d5, Some(ArrayModelKind::Kernel))
        .unwrap()
        .matrix;
    let k3 = model_matrix(&d3, Some(ArrayModelKind::Kernel))
        .unwrap()
        .matrix;
    assert_eq!(k5.sensitivity_pm_per_g, k3.sensitivity_pm_per_g);
}

fn increasing(v: &[f64]) -> bool {
    v.windows(2).all(|w| w[1] > w[0])
}

#[test]
fn sensitivity_and_its_fall_off_move_with_thickness_depth_modulus_base_and_direction() {
    let base = paper_model();
    let run = |f: &dyn Fn(&mut SheetModel)| {
        let mut m = base.clone();
        f(&mut m);
        shape(&m)
    };
    // Thickness (fibers at mid-depth): a thicker sheet spreads the load further: more
    // signal at every distance and a slower fall-off (far/near rises).
    let by_h: Vec<([f64; 3], f64)> = [3.0, 5.0, 8.0]
        .iter()
        .map(|&h| {
            run(&|m: &mut SheetModel| {
                m.thickness_mm = h;
                m.fiber_depth_mm = h / 2.0;
            })
        })
        .collect();
    let near: Vec<f64> = by_h.iter().map(|s| s.0[0]).collect();
    let fall: Vec<f64> = by_h.iter().map(|s| s.0[2] / s.0[0]).collect();
    let direct: Vec<f64> = by_h.iter().map(|s| s.1).collect();
    assert!(
        increasing(&near) && increasing(&fall) && increasing(&direct),
        "{by_h:?}"
    );
    // Fiber depth in the 5 mm sheet: loads 15–40 mm away notice little (≤ 10 %); the
    // direct load does, and reads most near mid-depth, least near the loaded face.
    let by_z: Vec<([f64; 3], f64)> = [1.0, 2.5, 4.0]
        .iter()
        .map(|&z| run(&|m: &mut SheetModel| m.fiber_depth_mm = z))
        .collect();
    for s in &by_z {
        for k in 0..3 {
            let r = s.0[k] / by_z[1].0[k];
            assert!((0.85..1.05).contains(&r), "depth: {by_z:?}");
        }
    }
    assert!(by_z[1].1 > by_z[0].1 && by_z[1].1 > by_z[2].1, "{by_z:?}");
    assert!(by_z[0].1 < 0.9 * by_z[1].1, "{by_z:?}");
    // Modulus at a fixed interface stiffness k_t: what sets the fall-off is k_t/μ, so
    // a stiffer silicone falls off more slowly; the direct reading barely moves over a
    // 16× range (the fiber collects load over its whole length).
    let by_e: Vec<([f64; 3], f64)> = [0.25, 1.0, 4.0]
        .iter()
        .map(|&e| run(&|m: &mut SheetModel| m.youngs_modulus_mpa = e))
        .collect();
    let fall: Vec<f64> = by_e.iter().map(|s| s.0[2] / s.0[0]).collect();
    assert!(increasing(&fall), "{by_e:?}");
    let (lo, hi) = by_e
        .iter()
        .map(|s| s.1)
        .fold((f64::MAX, 0.0f64), |(l, h), v| (l.min(v), h.max(v)));
    assert!(hi / lo < 1.25, "direct over E = 0.25–4 MPa: {by_e:?}");
    // The base: bonded falls off fastest, then gripping from stiff to soft, then
    // frictionless, the slowest.
    let bases = [
        BaseCondition::Bonded,
        BaseCondition::Gripping {
            tangential_stiffness_n_per_mm3: 0.1,
        },
        BaseCondition::Gripping {
            tangential_stiffness_n_per_mm3: 0.02,
        },
        BaseCondition::Gripping {
            tangential_stiffness_n_per_mm3: 0.005,
        },
        BaseCondition::Frictionless,
    ];
    let by_b: Vec<([f64; 3], f64)> = bases
        .iter()
        .map(|&b| run(&|m: &mut SheetModel| m.base = b))
        .collect();
    let fall: Vec<f64> = by_b.iter().map(|s| s.0[2] / s.0[0]).collect();
    assert!(increasing(&fall), "{by_b:?}");
    assert!(fall[4] > 10.0 * fall[0], "frictionless vs bonded: {fall:?}");
    // Direction: at the same distance a load across the fiber (beside the grating)
    // stretches it more than one along the fiber, which beyond ~20 mm pushes the
    // fiber's middle into compression (a negative reading).
    let sol = base.solve().unwrap();
    let g = GratingOnFiber {
        fiber: 2,
        y_mm: 0.0,
        length_mm: 3.0,
    };
    let fx = base.fiber_x_mm[2];
    let dists = [5.0, 10.0, 15.0, 25.0];
    let mut loads = Vec::new();
    for d in dists {
        loads.push((fx, d));
        loads.push((fx + d, 0.0));
    }
    let r = sol.strain_per_n(&[g], &loads);
    let along: Vec<f64> = (0..dists.len()).map(|i| r[(0, 2 * i)]).collect();
    let across: Vec<f64> = (0..dists.len()).map(|i| r[(0, 2 * i + 1)]).collect();
    for i in 1..dists.len() {
        assert!(
            across[i] > along[i],
            "{:?}: along {along:?} across {across:?}",
            dists[i]
        );
    }
    assert!(across.iter().all(|&v| v > 0.0), "{across:?}");
    assert!(along[0] > 0.0 && along[3] < 0.0, "along {along:?}");
    assert!(
        across[2] > 2.0 * along[2],
        "15 mm: along {along:?} across {across:?}"
    );
}
