//! Unilateral contact (`fem::contact`) against exact answers: a gap closing between
//! two elastic blocks (piecewise-linear response with a knee at a known force) and
//! Hertz's rigid sphere pressed into an elastic half-space; then the module: the
//! printed dome clearance closes under load at a knee, and along the cylinders the
//! printed clearance never closes (so friction there would carry nothing).

use crate::common;
use fbgforge::fem::contact::{self, ContactPair};
use fbgforge::fem::element::{ElasticConstants, Formulation};
use fbgforge::fem::mesh::{edge_forces, Mesh};
use fbgforge::fem::solve::{EnvelopeCholesky, Problem, R, Z};
use fbgforge::fem::{solve_response, ContactReading, FemOptions};
use fbgforge::model::{Configuration, LoadCase};

/// Nodes of a structured block on the doubled grid of coordinates `rs` × `zs`
/// (element corners and mid-side points).
fn block(mesh: &mut Mesh, rs: &[f64], zs: &[f64], material: usize) -> Vec<Vec<usize>> {
    let doubled = |c: &[f64]| -> Vec<f64> {
        let mut out = Vec::new();
        for w in c.windows(2) {
            out.push(w[0]);
            out.push(0.5 * (w[0] + w[1]));
        }
        out.push(*c.last().unwrap());
        out
    };
    let (dr, dz) = (doubled(rs), doubled(zs));
    let ids: Vec<Vec<usize>> = dr
        .iter()
        .map(|&r| dz.iter().map(|&z| mesh.add_node(r, z)).collect())
        .collect();
    mesh.add_block(&ids, material);
    ids
}

fn uniform(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..=n).map(|k| a + (b - a) * k as f64 / n as f64).collect()
}

/// Consistent nodal forces of a uniform axial traction `p` (N/mm², + up) on the face
/// of a block whose nodes along r are `row` (doubled grid).
fn face_traction(mesh: &Mesh, row: &[usize], p: f64) -> Vec<(usize, usize, f64)> {
    let mut loads = Vec::new();
    for k in (0..row.len() - 1).step_by(2) {
        let ids = [row[k], row[k + 1], row[k + 2]];
        let xy = ids.map(|i| mesh.nodes[i]);
        let f = edge_forces(xy, -1.0, 1.0, |_, _, dr, _| [0.0, p * dr.abs()]);
        for j in 0..3 {
            loads.push((ids[j], Z, f[j][1]));
        }
    }
    loads
}

