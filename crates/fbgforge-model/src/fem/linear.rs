//! Direct solvers for the symmetric positive definite stiffness systems K u = f of
//! [`crate::fem::solve`], interchangeable behind one trait, [`LinearSolver`].
//!
//! Every solver works in two phases, so that matrices with one sparsity pattern (one
//! mesh with its ties and supports: another core, insert or modulus on the same
//! geometry) pay the first phase once:
//! - **symbolic** ([`LinearSolver::analyse`]): a fill-reducing ordering of the unknowns
//!   and the structure of the factor, from the pattern alone;
//! - **numeric** ([`SymbolicFactorization::factor`]): the factor of one set of values.
//!
//! The solvers:
//! - [`SparseLlt`] (default): faer's sparse Cholesky, approximate minimum degree (AMD)
//!   ordering and a supernodal (dense-block) factorisation when the factor is dense
//!   enough, simplicial otherwise;
//! - [`EnvelopeCholesky`]: hand-written envelope (skyline) Cholesky after a reverse
//!   Cuthill–McKee ordering; rows are contiguous, so its inner loops are dot products
//!   (the independent check of the default: the two agree to round-off).
//!
//! The criterion bench `benches/fem.rs` times the two on the module's matrices
//! (docs/fem.md §5). nalgebra-sparse's `CscCholesky`, a third solver once, was 24×
//! slower than the default and is gone with that dependency.
//!
//! Matrices are handed over as the lower triangle of K in compressed columns
//! ([`LowerPattern`] plus a value slice in the pattern's order); each solver permutes
//! internally, so solutions come back in the caller's numbering.

use anyhow::{anyhow, bail, Result};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::linalg::{amd, SupernodalThreshold};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::{DMatrix, DVector};
use std::collections::VecDeque;
use std::sync::Arc;

/// The lower triangle (row ≥ column, diagonal included) of a symmetric sparsity
/// pattern in compressed columns, rows sorted within each column.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LowerPattern {
    /// Order of the matrix.
    pub n: usize,
    /// Start of each column in `row_idx` (n + 1 entries).
    pub col_ptr: Vec<usize>,
    /// Row of each stored entry.
    pub row_idx: Vec<usize>,
}

impl LowerPattern {
    /// The lower triangle of a square dense matrix: the pattern of its nonzero
    /// entries (the whole diagonal always) and their values.
    pub(crate) fn from_dense(k: &DMatrix<f64>) -> Result<(Self, Vec<f64>)> {
        if k.nrows() != k.ncols() {
            bail!("the matrix is not square ({} × {})", k.nrows(), k.ncols());
        }
        let n = k.ncols();
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let (mut row_idx, mut values) = (Vec::new(), Vec::new());
        for j in 0..n {
            for i in j..n {
                let v = k[(i, j)];
                if i == j || v != 0.0 {
                    row_idx.push(i);
                    values.push(v);
                }
            }
            col_ptr.push(row_idx.len());
        }
        Ok((
            LowerPattern {
                n,
                col_ptr,
                row_idx,
            },
            values,
        ))
    }

    /// The pattern of the element matrices' union: `elements` lists each element's
    /// unknowns (`None`: a held component) among `n`.
    pub(crate) fn from_elements<const D: usize>(n: usize, elements: &[[Option<usize>; D]]) -> Self {
        // Unknown → elements incidence, then each column from its elements, marking
        // rows seen (no per-column allocation).
        let mut ptr = vec![0usize; n + 1];
        for d in elements {
            for &i in d.iter().flatten() {
                ptr[i + 1] += 1;
            }
        }
        for j in 0..n {
            ptr[j + 1] += ptr[j];
        }
        let mut next = ptr.clone();
        let mut incidence = vec![0usize; ptr[n]];
        for (e, d) in elements.iter().enumerate() {
            for &i in d.iter().flatten() {
                incidence[next[i]] = e;
                next[i] += 1;
            }
        }
        let mut mark = vec![usize::MAX; n];
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::with_capacity(10 * ptr[n]);
        for j in 0..n {
            let start = row_idx.len();
            for &e in &incidence[ptr[j]..ptr[j + 1]] {
                for &i in elements[e].iter().flatten() {
                    if i >= j && mark[i] != j {
                        mark[i] = j;
                        row_idx.push(i);
                    }
                }
            }
            row_idx[start..].sort_unstable();
            col_ptr.push(row_idx.len());
        }
        LowerPattern {
            n,
            col_ptr,
            row_idx,
        }
    }

