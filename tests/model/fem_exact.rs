//! Verification of the axisymmetric solver against exact elasticity solutions: a
//! thick-walled cylinder under axial load and a Lamé cylinder under internal
//! pressure (plane strain), with near-incompressible rubber (ν = 0.49, 0.4999).

use fbgforge::fem::element::{ElasticConstants, Formulation};
use fbgforge::fem::mesh::{edge_forces, Mesh};
use fbgforge::fem::solve::{Problem, Solution, R, Z};

fn rubber(nu: f64) -> ElasticConstants {
    ElasticConstants {
        youngs_modulus_mpa: 3.2,
        poisson_ratio: nu,
    }
}

/// Apply a traction on the edge of the doubled grid column/row given by node ids.
fn load_edge(loads: &mut Vec<(usize, usize, f64)>, mesh: &Mesh, ids: &[usize], traction: [f64; 2]) {
    for w in (0..ids.len() - 2).step_by(2) {
        let three = [ids[w], ids[w + 1], ids[w + 2]];
        let xy = [
            mesh.nodes[three[0]],
            mesh.nodes[three[1]],
            mesh.nodes[three[2]],
        ];
        let f = edge_forces(xy, -1.0, 1.0, |_, _, dr, dz| {
            let len = (dr * dr + dz * dz).sqrt();
            [traction[0] * len, traction[1] * len]
        });
        for k in 0..3 {
            loads.push((three[k], R, f[k][0]));
            loads.push((three[k], Z, f[k][1]));
        }
    }
}

/// Thick cylinder a ≤ r ≤ b, 0 ≤ z ≤ len, frictionless base, axial force `force_n`
/// (compressive) spread uniformly over the top.
fn axial_cylinder(nu: f64, formulation: Formulation) -> (Mesh, Solution, f64, f64, f64) {
    let (a, b, len, force) = (5.0, 8.0, 12.0, 10.0);
    let (mesh, ids) = Mesh::rectangle(a, b, 0.0, len, 2, 3);
    let area = std::f64::consts::PI * (b * b - a * a);
    let top: Vec<usize> = ids.iter().map(|col| *col.last().unwrap()).collect();
    let mut loads = Vec::new();
    load_edge(&mut loads, &mesh, &top, [0.0, -force / area]);
    let fixed = ids.iter().map(|col| (col[0], Z)).collect();
    let p = Problem {
        mesh: mesh.clone(),
        materials: vec![rubber(nu)],
        formulation,
        fixed,
        ties: vec![],
        loads,
    };
    let sol = p.solve().unwrap();
    (mesh, sol, force / area, a, b)
}

#[test]
fn thick_cylinder_under_axial_load_matches_uniform_stress() {
    for nu in [0.3, 0.49, 0.4999] {
        let (mesh, sol, sigma, _, _) = axial_cylinder(nu, Formulation::MixedQ9P1);
        let eps_exact = -sigma / 3.2;
        for (i, q) in mesh.nodes.iter().enumerate() {
            let u = sol.displacement_mm[i];
            let ur_exact = -nu * eps_exact * q[0];
            let uz_exact = eps_exact * q[1];
            assert!(
                (u[0] - ur_exact).abs() <= 0.01 * ur_exact.abs(),
                "ν={nu} u_r at {q:?}: {} vs {ur_exact}",
                u[0]
            );
            if q[1] > 0.0 {
                assert!(
                    (u[1] - uz_exact).abs() <= 0.01 * uz_exact.abs(),
                    "ν={nu} u_z at {q:?}"
                );
            }
        }
        let e = sol.strain_at(&mesh, None, 6.3, 7.7).unwrap();
        assert!(
            (e[1] - eps_exact).abs() <= 0.01 * eps_exact.abs(),
            "ν={nu} ε_zz {} vs {eps_exact}",
            e[1]
        );
        assert!(
            (e[2] + nu * eps_exact).abs() <= 0.01 * (nu * eps_exact).abs(),
            "ε_θθ"
        );
    }
}

/// Lamé cylinder a ≤ r ≤ b in plane strain (u_z = 0 top and bottom) with internal
/// pressure p: u_r(r) = (1+ν) p a² / (E (b² − a²)) · ((1 − 2ν) r + b² / r).
fn lame(nu: f64, formulation: Formulation, nr: usize) -> f64 {
    let (a, b, len, p, e) = (4.0, 10.0, 2.0, 0.2, 3.2);
    let (mesh, ids) = Mesh::rectangle(a, b, 0.0, len, nr, 1);
    let mut loads = Vec::new();
    load_edge(&mut loads, &mesh, &ids[0], [p, 0.0]);
    let mut fixed = Vec::new();
    for col in &ids {
        fixed.push((col[0], Z));
        fixed.push((*col.last().unwrap(), Z));
    }
    // All u_z are zero in plane strain; also pin the mid row.
    for col in &ids {
        fixed.push((col[1], Z));
    }
    let prob = Problem {
        mesh: mesh.clone(),
        materials: vec![ElasticConstants {
            youngs_modulus_mpa: e,
            poisson_ratio: nu,
        }],
        formulation,
        fixed,
        ties: vec![],
        loads,
    };
    let sol = prob.solve().unwrap();
    let exact = |r: f64| {
        (1.0 + nu) * p * a * a / (e * (b * b - a * a)) * ((1.0 - 2.0 * nu) * r + b * b / r)
    };
    let mut worst: f64 = 0.0;
    for (i, q) in mesh.nodes.iter().enumerate() {
        let rel = (sol.displacement_mm[i][0] - exact(q[0])).abs() / exact(q[0]);
        worst = worst.max(rel);
    }
    worst
}

#[test]
fn lame_cylinder_under_pressure_within_one_percent_without_locking() {
    for nu in [0.3, 0.49, 0.4999] {
        let err = lame(nu, Formulation::MixedQ9P1, 4);
        assert!(err < 0.01, "ν = {nu}: worst relative error of u_r {err:.4}");
    }
}

#[test]
fn lame_error_falls_with_refinement() {
    let coarse = lame(0.49, Formulation::MixedQ9P1, 1);
    let fine = lame(0.49, Formulation::MixedQ9P1, 2);
    assert!(fine < coarse / 4.0, "coarse {coarse:.2e}, fine {fine:.2e}");
}

#[test]
fn plain_displacement_elements_lock_where_the_mixed_ones_do_not() {
    // The same coarse mesh at ν = 0.4999: the plain element is far too stiff.
    let plain = lame(0.4999, Formulation::Displacement, 1);
    let mixed = lame(0.4999, Formulation::MixedQ9P1, 1);
    assert!(mixed < 0.05, "mixed {mixed:.3}");
    assert!(plain > 3.0 * mixed, "plain {plain:.3} vs mixed {mixed:.3}");
}