#[test]
fn a_gap_between_two_blocks_closes_at_the_exact_force_and_shares_the_load_exactly() {
    // Block A stands on the table; block B hangs from the ceiling above it across a gap
    // g0 and is pulled down by a traction on its lower face (total F). B stretches as a
    // spring k_B = E A / L_B until the gap closes at F* = k_B g0; beyond it A takes the
    // rest: δ = (F + k_A g0)/(k_A + k_B). Uniform uniaxial stress: exact for the
    // elements, for any ν.
    let (radius, la, lb, g0) = (5.0, 8.0, 12.0, 0.05);
    for nu in [0.0, 0.3, 0.49] {
        let e = 40.0;
        let mut mesh = Mesh::default();
        let rs = uniform(0.0, radius, 3);
        let a = block(&mut mesh, &rs, &uniform(0.0, la, 4), 0);
        let b = block(&mut mesh, &rs, &uniform(la + g0, la + g0 + lb, 5), 0);
        let top_a: Vec<usize> = a.iter().map(|c| *c.last().unwrap()).collect();
        let bottom_b: Vec<usize> = b.iter().map(|c| c[0]).collect();
        let mut fixed: Vec<(usize, usize)> = a.iter().map(|c| (c[0], Z)).collect();
        fixed.extend(b.iter().map(|c| (*c.last().unwrap(), Z)));
        fixed.extend(a[0].iter().chain(&b[0]).map(|&n| (n, R)));
        let area = std::f64::consts::PI * radius * radius;
        // 1 N in total, downwards.
        let loads = face_traction(&mesh, &bottom_b, -1.0 / area);
        let problem = Problem {
            mesh,
            materials: vec![ElasticConstants {
                youngs_modulus_mpa: e,
                poisson_ratio: nu,
            }],
            formulation: Formulation::MixedQ9P1,
            fixed,
            ties: vec![],
            interpolations: vec![],
            loads: loads.clone(),
        };
        let pairs: Vec<ContactPair> = top_a
            .iter()
            .zip(&bottom_b)
            .map(|(&a, &b)| ContactPair {
                a,
                b: Some(b),
                normal: [0.0, 1.0],
                gap_mm: g0,
            })
            .collect();
        let factored = problem.factor_with(&EnvelopeCholesky).unwrap();
        let probe = bottom_b[0];
        let reduced = contact::reduce(&factored, &loads, &pairs, |s| {
            Ok(vec![s.displacement_mm[probe][1]])
        })
        .unwrap();
        let (ka, kb) = (e * area / la, e * area / lb);
        let knee = reduced.knee_load_factor().unwrap();
        assert!(
            (knee / (kb * g0) - 1.0).abs() < 1e-9,
            "ν = {nu}: knee {knee} N vs {}",
            kb * g0
        );
        for f in [0.5 * knee, 0.99 * knee, 1.5 * knee, 4.0 * knee, 20.0 * knee] {
            let s = reduced.solve(f, 0.0).unwrap();
            let delta = -s.observed[0];
            let (want, want_contact) = if f <= knee {
                (f / kb, 0.0)
            } else {
                let d = (f + ka * g0) / (ka + kb);
                (d, f - kb * d)
            };
            let contact_force: f64 = s.normal_force_n.iter().sum();
            assert!(
                (delta / want - 1.0).abs() < 1e-8,
                "ν = {nu}, F = {f}: δ {delta} vs {want}"
            );
            assert!(
                (contact_force - want_contact).abs() < 1e-8 * f,
                "ν = {nu}, F = {f}: contact force {contact_force} vs {want_contact}"
            );
            // No pair pulls, no pair overlaps.
            assert!(s.normal_force_n.iter().all(|&l| l >= 0.0));
            assert!(s.gap_mm.iter().all(|&g| g >= -1e-12));
            if f > knee {
                // The whole face touches (the pair on the axis carries no force: its
                // ring has no area).
                assert!(
                    s.gap_mm.iter().all(|g| g.abs() < 1e-9 * g0),
                    "{:?}",
                    s.gap_mm
                );
                assert!(s.active() >= pairs.len() - 1);
            } else {
                assert_eq!(s.active(), 0);
            }
        }
    }
}

/// Coordinates from 0 to `fine_to` in steps of `h`, then growing by `growth` to `end`.
fn graded(h: f64, fine_to: f64, end: f64, growth: f64) -> Vec<f64> {
    let mut c = uniform(0.0, fine_to, (fine_to / h).round() as usize);
    let mut step = h;
    while *c.last().unwrap() < end {
        step *= growth;
        let next = (c.last().unwrap() + step).min(end);
        c.push(next);
    }
    c
}

/// Rigid sphere of radius `rs` pressed by `d` into an elastic cylinder standing on a
/// frictionless table (large enough to stand for a half-space), with elements of
/// `h` mm near the contact. Returns (total force N, radius of the outermost touching
/// node mm).
fn sphere_on_flat(e: f64, nu: f64, rs: f64, d: f64, h: f64) -> (f64, f64) {
    let a = (rs * d).sqrt();
    let size = 200.0 * a;
    let mut mesh = Mesh::default();
    let r = graded(h, 2.0 * a, size, 1.25);
    let depth = graded(h, 2.0 * a, size, 1.25);
    let zs: Vec<f64> = depth.iter().rev().map(|t| size - t).collect();
    let ids = block(&mut mesh, &r, &zs, 0);
    let mut fixed: Vec<(usize, usize)> = ids.iter().map(|c| (c[0], Z)).collect();
    fixed.extend(ids[0].iter().map(|&n| (n, R)));
    let surface: Vec<usize> = ids.iter().map(|c| *c.last().unwrap()).collect();
    let problem = Problem {
        mesh,
        materials: vec![ElasticConstants {
            youngs_modulus_mpa: e,
            poisson_ratio: nu,
        }],
        formulation: Formulation::MixedQ9P1,
        fixed,
        ties: vec![],
        interpolations: vec![],
        loads: vec![],
    };
    // The sphere touches the surface at the axis; the gap under it at radius r.
    let pairs: Vec<ContactPair> = surface
        .iter()
        .filter(|&&n| problem.mesh.nodes[n][0] <= 3.0 * a)
        .map(|&n| {
            let x = problem.mesh.nodes[n][0];
            ContactPair {
                a: n,
                b: None,
                normal: [0.0, 1.0],
                gap_mm: rs - (rs * rs - x * x).sqrt(),
            }
        })
        .collect();
    let factored = problem.factor_with(&EnvelopeCholesky).unwrap();
    let reduced = contact::reduce(&factored, &[], &pairs, |_| Ok(vec![])).unwrap();
    let s = reduced.solve(0.0, d).unwrap();
    let force: f64 = s.normal_force_n.iter().sum();
    let edge = pairs
        .iter()
        .zip(&s.normal_force_n)
        .filter(|(_, l)| **l > 0.0)
        .map(|(p, _)| problem.mesh.nodes[p.a][0])
        .fold(0.0, f64::max);
    (force, edge)
}

