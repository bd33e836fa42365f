//! The sheet model's solvers against exact solutions: Kelvin (a point force inside an
//! infinite solid), a direct integration of Navier's equations across the layer,
//! Boussinesq (a point load on a half-space), the disc load's settlement on a
//! half-space and on a thin bonded layer (uniaxial strain), Cox's shear-lag closed form
//! for a fiber with a local interface, and a long fiber in infinite silicone under a
//! sinusoidal field (line-force compliance in closed form). docs/array.md §12.2.

use fbgforge::array::sheet::fiber::{FiberBar, FiberLines, FiberSystem, SiliconeCompliance};
use fbgforge::array::sheet::hankel::{self, KGrid, Order, RadialTable};
use fbgforge::array::sheet::layer::{BaseCondition, Layer, PsvLoad};
use fbgforge::array::sheet::{GratingOnFiber, Resolution, SheetModel};
use nalgebra::DMatrix;
use std::f64::consts::PI;

fn layer(h: f64, e: f64, nu: f64, base: BaseCondition) -> Layer {
    Layer {
        thickness_mm: h,
        shear_modulus_mpa: e / (2.0 * (1.0 + nu)),
        poisson_ratio: nu,
        base,
    }
}

const BASES: [BaseCondition; 3] = [
    BaseCondition::Bonded,
    BaseCondition::Frictionless,
    BaseCondition::Gripping {
        tangential_stiffness_n_per_mm3: 0.05,
    },
];

#[test]
fn a_force_deep_inside_a_thick_layer_sees_kelvins_solution() {
    for base in BASES {
        let l = layer(200.0, 1.3, 0.48, base);
        for k in [0.5, 2.0, 10.0] {
            let (ak, bk) = l.kelvin_along_normal(k);
            let a = l.horizontal_force_along(k, 100.0, 100.0);
            let b = l.sh_displacement(k, 100.0, 100.0);
            assert!((a / ak - 1.0).abs() < 1e-9, "{base:?} k {k}: A {a} vs {ak}");
            assert!((b / bk - 1.0).abs() < 1e-9, "{base:?} k {k}: B {b} vs {bk}");
        }
    }
}