    /// The lower pattern of P K Pᵀ, P taking unknown i to `new_of[i]`: its column
    /// pointers and rows, and where each of this pattern's entries lands in it.
    pub(crate) fn permuted(&self, new_of: &[usize]) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
        let (n, nnz) = (self.n, self.nonzeros());
        let entry = |j: usize, i: usize| {
            let (a, b) = (new_of[i], new_of[j]);
            (a.max(b), a.min(b))
        };
        let mut col_ptr = vec![0usize; n + 1];
        for j in 0..n {
            for &i in &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]] {
                col_ptr[entry(j, i).1 + 1] += 1;
            }
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        let mut next = col_ptr.clone();
        let mut rows = vec![(0usize, 0usize); nnz];
        let mut k = 0;
        for j in 0..n {
            for &i in &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]] {
                let (r, c) = entry(j, i);
                rows[next[c]] = (r, k);
                next[c] += 1;
                k += 1;
            }
        }
        let mut slot = vec![0usize; nnz];
        let mut row_idx = Vec::with_capacity(nnz);
        for c in 0..n {
            let seg = &mut rows[col_ptr[c]..col_ptr[c + 1]];
            seg.sort_unstable();
            for &(r, k) in seg.iter() {
                slot[k] = row_idx.len();
                row_idx.push(r);
            }
        }
        (col_ptr, row_idx, slot)
    }

    /// Stored entries.
    pub(crate) fn nonzeros(&self) -> usize {
        self.row_idx.len()
    }

    /// Index of entry (i, j), i ≥ j, in the value slice.
    pub fn position(&self, i: usize, j: usize) -> Option<usize> {
        let (a, b) = (self.col_ptr[j], self.col_ptr[j + 1]);
        self.row_idx[a..b].binary_search(&i).ok().map(|k| a + k)
    }

    /// Adjacency lists of the symmetric graph (diagonal left out), for orderings.
    fn adjacency(&self) -> Vec<Vec<usize>> {
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); self.n];
        for j in 0..self.n {
            for &i in &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]] {
                if i != j {
                    adj[i].push(j);
                    adj[j].push(i);
                }
            }
        }
        for a in adj.iter_mut() {
            a.sort_unstable();
        }
        adj
    }
}

/// A factorised symmetric positive definite matrix.
pub trait Factorization: Send + Sync {
    /// Overwrite `b` with the solution of K x = b.
    fn solve_in_place(&self, b: &mut [f64]);
    /// Overwrite the `columns` right-hand sides stored one after the other in `b`
    /// (column-major, n × columns) with their solutions.
    fn solve_columns_in_place(&self, b: &mut [f64], columns: usize) {
        if columns == 0 {
            return;
        }
        let n = b.len() / columns;
        for col in b.chunks_exact_mut(n) {
            self.solve_in_place(col);
        }
    }
    /// Stored entries of the factor.
    fn nonzeros(&self) -> usize;
}

/// The symbolic phase of a factorisation: ordering and factor structure of one
/// pattern, shared by every matrix with that pattern.
pub trait SymbolicFactorization: Send + Sync {
    /// The numeric phase: factorise the matrix with the analysed pattern and these
    /// values (lower triangle, in the pattern's order).
    fn factor(&self, values: &[f64]) -> Result<Box<dyn Factorization>>;
}

