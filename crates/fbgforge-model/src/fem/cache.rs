//! Re-use of the moduli-independent part of finite-element solves across calls.
//!
//! A [`ProblemStructure`] (numbering of the unknowns, stiffness pattern, element
//! stiffness per unit modulus, the solver's symbolic analysis) depends on the mesh, its
//! ties and supports and the element formulation, never on the moduli. The model
//! policy solves many problems that share one: the cores and inserts of one load case
//! and contact reading, every step of a sweep over a modulus, every evaluation of an
//! optimiser that changes only materials. [`GeometryCache`] keeps the structures and
//! hands the same one to every problem of the same shape, so those solves cost one
//! assembly pass and one numeric factorisation each.
//!
//! The key is the problem's shape itself (node coordinates bit for bit, elements,
//! held and tied components, formulation, solver), compared in full on every hit: a
//! design that changes any length meshes differently and misses; nothing can be
//! served a stale structure. Concurrent requests for one shape build it once (the
//! others wait for it). Entries are dropped least recently used first beyond a memory
//! budget.
//!
//! There is no process-wide cache: whoever runs the solves owns one and passes it
//! (faer, too, leaves the symbolic factorisation with its caller). A use case keeps
//! one for its run (a sweep's steps, an optimisation's evaluations), the Python
//! package one per process, a study or a test its own; a [`GeometryCache`] is a
//! handle, so clones share one store. A request that names none gets a fresh one.

use super::element::Formulation;
use super::mesh::Element;
use super::solve::{Component, FactoredProblem, LinearSolver, Problem, ProblemStructure};
use anyhow::{anyhow, Result};
use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex, OnceLock};

/// An interpolation as compared: (node, component, [(master, weight bits)]).
type InterpolationShape = (usize, Component, [(usize, u64); 3]);

/// What fixes a problem's structure.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct ProblemShape {
    node_bits: Vec<[u64; 2]>,
    elements: Vec<Element>,
    fixed: Vec<(usize, Component)>,
    ties: Vec<(usize, usize, Component)>,
    interpolations: Vec<InterpolationShape>,
    displacement_formulation: bool,
    solver: &'static str,
}

impl ProblemShape {
    fn of(p: &Problem, solver: &dyn LinearSolver) -> Self {
        ProblemShape {
            node_bits: p
                .mesh
                .nodes
                .iter()
                .map(|[r, z]| [r.to_bits(), z.to_bits()])
                .collect(),
            elements: p.mesh.elements.clone(),
            fixed: p.fixed.clone(),
            ties: p.ties.clone(),
            interpolations: p
                .interpolations
                .iter()
                .map(|f| {
                    (
                        f.node,
                        f.component,
                        f.masters.map(|(m, w)| (m, w.to_bits())),
                    )
                })
                .collect(),
            displacement_formulation: p.formulation == Formulation::Displacement,
            solver: solver.name(),
        }
    }

    fn hash64(&self) -> u64 {
        let mut h = DefaultHasher::new();
        self.hash(&mut h);
        h.finish()
    }
}

type Slot = Arc<OnceLock<Result<Arc<ProblemStructure>, String>>>;

struct Entry {
    hash: u64,
    shape: Arc<ProblemShape>,
    slot: Slot,
    last_used: u64,
    bytes: usize,
}

#[derive(Default)]
struct Inner {
    entries: Vec<Entry>,
    clock: u64,
    stats: CacheStats,
}

/// Counters of a [`GeometryCache`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct CacheStats {
    /// Requests served from a stored structure.
    pub hits: u64,
    /// Requests that built a new structure.
    pub misses: u64,
    /// Structures held now.
    pub entries: usize,
    /// Approximate bytes they hold.
    pub bytes: usize,
}

/// Problem structures by shape, least recently used dropped first beyond a budget: a
/// handle (clones share one store), owned by whoever runs the solves.
#[derive(Clone)]
pub struct GeometryCache {
    shared: Arc<Shared>,
}

struct Shared {
    inner: Mutex<Inner>,
    budget_bytes: usize,
}

/// Budget of a default cache, bytes: about 20 structures of the default level-1 Case I
/// mesh, far more than one `predict` needs (10).
pub(crate) const DEFAULT_BUDGET_BYTES: usize = 768 << 20;

impl Default for GeometryCache {
    /// An empty cache of [`DEFAULT_BUDGET_BYTES`].
    fn default() -> Self {
        GeometryCache::new(DEFAULT_BUDGET_BYTES)
    }
}

impl std::fmt::Debug for GeometryCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = self.stats();
        f.debug_struct("GeometryCache")
            .field("entries", &s.entries)
            .field("bytes", &s.bytes)
            .field("budget_bytes", &self.shared.budget_bytes)
            .finish()
    }
}

impl PartialEq for GeometryCache {
    /// The same store (a clone of one handle).
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.shared, &other.shared)
    }
}

