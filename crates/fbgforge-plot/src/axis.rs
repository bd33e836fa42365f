//! Axes of a chart: the range a set of values needs (padded a little), the map from a
//! value to its place along the axis, linear or log10, and the ticks with readable
//! labels (1, 2, 5 × 10ⁿ steps on a linear axis; decades, with 2–9 between them as
//! minor lines, on a log axis, labelled with the values themselves, not their logs).

/// One axis of a chart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axis {
    /// Log10 axis.
    pub log: bool,
    /// Value at the start of the axis (data units).
    pub lo: f64,
    /// Value at the end of the axis (data units).
    pub hi: f64,
}

/// A tick: where it is, its label (empty for a minor tick).
#[derive(Debug, Clone, PartialEq)]
pub struct Tick {
    /// Value (data units).
    pub value: f64,
    /// Label; empty on a minor tick.
    pub label: String,
    /// A labelled tick (a minor one draws only a light grid line).
    pub major: bool,
}

impl Axis {
    /// The axis that shows `values` (non-finite values, and on a log axis values ≤ 0,
    /// are left out), padded by 5 % of the span on each side; `None` when no value can
    /// be shown.
    pub fn fit(values: impl IntoIterator<Item = f64>, log: bool) -> Option<Axis> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values {
            if let Some(t) = transform(v, log) {
                lo = lo.min(t);
                hi = hi.max(t);
            }
        }
        if lo > hi {
            return None;
        }
        let d = if hi - lo < 1e-12 * lo.abs().max(1e-300) || hi == lo {
            if log {
                0.1
            } else {
                lo.abs().max(1.0) * 0.05
            }
        } else {
            (hi - lo) * 0.05
        };
        let (lo, hi) = (lo - d, hi + d);
        Some(if log {
            Axis {
                log,
                lo: 10f64.powf(lo),
                hi: 10f64.powf(hi),
            }
        } else {
            Axis { log, lo, hi }
        })
    }

    /// Where `v` falls along the axis, 0 at `lo` and 1 at `hi`; `None` when it cannot
    /// be drawn (not finite, or ≤ 0 on a log axis).
    pub fn fraction(&self, v: f64) -> Option<f64> {
        let t = transform(v, self.log)?;
        let (a, b) = (transform(self.lo, self.log)?, transform(self.hi, self.log)?);
        Some((t - a) / (b - a))
    }

    /// The ticks inside the axis, in increasing order.
    pub fn ticks(&self) -> Vec<Tick> {
        if self.log {
            log_ticks(self.lo, self.hi)
        } else {
            linear_ticks(self.lo, self.hi, 6)
        }
    }
}

fn transform(v: f64, log: bool) -> Option<f64> {
    if !v.is_finite() {
        return None;
    }
    if log {
        (v > 0.0).then(|| v.log10())
    } else {
        Some(v)
    }
}

/// A step of 1, 2 or 5 × 10ⁿ near `span / target`.
fn nice_step(span: f64, target: usize) -> f64 {
    let raw = span / target.max(1) as f64;
    let p = 10f64.powf(raw.log10().floor());
    let r = raw / p;
    let nice = if r < 1.5 {
        1.0
    } else if r < 3.0 {
        2.0
    } else if r < 7.0 {
        5.0
    } else {
        10.0
    };
    nice * p
}

/// A number written with as many decimals as a tick step of `step` needs.
pub(crate) fn format_number(v: f64, step: f64) -> String {
    if v.abs() <= step.abs() * 1e-6 {
        return "0".into();
    }
    let a = v.abs();
    let step_mag = step.abs().log10().floor();
    if !(1e-4..1e6).contains(&a) {
        let digits = (a.log10().floor() - step_mag).clamp(0.0, 6.0) as usize;
        let s = format!("{v:.digits$e}");
        return s;
    }
    let decimals = (-step_mag).clamp(0.0, 10.0) as usize;
    format!("{v:.decimals$}")
}

fn linear_ticks(lo: f64, hi: f64, target: usize) -> Vec<Tick> {
    let step = nice_step(hi - lo, target);
    if !(step.is_finite() && step > 0.0) {
        return Vec::new();
    }
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last)
        .map(|k| {
            let value = k as f64 * step;
            Tick {
                value,
                label: format_number(value, step),
                major: true,
            }
        })
        .collect()
}

/// A value on a log axis written as itself: 0.001 … 10000 in decimals, else `1e6`.
pub(crate) fn format_log_value(v: f64) -> String {
    if (1e-3..1e5).contains(&v) {
        let decimals = (-v.log10().floor()).max(0.0) as usize;
        let s = format!("{v:.decimals$}");
        s
    } else {
        format!("{v:e}")
    }
}