/// A direct solver for a symmetric positive definite system K u = f.
pub trait LinearSolver: Sync {
    /// Short name for tables.
    fn name(&self) -> &'static str;
    /// The symbolic phase for a pattern.
    fn analyse(&self, pattern: &LowerPattern) -> Result<Box<dyn SymbolicFactorization>>;
    /// Factorise K (both phases; only its lower triangle is read).
    fn factor(&self, k: &DMatrix<f64>) -> Result<Box<dyn Factorization>> {
        let (pattern, values) = LowerPattern::from_dense(k)?;
        self.analyse(&pattern)?.factor(&values)
    }
    /// Solve; returns u and the number of stored entries of the factor.
    fn solve(&self, k: &DMatrix<f64>, f: &DVector<f64>) -> Result<(DVector<f64>, usize)> {
        let factor = self.factor(k)?;
        let mut u = f.clone();
        factor.solve_in_place(u.as_mut_slice());
        Ok((u, factor.nonzeros()))
    }
}

/// Reverse Cuthill–McKee permutation of a graph given by adjacency lists:
/// returns new index of each old vertex.
pub fn reverse_cuthill_mckee(adj: &[Vec<usize>]) -> Vec<usize> {
    let n = adj.len();
    let mut order = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let degree: Vec<usize> = adj.iter().map(|a| a.len()).collect();
    let mut by_degree: Vec<usize> = (0..n).collect();
    by_degree.sort_by_key(|&v| degree[v]);
    for &start in &by_degree {
        if seen[start] {
            continue;
        }
        // A pseudo-peripheral start: the last vertex reached by a BFS from `start`.
        let mut root = start;
        for _ in 0..2 {
            let mut level = vec![usize::MAX; n];
            let mut q = VecDeque::from([root]);
            level[root] = 0;
            let mut last = root;
            while let Some(v) = q.pop_front() {
                last = v;
                for &w in &adj[v] {
                    if level[w] == usize::MAX {
                        level[w] = level[v] + 1;
                        q.push_back(w);
                    }
                }
            }
            root = last;
        }
        let mut q = VecDeque::from([root]);
        seen[root] = true;
        while let Some(v) = q.pop_front() {
            order.push(v);
            let mut next: Vec<usize> = adj[v].iter().copied().filter(|&w| !seen[w]).collect();
            next.sort_by_key(|&w| degree[w]);
            for w in next {
                if !seen[w] {
                    seen[w] = true;
                    q.push_back(w);
                }
            }
        }
    }
    let mut new_index = vec![0; n];
    for (k, &v) in order.iter().rev().enumerate() {
        new_index[v] = k;
    }
    new_index
}

/// `b` in the solver's numbering: `out[perm[i]] = b[i]`.
fn permute(perm: &[usize], b: &[f64], out: &mut [f64]) {
    for (i, &p) in perm.iter().enumerate() {
        out[p] = b[i];
    }
}

/// Back to the caller's numbering: `b[i] = y[perm[i]]`.
fn unpermute(perm: &[usize], y: &[f64], b: &mut [f64]) {
    for (i, &p) in perm.iter().enumerate() {
        b[i] = y[p];
    }
}

// ---------------------------------------------------------------------------------
// faer: sparse Cholesky with AMD ordering.

/// faer's sparse Cholesky (LLᵀ) with its approximate minimum degree ordering:
/// supernodal where the factor has dense blocks, simplicial otherwise. Default.
#[derive(Debug, Clone, Copy, Default)]
pub struct SparseLlt {
    /// Which of faer's two numeric kernels to use.
    pub kernel: LltKernel,
}

/// faer's numeric Cholesky kernels.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LltKernel {
    /// faer's own choice from the factor's flop count per entry.
    Auto,
    /// Supernodal (dense blocks, BLAS-3) always. Default: on the module's meshes
    /// faer's own choice picks the simplicial kernel, which factorised the paper's
    /// Case I mesh (level 1, 9 284 unknowns) in 13.1 ms against the supernodal 4.0 ms,
    /// and its level-0 mesh in 3.9 against 1.6 ms (docs/fem.md §5.2).
    #[default]
    Supernodal,
    /// Simplicial (column by column) always.
    Simplicial,
}