#[test]
fn a_rigid_sphere_on_an_elastic_half_space_follows_hertz() {
    // Hertz: F = (4/3) E* √R d^{3/2}, contact radius a = √(R d), E* = E/(1 − ν²).
    let (e, rs): (f64, f64) = (10.0, 20.0);
    for nu in [0.3, 0.49] {
        let e_star = e / (1.0 - nu * nu);
        for d in [0.005f64, 0.02] {
            let a = (rs * d).sqrt();
            let h = a / 10.0;
            let (force, edge) = sphere_on_flat(e, nu, rs, d, h);
            let hertz = 4.0 / 3.0 * e_star * rs.sqrt() * d.powf(1.5);
            assert!(
                (force / hertz - 1.0).abs() < 0.02,
                "ν = {nu}, d = {d}: F {force} vs Hertz {hertz} ({:+.2} %)",
                100.0 * (force / hertz - 1.0)
            );
            // The outermost touching node lies within one node spacing of a.
            assert!(
                (edge - a).abs() <= h,
                "ν = {nu}, d = {d}: contact edge {edge} vs a = {a}"
            );
        }
    }
}

#[test]
fn the_module_s_dome_clearance_closes_at_a_knee_and_the_cylinders_stay_apart() {
    let d = common::shipped("clip-on-34mm.toml");
    let m = d.module.as_ref().unwrap();
    let opt = FemOptions::level(0).with_reading(m, ContactReading::Unilateral, LoadCase::I);
    let config = Configuration {
        core: "psc1".into(),
        case: LoadCase::I,
        insert: Some("blue".into()),
    };
    let forces = [0.1, 0.2, 0.3, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0];
    let r = solve_response(&d, &config, &opt, &forces, crate::fe_cache()).unwrap();
    let knee = r.knee_force_n.unwrap();
    assert!(knee > 0.1 && knee < 2.0, "knee at {knee} N");
    let shift = r.shift_pm(&d.fiber, 0);
    // Below the knee the response is linear (the gap is open) and steep: the cap's
    // compression and the core's stretch take all the force.
    let k_open = shift[0] / forces[0];
    for (f, s) in forces.iter().zip(&shift).take_while(|(f, _)| **f < knee) {
        assert!((s / f / k_open - 1.0).abs() < 1e-9, "{f} N");
        assert_eq!(r.active_pairs[0], 0);
    }
    // Above it the domes touch and the tangent sensitivity falls far below the open one.
    let tangent = (shift[8] - shift[7]) / (forces[8] - forces[7]);
    assert!(r.active_pairs[8] > 0);
    assert!(
        tangent.abs() < 0.1 * k_open,
        "tangent {tangent} vs open {k_open} pm/N"
    );
    // Along the cylinders the printed radial clearance only opens: the cap, compressed,
    // grows in radius and the core, stretched, shrinks. So every touching pair is on
    // the domes, and no normal force arises along the cylinders for friction to act on.
    assert!(
        r.active_cylinder_pairs.iter().all(|&n| n == 0),
        "{:?}",
        r.active_cylinder_pairs
    );
}