fn log_ticks(lo: f64, hi: f64) -> Vec<Tick> {
    let (a, b) = (lo.log10(), hi.log10());
    let first = a.ceil() as i32;
    let last = b.floor() as i32;
    let in_range = |v: f64| v >= lo * (1.0 - 1e-12) && v <= hi * (1.0 + 1e-12);
    if last - first >= 1 {
        // Decades; thinned to at most ~8 labels.
        let count = (last - first + 1) as usize;
        let stride = count.div_ceil(8).max(1);
        let mut ticks: Vec<Tick> = (first..=last)
            .filter(|k| ((k - first) as usize).is_multiple_of(stride))
            .map(|k| {
                let value = 10f64.powi(k);
                Tick {
                    value,
                    label: format_log_value(value),
                    major: true,
                }
            })
            .collect();
        if b - a <= 6.0 {
            for k in (a.floor() as i32)..=last {
                for m in 2..=9 {
                    let value = m as f64 * 10f64.powi(k);
                    if in_range(value) {
                        ticks.push(Tick {
                            value,
                            label: String::new(),
                            major: false,
                        });
                    }
                }
            }
        }
        ticks.sort_by(|p, q| p.value.total_cmp(&q.value));
        return ticks;
    }
    // Less than two decades in view: 1, 2 and 5 × 10ⁿ when three of them fit.
    let mut ticks: Vec<Tick> = ((a.floor() as i32)..=(b.ceil() as i32))
        .flat_map(|k| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(k)))
        .filter(|&v| in_range(v))
        .map(|value| Tick {
            value,
            label: format_log_value(value),
            major: true,
        })
        .collect();
    if ticks.len() < 3 {
        // A narrow range: plain steps, placed on the log axis.
        ticks = linear_ticks(lo, hi, 4);
    }
    ticks
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_ticks_are_round_and_inside() {
        let t = linear_ticks(-0.3, 10.4, 6);
        let v: Vec<f64> = t.iter().map(|t| t.value).collect();
        assert_eq!(v, vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]);
        assert_eq!(t[1].label, "2");
        let t = linear_ticks(0.0012, 0.0049, 6);
        assert_eq!(t.first().unwrap().label, "0.0015");
        assert!(t.iter().all(|t| t.value >= 0.0012 && t.value <= 0.0049));
        // Large values are written in exponent form with the digits the step needs.
        assert_eq!(format_number(2_500_000.0, 500_000.0), "2.5e6");
        assert_eq!(format_number(-1e-12, 1.0), "0");
    }

    #[test]
    fn a_log_axis_over_three_decades_has_decade_labels_and_minor_lines() {
        let ax = Axis::fit([10.0, 2000.0], true).unwrap();
        let t = ax.ticks();
        let majors: Vec<&str> = t
            .iter()
            .filter(|t| t.major)
            .map(|t| t.label.as_str())
            .collect();
        assert_eq!(majors, vec!["10", "100", "1000"]);
        assert!(t.iter().any(|t| !t.major && (t.value - 50.0).abs() < 1e-9));
        // Decades are equally spaced along the axis.
        let f: Vec<f64> = [10.0, 100.0, 1000.0]
            .iter()
            .map(|&v| ax.fraction(v).unwrap())
            .collect();
        assert!(((f[1] - f[0]) - (f[2] - f[1])).abs() < 1e-12);
        assert!(ax.fraction(0.0).is_none() && ax.fraction(-1.0).is_none());
    }

    #[test]
    fn a_narrow_log_axis_still_has_labels() {
        let ax = Axis::fit([120.0, 150.0], true).unwrap();
        let t = ax.ticks();
        assert!(t.len() >= 2, "{t:?}");
        assert!(t.iter().all(|t| t.value >= ax.lo && t.value <= ax.hi));
        let ax = Axis::fit([3.0, 70.0], true).unwrap();
        let labels: Vec<String> = ax.ticks().into_iter().map(|t| t.label).collect();
        assert_eq!(labels, vec!["5", "10", "20", "50"]);
    }

    #[test]
    fn values_that_cannot_be_drawn_are_left_out_of_the_range() {
        let ax = Axis::fit([f64::NAN, -5.0, 0.0, 1.0, 100.0], true).unwrap();
        assert!(ax.lo > 0.5 && ax.lo < 1.0 && ax.hi > 100.0 && ax.hi < 200.0);
        assert!(Axis::fit([f64::NAN, -1.0], true).is_none());
        let flat = Axis::fit([3.0, 3.0], false).unwrap();
        assert!(flat.lo < 3.0 && flat.hi > 3.0);
    }
}
