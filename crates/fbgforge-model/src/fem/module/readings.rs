//! Reading a solved module: the axial strain a grating feels, averaged over its
//! length on the fiber axis in the web ring, or sampled along it (the profile the
//! transfer-matrix model of the grating takes, `crate::prediction::spectrum`).

use super::ModuleModel;
use crate::fem::solve::Solution;
use anyhow::{anyhow, bail, Result};
use serde::Serialize;

/// The axial strain along one grating, sampled at the quadrature points of the mean
/// (3 Gauss points in each of at least 16 pieces cut at the mesh's z-breaks), so that
/// the weighted mean of the samples *is* the grating's mean strain.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxialStrainProfile {
    /// Positions along the grating from its start (z_start), mm, increasing.
    pub z_mm: Vec<f64>,
    /// Quadrature weight of each sample, mm (they sum to the grating's length).
    pub weight_mm: Vec<f64>,
    /// Axial strain ε_zz at each sample (per newton when read from a 1 N solve).
    pub strain: Vec<f64>,
}

impl AxialStrainProfile {
    /// The weighted mean strain over the grating (the reading the policy's K is made of).
    pub fn mean(&self) -> f64 {
        let len: f64 = self.weight_mm.iter().sum();
        self.strain
            .iter()
            .zip(&self.weight_mm)
            .map(|(e, w)| e * w)
            .sum::<f64>()
            / len
    }

    /// The profile with `delta` added to every sample (a Richardson step on the mean,
    /// carried by the fine mesh's shape).
    pub fn shifted(&self, delta: f64) -> Self {
        AxialStrainProfile {
            strain: self.strain.iter().map(|e| e + delta).collect(),
            ..self.clone()
        }
    }
}

impl ModuleModel {
    /// The quadrature points (absolute z, mm) and weights (mm) of the grating z0..z1.
    fn grating_quadrature(&self, z0: f64, z1: f64) -> Result<Vec<(f64, f64)>> {
        if z1.partial_cmp(&z0) != Some(std::cmp::Ordering::Greater) {
            bail!("grating range {z0}..{z1} mm is empty");
        }
        let mut cuts: Vec<f64> = vec![z0, z1];
        cuts.extend(
            self.z_breaks_mm
                .iter()
                .copied()
                .filter(|&z| z > z0 && z < z1),
        );
        let n_min = 16;
        for k in 1..n_min {
            cuts.push(z0 + (z1 - z0) * k as f64 / n_min as f64);
        }
        cuts.sort_by(|a, b| a.total_cmp(b));
        cuts.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        let (gp, gw) = crate::fem::element::GAUSS3;
        let mut points = Vec::with_capacity(3 * cuts.len());
        for w in cuts.windows(2) {
            let half = 0.5 * (w[1] - w[0]);
            for (p, wt) in gp.iter().zip(gw) {
                points.push((0.5 * (w[0] + w[1]) + half * p, wt * half));
            }
        }
        Ok(points)
    }

    /// Axial strain ε_zz sampled along z ∈ [z0, z1] on the fiber axis.
    pub fn axial_strain_profile(
        &self,
        sol: &Solution,
        z0: f64,
        z1: f64,
    ) -> Result<AxialStrainProfile> {
        let elems: Vec<usize> = self.web_elements.clone().collect();
        let points = self.grating_quadrature(z0, z1)?;
        let mut out = AxialStrainProfile {
            z_mm: Vec::with_capacity(points.len()),
            weight_mm: Vec::with_capacity(points.len()),
            strain: Vec::with_capacity(points.len()),
        };
        for (z, w) in points {
            let e = sol
                .strain_at(&self.problem.mesh, Some(&elems), self.fiber_radius_mm, z)
                .ok_or_else(|| {
                    anyhow!(
                        "grating point (r = {:.3} mm, z = {z:.3} mm) lies outside the pillar ring",
                        self.fiber_radius_mm
                    )
                })?;
            out.z_mm.push(z - z0);
            out.weight_mm.push(w);
            out.strain.push(e[1]);
        }
        Ok(out)
    }

    /// Axial strain ε_zz averaged over z ∈ [z0, z1] on the fiber axis.
    pub fn mean_axial_strain(&self, sol: &Solution, z0: f64, z1: f64) -> Result<f64> {
        let elems: Vec<usize> = self.web_elements.clone().collect();
        let mut sum = 0.0;
        for (z, wt) in self.grating_quadrature(z0, z1)? {
            let e = sol
                .strain_at(&self.problem.mesh, Some(&elems), self.fiber_radius_mm, z)
                .ok_or_else(|| {
                    anyhow!(
                        "grating point (r = {:.3} mm, z = {z:.3} mm) lies outside the pillar ring",
                        self.fiber_radius_mm
                    )
                })?;
            sum += e[1] * wt;
        }
        Ok(sum / (z1 - z0))
    }
}
