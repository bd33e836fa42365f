//! Strided copies of the shift and force samples over a span, the input of every
//! lag-model fit (clock offset and per grating), and the costs built on them.

use crate::fit::LagModelCost;

/// Strided copy of the samples inside [a, b] for fitting.
pub(super) struct FitData {
    /// Shift sample times, s.
    pub(super) st: Vec<f64>,
    /// Shifts, pm.
    sv: Vec<f64>,
    /// Force sample times, s.
    pub(super) ft: Vec<f64>,
    /// Forces, N.
    fv: Vec<f64>,
    /// Middle of the shift samples' span (the drift's origin), s.
    t_mid: f64,
    /// Force-clock stretches left out of the fit (see [`LagModelCost::excluded_s`]), s.
    excluded_s: Vec<(f64, f64)>,
}

impl FitData {
    /// Shift samples (tw, s) inside [a, b], strided to at most `max_wl`; force samples
    /// (u, f) over the same span plus `memory_s` before and after, strided to at most
    /// `max_force`; `excluded_s`: stretches of the force clock (u) left out of the fit.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        tw: &[f64],
        s: &[f64],
        u: &[f64],
        f: &[f64],
        a: f64,
        b: f64,
        max_wl: usize,
        max_force: usize,
        memory_s: f64,
        excluded_s: &[(f64, f64)],
    ) -> Self {
        let idx: Vec<usize> = (0..tw.len())
            .filter(|&i| tw[i] >= a && tw[i] <= b && s[i].is_finite())
            .collect();
        let stride = idx.len().div_ceil(max_wl.max(1)).max(1);
        let st: Vec<f64> = idx.iter().step_by(stride).map(|&i| tw[i]).collect();
        let sv: Vec<f64> = idx.iter().step_by(stride).map(|&i| s[i]).collect();
        let lo = u.partition_point(|&x| x < a - memory_s).saturating_sub(1);
        let hi = (u.partition_point(|&x| x <= b + memory_s) + 1).min(u.len());
        let n = hi.saturating_sub(lo);
        let fs = n.div_ceil(max_force.max(1)).max(1);
        let ft: Vec<f64> = (lo..hi).step_by(fs).map(|i| u[i]).collect();
        let fv: Vec<f64> = (lo..hi).step_by(fs).map(|i| f[i]).collect();
        let t_mid = if st.is_empty() {
            0.0
        } else {
            (st[0] + st[st.len() - 1]) / 2.0
        };
        FitData {
            st,
            sv,
            ft,
            fv,
            t_mid,
            excluded_s: excluded_s.to_vec(),
        }
    }

    /// The shift samples: times and shifts.
    pub(super) fn shift(&self) -> (&[f64], &[f64]) {
        (&self.st, &self.sv)
    }

    /// The force samples: times and forces.
    pub(super) fn force(&self) -> (&[f64], &[f64]) {
        (&self.ft, &self.fv)
    }

    /// The drift's origin, s.
    pub(super) fn t_mid(&self) -> f64 {
        self.t_mid
    }

    /// Whether force-clock time `u` lies in a stretch left out (`cursor` walks the
    /// stretches along increasing `u`).
    pub(super) fn excluded(&self, u: f64, cursor: &mut usize) -> bool {
        let ex = &self.excluded_s;
        while *cursor < ex.len() && ex[*cursor].1 < u {
            *cursor += 1;
        }
        *cursor < ex.len() && ex[*cursor].0 <= u
    }

    /// The cost with the offset free within `w` of `delta`.
    pub(super) fn cost_around(&self, delta: f64, w: f64) -> LagModelCost<'_> {
        LagModelCost {
            offset_range_s: Some((delta - w, delta + w)),
            ..self.cost(None)
        }
    }

    pub(super) fn cost(&self, fixed: Option<f64>) -> LagModelCost<'_> {
        LagModelCost {
            shift_t: &self.st,
            shift_pm: &self.sv,
            force_t: &self.ft,
            force_n: &self.fv,
            fixed_offset_s: fixed,
            offset_range_s: None,
            t_mid: self.t_mid,
            excluded_s: &self.excluded_s,
        }
    }

    /// The cost with the clocks aligned and a transport delay of at most `max_delay_s`
    /// free (parameters: −delay, ln τ, logit r).
    pub(super) fn cost_with_delay(&self, max_delay_s: f64) -> LagModelCost<'_> {
        LagModelCost {
            offset_range_s: Some((-max_delay_s, max_delay_s)),
            ..self.cost(None)
        }
    }
}