/// Navier's equations across the layer as a first-order system in (U, W, T, N)
/// (the conventions of `layer`), integrated by RK4 from the loaded face down; the two
/// unknown face displacements found by superposition so that the base condition
/// holds. An independent route to the same numbers as the closed-form basis.
fn shoot(l: &Layer, k: f64, load: PsvLoad, s: f64, obs: f64) -> (f64, f64) {
    let mu = l.shear_modulus_mpa;
    let nu = l.poisson_ratio;
    let lam = 2.0 * mu * nu / (1.0 - 2.0 * nu);
    let rhs = |y: [f64; 4]| -> [f64; 4] {
        let (u, w, t, n) = (y[0], y[1], y[2], y[3]);
        let du = t / mu - k * w;
        let dw = (n + lam * k * u) / (lam + 2.0 * mu);
        let dt = (lam + 2.0 * mu) * k * k * u - lam * k * dw;
        let dn = k * t;
        [du, dw, dt, dn]
    };
    let steps = 4000;
    // Integrate from 0 to h with a jump in traction at s, recording the state at obs.
    let run = |y0: [f64; 4], jump: [f64; 4]| -> ([f64; 4], [f64; 4]) {
        let h = l.thickness_mm;
        let mut y = y0;
        let mut at_obs = y0;
        let dz = h / steps as f64;
        let i_jump = (s / dz).round() as usize;
        let i_obs = (obs / dz).round() as usize;
        for step in 0..steps {
            if step == i_jump {
                for i in 0..4 {
                    y[i] += jump[i];
                }
            }
            if step == i_obs {
                at_obs = y;
            }
            let k1 = rhs(y);
            let y2: [f64; 4] = std::array::from_fn(|i| y[i] + 0.5 * dz * k1[i]);
            let k2 = rhs(y2);
            let y3: [f64; 4] = std::array::from_fn(|i| y[i] + 0.5 * dz * k2[i]);
            let k3 = rhs(y3);
            let y4: [f64; 4] = std::array::from_fn(|i| y[i] + dz * k3[i]);
            let k4 = rhs(y4);
            for i in 0..4 {
                y[i] += dz / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        (y, at_obs)
    };
    let (top, jump) = match load {
        PsvLoad::SurfacePressure => ([0.0, 0.0, 0.0, -1.0], [0.0; 4]),
        PsvLoad::HorizontalForce => ([0.0; 4], [0.0, 0.0, 1.0, 0.0]),
        PsvLoad::VerticalForce => ([0.0; 4], [0.0, 0.0, 0.0, -1.0]),
    };
    let (p_end, p_obs) = run(top, jump);
    let (a_end, a_obs) = run([1.0, 0.0, 0.0, 0.0], [0.0; 4]);
    let (b_end, b_obs) = run([0.0, 1.0, 0.0, 0.0], [0.0; 4]);
    // Base conditions: W = 0 and (U = 0 | T + q U = 0).
    let cond = |y: [f64; 4]| -> (f64, f64) {
        let tang = match l.base {
            BaseCondition::Bonded => y[0],
            BaseCondition::Frictionless => y[2],
            BaseCondition::Gripping {
                tangential_stiffness_n_per_mm3: kt,
            } => y[2] + kt * y[0],
        };
        (y[1], tang)
    };
    let (p1, p2) = cond(p_end);
    let (a1, a2) = cond(a_end);
    let (b1, b2) = cond(b_end);
    let det = a1 * b2 - a2 * b1;
    let ca = (-p1 * b2 + p2 * b1) / det;
    let cb = (-a1 * p2 + a2 * p1) / det;
    let u = p_obs[0] + ca * a_obs[0] + cb * b_obs[0];
    let w = p_obs[1] + ca * a_obs[1] + cb * b_obs[1];
    (u, w)
}

#[test]
fn the_layer_solution_matches_a_direct_integration_of_navier_equations() {
    for base in BASES {
        let l = layer(5.0, 1.0, 0.45, base);
        for k in [0.05, 0.3, 1.0, 2.5] {
            for (load, s, obs) in [
                (PsvLoad::SurfacePressure, 2.5, 2.5),
                (PsvLoad::SurfacePressure, 1.25, 1.25),
                (PsvLoad::HorizontalForce, 2.5, 2.5),
                (PsvLoad::HorizontalForce, 1.25, 3.75),
                (PsvLoad::VerticalForce, 2.5, 1.25),
            ] {
                let f = l.psv(k, s, load).at(obs);
                let (u, w) = shoot(&l, k, load, s, obs);
                let scale = u.abs().max(w.abs());
                assert!(
                    (f.u - u).abs() < 1e-6 * scale && (f.w - w).abs() < 1e-6 * scale,
                    "{base:?} k {k} {load:?} s {s} at {obs}: closed form ({}, {}) vs ODE ({u}, {w})",
                    f.u,
                    f.w
                );
            }
        }
    }
}

/// Boussinesq's radial displacement at depth z under a point load P on a half-space.
fn boussinesq_ur(p: f64, mu: f64, nu: f64, rho: f64, z: f64) -> f64 {
    let r = rho.hypot(z);
    p / (4.0 * PI * mu) * (rho * z / r.powi(3) - (1.0 - 2.0 * nu) * rho / (r * (r + z)))
}

#[test]
fn a_point_load_on_a_thick_sheet_matches_boussinesq() {
    for nu in [0.3, 0.48] {
        let model = SheetModel {
            thickness_mm: 2000.0,
            youngs_modulus_mpa: 1.0,
            poisson_ratio: nu,
            fiber_depth_mm: 5.0,
            base: BaseCondition::Frictionless,
            indenter_diameter_mm: 0.0,
            sheet_mm: (30.0, 30.0),
            fiber_x_mm: vec![0.0],
            fiber: FiberBar::standard(0.25),
            resolution: Resolution::standard(),
        };
        let t = model.tables().unwrap();
        let mu = model.layer().shear_modulus_mpa;
        let rhos = [1.0, 3.0, 5.0, 10.0, 20.0];
        let peak = rhos
            .iter()
            .map(|&r| boussinesq_ur(1.0, mu, nu, r, 5.0).abs())
            .fold(0.0, f64::max);
        for rho in rhos {
            let exact = boussinesq_ur(1.0, mu, nu, rho, 5.0);
            let got = t.radial_displacement.at(rho);
            assert!(
                (got - exact).abs() < 0.005 * peak,
                "ν {nu} ρ {rho}: model {got} vs Boussinesq {exact}"
            );
        }
    }
}

/// Settlement of the loaded face at the centre of a uniform disc load (radius a,
/// total 1 N), by the layer's W(0) kernel.
fn disc_settlement(l: &Layer, a: f64) -> f64 {
    let grid = KGrid::new(4.0 * a, 500.0 / a, 0.5);
    let kern: Vec<f64> = grid
        .k
        .iter()
        .map(|&k| {
            let w = l
                .psv(k, 0.5 * l.thickness_mm, PsvLoad::SurfacePressure)
                .at(0.0)
                .w;
            w * 2.0 * libm::j1(k * a) / (k * a)
        })
        .collect();
    let t: Vec<RadialTable> = hankel::transform(
        &grid,
        &[hankel::Transformable {
            values: &kern,
            order: Order::J0,
            k_max: f64::INFINITY,
        }],
        1.0,
        1.0,
    );
    t[0].at(0.0)
}

#[test]
fn a_disc_load_settles_a_half_space_and_a_thin_bonded_layer_as_exactly_known() {
    let (e, nu, a) = (1.0, 0.3, 10.0);
    let p = 1.0 / (PI * a * a);
    // Half-space: w(0) = 2(1 − ν²) p a / E.
    let thick = layer(5000.0, e, nu, BaseCondition::Frictionless);
    let exact = 2.0 * (1.0 - nu * nu) * p * a / e;
    let got = disc_settlement(&thick, a);
    assert!(
        (got / exact - 1.0).abs() < 0.01,
        "half-space: {got} vs {exact}"
    );
    // A layer much thinner than the disc, bonded: uniaxial strain under the centre,
    // w = p h (1 + ν)(1 − 2ν) / (E (1 − ν)).
    let h = 0.2;
    let thin = layer(h, e, nu, BaseCondition::Bonded);
    let exact = p * h * (1.0 + nu) * (1.0 - 2.0 * nu) / (e * (1.0 - nu));
    let got = disc_settlement(&thin, a);
    assert!(
        (got / exact - 1.0).abs() < 0.01,
        "thin layer: {got} vs {exact}"
    );
}

#[test]
fn a_fiber_with_a_local_interface_follows_coxs_shear_lag_closed_form() {
    // Cox: interface compliance g per unit length (mm²/N), uniform remote strain ε∞:
    // ε(y) = ε∞ (1 − cosh(y/ℓ)/cosh(L/2ℓ)), ℓ = √(EA·g).
    let bar = FiberBar {
        axial_stiffness_n: 884.0,
        coupling_radius_mm: 0.125,
    };
    let g_local = 4.0; // mm/N per mm
    let l_shear = (bar.axial_stiffness_n * g_local).sqrt();
    let len = 60.0;
    let lines = FiberLines {
        x_mm: vec![0.0],
        span_mm: (-len / 2.0, len / 2.0),
        segments: 600,
    };
    let dy = lines.segment_mm();
    let g = DMatrix::from_diagonal_element(600, 600, g_local / dy);
    let sys = FiberSystem::with_compliance(lines.clone(), bar, g).unwrap();
    let eps = 1e-3;
    let u0 = DMatrix::from_fn(600, 1, |i, _| eps * lines.node_y(i));
    let f = sys.forces(&u0);
    for y in [0.0, 10.0, 20.0, 27.0] {
        let w = sys.strain_weights(0, y, 0.0);
        let got = w.dot(&f.column(0));
        let exact = eps * (1.0 - (y / l_shear).cosh() / (len / (2.0 * l_shear)).cosh());
        assert!(
            (got - exact).abs() < 2e-3 * eps,
            "y {y}: {got} vs Cox {exact} (ℓ = {l_shear:.1} mm)"
        );
    }
    // A grating's average over its length is the average of the closed form.
    let (y, lg) = (5.0, 3.0);
    let w = sys.strain_weights(0, y, lg);
    let got = w.dot(&f.column(0));
    let exact = eps
        * (1.0 - l_shear * ((y + lg / 2.0) / l_shear).sinh() / lg / (len / (2.0 * l_shear)).cosh()
            + l_shear * ((y - lg / 2.0) / l_shear).sinh() / lg / (len / (2.0 * l_shear)).cosh());
    assert!((got - exact).abs() < 2e-3 * eps, "{got} vs {exact}");
}

/// K₀ and K₁ by quadrature of their integral representations.
fn bessel_k01(x: f64) -> (f64, f64) {
    let (mut k0, mut k1) = (0.0, 0.0);
    let n = 20000;
    let tmax = 12.0;
    let dt = tmax / n as f64;
    for i in 0..n {
        let t = (i as f64 + 0.5) * dt;
        let e = (-x * t.cosh()).exp();
        k0 += e * dt;
        k1 += t.cosh() * e * dt;
    }
    (k0, k1)
}

#[test]
fn a_long_fiber_in_infinite_silicone_matches_the_line_force_closed_form() {
    // Infinite silicone (no layer correction), a fiber under u0 = U sin(qy): the
    // silicone's compliance to a line force f sin(qy) along the fiber, read on the
    // fiber's surface, is g(q) = K₀(qa)/(2πμ) − qa K₁(qa)/(8πμ(1 − ν)) (Kelvin
    // integrated along the line), so the fiber moves by V = U/(1 + g EA q²) and the
    // silicone pulls on it with EA q² V sin(qy) per mm. Compared on the middle half of
    // a fiber 10.5 wavelengths long, where the free ends no longer matter.
    let (mu, nu, a) = (0.34, 0.48, 0.125);
    let bar = FiberBar {
        axial_stiffness_n: 884.0,
        coupling_radius_mm: a,
    };
    let zero = RadialTable {
        step_mm: 1.0,
        values: vec![0.0; 2],
    };
    for wavelength in [10.0, 40.0] {
        let q = 2.0 * PI / wavelength;
        let len = 10.5 * wavelength;
        let seg = (len / 0.25).round() as usize;
        let lines = FiberLines {
            x_mm: vec![0.0],
            span_mm: (-len / 2.0, len / 2.0),
            segments: seg,
        };
        let dy = lines.segment_mm();
        let g = SiliconeCompliance {
            shear_modulus_mpa: mu,
            poisson_ratio: nu,
            correction_0: &zero,
            correction_2: &zero,
        }
        .matrix(&lines, a);
        let sys = FiberSystem::with_compliance(lines.clone(), bar, g).unwrap();
        let u = 1e-3;
        let u0 = DMatrix::from_fn(seg, 1, |i, _| u * (q * lines.node_y(i)).sin());
        let f = sys.forces(&u0);
        let (mut num, mut den) = (0.0, 0.0);
        for l in 0..seg {
            let y = lines.node_y(l);
            if y.abs() < len / 4.0 {
                num += f[(l, 0)] / dy * (q * y).sin();
                den += (q * y).sin().powi(2);
            }
        }
        let got = num / den;
        let (k0, k1) = bessel_k01(q * a);
        let gq = k0 / (2.0 * PI * mu) - q * a * k1 / (8.0 * PI * mu * (1.0 - nu));
        let ea = bar.axial_stiffness_n;
        let exact = ea * q * q * u / (1.0 + gq * ea * q * q);
        assert!(
            (got / exact - 1.0).abs() < 0.01,
            "λ {wavelength} mm: force amplitude {got} N/mm vs closed form {exact} (g = {gq} mm/N)"
        );
    }
}

#[test]
fn reciprocity_gives_the_direct_solves_readings() {
    let d = fbgforge::design::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("designs/tactile-array-60x80.toml"),
    )
    .unwrap();
    let model = SheetModel::from_design(&d).unwrap();
    let sol = model.solve().unwrap();
    let g = fbgforge::array::sheet::gratings_of(&d).unwrap();
    let loads = [(0.0, 0.0), (-30.0, -15.0), (12.0, 7.0), (39.0, 29.0)];
    let direct = sol.strain_per_n(&g, &loads);
    let adjoint = sol.strain_map_per_n(&g, &loads);
    let scale = direct.amax();
    assert!((direct - adjoint).amax() < 1e-9 * scale);
    // A point reading is the limit of a short grating's.
    let short = GratingOnFiber {
        length_mm: 1e-4,
        ..g[2]
    };
    let point = GratingOnFiber {
        length_mm: 0.0,
        ..g[2]
    };
    let a = sol.strain_per_n(&[short, point], &loads[..1]);
    assert!((a[(0, 0)] - a[(1, 0)]).abs() < 1e-6 * a[(1, 0)].abs());
}
