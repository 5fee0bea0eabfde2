//! Sparse LU for large mechanisms, on faer: [`SparseLu`].
//!
//! # Why faer
//!
//! * It is pure Rust (no C toolchain, no BLAS to link), actively maintained,
//!   and its sparse LU splits the work the way a fixed-pattern Jacobian
//!   wants: the fill-reducing column ordering (COLAMD) is computed once from
//!   the structure, and each numeric factorization reuses it.
//! * Every numeric routine takes its scratch memory from the caller
//!   (`MemStack`), so the per-step path runs on a buffer sized once in
//!   [`analyze`](LinearSolver::analyze) and does not allocate.
//! * Its simplicial (Gilbert–Peierls, left-looking) LU with partial pivoting
//!   exposes the U factor, so pivots can be checked against our singularity
//!   criterion instead of silently producing infinities, and exposes the row
//!   and column permutations, which our recorded refactorization reuses.
//! * The alternatives are either bindings to C (UMFPACK, KLU through
//!   suitesparse-sys, which a generated solver's users would have to build)
//!   or unmaintained.
//!
//! We use the simplicial variant directly: mechanism Jacobians have a handful
//! of nonzeros per column and little fill, the regime where supernodes do not
//! pay.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::perm::PermRef;
use faer::sparse::linalg::LuError;
use faer::sparse::linalg::colamd;
use faer::sparse::linalg::lu::simplicial::{
    SimplicialLu, factorize_simplicial_numeric_lu, factorize_simplicial_numeric_lu_scratch,
    solve_in_place_scratch, solve_transpose_in_place_scratch,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};

use std::collections::BTreeMap;

use super::schedule::{Schedule, SlotIndex, SparseStructure};
use super::{
    LinalgError, LinearSolver, PivotReport, check_len, permutation_sign, validate_pattern,
};

/// Sparse LU for large systems: faer chooses the pivots, a recorded
/// elimination does the per-step work.
///
/// [`analyze`](LinearSolver::analyze) converts the pattern to compressed
/// columns and computes a COLAMD column ordering Q once. The first
/// [`factor`](LinearSolver::factor) runs faer's simplicial LU with partial
/// pivoting, P A Q = L U, checks its pivots against the singularity
/// criterion, and records the elimination for that P and Q; later
/// factorizations replay the recording (see [the module
/// docs](super#refactorization)) until a pivot fails the threshold test,
/// which sends the factorization back to faer.
///
/// Allocation: none per step while the pivot order holds. A repivot
/// rebuilds the recording, which allocates (ordered sets for the symbolic
/// fill); along the benchmark motions it happens only at the first
/// factorization.
pub struct SparseLu {
    n: usize,
    /// Compressed sparse column structure of A (rows sorted in each column).
    col_ptr: Box<[usize]>,
    row_idx: Box<[usize]>,
    /// Values in compressed-column order.
    values: Box<[f64]>,
    /// For pattern entry k, its position in `values`.
    slot: Box<[usize]>,
    col_perm: Box<[usize]>,
    col_perm_inv: Box<[usize]>,
    row_perm: Box<[usize]>,
    row_perm_inv: Box<[usize]>,
    lu: SimplicialLu<usize, f64>,
    scratch: MemBuffer,
    pattern: Box<[(u32, u32)]>,
    schedule: Schedule,
    /// Pivots of faer's last factorization.
    faer_report: PivotReport,
    /// Scratch for the permutations' sign.
    perm_scratch: Box<[usize]>,
    active: Active,
}

/// Which factorization the next solve uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Active {
    None,
    Faer,
    Schedule,
}

impl std::fmt::Debug for SparseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLu")
            .field("n", &self.n)
            .field("nnz", &self.values.len())
            .field("active", &self.active)
            .finish_non_exhaustive()
    }
}

