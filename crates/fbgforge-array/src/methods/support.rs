//! `support` and `wsupport`: exact ℓ0-penalised bounded least squares over every
//! support of up to m cells; `wsupport` scores each support by its Laplace-approximated
//! evidence under the [`NoisePrior`] instead of the plain residual.

use super::*;

/// The registry entry of `support`.
pub(super) const SUPPORT: MethodEntry = MethodEntry {
    name: "support",
    penalty_grid: doubling_grid,
    defaults: |prior| MethodSettings::Support(SupportSettings::for_prior(prior)),
};

/// The registry entry of `wsupport`.
pub(super) const WEIGHTED_SUPPORT: MethodEntry = MethodEntry {
    name: "wsupport",
    penalty_grid: || (0..13).map(|k| 0.25 * 1.5f64.powi(k)).collect(),
    defaults: |prior| MethodSettings::WeightedSupport(WeightedSupportSettings::for_prior(prior)),
};

/// Settings of `support`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SupportSettings {
    /// λ per non-zero load, pm² (with normalised columns the working unknown is in
    /// pm): the price of one more load in squared residual.
    pub penalty: f64,
    /// Most simultaneous loads a support may hold: supports grow as C(n, ≤ K)
    /// instead of 2ⁿ. Capped at the number of gratings.
    pub max_loads: usize,
}

impl SupportSettings {
    /// For readings of this kind: λ from the resolution
    /// ([`l0_penalty_for_resolution`]: 4 at the paper's 0.5 pm) and its load cap.
    pub fn for_prior(prior: &ReadingSettings) -> Self {
        SupportSettings {
            penalty: l0_penalty_for_resolution(prior.resolution_pm),
            max_loads: prior.max_loads,
        }
    }
}

impl Default for SupportSettings {
    /// The paper's readings.
    fn default() -> Self {
        Self::for_prior(&ReadingSettings::paper())
    }
}

impl Knobs for SupportSettings {
    fn method(&self) -> Method {
        Method::Support
    }
    fn build(&self, common: Common) -> Result<Box<dyn Reconstructor>, ArrayError> {
        Ok(Box::new(SupportSearch::new(
            common,
            self.penalty,
            None,
            self.max_loads,
        )?))
    }
    fn penalty_mut(&mut self) -> Option<&mut f64> {
        Some(&mut self.penalty)
    }
    fn max_loads_mut(&mut self) -> Option<&mut usize> {
        Some(&mut self.max_loads)
    }
}

/// Settings of `wsupport`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WeightedSupportSettings {
    /// λ per non-zero load, in units of the negative log-likelihood (a small extra
    /// price on top of the evidence; 4, chosen on the protocol's seeds 1001–1020).
    pub penalty: f64,
    /// Most simultaneous loads a support may hold (as `support`).
    pub max_loads: usize,
    /// Noise the likelihood assumes. It keeps the paper's numbers whatever the
    /// prior's resolution (the tuned penalty was chosen with them).
    pub noise_prior: NoisePrior,
}

impl WeightedSupportSettings {
    /// For readings of this kind: the load cap; the tuned penalty and the paper's
    /// noise.
    pub fn for_prior(prior: &ReadingSettings) -> Self {
        WeightedSupportSettings {
            penalty: 4.0,
            max_loads: prior.max_loads,
            noise_prior: NoisePrior::paper(),
        }
    }
}

impl Default for WeightedSupportSettings {
    /// The paper's readings.
    fn default() -> Self {
        Self::for_prior(&ReadingSettings::paper())
    }
}

impl Knobs for WeightedSupportSettings {
    fn method(&self) -> Method {
        Method::WeightedSupport
    }
    fn build(&self, common: Common) -> Result<Box<dyn Reconstructor>, ArrayError> {
        Ok(Box::new(SupportSearch::new(
            common,
            self.penalty,
            Some(self.noise_prior),
            self.max_loads,
        )?))
    }
    fn penalty_mut(&mut self) -> Option<&mut f64> {
        Some(&mut self.penalty)
    }
    fn max_loads_mut(&mut self) -> Option<&mut usize> {
        Some(&mut self.max_loads)
    }
}