struct FaerSymbolic {
    /// New position of each unknown (AMD).
    new_of: Arc<Vec<usize>>,
    /// The permuted lower pattern, checked once here (faer checks a pattern's
    /// invariants whenever a view is made from slices: once per pattern, not once per
    /// numeric factorisation).
    lower: SymbolicSparseColMat<usize>,
    /// Where each entry of the caller's pattern goes in the permuted one.
    slot: Vec<usize>,
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// The numeric phase's scratch, the same for every factorisation of the pattern.
    scratch: StackReq,
}

struct FaerFactor {
    new_of: Arc<Vec<usize>>,
    symbolic: Arc<SymbolicCholesky<usize>>,
    l: Vec<f64>,
}

impl LinearSolver for SparseLlt {
    fn name(&self) -> &'static str {
        match self.kernel {
            LltKernel::Auto => "sparse Cholesky, AMD (faer)",
            LltKernel::Supernodal => "sparse Cholesky, AMD (faer, supernodal)",
            LltKernel::Simplicial => "sparse Cholesky, AMD (faer, simplicial)",
        }
    }
    fn analyse(&self, pattern: &LowerPattern) -> Result<Box<dyn SymbolicFactorization>> {
        let n = pattern.n;
        let lower =
            SymbolicSparseColMatRef::new_checked(n, n, &pattern.col_ptr, None, &pattern.row_idx);
        // The ordering is applied here, once, to the pattern (faer would otherwise
        // permute the values at every numeric factorisation).
        let (mut fwd, mut inv) = (vec![0usize; n], vec![0usize; n]);
        let mut mem = MemBuffer::try_new(amd::order_scratch::<usize>(n, pattern.nonzeros()))
            .map_err(|_| anyhow!("sparse Cholesky (faer): out of memory"))?;
        amd::order(
            &mut fwd,
            &mut inv,
            lower,
            amd::Control::default(),
            MemStack::new(&mut mem),
        )
        .map_err(|e| anyhow!("sparse Cholesky (faer), AMD ordering: {e:?}"))?;
        let new_of = inv;
        let (col_ptr, row_idx, slot) = pattern.permuted(&new_of);
        let threshold = match self.kernel {
            LltKernel::Auto => SupernodalThreshold::AUTO,
            LltKernel::Supernodal => SupernodalThreshold::FORCE_SUPERNODAL,
            LltKernel::Simplicial => SupernodalThreshold::FORCE_SIMPLICIAL,
        };
        // Without an ordering of its own, faer's symbolic phase reads the upper
        // triangle: the transpose of the permuted lower one.
        let mut up_ptr = vec![0usize; n + 1];
        for &r in &row_idx {
            up_ptr[r + 1] += 1;
        }
        for j in 0..n {
            up_ptr[j + 1] += up_ptr[j];
        }
        let mut up_idx = vec![0usize; row_idx.len()];
        let mut next = up_ptr.clone();
        for c in 0..n {
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                up_idx[next[r]] = c;
                next[r] += 1;
            }
        }
        let symbolic = factorize_symbolic_cholesky(
            SymbolicSparseColMatRef::new_checked(n, n, &up_ptr, None, &up_idx),
            Side::Upper,
            SymmetricOrdering::Identity,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: threshold,
                ..Default::default()
            },
        )
        .map_err(|e| anyhow!("sparse Cholesky (faer), symbolic phase: {e:?}"))?;
        let scratch = symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default());
        Ok(Box::new(FaerSymbolic {
            new_of: Arc::new(new_of),
            lower: SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx),
            slot,
            symbolic: Arc::new(symbolic),
            scratch,
        }))
    }
}