impl SparseLu {
    /// As [`analyze`](LinearSolver::analyze), with the fill-reducing
    /// column ordering computed from `ordering` (entries of `pattern`)
    /// instead of the whole pattern: for entries that are there for a
    /// reason other than structure (a regularization's small diagonal,
    /// which would otherwise change the ordering and add fill).
    ///
    /// # Errors
    /// As [`analyze`](LinearSolver::analyze), for either pattern.
    pub fn analyze_ordered_by(
        n: usize,
        pattern: &[(u32, u32)],
        ordering: &[(u32, u32)],
    ) -> Result<Self, LinalgError> {
        validate_pattern(n, pattern)?;
        validate_pattern(n, ordering)?;
        let nnz = pattern.len();
        // Counting sort by column, then by row within a column.
        let mut col_ptr = vec![0usize; n + 1];
        for &(_, c) in pattern {
            col_ptr[c as usize + 1] += 1;
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let mut order: Vec<usize> = (0..nnz).collect();
        order.sort_unstable_by_key(|&k| (pattern[k].1, pattern[k].0));
        let mut row_idx = vec![0usize; nnz];
        let mut slot = vec![0usize; nnz];
        for (pos, &k) in order.iter().enumerate() {
            row_idx[pos] = pattern[k].0 as usize;
            slot[k] = pos;
        }

        let (order_ptr, order_rows) = compressed_columns(n, ordering);
        let symbolic = SymbolicSparseColMatRef::new_checked(n, n, &order_ptr, None, &order_rows);
        let mut col_perm = vec![0usize; n];
        let mut col_perm_inv = vec![0usize; n];
        {
            let req = colamd::order_scratch::<usize>(n, n, order_rows.len());
            let mut mem =
                MemBuffer::try_new(req).map_err(|e| LinalgError::Backend(format!("{e:?}")))?;
            colamd::order(
                &mut col_perm,
                &mut col_perm_inv,
                symbolic,
                colamd::Control::default(),
                MemStack::new(&mut mem),
            )
            .map_err(|e| LinalgError::Backend(format!("{e:?}")))?;
        }
        let req = StackReq::any_of(&[
            factorize_simplicial_numeric_lu_scratch::<usize, f64>(n, n),
            solve_in_place_scratch::<usize, f64>(n, 1, Par::Seq),
            solve_transpose_in_place_scratch::<usize, f64>(n, 1, Par::Seq),
        ]);
        let scratch =
            MemBuffer::try_new(req).map_err(|e| LinalgError::Backend(format!("{e:?}")))?;
        Ok(Self {
            n,
            col_ptr: col_ptr.into_boxed_slice(),
            row_idx: row_idx.into_boxed_slice(),
            values: vec![0.0; nnz].into_boxed_slice(),
            slot: slot.into_boxed_slice(),
            col_perm: col_perm.into_boxed_slice(),
            col_perm_inv: col_perm_inv.into_boxed_slice(),
            row_perm: vec![0; n].into_boxed_slice(),
            row_perm_inv: vec![0; n].into_boxed_slice(),
            lu: SimplicialLu::new(),
            scratch,
            pattern: pattern.into(),
            schedule: Schedule::with_capacity(n, nnz, 0, 0),
            faer_report: PivotReport {
                ratio: 0.0,
                det_sign: 1.0,
            },
            perm_scratch: vec![0; n].into_boxed_slice(),
            active: Active::None,
        })
    }
}

/// Column pointers and row indices (rows sorted in each column) of
/// `pattern`.
fn compressed_columns(n: usize, pattern: &[(u32, u32)]) -> (Vec<usize>, Vec<usize>) {
    let mut col_ptr = vec![0usize; n + 1];
    for &(_, c) in pattern {
        col_ptr[c as usize + 1] += 1;
    }
    for j in 0..n {
        col_ptr[j + 1] += col_ptr[j];
    }
    let mut sorted: Vec<(u32, u32)> = pattern.iter().map(|&(r, c)| (c, r)).collect();
    sorted.sort_unstable();
    (
        col_ptr,
        sorted.into_iter().map(|(_, r)| r as usize).collect(),
    )
}

impl LinearSolver for SparseLu {
    fn analyze(n: usize, pattern: &[(u32, u32)]) -> Result<Self, LinalgError> {
        Self::analyze_ordered_by(n, pattern, pattern)
    }