/// What the `wsupport` method knows about the measurement noise (datasheet-level
/// numbers, not the simulation's draws). Two facts shape it:
///
/// * A per-load error that every grating sees in proportion to its sensitivity
///   (hysteresis, linearity, a column's calibration scale) moves y along the columns
///   of the true support: A·diag(e)·x lies in the span of A_S. Such a term changes the
///   fitted loads but not the residual, and by Kruskal's theorem the generalised least
///   squares estimate with covariance σ²I + A_S D A_Sᵀ equals the ordinary one. It
///   therefore plays no part in choosing between supports and is not modelled.
/// * What leaves the span is the interrogator noise (σ² on every grating) and the
///   additivity error of simultaneous loads, a relative error of each grating's
///   reading, variance (a²/3)·ŷ_i² for a uniform ± a. It grows with the signal, so a
///   fixed residual penalty (`support`) is too lenient for strong frames and too
///   strict for weak ones.
///
/// `wsupport` scores each support by the Gaussian negative log-likelihood under this
/// covariance (one hypothesis for a single load, another for several) plus λ·|S|.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NoisePrior {
    /// Standard deviation of the interrogator noise, pm.
    pub resolution_pm: f64,
    /// Bound of the relative additivity error of each reading when two or more loads
    /// act (uniform in ± this).
    pub additivity_frac: f64,
    /// Load each column of the matrix was calibrated with, g (its noise grows with
    /// the load being reconstructed).
    pub calibration_load_g: f64,
}

impl NoisePrior {
    /// The paper's numbers: 0.5 pm resolution; the ± 4 % additivity term the simulated
    /// protocol is sized with (docs/array.md §4).
    pub fn paper() -> Self {
        NoisePrior {
            resolution_pm: 0.5,
            additivity_frac: 0.04,
            calibration_load_g: 200.0,
        }
    }
}

pub(super) struct SupportEntry {
    pub(super) cols: Vec<usize>,
    /// Pseudo-inverse (ÂₛᵀÂₛ)⁻¹Âₛᵀ, k × m row-major.
    pub(super) pinv: Vec<f64>,
    /// Âₛ columns, k × m (column a of the support at [a*m..(a+1)*m]).
    pub(super) cols_data: Vec<f64>,
    /// −2 ln of the support's prior and of its loads' prior volume (`wsupport`):
    /// 2 ln C(n, k) (every load count equally likely a priori, every support of that
    /// count too) + 2 Σ ln(upper_a − lower_a) (loads uniform on [min_load, ulimit],
    /// lower_a = 0 without a load range) − k ln 2π (the
    /// Gaussian part of the Laplace evidence).
    pub(super) occam: f64,
}

pub(super) struct SupportSearch {
    pub(super) common: Common,
    pub(super) lambda: f64,
    /// Noise the likelihood-scored variant (`wsupport`) assumes; None for `support`.
    pub(super) prior: Option<NoisePrior>,
    /// Supports sorted by size.
    pub(super) entries: Vec<SupportEntry>,
}

/// ln Φ(t), the log of the standard normal distribution function, accurate in the far
/// left tail (where Φ underflows): ln Φ(t) = ln(½ erfc(−t/√2)), with erfc from the
/// Chebyshev fit of Numerical Recipes (§6.2, relative error < 1.2e−7 everywhere),
/// which gives ln erfc directly for large arguments.
pub(crate) fn ln_normal_cdf(t: f64) -> f64 {
    let x = -t / std::f64::consts::SQRT_2;
    let ax = x.abs();
    let tt = 1.0 / (1.0 + 0.5 * ax);
    let poly = -1.265_512_23
        + tt * (1.000_023_68
            + tt * (0.374_091_96
                + tt * (0.096_784_18
                    + tt * (-0.186_288_06
                        + tt * (0.278_868_07
                            + tt * (-1.135_203_98
                                + tt * (1.488_515_87
                                    + tt * (-0.822_152_23 + tt * 0.170_872_77))))))));
    // ln erfc(|x|)
    let ln_erfc_abs = tt.ln() - ax * ax + poly;
    if x >= 0.0 {
        ln_erfc_abs - std::f64::consts::LN_2
    } else {
        // erfc(x) = 2 − erfc(|x|) for x < 0.
        (-0.5 * ln_erfc_abs.exp()).ln_1p()
    }
}

