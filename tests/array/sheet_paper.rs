//! The sheet model against the paper (Tables 1 and 2) and how its answer moves with
//! the design: thickness, fiber depth, modulus, table interface, direction to the load.
//! docs/array.md §11.3–11.5.

use crate::common;
use fbgforge::array::sheet::fit::compare_with_paper;
use fbgforge::array::sheet::{GratingOnFiber, SheetModel};
use fbgforge::spec::BaseCondition;
use std::time::Instant;

#[test]
fn explore() {
    let d = common::shipped("tactile-array-60x80.toml");
    let m = SheetModel::from_design(&d).unwrap();
    for _ in 0..3 {
        let t0 = Instant::now();
        let t = m.tables().unwrap();
        let t1 = t0.elapsed().as_secs_f64();
        let s = fbgforge::array::sheet::SheetSolution::new(m.clone(), t).unwrap();
        let t2 = t0.elapsed().as_secs_f64();
        let mat = fbgforge::array::sheet::design_matrix(&d).unwrap();
        let t3 = t0.elapsed().as_secs_f64();
        println!("tables {t1:.3} s, system {:.3} s, design matrix {:.3} s, k nodes {}", t2 - t1, t3 - t2, s.tables.k_nodes);
        let _ = mat;
    }
    let t0 = Instant::now();
    let c = compare_with_paper(&m, &d).unwrap();
    println!("compare {:.3} s", t0.elapsed().as_secs_f64());
    println!("{}", serde_json::to_string_pretty(&c).unwrap());
    for (name, base) in [
        ("bonded", BaseCondition::Bonded),
        ("frictionless", BaseCondition::Frictionless),
        ("g0.01", BaseCondition::Gripping { tangential_stiffness_n_per_mm3: 0.01 }),
        ("g0.03", BaseCondition::Gripping { tangential_stiffness_n_per_mm3: 0.03 }),
    ] {
        let mut mm = m.clone();
        mm.base = base;
        let c = compare_with_paper(&mm, &d).unwrap();
        println!("{name}: scale {:.3} worst {:.1} pairs {:?} direct {:.3}", c.common_scale, c.worst_shape_error_pct,
            c.pairs.iter().map(|p| (p.model_pm_per_g, p.shape_error_pct)).collect::<Vec<_>>(), c.table2_model_mean_pm_per_g);
    }
    let sol = m.solve().unwrap();
    let g = GratingOnFiber { fiber: 2, y_mm: 0.0, length_mm: 3.0 };
    for dist in [10.0, 15.0, 20.0] {
        let r = sol.strain_per_n(&[g], &[(-7.5, dist), (-7.5 + dist, 0.0)]);
        println!("dist {dist}: along fiber {:.4e} across {:.4e}", r[(0, 0)], r[(0, 1)]);
    }
}
