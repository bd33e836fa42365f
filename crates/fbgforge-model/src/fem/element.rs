//! The axisymmetric 9-node quadrilateral (Q9) with a condensed linear pressure (Q9/P1).
//!
//! Coordinates are (r, z) in mm, displacements (u_r, u_z) in mm, moduli in MPa, so
//! forces come out in N. Strain components are ordered [ε_rr, ε_zz, ε_θθ, γ_rz] with
//! ε_θθ = u_r / r. Every integral carries the full ring factor 2π r, so a nodal force
//! is the resultant over the whole circumference.
//!
//! Why mixed: the rubber cores have ν ≈ 0.49 (bulk modulus ≈ 50 × shear modulus). A
//! pure displacement element then over-constrains the volume change (volumetric
//! locking) and comes out too stiff. Here the deviatoric energy is integrated with
//! 3 × 3 Gauss points while the volumetric strain is first projected (L2, weighted by
//! the volume element) onto a discontinuous linear pressure field {1, r, z} per
//! element. The pressure is condensed at element level, so the global stiffness stays
//! symmetric positive definite (Cholesky applies) and the Q9/P1 pair is inf-sup stable.
//! [`Formulation::Displacement`] keeps the plain element for the locking demonstration.

use std::f64::consts::PI;

/// Element formulation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Formulation {
    /// Q9 displacement with a condensed, discontinuous linear pressure (locking free).
    MixedQ9P1,
    /// Plain Q9 displacement element with full 3 × 3 integration (locks as ν → 0.5).
    Displacement,
}

/// Isotropic linear-elastic constants of one element region.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElasticConstants {
    /// Young's modulus, MPa.
    pub youngs_modulus_mpa: f64,
    /// Poisson's ratio.
    pub poisson_ratio: f64,
}

impl ElasticConstants {
    /// Shear modulus μ, MPa.
    pub fn shear_modulus_mpa(&self) -> f64 {
        self.youngs_modulus_mpa / (2.0 * (1.0 + self.poisson_ratio))
    }
    /// Bulk modulus κ, MPa.
    pub(crate) fn bulk_modulus_mpa(&self) -> f64 {
        self.youngs_modulus_mpa / (3.0 * (1.0 - 2.0 * self.poisson_ratio))
    }
}

/// 1D quadratic Lagrange shape functions on [-1, 1] at nodes -1, 0, 1.
pub(crate) fn lagrange3(x: f64) -> [f64; 3] {
    [0.5 * x * (x - 1.0), 1.0 - x * x, 0.5 * x * (x + 1.0)]
}

/// Derivatives of [`lagrange3`].
pub(crate) fn lagrange3_d(x: f64) -> [f64; 3] {
    [x - 0.5, -2.0 * x, x + 0.5]
}

/// Q9 shape functions and their natural derivatives at (ξ, η). Node k = a + 3 b, with
/// a the ξ-index and b the η-index (0, 1, 2 for -1, 0, +1).
pub(crate) fn shape_q9(xi: f64, eta: f64) -> ([f64; 9], [f64; 9], [f64; 9]) {
    let (lx, ly) = (lagrange3(xi), lagrange3(eta));
    let (dx, dy) = (lagrange3_d(xi), lagrange3_d(eta));
    let mut n = [0.0; 9];
    let mut nxi = [0.0; 9];
    let mut neta = [0.0; 9];
    for b in 0..3 {
        for a in 0..3 {
            let k = a + 3 * b;
            n[k] = lx[a] * ly[b];
            nxi[k] = dx[a] * ly[b];
            neta[k] = lx[a] * dy[b];
        }
    }
    (n, nxi, neta)
}

/// 3-point Gauss–Legendre rule on [-1, 1]: (points, weights).
pub(crate) const GAUSS3: ([f64; 3], [f64; 3]) = (
    [-0.774_596_669_241_483_4, 0.0, 0.774_596_669_241_483_4],
    [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0],
);

/// Geometry of one integration point: shape values, physical derivatives, r, weight.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PointGeometry {
    /// Shape function values.
    pub n: [f64; 9],
    /// ∂N/∂r.
    pub dn_dr: [f64; 9],
    /// ∂N/∂z.
    pub dn_dz: [f64; 9],
    /// Radius of the point, mm.
    pub r_mm: f64,
    /// Height of the point, mm.
    pub z_mm: f64,
    /// |det J|, mm².
    pub det_j: f64,
}