/// ln C(n, k).
fn ln_binom(n: usize, k: usize) -> f64 {
    (0..k).map(|i| ((n - i) as f64 / (k - i) as f64).ln()).sum()
}

/// Supports at most this many (2^16 cells' worth is already too slow per frame).
const MAX_SUPPORTS: usize = 70_000;

impl SupportSearch {
    pub(super) fn new(
        common: Common,
        lambda: f64,
        prior: Option<NoisePrior>,
        max_loads: usize,
    ) -> Result<Self, ArrayError> {
        let (m, n) = (common.problem.n_gratings(), common.n());
        if max_loads == 0 {
            return Err(ArrayError::Input("max_loads must be at least 1".into()));
        }
        let kmax = m.min(n).min(max_loads);
        let mut count: f64 = 0.0;
        let mut binom: f64 = 1.0;
        for k in 1..=kmax {
            binom = binom * (n + 1 - k) as f64 / k as f64;
            count += binom;
        }
        if count > MAX_SUPPORTS as f64 {
            return Err(ArrayError::Input(format!(
                "support enumeration would try {count:.0} supports of up to {kmax} loads for {n} cells \
                 and {m} gratings (limit {MAX_SUPPORTS}); use `bnb` (the `support` objective by \
                 branch and bound) or the default method choice for arrays this large, or lower \
                 --max-loads"
            )));
        }
        let mut entries = Vec::new();
        for k in 1..=kmax {
            let mut cols: Vec<usize> = (0..k).collect();
            loop {
                let a_s = DMatrix::from_fn(m, k, |i, a| common.problem.working[(i, cols[a])]);
                let g = a_s.transpose() * &a_s;
                // Skip supports whose columns are (nearly) dependent: a smaller support
                // explains the same shifts.
                let eig = g.clone().symmetric_eigenvalues();
                let (lo, hi) = eig
                    .iter()
                    .fold((f64::INFINITY, 0.0f64), |(l, h), &e| (l.min(e), h.max(e)));
                if lo > 1e-12 * hi {
                    if let Some(ch) = g.cholesky() {
                        let p = ch.solve(&a_s.transpose());
                        entries.push(SupportEntry {
                            cols: cols.clone(),
                            pinv: (0..k * m).map(|q| p[(q / m, q % m)]).collect(),
                            cols_data: (0..k * m).map(|q| a_s[(q % m, q / m)]).collect(),
                            occam: 2.0 * ln_binom(n, k)
                                + cols
                                    .iter()
                                    .map(|&j| {
                                        let p = &common.problem;
                                        2.0 * (p.upper[j] - p.lower[j]).max(1e-300).ln()
                                    })
                                    .sum::<f64>()
                                - k as f64 * (2.0 * std::f64::consts::PI).ln(),
                        });
                    }
                }
                // Next k-combination in lexicographic order.
                let mut i = k;
                while i > 0 && cols[i - 1] == n - k + i - 1 {
                    i -= 1;
                }
                if i == 0 {
                    break;
                }
                cols[i - 1] += 1;
                for q in i..k {
                    cols[q] = cols[q - 1] + 1;
                }
            }
        }
        Ok(SupportSearch {
            common,
            lambda,
            prior,
            entries,
        })
    }

