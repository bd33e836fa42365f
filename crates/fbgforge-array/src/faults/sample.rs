//! What the stream diagnosis keeps of a stream, in one pass and bounded memory
//! (independent of the number of frames): frames spread evenly over the stream, the
//! strongest frames, and each grating's largest readings.

use crate::problem::SensingProblem;

/// Frames spread over the stream kept at least (between this and twice this).
pub(crate) const SPREAD_FRAMES: usize = 48;

/// Strongest frames (largest ‖y‖) kept.
pub(crate) const STRONGEST_FRAMES: usize = 48;

/// Largest readings kept per grating.
pub(crate) const TOP_READINGS: usize = 32;

/// A frame of the stream with its index (its place in time).
pub(crate) type Indexed = (usize, Vec<f64>);

/// The sample of a stream the diagnosis works on (fill it with [`Self::push`], frame
/// by frame, in order).
#[derive(Debug, Clone)]
pub struct StreamSample {
    problem: SensingProblem,
    frames: usize,
    usable: usize,
    stride: usize,
    spread: Vec<Indexed>,
    strongest: Largest,
    tops: Vec<Largest>,
    most_held: usize,
}

/// The entries with the largest keys (pruned at twice `keep`, so that the cost per
/// frame stays O(1) amortised; below the smallest key kept, a frame is not copied).
#[derive(Debug, Clone, Default)]
struct Largest {
    items: Vec<(f64, Indexed)>,
    floor: f64,
}

impl Largest {
    fn offer(&mut self, key: f64, (index, y): (usize, &[f64]), keep: usize) {
        if self.items.len() >= keep && key < self.floor {
            return;
        }
        self.items.push((key, (index, y.to_vec())));
        if self.items.len() >= 2 * keep {
            self.sorted_truncate(keep);
            self.floor = self.items.last().map_or(f64::MIN, |e| e.0);
        }
    }

    fn sorted_truncate(&mut self, keep: usize) {
        self.items
            .sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1 .0.cmp(&b.1 .0)));
        self.items.truncate(keep);
    }

    fn largest(&self, keep: usize) -> Vec<&(f64, Indexed)> {
        let mut v: Vec<&(f64, Indexed)> = self.items.iter().collect();
        v.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1 .0.cmp(&b.1 .0)));
        v.truncate(keep);
        v
    }
}

impl StreamSample {
    /// An empty sample for frames of `problem` (its gratings; its window decides
    /// which frames are usable).
    pub fn new(problem: &SensingProblem) -> Self {
        StreamSample {
            problem: problem.clone(),
            frames: 0,
            usable: 0,
            stride: 1,
            spread: Vec::new(),
            strongest: Largest::default(),
            tops: vec![Largest::default(); problem.n_gratings()],
            most_held: 0,
        }
    }

    /// Take the next frame of the stream (unusable frames count in time only).
    pub fn push(&mut self, y: &[f64]) {
        let index = self.frames;
        self.frames += 1;
        if self.problem.check_shifts(y).is_err() {
            return;
        }
        self.usable += 1;
        if index.is_multiple_of(self.stride) {
            self.spread.push((index, y.to_vec()));
            if self.spread.len() >= 2 * SPREAD_FRAMES {
                let s = self.stride;
                self.spread.retain(|(f, _)| (f / s).is_multiple_of(2));
                self.stride *= 2;
            }
        }
        let norm = y.iter().map(|v| v * v).sum::<f64>().sqrt();
        self.strongest.offer(norm, (index, y), STRONGEST_FRAMES);
        for (i, tops) in self.tops.iter_mut().enumerate() {
            tops.offer(y[i], (index, y), TOP_READINGS);
        }
        let held = self.spread.len()
            + self.strongest.items.len()
            + self.tops.iter().map(|t| t.items.len()).sum::<usize>();
        self.most_held = self.most_held.max(held);
    }

    /// The most frames (copies of a frame's readings) the sample held at once: at
    /// most 2 × ([`SPREAD_FRAMES`] + [`STRONGEST_FRAMES`] + [`TOP_READINGS`] per
    /// grating), whatever the stream's length.
    pub fn most_frames_held(&self) -> usize {
        self.most_held
    }

    /// Frames seen (usable or not).
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Usable frames seen.
    pub fn usable(&self) -> usize {
        self.usable
    }

    /// The frames spread over the stream, in order.
    pub(crate) fn spread(&self) -> &[Indexed] {
        &self.spread
    }

    /// The strongest frames, strongest first.
    pub(crate) fn strongest(&self) -> Vec<&Indexed> {
        self.strongest
            .largest(STRONGEST_FRAMES)
            .into_iter()
            .map(|(_, f)| f)
            .collect()
    }

    /// Grating i's largest readings with their frames, largest first.
    pub(crate) fn tops(&self, i: usize) -> Vec<&(f64, Indexed)> {
        self.tops[i].largest(TOP_READINGS)
    }
}