impl SymbolicFactorization for FaerSymbolic {
    fn factor(&self, values: &[f64]) -> Result<Box<dyn Factorization>> {
        if values.len() != self.slot.len() {
            bail!(
                "{} values for a pattern of {} entries",
                values.len(),
                self.slot.len()
            );
        }
        let mut permuted = vec![0.0; values.len()];
        for (v, &s) in values.iter().zip(&self.slot) {
            permuted[s] = *v;
        }
        let a = SparseColMatRef::new(self.lower.as_ref(), &permuted[..]);
        let sym = &self.symbolic;
        let mut l = vec![0.0; sym.len_val()];
        let mut mem = MemBuffer::try_new(self.scratch)
            .map_err(|_| anyhow!("sparse Cholesky (faer): out of memory"))?;
        sym.factorize_numeric_llt(
            &mut l,
            a,
            Side::Lower,
            LltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .map_err(|e| anyhow!("sparse Cholesky (faer): {e:?}"))?;
        Ok(Box::new(FaerFactor {
            new_of: Arc::clone(&self.new_of),
            symbolic: Arc::clone(sym),
            l,
        }))
    }
}

impl Factorization for FaerFactor {
    fn solve_in_place(&self, b: &mut [f64]) {
        self.solve_columns_in_place(b, 1);
    }
    fn solve_columns_in_place(&self, b: &mut [f64], columns: usize) {
        let n = self.symbolic.nrows();
        if columns == 0 || n == 0 {
            return;
        }
        let mut y = vec![0.0; b.len()];
        for (bc, yc) in b.chunks_exact(n).zip(y.chunks_exact_mut(n)) {
            permute(&self.new_of, bc, yc);
        }
        let rhs = MatMut::from_column_major_slice_mut(&mut y, n, columns);
        let mut mem = MemBuffer::new(
            self.symbolic
                .solve_in_place_scratch::<f64>(columns, Par::Seq),
        );
        LltRef::new(&self.symbolic, &self.l).solve_in_place_with_conj(
            Conj::No,
            rhs,
            Par::Seq,
            MemStack::new(&mut mem),
        );
        for (bc, yc) in b.chunks_exact_mut(n).zip(y.chunks_exact(n)) {
            unpermute(&self.new_of, yc, bc);
        }
    }
    fn nonzeros(&self) -> usize {
        self.l.len()
    }
}

// ---------------------------------------------------------------------------------
// Envelope (skyline) Cholesky after RCM.

/// Dot product with eight independent partial sums, so the compiler can vectorise it
/// (a single running sum fixes the order of the additions and cannot be).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s: f64 = acc.iter().sum();
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// Envelope (skyline) Cholesky after a reverse Cuthill–McKee ordering: row i of L is
/// stored densely from its first non-zero column to the diagonal; fill stays inside
/// that envelope.
#[derive(Debug, Clone, Copy, Default)]
pub struct EnvelopeCholesky;

/// The envelope's layout: row i of L from column `first[i]` to the diagonal, stored
/// contiguously from `start[i]` (rows and columns in the RCM numbering).
struct EnvelopeSymbolic {
    perm: Arc<Vec<usize>>,
    first: Arc<Vec<usize>>,
    start: Arc<Vec<usize>>,
    /// Where each entry of the caller's lower pattern goes in the envelope.
    slot: Vec<usize>,
}

struct EnvelopeFactor {
    perm: Arc<Vec<usize>>,
    first: Arc<Vec<usize>>,
    start: Arc<Vec<usize>>,
    l: Vec<f64>,
}

impl LinearSolver for EnvelopeCholesky {
    fn name(&self) -> &'static str {
        "envelope Cholesky, RCM"
    }
    fn analyse(&self, pattern: &LowerPattern) -> Result<Box<dyn SymbolicFactorization>> {
        let n = pattern.n;
        let perm = reverse_cuthill_mckee(&pattern.adjacency());
        let mut first: Vec<usize> = (0..n).collect();
        for j in 0..n {
            for &i in &pattern.row_idx[pattern.col_ptr[j]..pattern.col_ptr[j + 1]] {
                let (r, c) = (perm[i].max(perm[j]), perm[i].min(perm[j]));
                first[r] = first[r].min(c);
            }
        }
        let mut start = vec![0usize; n + 1];
        for i in 0..n {
            start[i + 1] = start[i] + (i - first[i] + 1);
        }
        let mut slot = Vec::with_capacity(pattern.nonzeros());
        for j in 0..n {
            for &i in &pattern.row_idx[pattern.col_ptr[j]..pattern.col_ptr[j + 1]] {
                let (r, c) = (perm[i].max(perm[j]), perm[i].min(perm[j]));
                slot.push(start[r] + (c - first[r]));
            }
        }
        Ok(Box::new(EnvelopeSymbolic {
            perm: Arc::new(perm),
            first: Arc::new(first),
            start: Arc::new(start),
            slot,
        }))
    }
}