    /// Misfit ‖y − Âₛz‖² of a support's solution.
    fn misfit_on(e: &SupportEntry, y: &[f64], z: &[f64]) -> f64 {
        let m = y.len();
        let mut rr = 0.0;
        for (i, yi) in y.iter().enumerate() {
            let mut fit = 0.0;
            for (a, za) in z.iter().enumerate() {
                fit += e.cols_data[a * m + i] * za;
            }
            rr += (yi - fit) * (yi - fit);
        }
        rr
    }

    /// Bounded least squares on one support, exactly ([`bounded::box_qp`]), from its
    /// Gram matrix G = ÂₛᵀWÂₛ and b = ÂₛᵀWy; None when the optimum has a load at 0
    /// (a smaller support's solution, valued on its own) or G is singular.
    fn bounded_sub(&self, cols: &[usize], g: &DMatrix<f64>, b: &DVector<f64>) -> Option<Vec<f64>> {
        let k = cols.len();
        let u = DVector::from_fn(k, |a, _| self.common.problem.upper[cols[a]]);
        let s = bounded::box_qp(g, b, &DVector::zeros(k), &u)?;
        if s.iter().any(|&v| v <= 0.0) {
            return None;
        }
        Some(s.iter().copied().collect())
    }

    /// `support`: plain residuals, fixed penalty per load. Exact at the ceiling: a
    /// support whose unconstrained fit has a negative load is skipped only when no
    /// load is above its bound ([`bounded::needs_bounded_solve`]); every other
    /// support that leaves the box gets the exact bounded solve. Returns the best
    /// support and its loads, and the work done (supports valued, each bounded solve
    /// counted as [`BOUNDED_SOLVE_UNITS`]).
    fn search_plain(&self, y: &[f64]) -> (Option<(usize, Vec<f64>)>, u64) {
        let m = y.len();
        let upper = &self.common.problem.upper;
        let mut best_cost: f64 = y.iter().map(|v| v * v).sum::<f64>();
        let mut best: Option<(usize, Vec<f64>)> = None;
        // k ≤ 64 always: MAX_SUPPORTS rejects any array where supports could be larger.
        let mut z = [0.0f64; 64];
        let mut tried = 0u64;
        let mut aty: Option<DVector<f64>> = None;
        for (e_idx, e) in self.entries.iter().enumerate() {
            let k = e.cols.len();
            let floor = self.lambda * k as f64;
            if floor >= best_cost {
                break; // sorted by size: no larger support can win
            }
            tried += 1;
            let (mut negative, mut above) = (false, false);
            for a in 0..k {
                let row = &e.pinv[a * m..(a + 1) * m];
                let v: f64 = row.iter().zip(y).map(|(p, yi)| p * yi).sum();
                negative |= v < 0.0;
                above |= v > upper[e.cols[a]];
                z[a] = v;
            }
            // A negative load with every load below its bound: the bounded optimum
            // has that load at 0, a smaller support's solution, tried on its own.
            if negative && !above {
                continue;
            }
            // The unconstrained misfit is a lower bound of the bounded one.
            let rr = Self::misfit_on(e, y, &z[..k]);
            if rr + floor >= best_cost {
                continue;
            }
            let (cost, zs) = if !negative && !above {
                (rr + floor, z[..k].to_vec())
            } else {
                tried += BOUNDED_SOLVE_UNITS;
                let aty = aty.get_or_insert_with(|| {
                    self.common.problem.working.transpose() * DVector::from_column_slice(y)
                });
                let g = DMatrix::from_fn(k, k, |a, b| self.common.gram[(e.cols[a], e.cols[b])]);
                let b = DVector::from_fn(k, |a, _| aty[e.cols[a]]);
                let Some(zb) = self.bounded_sub(&e.cols, &g, &b) else {
                    continue;
                };
                (Self::misfit_on(e, y, &zb) + floor, zb)
            };
            if cost < best_cost {
                best_cost = cost;
                best = Some((e_idx, zs));
            }
        }
        (best, tried)
    }