/// Errors of the element routines.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ElementError {
    /// The map from the reference square folds over or collapses.
    #[error("element with first node at (r = {r_mm:.4} mm, z = {z_mm:.4} mm) is folded or collapsed (det J = {det_j:.3e})")]
    Distorted {
        /// r of the element's first node, mm.
        r_mm: f64,
        /// z of the element's first node, mm.
        z_mm: f64,
        /// Offending Jacobian determinant.
        det_j: f64,
    },
}

/// Evaluate the isoparametric map at (ξ, η). Returns the signed det J.
pub(crate) fn point_geometry(xy: &[[f64; 2]; 9], xi: f64, eta: f64) -> (PointGeometry, f64) {
    let (n, nxi, neta) = shape_q9(xi, eta);
    let (mut r, mut z) = (0.0, 0.0);
    let (mut r_xi, mut r_eta, mut z_xi, mut z_eta) = (0.0, 0.0, 0.0, 0.0);
    for k in 0..9 {
        r += n[k] * xy[k][0];
        z += n[k] * xy[k][1];
        r_xi += nxi[k] * xy[k][0];
        r_eta += neta[k] * xy[k][0];
        z_xi += nxi[k] * xy[k][1];
        z_eta += neta[k] * xy[k][1];
    }
    let det = r_xi * z_eta - r_eta * z_xi;
    let mut dn_dr = [0.0; 9];
    let mut dn_dz = [0.0; 9];
    for k in 0..9 {
        // Inverse Jacobian: [ξ_r ξ_z; η_r η_z] = 1/det [z_η -r_η; -z_ξ r_ξ].
        dn_dr[k] = (nxi[k] * z_eta - neta[k] * z_xi) / det;
        dn_dz[k] = (-nxi[k] * r_eta + neta[k] * r_xi) / det;
    }
    (
        PointGeometry {
            n,
            dn_dr,
            dn_dz,
            r_mm: r,
            z_mm: z,
            det_j: det.abs(),
        },
        det,
    )
}

/// Strain-displacement rows at a point: B is 4 × 18 ([ε_rr, ε_zz, ε_θθ, γ_rz]).
fn b_matrix(g: &PointGeometry) -> [[f64; 18]; 4] {
    let mut b = [[0.0; 18]; 4];
    // On the axis u_r = 0 is imposed; Gauss points never sit on it, so r > 0 here.
    let inv_r = 1.0 / g.r_mm;
    for k in 0..9 {
        b[0][2 * k] = g.dn_dr[k];
        b[1][2 * k + 1] = g.dn_dz[k];
        b[2][2 * k] = g.n[k] * inv_r;
        b[3][2 * k] = g.dn_dz[k];
        b[3][2 * k + 1] = g.dn_dr[k];
    }
    b
}

/// Strain [ε_rr, ε_zz, ε_θθ, γ_rz] at (ξ, η) from the element's nodal displacements.
pub fn strain_at(xy: &[[f64; 2]; 9], u: &[[f64; 2]; 9], xi: f64, eta: f64) -> [f64; 4] {
    let (g, _) = point_geometry(xy, xi, eta);
    let b = b_matrix(&g);
    let mut e = [0.0; 4];
    for (i, row) in b.iter().enumerate() {
        for k in 0..9 {
            e[i] += row[2 * k] * u[k][0] + row[2 * k + 1] * u[k][1];
        }
    }
    e
}

/// An element's stiffness split by modulus: K = μ · `shear` + κ · `bulk`, N/mm per MPa.
/// Both parts depend on the element's shape only, so a change of moduli (a sweep over
/// E, another core or insert on the same mesh) re-uses them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StiffnessParts {
    /// Stiffness per unit shear modulus μ (the deviatoric energy 2μ dev ε : dev ε).
    pub shear: [[f64; 18]; 18],
    /// Stiffness per unit bulk modulus κ (the volumetric energy).
    pub bulk: [[f64; 18]; 18],
}

