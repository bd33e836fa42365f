//! The angles at which every circle of a module part is cut: the part's special angles
//! (pillar and slot edges) subdivided so no face patch spans more than 90°, and the
//! coarser subset used above the band, where the circles near an apex are small.

use std::f64::consts::{FRAC_PI_2, TAU};

/// Largest angular span of one face patch, radians.
pub(super) const MAX_PATCH_RAD: f64 = FRAC_PI_2;

/// Angles (radians, increasing, spanning one turn) where every circle of a part is cut.
#[derive(Debug, Clone)]
pub(super) struct Angles(pub(super) Vec<f64>);

impl Angles {
    /// Subdivide the increasing `base` angles so no interval exceeds 90°; returns the
    /// set and the new index of each base angle.
    pub(super) fn new(base: &[f64]) -> (Self, Vec<usize>) {
        let mut th = Vec::new();
        let mut idx = Vec::new();
        for (i, &a) in base.iter().enumerate() {
            idx.push(th.len());
            let b = if i + 1 < base.len() {
                base[i + 1]
            } else {
                base[0] + TAU
            };
            let n = ((b - a) / MAX_PATCH_RAD).ceil().max(1.0) as usize;
            for k in 0..n {
                th.push(a + (b - a) * k as f64 / n as f64);
            }
        }
        (Angles(th), idx)
    }

    pub(super) fn len(&self) -> usize {
        self.0.len()
    }

    /// Interval k as (start, end) with end > start.
    pub(super) fn interval(&self, k: usize) -> (f64, f64) {
        let n = self.len();
        let a = self.0[k % n];
        let b = if k % n + 1 < n {
            self.0[k % n + 1]
        } else {
            self.0[0] + TAU
        };
        (a, b)
    }

    /// Interval indices walking counter-clockwise from angle index `from` to `to`
    /// (a full turn when they are equal).
    pub(super) fn walk(&self, from: usize, to: usize) -> Vec<usize> {
        let n = self.len();
        let mut out = vec![from % n];
        let mut k = (from + 1) % n;
        while k != to % n {
            out.push(k);
            k = (k + 1) % n;
        }
        out
    }
}

impl Angles {
    /// A coarser set of cuts: some of these angles, no interval over 90°. The features
    /// that need every cut (pillars, slots) end below the domes, and the small circles
    /// near an apex would otherwise be cut into arcs too short to mesh.
    pub(super) fn coarse(&self) -> (Angles, Vec<usize>) {
        let n = self.len();
        let end = self.0[0] + TAU;
        let mut idx = vec![0];
        let mut i = 0;
        while end - self.0[i] > MAX_PATCH_RAD + 1e-12 {
            let mut j = i + 1;
            while j + 1 < n && self.0[j + 1] - self.0[i] <= MAX_PATCH_RAD + 1e-12 {
                j += 1;
            }
            if j >= n {
                break;
            }
            idx.push(j);
            i = j;
        }
        (Angles(idx.iter().map(|&k| self.0[k]).collect()), idx)
    }
}

/// The cut angles of one part: `special` angles (pillar and slot edges, any order,
/// any turn) sorted into one increasing set from the first, subdivided so no interval
/// exceeds 90°, with a lookup from a special angle to its index.
pub(super) struct Cuts {
    pub(super) ang: Angles,
    base: Vec<f64>,
    idx: Vec<usize>,
}

impl Cuts {
    pub(super) fn new(special: &[f64]) -> Self {
        let a0 = special[0];
        let mut base: Vec<f64> = special
            .iter()
            .map(|&a| a0 + (a - a0).rem_euclid(TAU))
            .collect();
        base.sort_by(|a, b| a.total_cmp(b));
        base.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        let (ang, idx) = Angles::new(&base);
        Cuts { ang, base, idx }
    }

    /// Index in the subdivided set of a special angle.
    pub(super) fn at(&self, angle: f64) -> usize {
        let a = self.base[0] + (angle - self.base[0]).rem_euclid(TAU);
        let k = self
            .base
            .iter()
            .position(|&b| (b - a).abs() < 1e-9 || (b - a).abs() > TAU - 1e-9)
            .expect("a special angle of this part");
        self.idx[k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_split_long_intervals_and_keep_the_base_angles() {
        // Three pillars: gaps of ~110° must be split, the 10° pillar spans kept.
        let w = 5f64.to_radians();
        let base: Vec<f64> = (0..3)
            .flat_map(|i| {
                let t = i as f64 * TAU / 3.0;
                [t - w, t + w]
            })
            .collect();
        let (ang, idx) = Angles::new(&base);
        assert_eq!(ang.len(), 9);
        for (k, &i) in idx.iter().enumerate() {
            assert!((ang.0[i] - base[k]).abs() < 1e-15);
        }
        let total: f64 = (0..ang.len())
            .map(|k| ang.interval(k).1 - ang.interval(k).0)
            .sum();
        assert!((total - TAU).abs() < 1e-12);
        assert!(
            (0..ang.len()).all(|k| ang.interval(k).1 - ang.interval(k).0 <= MAX_PATCH_RAD + 1e-12)
        );
        // A walk from a pillar's end to the next pillar's start covers the gap only.
        let gap: Vec<usize> = ang.walk(idx[1], idx[2]);
        let span: f64 = gap
            .iter()
            .map(|&k| ang.interval(k).1 - ang.interval(k).0)
            .sum();
        assert!((span - (TAU / 3.0 - 2.0 * w)).abs() < 1e-12);
        assert_eq!(ang.walk(0, 0).len(), ang.len());
    }
}