    /// `wsupport`: each support S is scored by −2 ln of its Laplace-approximated
    /// evidence, χ² + ln det Σ + ln det G + [`SupportEntry::occam`], plus λ·|S|:
    ///
    /// * the loads are the generalised least-squares fit with the weights
    ///   1/(σ² + (a²/3)·y_i²) (several loads) or 1/σ² (one load), the observed reading
    ///   standing in for the prediction in the additivity variance; G = ÂₛᵀWÂₛ;
    /// * χ² and ln det Σ are then evaluated with the support's own covariance: σ², plus
    ///   (a²/3)·(Âₛz)_i² for several loads, plus σ²·Σ_j (x_j/x_cal)² from the
    ///   calibration readings' noise (each column was read once at x_cal);
    /// * with a load range (`min_load_g` > 0) the loads' prior is uniform on
    ///   [min_load, ulimit], and the score adds −2 Σ ln Φ((z_a − l_a)/sd_a), the share
    ///   of each load's Laplace posterior N(z_a, (G⁻¹)_aa) above min_load: a support
    ///   whose fit needs a load well below the rated range pays for it, one whose
    ///   small load is within noise of min_load hardly does.
    ///
    /// λ only absorbs what the Gaussian model gets wrong (uniform errors, the fit
    /// standing in for the true loads).
    fn search_likelihood(&self, y: &[f64], prior: NoisePrior) -> LikelihoodOutcome {
        let frame = LikelihoodFrame::new(&self.common, y, prior);
        let mut best_cost = y.iter().map(|v| v * v / frame.var0).sum::<f64>() + frame.ln_var0_sum;
        let mut best: Option<(usize, Vec<f64>)> = None;
        let mut tried = 0u64;
        let mut skipped_on_heuristic = false;
        // k ≤ 64 always: MAX_SUPPORTS rejects any array where supports could be larger.
        let mut l = [0.0f64; 64 * 64];
        let mut z = [0.0f64; 64];
        // Posterior standard deviations of the loads and a column of L⁻¹ (load range).
        let (mut sd, mut w) = ([0.0f64; 64], [0.0f64; 64]);
        for (e_idx, e) in self.entries.iter().enumerate() {
            let k = e.cols.len();
            let (g, b) = &frame.sets[usize::from(k >= 2)];
            // Cholesky of the k × k weighted Gram matrix, then z = G⁻¹b.
            if !cholesky_on(g, &e.cols, &mut l) {
                continue;
            }
            let ln_det_g: f64 = (0..k).map(|r| 2.0 * l[r * k + r].ln()).sum();
            let prior_cost = self.lambda * k as f64 + e.occam + ln_det_g;
            // χ² ≥ 0 and ln det Σ ≥ m ln σ²: a lower bound of this support's score.
            if prior_cost + frame.ln_var0_sum >= best_cost {
                continue;
            }
            tried += 1;
            cholesky_solve(&l, k, |r| b[e.cols[r]], &mut z);
            let negative = z[..k].iter().any(|&v| v < 0.0);
            let above = (0..k).any(|a| z[a] > frame.problem.upper[e.cols[a]]);
            if negative && !above {
                continue; // a smaller support's solution, tried on its own
            }
            // Needed only for the load-range prior.
            if frame.use_lower {
                posterior_sds(&l, k, &mut sd, &mut w);
            }
            let (cost, zs) = if !negative && !above {
                (frame.score(e, &sd, prior_cost, &z[..k]), z[..k].to_vec())
            } else {
                // The unconstrained fit (without negative loads) scores at least as
                // well as the bounded one in practice (it minimises the weighted
                // misfit; only the re-evaluated covariance could reverse that): a
                // support that loses unconstrained is not given the costly bounded
                // solve, and the frame is then not certified.
                if !negative && frame.score(e, &sd, prior_cost, &z[..k]) >= best_cost {
                    skipped_on_heuristic = true;
                    continue;
                }
                tried += BOUNDED_SOLVE_UNITS;
                let gs = DMatrix::from_fn(k, k, |a, q| g[(e.cols[a], e.cols[q])]);
                let bs = DVector::from_fn(k, |a, _| b[e.cols[a]]);
                let Some(zb) = self.bounded_sub(&e.cols, &gs, &bs) else {
                    continue;
                };
                (frame.score(e, &sd, prior_cost, &zb), zb)
            };
            if cost < best_cost {
                best_cost = cost;
                best = Some((e_idx, zs));
            }
        }
        LikelihoodOutcome {
            best,
            tried,
            certified: !skipped_on_heuristic,
        }
    }
}