impl SymbolicFactorization for EnvelopeSymbolic {
    fn factor(&self, values: &[f64]) -> Result<Box<dyn Factorization>> {
        if values.len() != self.slot.len() {
            bail!(
                "{} values for a pattern of {} entries",
                values.len(),
                self.slot.len()
            );
        }
        let (first, start) = (&self.first, &self.start);
        let n = first.len();
        let mut l = vec![0.0; start[n]];
        for (v, &s) in values.iter().zip(&self.slot) {
            l[s] += v;
        }
        for i in 0..n {
            let fi = first[i];
            for j in fi..i {
                let fj = first[j];
                let lo = fi.max(fj);
                let (head, row_i) = l.split_at_mut(start[i]);
                let row_j = &head[start[j]..start[j] + (j - fj + 1)];
                let a = &row_i[lo - fi..j - fi];
                let b = &row_j[lo - fj..j - fj];
                let dot = dot(a, b);
                let d = row_j[j - fj];
                row_i[j - fi] = (row_i[j - fi] - dot) / d;
            }
            let row_i = &mut l[start[i]..start[i + 1]];
            let (off, diag) = row_i.split_at_mut(i - fi);
            let s = diag[0] - off.iter().map(|x| x * x).sum::<f64>();
            if s.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !s.is_finite() {
                bail!("envelope Cholesky: pivot {i} is not positive ({s:.3e})");
            }
            diag[0] = s.sqrt();
        }
        Ok(Box::new(EnvelopeFactor {
            perm: Arc::clone(&self.perm),
            first: Arc::clone(first),
            start: Arc::clone(start),
            l,
        }))
    }
}