/// The two parts of an element's stiffness ([`StiffnessParts`]), dofs
/// [u_r0, u_z0, u_r1, …].
pub(crate) fn stiffness_parts(
    xy: &[[f64; 2]; 9],
    formulation: Formulation,
) -> Result<StiffnessParts, ElementError> {
    let (gp, gw) = GAUSS3;
    let mut shear = [[0.0; 18]; 18];
    let mut bulk = [[0.0; 18]; 18];
    // Centroid and size for a well-scaled pressure basis {1, (r - rc)/h, (z - zc)/h}.
    let rc = xy[4][0];
    let zc = xy[4][1];
    let h = ((xy[8][0] - xy[0][0]).powi(2) + (xy[8][1] - xy[0][1]).powi(2))
        .sqrt()
        .max(1e-12);
    let mut m = [[0.0; 3]; 3];
    let mut gmat = [[0.0; 18]; 3];
    let mut sign = 0.0;
    for (i, &xi) in gp.iter().enumerate() {
        for (j, &eta) in gp.iter().enumerate() {
            let (g, det) = point_geometry(xy, xi, eta);
            if det == 0.0 || !det.is_finite() || (sign != 0.0 && det.signum() != sign) {
                return Err(ElementError::Distorted {
                    r_mm: xy[0][0],
                    z_mm: xy[0][1],
                    det_j: det,
                });
            }
            sign = det.signum();
            let dv = 2.0 * PI * g.r_mm * g.det_j * gw[i] * gw[j];
            let b = b_matrix(&g);
            // Deviatoric part per unit μ: σ_dev = 2 dev(ε); the shear row carries γ.
            let mut db = [[0.0; 18]; 4];
            let mut tr = [0.0; 18];
            for c in 0..18 {
                tr[c] = b[0][c] + b[1][c] + b[2][c];
                for (row, brow) in db.iter_mut().zip(&b).take(3) {
                    row[c] = 2.0 * (brow[c] - tr[c] / 3.0);
                }
                db[3][c] = b[3][c];
            }
            // Both parts are symmetric: the upper triangle here, mirrored below.
            for a in 0..18 {
                for c in a..18 {
                    let mut s = 0.0;
                    for row in 0..4 {
                        s += b[row][a] * db[row][c];
                    }
                    shear[a][c] += s * dv;
                }
            }
            match formulation {
                // Plain displacement element: the full volumetric energy κ tr(ε)².
                Formulation::Displacement => {
                    for a in 0..18 {
                        for c in a..18 {
                            bulk[a][c] += tr[a] * tr[c] * dv;
                        }
                    }
                }
                Formulation::MixedQ9P1 => {
                    let np = [1.0, (g.r_mm - rc) / h, (g.z_mm - zc) / h];
                    for p in 0..3 {
                        for q in 0..3 {
                            m[p][q] += np[p] * np[q] * dv;
                        }
                        for c in 0..18 {
                            gmat[p][c] += np[p] * tr[c] * dv;
                        }
                    }
                }
            }
        }
    }
    if formulation == Formulation::MixedQ9P1 {
        // Volumetric energy of the projected volume change: κ Gᵀ M⁻¹ G.
        let minv = invert3(&m).ok_or(ElementError::Distorted {
            r_mm: xy[0][0],
            z_mm: xy[0][1],
            det_j: 0.0,
        })?;
        let mut mg = [[0.0; 18]; 3];
        for p in 0..3 {
            for c in 0..18 {
                mg[p][c] = (0..3).map(|q| minv[p][q] * gmat[q][c]).sum();
            }
        }
        for a in 0..18 {
            for c in a..18 {
                bulk[a][c] = (0..3).map(|p| gmat[p][a] * mg[p][c]).sum();
            }
        }
    }
    for a in 0..18 {
        for c in 0..a {
            shear[a][c] = shear[c][a];
            bulk[a][c] = bulk[c][a];
        }
    }
    Ok(StiffnessParts { shear, bulk })
}

/// Element stiffness (18 × 18, row-major, dofs [u_r0, u_z0, u_r1, …]), N/mm.
pub fn stiffness(
    xy: &[[f64; 2]; 9],
    mat: ElasticConstants,
    formulation: Formulation,
) -> Result<[[f64; 18]; 18], ElementError> {
    let parts = stiffness_parts(xy, formulation)?;
    let (mu, kappa) = (mat.shear_modulus_mpa(), mat.bulk_modulus_mpa());
    let mut k = [[0.0; 18]; 18];
    for ((row, shear), bulk) in k.iter_mut().zip(&parts.shear).zip(&parts.bulk) {
        for ((v, s), b) in row.iter_mut().zip(shear).zip(bulk) {
            *v = mu * s + kappa * b;
        }
    }
    Ok(k)
}

fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    let c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    let c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    let det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    if det.abs() < 1e-300 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    Some([
        [
            c00 * inv,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * inv,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv,
        ],
        [
            c01 * inv,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * inv,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv,
        ],
        [
            c02 * inv,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * inv,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv,
        ],
    ])
}

/// Invert the isoparametric map: natural coordinates of (r, z) in the element, by
/// Newton iteration from the centre. None when it does not converge or lands outside.
pub(crate) fn locate(xy: &[[f64; 2]; 9], r: f64, z: f64) -> Option<(f64, f64)> {
    let (mut xi, mut eta) = (0.0, 0.0);
    for _ in 0..30 {
        let (n, nxi, neta) = shape_q9(xi, eta);
        let (mut pr, mut pz, mut r_xi, mut r_eta, mut z_xi, mut z_eta) =
            (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for k in 0..9 {
            pr += n[k] * xy[k][0];
            pz += n[k] * xy[k][1];
            r_xi += nxi[k] * xy[k][0];
            r_eta += neta[k] * xy[k][0];
            z_xi += nxi[k] * xy[k][1];
            z_eta += neta[k] * xy[k][1];
        }
        let det = r_xi * z_eta - r_eta * z_xi;
        if det == 0.0 {
            return None;
        }
        let (fr, fz) = (r - pr, z - pz);
        let dxi = (z_eta * fr - r_eta * fz) / det;
        let deta = (-z_xi * fr + r_xi * fz) / det;
        xi += dxi;
        eta += deta;
        if xi.abs() > 3.0 || eta.abs() > 3.0 {
            return None;
        }
        if dxi.abs() + deta.abs() < 1e-13 {
            break;
        }
    }
    let tol = 1e-9;
    (xi.abs() <= 1.0 + tol && eta.abs() <= 1.0 + tol)
        .then_some((xi.clamp(-1.0, 1.0), eta.clamp(-1.0, 1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(r0: f64, r1: f64, z0: f64, z1: f64) -> [[f64; 2]; 9] {
        let mut xy = [[0.0; 2]; 9];
        for b in 0..3 {
            for a in 0..3 {
                xy[a + 3 * b] = [
                    r0 + (r1 - r0) * a as f64 / 2.0,
                    z0 + (z1 - z0) * b as f64 / 2.0,
                ];
            }
        }
        xy
    }

    #[test]
    fn shape_functions_partition_unity_and_interpolate_nodes() {
        let (n, nxi, neta) = shape_q9(0.3, -0.7);
        assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        assert!(nxi.iter().sum::<f64>().abs() < 1e-14);
        assert!(neta.iter().sum::<f64>().abs() < 1e-14);
        let (n, _, _) = shape_q9(1.0, 0.0);
        assert!((n[2 + 3] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn rigid_axial_translation_has_no_energy_and_stiffness_is_symmetric() {
        let xy = rect(2.0, 3.0, 0.0, 1.5);
        let mat = ElasticConstants {
            youngs_modulus_mpa: 3.2,
            poisson_ratio: 0.49,
        };
        let k = stiffness(&xy, mat, Formulation::MixedQ9P1).unwrap();
        for a in 0..18 {
            // u_z = 1 everywhere is the only rigid motion in axisymmetry.
            let f: f64 = (0..9).map(|n| k[a][2 * n + 1]).sum();
            assert!(f.abs() < 1e-9 * k[a][a].abs().max(1.0), "row {a}: {f}");
            for c in 0..18 {
                assert!((k[a][c] - k[c][a]).abs() < 1e-9 * (k[a][a] * k[c][c]).sqrt());
            }
        }
    }

    #[test]
    fn locate_inverts_a_curved_element() {
        let mut xy = rect(2.0, 3.0, 0.0, 1.5);
        xy[1][1] -= 0.1; // bow the bottom edge
        let (g, _) = point_geometry(&xy, 0.25, -0.6);
        let (xi, eta) = locate(&xy, g.r_mm, g.z_mm).unwrap();
        assert!((xi - 0.25).abs() < 1e-10 && (eta + 0.6).abs() < 1e-10);
        assert!(locate(&xy, 10.0, 0.0).is_none());
    }
}