    #[inline]
    fn dim(&self) -> usize {
        self.n
    }

    fn factor(&mut self, values: &[f64], singular_tolerance: f64) -> Result<(), LinalgError> {
        self.active = Active::None;
        check_len("Jacobian values", self.slot.len(), values.len())?;
        if self.schedule.is_ready() && self.schedule.refactor(values, singular_tolerance).is_ok() {
            self.active = Active::Schedule;
            return Ok(());
        }
        self.factor_with_faer(values, singular_tolerance)?;
        self.active = Active::Faer;
        // Record the elimination for faer's pivot order (allocates; only when
        // the pivot order changes).
        let mut structure = SparseStructure::new(self.n);
        let mut slots = SlotIndex::Sparse(BTreeMap::new());
        self.schedule.build(
            &self.pattern,
            self.row_perm.iter().map(|&r| r as u32),
            self.col_perm.iter().map(|&c| c as u32),
            &mut structure,
            &mut slots,
        );
        if self.schedule.refactor(values, singular_tolerance).is_ok() {
            self.active = Active::Schedule;
        }
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", self.n, rhs.len())?;
        match self.active {
            Active::None => Err(LinalgError::NotFactored),
            Active::Schedule => {
                self.schedule.solve(rhs);
                Ok(())
            }
            Active::Faer => {
                self.solve_with_faer(rhs, false);
                Ok(())
            }
        }
    }

    fn solve_transpose_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", self.n, rhs.len())?;
        match self.active {
            Active::None => Err(LinalgError::NotFactored),
            Active::Schedule => {
                self.schedule.solve_transpose(rhs);
                Ok(())
            }
            Active::Faer => {
                self.solve_with_faer(rhs, true);
                Ok(())
            }
        }
    }

    fn pivot_report(&self) -> Option<PivotReport> {
        match self.active {
            Active::None => None,
            Active::Schedule => Some(self.schedule.pivot_report()),
            Active::Faer => Some(self.faer_report),
        }
    }
}

impl SparseLu {
    /// Numeric LU by faer with partial pivoting, reusing the symbolic
    /// analysis; checks the pivots.
    fn factor_with_faer(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
    ) -> Result<(), LinalgError> {
        let mut scale = 0.0_f64;
        for (&pos, &v) in self.slot.iter().zip(values) {
            if let Some(dst) = self.values.get_mut(pos) {
                *dst = v;
            }
            scale = scale.max(v.abs());
        }
        let n = self.n;
        let symbolic =
            SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let a = SparseColMatRef::new(symbolic, &self.values);
        let col_perm = PermRef::new_checked(&self.col_perm, &self.col_perm_inv, n);
        factorize_simplicial_numeric_lu(
            &mut self.row_perm,
            &mut self.row_perm_inv,
            &mut self.lu,
            a,
            col_perm,
            MemStack::new(&mut self.scratch),
        )
        .map_err(|e| match e {
            LuError::SymbolicSingular { index } => LinalgError::Singular {
                step: index,
                pivot: 0.0,
                scale,
            },
            LuError::Generic(e) => LinalgError::Backend(format!("{e:?}")),
        })?;
        // Check the pivots u_jj (faer stores the diagonal last in each column
        // of U; we look it up by row index all the same).
        let threshold = singular_tolerance * scale;
        let u = self.lu.u_factor_unsorted();
        let mut sign = permutation_sign(self.row_perm.iter().copied(), &mut self.perm_scratch)
            * permutation_sign(self.col_perm.iter().copied(), &mut self.perm_scratch);
        let mut min_pivot = f64::INFINITY;
        for j in 0..n {
            let rows = u.row_idx_of_col_raw(j);
            let vals = u.val_of_col(j);
            let signed = rows
                .iter()
                .rposition(|&r| r == j)
                .and_then(|p| vals.get(p))
                .copied()
                .unwrap_or(0.0);
            if signed < 0.0 {
                sign = -sign;
            }
            let pivot = signed.abs();
            min_pivot = min_pivot.min(pivot);
            let acceptable = pivot > threshold;
            if !acceptable {
                return Err(LinalgError::Singular {
                    step: j,
                    pivot,
                    scale,
                });
            }
        }
        self.faer_report = PivotReport {
            ratio: if scale > 0.0 { min_pivot / scale } else { 0.0 },
            det_sign: sign,
        };
        Ok(())
    }