impl Factorization for EnvelopeFactor {
    fn solve_in_place(&self, b: &mut [f64]) {
        let (first, start, l) = (&self.first, &self.start, &self.l);
        let n = first.len();
        let mut y = vec![0.0; n];
        permute(&self.perm, b, &mut y);
        // Forward L y = f, then backward Lᵀ u = y.
        for i in 0..n {
            let row = &l[start[i]..start[i + 1]];
            let fi = first[i];
            let dot = dot(&row[..i - fi], &y[fi..i]);
            y[i] = (y[i] - dot) / row[i - fi];
        }
        for i in (0..n).rev() {
            let row = &l[start[i]..start[i + 1]];
            let fi = first[i];
            y[i] /= row[i - fi];
            let yi = y[i];
            for (k, &lik) in row[..i - fi].iter().enumerate() {
                y[fi + k] -= lik * yi;
            }
        }
        unpermute(&self.perm, &y, b);
    }
    fn nonzeros(&self) -> usize {
        self.l.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1D Laplacian plus long-range couplings: SPD, with a ragged envelope, given in
    /// a scrambled numbering so that the orderings have work to do.
    fn test_matrix(n: usize) -> DMatrix<f64> {
        let scramble = |i: usize| (i * 7) % n;
        let mut k = DMatrix::zeros(n, n);
        for i in 0..n {
            k[(scramble(i), scramble(i))] += 4.0;
            if i + 1 < n {
                k[(scramble(i), scramble(i + 1))] += -1.0;
                k[(scramble(i + 1), scramble(i))] += -1.0;
            }
            if i + 7 < n && i % 3 == 0 {
                k[(scramble(i), scramble(i + 7))] += -0.5;
                k[(scramble(i + 7), scramble(i))] += -0.5;
            }
        }
        k
    }

    #[test]
    fn the_solvers_agree_and_leave_a_round_off_residual() {
        let n = 40; // coprime with the scramble's 7
        let k = test_matrix(n);
        let f = DVector::from_fn(n, |i, _| (i as f64).sin() + 1.0);
        let (a, _) = EnvelopeCholesky.solve(&k, &f).unwrap();
        let (c, _) = SparseLlt::default().solve(&k, &f).unwrap();
        // The dense LU of the whole matrix: a third, independent answer.
        let b = k.clone().lu().solve(&f).unwrap();
        assert!((&a - &b).norm() < 1e-12 * b.norm());
        assert!((&c - &b).norm() < 1e-12 * b.norm());
        for u in [&a, &b, &c] {
            let r = &k * u - &f;
            assert!(r.norm() < 1e-12 * f.norm());
        }
    }

    #[test]
    fn one_symbolic_phase_serves_new_values_and_many_right_hand_sides() {
        let n = 40;
        let k = test_matrix(n);
        let (pattern, values) = LowerPattern::from_dense(&k).unwrap();
        // Scaling K by 3 scales the solution by 1/3: same pattern, new numeric phase.
        let scaled: Vec<f64> = values.iter().map(|v| 3.0 * v).collect();
        for solver in [
            &EnvelopeCholesky as &dyn LinearSolver,
            &SparseLlt::default(),
        ] {
            let sym = solver.analyse(&pattern).unwrap();
            let f1 = sym.factor(&values).unwrap();
            let f3 = sym.factor(&scaled).unwrap();
            let b1: Vec<f64> = (0..n).map(|i| (i as f64).cos()).collect();
            let b2: Vec<f64> = (0..n).map(|i| ((n + i) as f64).cos()).collect();
            let mut two = [b1.clone(), b2.clone()].concat();
            f1.solve_columns_in_place(&mut two, 2);
            let (mut x1, mut x2, mut y2) = (b1.clone(), b2.clone(), b2.clone());
            f1.solve_in_place(&mut x1);
            f1.solve_in_place(&mut x2);
            f3.solve_in_place(&mut y2);
            let r = &k * DVector::from_column_slice(&x1) - DVector::from_column_slice(&b1);
            assert!(r.norm() < 1e-12, "{}", solver.name());
            for i in 0..n {
                assert!((two[i] - x1[i]).abs() < 1e-13, "{}", solver.name());
                assert!((two[n + i] - x2[i]).abs() < 1e-13, "{}", solver.name());
                assert!((3.0 * y2[i] - x2[i]).abs() < 1e-13, "{}", solver.name());
            }
        }
    }

    #[test]
    fn every_solver_rejects_an_indefinite_matrix() {
        let k = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        for solver in [
            &EnvelopeCholesky as &dyn LinearSolver,
            &SparseLlt::default(),
        ] {
            assert!(
                solver.solve(&k, &DVector::from_element(2, 1.0)).is_err(),
                "{}",
                solver.name()
            );
        }
    }

    #[test]
    fn rcm_is_a_permutation() {
        let adj = vec![vec![3], vec![2], vec![1, 3], vec![0, 2]];
        let mut p = reverse_cuthill_mckee(&adj);
        p.sort_unstable();
        assert_eq!(p, vec![0, 1, 2, 3]);
    }
}