/// What the `wsupport` search found in one frame.
struct LikelihoodOutcome {
    best: Option<(usize, Vec<f64>)>,
    tried: u64,
    certified: bool,
}

/// One frame's constants for the `wsupport` search: noise variances and the weighted
/// normal equations.
struct LikelihoodFrame<'a> {
    problem: &'a SensingProblem,
    y: &'a [f64],
    prior: NoisePrior,
    /// σ², pm².
    var0: f64,
    /// a²/3, the relative additivity variance.
    add: f64,
    /// m ln σ².
    ln_var0_sum: f64,
    /// Whether the load range's prior applies (`min_load_g` > 0).
    use_lower: bool,
    /// Weighted normal equations (ÂᵀWÂ, ÂᵀWy) for one load (index 0) and for several (index 1).
    sets: Vec<(DMatrix<f64>, DVector<f64>)>,
}

impl<'a> LikelihoodFrame<'a> {
    /// The noise variances and weighted normal equations for frame `y`.
    fn new(common: &'a Common, y: &'a [f64], prior: NoisePrior) -> Self {
        let m = y.len();
        let n = common.n();
        let problem = &common.problem;
        let a_w = &problem.working;
        let var0 = (prior.resolution_pm * prior.resolution_pm).max(1e-12);
        let add = prior.additivity_frac * prior.additivity_frac / 3.0;
        let sets: Vec<(DMatrix<f64>, DVector<f64>)> = [0.0, add]
            .iter()
            .map(|&rel| {
                let wa = DMatrix::from_fn(m, n, |i, j| a_w[(i, j)] / (var0 + rel * y[i] * y[i]));
                (
                    a_w.transpose() * &wa,
                    wa.transpose() * DVector::from_column_slice(y),
                )
            })
            .collect();
        LikelihoodFrame {
            problem,
            y,
            prior,
            var0,
            add,
            ln_var0_sum: m as f64 * var0.ln(),
            use_lower: problem.min_load_g > 0.0,
            sets,
        }
    }

    /// The support `e`'s score at loads zs, with its own covariance (`sd`: the loads'
    /// posterior standard deviations, used with a load range).
    fn score(&self, e: &SupportEntry, sd: &[f64], prior_cost: f64, zs: &[f64]) -> f64 {
        let (problem, y, var0, add) = (self.problem, self.y, self.var0, self.add);
        let (m, k) = (y.len(), e.cols.len());
        // Calibration noise: a column's entries carry σ/x_cal of noise, so a
        // load x_j adds σ²(x_j/x_cal)² to every grating's variance.
        let calibration_var: f64 = var0
            * (0..k)
                .map(|a| {
                    let x_rel = zs[a] / problem.scale[e.cols[a]] / self.prior.calibration_load_g;
                    x_rel * x_rel
                })
                .sum::<f64>();
        let mut chi2 = 0.0;
        let mut ln_det_sigma = 0.0;
        for (i, yi) in y.iter().enumerate() {
            let fit: f64 = (0..k).map(|a| e.cols_data[a * m + i] * zs[a]).sum();
            let additivity_var = if k >= 2 { add * fit * fit } else { 0.0 };
            let v = var0 + additivity_var + calibration_var;
            chi2 += (yi - fit) * (yi - fit) / v;
            ln_det_sigma += v.ln();
        }
        // Load-range prior: the evidence integrates the likelihood over the
        // prior box [min_load, ulimit]; the Laplace posterior N(z, G⁻¹) puts
        // the share Φ((z_a − l_a)/sd_a) of each load's mass above min_load
        // (marginals, correlations neglected). −2 ln of that share charges a
        // fit that needs a load well below min_load, allowing for noise.
        let range: f64 = if self.use_lower {
            (0..k)
                .map(|a| {
                    let lo = problem.lower[e.cols[a]];
                    -2.0 * ln_normal_cdf((zs[a] - lo) / sd[a].max(1e-300))
                })
                .sum()
        } else {
            0.0
        };
        chi2 + ln_det_sigma + prior_cost + range
    }
}