    /// Solves A x = b (or Aᵀ x = b) in place with faer's factorization.
    fn solve_with_faer(&mut self, rhs: &mut [f64], transpose: bool) {
        let n = self.n;
        let row_perm = PermRef::new_checked(&self.row_perm, &self.row_perm_inv, n);
        let col_perm = PermRef::new_checked(&self.col_perm, &self.col_perm_inv, n);
        let rhs = MatMut::from_column_major_slice_mut(rhs, n, 1);
        let stack = MemStack::new(&mut self.scratch);
        if transpose {
            self.lu.solve_transpose_in_place_with_conj(
                row_perm,
                col_perm,
                Conj::No,
                rhs,
                Par::Seq,
                stack,
            );
        } else {
            self.lu
                .solve_in_place_with_conj(row_perm, col_perm, Conj::No, rhs, Par::Seq, stack);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::DynDenseLu;

    /// Tridiagonal-plus-corner test matrix with a zero on the diagonal.
    fn example(n: usize) -> (Vec<(u32, u32)>, Vec<f64>) {
        let mut pattern = Vec::new();
        let mut values = Vec::new();
        for i in 0..n {
            for j in i.saturating_sub(1)..(i + 2).min(n) {
                pattern.push((i as u32, j as u32));
                values.push(if i == j {
                    (i % 3) as f64
                } else {
                    1.0 + 0.1 * j as f64
                });
            }
        }
        pattern.push((n as u32 - 1, 0));
        values.push(0.5);
        (pattern, values)
    }

    #[test]
    fn agrees_with_dense() -> Result<(), LinalgError> {
        let n = 40;
        let (pattern, values) = example(n);
        let mut sparse = SparseLu::analyze(n, &pattern)?;
        let mut dense = DynDenseLu::analyze(n, &pattern)?;
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        for round in 0..2 {
            let vals: Vec<f64> = values.iter().map(|v| v * (1.0 + round as f64)).collect();
            sparse.factor(&vals, 1e-14)?;
            dense.factor(&vals, 1e-14)?;
            let (mut xs, mut xd) = (b.clone(), b.clone());
            sparse.solve_in_place(&mut xs)?;
            dense.solve_in_place(&mut xd)?;
            for (s, d) in xs.iter().zip(&xd) {
                assert!((s - d).abs() < 1e-12 * (1.0 + d.abs()), "{s} vs {d}");
            }
        }
        Ok(())
    }

    #[test]
    fn reports_singular_and_structurally_singular() -> Result<(), LinalgError> {
        // Two equal rows.
        let pattern = [(0, 0), (0, 1), (1, 0), (1, 1)];
        let mut lu = SparseLu::analyze(2, &pattern)?;
        assert!(matches!(
            lu.factor(&[1.0, 2.0, 1.0, 2.0], 1e-12),
            Err(LinalgError::Singular { .. })
        ));
        // Column 1 empty.
        let mut lu = SparseLu::analyze(2, &[(0, 0), (1, 0)])?;
        assert!(matches!(
            lu.factor(&[1.0, 1.0], 1e-12),
            Err(LinalgError::Singular { .. })
        ));
        Ok(())
    }
}