impl GeometryCache {
    /// An empty cache holding about `budget_bytes` (at least the latest structure).
    pub fn new(budget_bytes: usize) -> Self {
        GeometryCache {
            shared: Arc::new(Shared {
                inner: Mutex::new(Inner::default()),
                budget_bytes,
            }),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        // A panic elsewhere while holding the lock leaves consistent data (every
        // update is a push, a field write or a removal), so recover it.
        self.shared.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The structure of `problem` for `solver`: the stored one when a problem of the
    /// same shape was seen, else built now (once, however many threads ask).
    pub fn structure(
        &self,
        problem: &Problem,
        solver: &dyn LinearSolver,
    ) -> Result<Arc<ProblemStructure>> {
        let shape = ProblemShape::of(problem, solver);
        let hash = shape.hash64();
        let slot = {
            let mut g = self.lock();
            g.clock += 1;
            let now = g.clock;
            let found = g
                .entries
                .iter_mut()
                .find(|e| e.hash == hash && *e.shape == shape)
                .map(|e| {
                    e.last_used = now;
                    Arc::clone(&e.slot)
                });
            match found {
                Some(slot) => {
                    g.stats.hits += 1;
                    slot
                }
                None => {
                    g.stats.misses += 1;
                    let slot: Slot = Arc::new(OnceLock::new());
                    g.entries.push(Entry {
                        hash,
                        shape: Arc::new(shape),
                        slot: Arc::clone(&slot),
                        last_used: now,
                        bytes: 0,
                    });
                    slot
                }
            }
        };
        let built = slot.get_or_init(|| {
            problem
                .structure(solver)
                .map(Arc::new)
                .map_err(|e| format!("{e:#}"))
        });
        let mut g = self.lock();
        match built {
            Ok(s) => {
                if let Some(e) = g.entries.iter_mut().find(|e| Arc::ptr_eq(&e.slot, &slot)) {
                    e.bytes = s.approximate_bytes();
                }
                self.evict(&mut g, &slot);
                Ok(Arc::clone(s))
            }
            Err(msg) => {
                // Deterministic, but not worth holding: the caller reports it.
                g.entries.retain(|e| !Arc::ptr_eq(&e.slot, &slot));
                Err(anyhow!("{msg}"))
            }
        }
    }

    /// Assemble `problem`'s stiffness for its materials on the cached structure and
    /// factorise it (numeric phase only, on a hit).
    pub fn factor(&self, problem: &Problem, solver: &dyn LinearSolver) -> Result<FactoredProblem> {
        self.structure(problem, solver)?.factor(&problem.materials)
    }

    /// Drop least recently used entries (never `keep`) until within the budget.
    fn evict(&self, g: &mut Inner, keep: &Slot) {
        loop {
            let total: usize = g.entries.iter().map(|e| e.bytes).sum();
            if total <= self.shared.budget_bytes {
                break;
            }
            let oldest = g
                .entries
                .iter()
                .enumerate()
                .filter(|(_, e)| !Arc::ptr_eq(&e.slot, keep) && e.slot.get().is_some())
                .min_by_key(|(_, e)| e.last_used)
                .map(|(i, _)| i);
            match oldest {
                Some(i) => {
                    g.entries.remove(i);
                }
                None => break,
            }
        }
    }

    /// Drop every stored structure (counters kept).
    pub fn clear(&self) {
        self.lock().entries.clear();
    }

    /// Hits, misses and what is held.
    pub fn stats(&self) -> CacheStats {
        let g = self.lock();
        CacheStats {
            entries: g.entries.len(),
            bytes: g.entries.iter().map(|e| e.bytes).sum(),
            ..g.stats
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::element::ElasticConstants;
    use crate::fem::mesh::Mesh;
    use crate::fem::solve::{SparseLlt, Z};

    fn block(width_mm: f64) -> Problem {
        let mut mesh = Mesh::default();
        let ids: Vec<Vec<usize>> = (0..3)
            .map(|i| {
                (0..3)
                    .map(|j| mesh.add_node(1.0 + width_mm * i as f64 / 2.0, j as f64))
                    .collect()
            })
            .collect();
        mesh.add_block(&ids, 0);
        Problem {
            mesh,
            materials: vec![ElasticConstants {
                youngs_modulus_mpa: 5.0,
                poisson_ratio: 0.3,
            }],
            formulation: Formulation::MixedQ9P1,
            fixed: (0..3).map(|i| (ids[i][0], Z)).collect(),
            ties: vec![],
            interpolations: vec![],
            loads: (0..3).map(|i| (ids[i][2], Z, -1.0)).collect(),
        }
    }

    #[test]
    fn a_modulus_change_hits_and_a_length_change_misses() {
        let cache = GeometryCache::new(1 << 30);
        let p = block(1.0);
        let a = cache.structure(&p, &SparseLlt::default()).unwrap();
        let mut stiffer = p.clone();
        stiffer.materials[0].youngs_modulus_mpa = 50.0;
        let b = cache.structure(&stiffer, &SparseLlt::default()).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        let wider = block(1.5);
        let c = cache.structure(&wider, &SparseLlt::default()).unwrap();
        assert!(!Arc::ptr_eq(&a, &c));
        let s = cache.stats();
        assert_eq!((s.hits, s.misses, s.entries), (1, 2, 2));
        // The stiffer block's displacement is a tenth (linear elasticity, same ν):
        // the reused structure took the new modulus.
        let top = |q: &Problem| {
            cache
                .factor(q, &SparseLlt::default())
                .unwrap()
                .solve_loads(&q.loads)
                .unwrap()
                .displacement_mm[q.loads[0].0][1]
        };
        let (soft, stiff) = (top(&p), top(&stiffer));
        assert!((soft / stiff - 10.0).abs() < 1e-9, "{soft} / {stiff}");
    }

    #[test]
    fn beyond_the_budget_the_least_recently_used_goes() {
        let cache = GeometryCache::new(1);
        for w in [1.0, 1.5, 2.0] {
            cache.structure(&block(w), &SparseLlt::default()).unwrap();
        }
        // Only the latest is kept under a 1-byte budget.
        assert_eq!(cache.stats().entries, 1);
        cache.structure(&block(2.0), &SparseLlt::default()).unwrap();
        assert_eq!(cache.stats().hits, 1);
        cache.clear();
        assert_eq!(cache.stats().entries, 0);
    }
}