/// Cholesky factor L (row-major, k × k with k = `cols.len()`) of `g` restricted to
/// `cols`; false if that matrix is not positive definite.
fn cholesky_on(g: &DMatrix<f64>, cols: &[usize], l: &mut [f64]) -> bool {
    let k = cols.len();
    for r in 0..k {
        for q in 0..=r {
            let mut v = g[(cols[r], cols[q])];
            for t in 0..q {
                v -= l[r * k + t] * l[q * k + t];
            }
            if r == q {
                if v <= 0.0 {
                    return false;
                }
                l[r * k + r] = v.sqrt();
            } else {
                l[r * k + q] = v / l[q * k + q];
            }
        }
    }
    true
}

/// z = (LLᵀ)⁻¹b by forward then back substitution, b given entry by entry.
fn cholesky_solve(l: &[f64], k: usize, b: impl Fn(usize) -> f64, z: &mut [f64]) {
    for r in 0..k {
        let mut v = b(r);
        for t in 0..r {
            v -= l[r * k + t] * z[t];
        }
        z[r] = v / l[r * k + r];
    }
    for r in (0..k).rev() {
        let mut v = z[r];
        for t in r + 1..k {
            v -= l[t * k + r] * z[t];
        }
        z[r] = v / l[r * k + r];
    }
}

/// Posterior standard deviation of each load (working units): the diagonal of
/// G⁻¹ = L⁻ᵀL⁻¹, column a of L⁻¹ by forward substitution (`w` is scratch).
fn posterior_sds(l: &[f64], k: usize, sd: &mut [f64], w: &mut [f64]) {
    for (a, sd_a) in sd.iter_mut().enumerate().take(k) {
        let mut var = 0.0;
        for r in a..k {
            let mut v = if r == a { 1.0 } else { 0.0 };
            for t in a..r {
                v -= l[r * k + t] * w[t];
            }
            w[r] = v / l[r * k + r];
            var += w[r] * w[r];
        }
        *sd_a = var.sqrt();
    }
}

impl Reconstructor for SupportSearch {
    fn method(&self) -> Method {
        if self.prior.is_some() {
            Method::WeightedSupport
        } else {
            Method::Support
        }
    }

    /// `support`: ‖Âz − y‖² + λ·|S|; `wsupport` scores supports, not loads: None.
    fn objective(&self, y: &[f64], loads_g: &[f64]) -> Option<f64> {
        if self.prior.is_some() {
            return None;
        }
        let (misfit, _) = self.common.misfit_of(y, loads_g)?;
        Some(misfit + self.lambda * loads_g.iter().filter(|&&x| x > 0.0).count() as f64)
    }

    fn reconstruct(&self, y: &[f64]) -> Reconstruction {
        if self.common.problem.check_shifts(y).is_err() {
            return self.common.unusable();
        }
        let (best, tried, certified) = match self.prior {
            Some(p) => {
                let o = self.search_likelihood(y, p);
                (o.best, o.tried, o.certified)
            }
            None => {
                let (b, t) = self.search_plain(y);
                (b, t, true)
            }
        };
        let mut full = vec![0.0; self.common.n()];
        if let Some((e_idx, zb)) = best {
            for (a, &j) in self.entries[e_idx].cols.iter().enumerate() {
                full[j] = zb[a];
            }
        }
        let mut r = self.common.finish(&full, y, true, tried);
        r.certified = certified;
        r
    }
}
