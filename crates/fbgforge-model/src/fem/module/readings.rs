//! Reading a solved module: the axial strain a grating feels, averaged over its
//! length on the fiber axis in the web ring.

use super::ModuleModel;
use crate::fem::solve::Solution;
use anyhow::{anyhow, bail, Result};

impl ModuleModel {
    /// Axial strain ε_zz averaged over z ∈ [z0, z1] on the fiber axis.
    pub fn mean_axial_strain(&self, sol: &Solution, z0: f64, z1: f64) -> Result<f64> {
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
        let elems: Vec<usize> = self.web_elements.clone().collect();
        let (gp, gw) = crate::fem::element::GAUSS3;
        let mut sum = 0.0;
        for w in cuts.windows(2) {
            let half = 0.5 * (w[1] - w[0]);
            for (p, wt) in gp.iter().zip(gw) {
                let z = 0.5 * (w[0] + w[1]) + half * p;
                let e = sol
                    .strain_at(&self.problem.mesh, Some(&elems), self.fiber_radius_mm, z)
                    .ok_or_else(|| anyhow!("grating point (r = {:.3} mm, z = {z:.3} mm) lies outside the pillar ring", self.fiber_radius_mm))?;
                sum += e[1] * wt * half;
            }
        }
        Ok(sum / (z1 - z0))
    }
}
