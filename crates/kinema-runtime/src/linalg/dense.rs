//! Dense LU with partial pivoting: [`DenseLu<N>`] (inline storage, size known
//! at compile time) and [`DynDenseLu`] (one heap buffer sized at analysis).
//!
//! Both run the same in-place kernel on a row-major n × n array:
//!
//! * row-major, so eliminating a row is one contiguous `row_i -= l · row_k`;
//! * rows whose entry in the pivot column is exactly zero are skipped. The
//!   Jacobians of mechanisms are sparse even when stored densely (21 of 81
//!   entries for the slider-crank), so most of the O(n³) updates vanish;
//! * the nonzeros are scattered through indices computed once from the
//!   fixed pattern;
//! * the reciprocals of the pivots are kept, so back substitution multiplies.
//!
//! Measured against nalgebra's `SMatrix::lu` on the slider-crank Jacobian
//! (`cargo bench -p kinema-runtime --bench linalg`), this kernel is several
//! times faster; see `BENCHMARKS-runtime.md`.

use super::schedule::{DenseStructure, Schedule, SlotIndex};
use super::{LinalgError, LinearSolver, PivotReport, check_len, validate_pattern};

/// LU with partial pivoting of an N × N matrix, sized at compile time — the
/// solver for generated code of small mechanisms, e.g.
/// `Solver<SliderCrank, DenseLu<9>>`.
///
/// Solves A x = b by PA = LU. Pivots are chosen by the dense kernel (partial
/// pivoting on an inline row-major `[[f64; N]; N]`); the elimination for that
/// pivot order is then recorded once over the structural nonzeros (see
/// [the module docs](super#refactorization)) and replayed at every later
/// factorization, so a step costs only the structural multiply-adds. When a
/// replayed pivot fails the threshold test the kernel repivots. All storage
/// is reserved at analysis for the worst case; nothing allocates afterwards.
///
/// Keep N small (up to a few dozen): the kernel's matrix lives inside the
/// struct and the reserved schedule grows as N³. Use
/// [`SparseLu`](super::SparseLu) for large systems.
#[derive(Debug, Clone)]
pub struct DenseLu<const N: usize> {
    /// Row-major matrix, overwritten by L (unit diagonal, below) and U.
    a: [[f64; N]; N],
    /// Row interchanges: at step k, row k was swapped with row `piv[k]`.
    piv: [usize; N],
    /// 1 / u_kk.
    inv_diag: [f64; N],
    /// maxᵢⱼ |aᵢⱼ| of the last kernel factorization.
    scale: f64,
    replay: DenseReplay,
}

impl<const N: usize> LinearSolver for DenseLu<N> {
    fn analyze(n: usize, pattern: &[(u32, u32)]) -> Result<Self, LinalgError> {
        check_len("system dimension for DenseLu<N>", N, n)?;
        Ok(Self {
            a: [[0.0; N]; N],
            piv: [0; N],
            inv_diag: [0.0; N],
            scale: 0.0,
            replay: DenseReplay::new(N, pattern)?,
        })
    }

    #[inline]
    fn dim(&self) -> usize {
        N
    }

    fn factor(&mut self, values: &[f64], singular_tolerance: f64) -> Result<(), LinalgError> {
        if self.replay.try_replay(values, singular_tolerance)? {
            return Ok(());
        }
        let a = self.a.as_flattened_mut();
        let scale = scatter(a, &self.replay.scatter, values);
        self.scale = scale;
        factor_in_place(
            a,
            N,
            &mut self.piv,
            &mut self.inv_diag,
            singular_tolerance * scale,
            scale,
        )?;
        self.replay.record(&self.piv, values, singular_tolerance);
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", N, rhs.len())?;
        match self.replay.active {
            Active::None => return Err(LinalgError::NotFactored),
            Active::Kernel => solve(self.a.as_flattened(), N, &self.piv, &self.inv_diag, rhs),
            Active::Schedule => self.replay.schedule.solve(rhs),
        }
        Ok(())
    }

    fn solve_transpose_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", N, rhs.len())?;
        match self.replay.active {
            Active::None => return Err(LinalgError::NotFactored),
            Active::Kernel => {
                solve_transpose(self.a.as_flattened(), N, &self.piv, &self.inv_diag, rhs)
            }
            Active::Schedule => self.replay.schedule.solve_transpose(rhs),
        }
        Ok(())
    }

    fn pivot_report(&self) -> Option<PivotReport> {
        self.replay.report(&self.piv, &self.inv_diag, self.scale)
    }
}

/// LU with partial pivoting of an n × n matrix whose size is known only at
/// run time — [`DenseLu`] with its matrix on the heap. All buffers are
/// allocated once in [`analyze`](LinearSolver::analyze), including room for
/// the worst-case schedule (O(n³) indices), so keep n moderate.
///
/// Solves A x = b by PA = LU, exactly as [`DenseLu`] does.
#[derive(Debug, Clone)]
pub struct DynDenseLu {
    n: usize,
    a: Box<[f64]>,
    piv: Box<[usize]>,
    inv_diag: Box<[f64]>,
    scale: f64,
    replay: DenseReplay,
}

impl LinearSolver for DynDenseLu {
    fn analyze(n: usize, pattern: &[(u32, u32)]) -> Result<Self, LinalgError> {
        Ok(Self {
            n,
            a: vec![0.0; n * n].into_boxed_slice(),
            piv: vec![0; n].into_boxed_slice(),
            inv_diag: vec![0.0; n].into_boxed_slice(),
            scale: 0.0,
            replay: DenseReplay::new(n, pattern)?,
        })
    }

    #[inline]
    fn dim(&self) -> usize {
        self.n
    }

    fn factor(&mut self, values: &[f64], singular_tolerance: f64) -> Result<(), LinalgError> {
        if self.replay.try_replay(values, singular_tolerance)? {
            return Ok(());
        }
        let scale = scatter(&mut self.a, &self.replay.scatter, values);
        self.scale = scale;
        factor_in_place(
            &mut self.a,
            self.n,
            &mut self.piv,
            &mut self.inv_diag,
            singular_tolerance * scale,
            scale,
        )?;
        self.replay.record(&self.piv, values, singular_tolerance);
        Ok(())
    }

    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", self.n, rhs.len())?;
        match self.replay.active {
            Active::None => return Err(LinalgError::NotFactored),
            Active::Kernel => solve(&self.a, self.n, &self.piv, &self.inv_diag, rhs),
            Active::Schedule => self.replay.schedule.solve(rhs),
        }
        Ok(())
    }

    fn solve_transpose_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", self.n, rhs.len())?;
        match self.replay.active {
            Active::None => return Err(LinalgError::NotFactored),
            Active::Kernel => solve_transpose(&self.a, self.n, &self.piv, &self.inv_diag, rhs),
            Active::Schedule => self.replay.schedule.solve_transpose(rhs),
        }
        Ok(())
    }

    fn pivot_report(&self) -> Option<PivotReport> {
        self.replay.report(&self.piv, &self.inv_diag, self.scale)
    }
}

/// Which factorization the next solve uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Active {
    None,
    Kernel,
    Schedule,
}

/// The replay part shared by the dense solvers: the schedule and the scratch
/// to rebuild it without allocating.
#[derive(Debug, Clone)]
struct DenseReplay {
    n: usize,
    /// For each pattern entry, its index row · n + col in the dense matrix.
    scatter: Box<[usize]>,
    pattern: Box<[(u32, u32)]>,
    schedule: Schedule,
    mask: Box<[bool]>,
    slot_table: Box<[u32]>,
    order: Box<[u32]>,
    active: Active,
}

impl DenseReplay {
    fn new(n: usize, pattern: &[(u32, u32)]) -> Result<Self, LinalgError> {
        let updates = n * n.saturating_sub(1) * (2 * n).saturating_sub(1) / 6;
        Ok(Self {
            n,
            scatter: scatter_indices(n, pattern)?,
            pattern: pattern.into(),
            schedule: Schedule::with_capacity(n, pattern.len(), n * n, updates),
            mask: vec![false; n * n].into_boxed_slice(),
            slot_table: vec![0; n * n].into_boxed_slice(),
            order: vec![0; n].into_boxed_slice(),
            active: Active::None,
        })
    }

    /// The pivots of the active factorization: the schedule's, or the
    /// kernel's (row interchanges `piv`, reciprocal pivots `inv_diag`).
    fn report(&self, piv: &[usize], inv_diag: &[f64], scale: f64) -> Option<PivotReport> {
        match self.active {
            Active::None => None,
            Active::Schedule => Some(self.schedule.pivot_report()),
            Active::Kernel => {
                let swaps = piv.iter().enumerate().filter(|&(k, &p)| p != k).count();
                let sign = if swaps % 2 == 0 { 1.0 } else { -1.0 };
                Some(PivotReport::from_inverse_pivots(inv_diag, scale, sign))
            }
        }
    }

    /// Checks the length, then replays the recorded elimination if there is
    /// one; `Ok(true)` if that factored A.
    fn try_replay(&mut self, values: &[f64], singular_tolerance: f64) -> Result<bool, LinalgError> {
        self.active = Active::None;
        check_len("Jacobian values", self.scatter.len(), values.len())?;
        if self.schedule.is_ready() && self.schedule.refactor(values, singular_tolerance).is_ok() {
            self.active = Active::Schedule;
            return Ok(true);
        }
        Ok(false)
    }

    /// After the kernel factored A with row interchanges `piv`: records the
    /// elimination for that order and replays it (falling back to the
    /// kernel's factors in the rare case the replay disagrees).
    fn record(&mut self, piv: &[usize], values: &[f64], singular_tolerance: f64) {
        self.active = Active::Kernel;
        for (k, o) in self.order.iter_mut().enumerate() {
            *o = k as u32;
        }
        for (k, &p) in piv.iter().enumerate() {
            self.order.swap(k, p);
        }
        self.mask.fill(false);
        let mut structure = DenseStructure {
            n: self.n,
            mask: &mut self.mask,
        };
        let mut slots = SlotIndex::Dense {
            n: self.n,
            table: &mut self.slot_table,
        };
        self.schedule.build(
            &self.pattern,
            self.order.iter().copied(),
            0..self.n as u32,
            &mut structure,
            &mut slots,
        );
        if self.schedule.refactor(values, singular_tolerance).is_ok() {
            self.active = Active::Schedule;
        }
    }
}

/// Flattened row-major index of each pattern entry (after validating it).
fn scatter_indices(n: usize, pattern: &[(u32, u32)]) -> Result<Box<[usize]>, LinalgError> {
    validate_pattern(n, pattern)?;
    Ok(pattern
        .iter()
        .map(|&(r, c)| r as usize * n + c as usize)
        .collect())
}

/// Zeroes `a`, writes the nonzeros, returns the scale maxᵢⱼ |aᵢⱼ|.
#[inline(always)]
fn scatter(a: &mut [f64], index: &[usize], values: &[f64]) -> f64 {
    a.fill(0.0);
    let mut scale = 0.0_f64;
    for (&k, &v) in index.iter().zip(values) {
        if let Some(slot) = a.get_mut(k) {
            *slot = v;
        }
        scale = scale.max(v.abs());
    }
    scale
}

/// In-place LU with partial pivoting of the row-major n × n matrix `a`
/// (PA = LU, L unit lower triangular stored below the diagonal).
///
/// Fails when the largest candidate pivot is not above `threshold` (a NaN
/// pivot fails too). `#[inline(always)]` so that `DenseLu<N>` gets a copy
/// specialized for its constant n.
#[inline(always)]
fn factor_in_place(
    a: &mut [f64],
    n: usize,
    piv: &mut [usize],
    inv_diag: &mut [f64],
    threshold: f64,
    scale: f64,
) -> Result<(), LinalgError> {
    for k in 0..n {
        // Pivot search down column k.
        let mut p = k;
        let mut best = a[k * n + k].abs();
        for i in k + 1..n {
            let v = a[i * n + k].abs();
            if v > best {
                best = v;
                p = i;
            }
        }
        // `best > threshold` is false for a NaN pivot too.
        let acceptable = best > threshold;
        if !acceptable {
            return Err(LinalgError::Singular {
                step: k,
                pivot: best,
                scale,
            });
        }
        piv[k] = p;
        if p != k {
            let (top, bottom) = a.split_at_mut(p * n);
            top[k * n..(k + 1) * n].swap_with_slice(&mut bottom[..n]);
        }
        let (top, bottom) = a.split_at_mut((k + 1) * n);
        let row_k = &top[k * n..];
        let inv = 1.0 / row_k[k];
        inv_diag[k] = inv;
        for row in bottom.chunks_exact_mut(n) {
            let lik = row[k];
            if lik != 0.0 {
                let l = lik * inv;
                row[k] = l;
                for (x, &u) in row[k + 1..].iter_mut().zip(&row_k[k + 1..]) {
                    *x -= l * u;
                }
            }
        }
    }
    Ok(())
}

/// Solves LU x = P b in place, given the output of [`factor_in_place`].
#[inline(always)]
fn solve(a: &[f64], n: usize, piv: &[usize], inv_diag: &[f64], x: &mut [f64]) {
    for (k, &p) in piv.iter().enumerate().take(n) {
        x.swap(k, p);
    }
    // Forward: L y = P b, L unit lower triangular.
    for i in 1..n {
        let row = &a[i * n..i * n + i];
        let s: f64 = row.iter().zip(&x[..i]).map(|(l, y)| l * y).sum();
        x[i] -= s;
    }
    // Backward: U x = y.
    for i in (0..n).rev() {
        let row = &a[i * n + i + 1..(i + 1) * n];
        let s: f64 = row.iter().zip(&x[i + 1..]).map(|(u, y)| u * y).sum();
        x[i] = (x[i] - s) * inv_diag[i];
    }
}

/// Solves Aᵀ x = b for PA = LU, in place, given
/// the output of [`factor_in_place`]: Uᵀ z = b, Lᵀ w = z, x = Pᵀ w.
#[inline(always)]
fn solve_transpose(a: &[f64], n: usize, piv: &[usize], inv_diag: &[f64], x: &mut [f64]) {
    // Forward: Uᵀ z = b, Uᵀ lower triangular (column i of U above the diagonal).
    for i in 0..n {
        let s: f64 = x[..i]
            .iter()
            .enumerate()
            .map(|(k, z)| a[k * n + i] * z)
            .sum();
        x[i] = (x[i] - s) * inv_diag[i];
    }
    // Backward: Lᵀ w = z, Lᵀ unit upper triangular (column i of L below).
    for i in (0..n).rev() {
        let s: f64 = x[i + 1..n]
            .iter()
            .enumerate()
            .map(|(d, w)| a[(i + 1 + d) * n + i] * w)
            .sum();
        x[i] -= s;
    }
    // x = Pᵀ w: the interchanges undone in reverse order.
    for (k, &p) in piv.iter().enumerate().take(n).rev() {
        x.swap(k, p);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dense_pattern(n: usize) -> Vec<(u32, u32)> {
        (0..n as u32)
            .flat_map(|r| (0..n as u32).map(move |c| (r, c)))
            .collect()
    }

    #[test]
    fn solves_a_permuted_system() -> Result<(), LinalgError> {
        // A needs pivoting: a_00 = 0.
        let a = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x = [1.0, -2.0, 0.5];
        let b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| a[i * 3 + j] * x[j]).sum())
            .collect();
        let mut lu = DenseLu::<3>::analyze(3, &dense_pattern(3))?;
        lu.factor(&a, 1e-14)?;
        let mut rhs = b.clone();
        lu.solve_in_place(&mut rhs)?;
        for (r, e) in rhs.iter().zip(&x) {
            assert!((r - e).abs() < 1e-14, "{r} vs {e}");
        }
        let mut dynlu = DynDenseLu::analyze(3, &dense_pattern(3))?;
        dynlu.factor(&a, 1e-14)?;
        let mut rhs2 = b;
        dynlu.solve_in_place(&mut rhs2)?;
        assert_eq!(rhs, rhs2);
        Ok(())
    }

    #[test]
    fn reports_singular_matrix() -> Result<(), LinalgError> {
        let a = [1.0, 2.0, 2.0, 4.0];
        let mut lu = DenseLu::<2>::analyze(2, &dense_pattern(2))?;
        let err = lu.factor(&a, 1e-12);
        assert!(
            matches!(err, Err(LinalgError::Singular { step: 1, .. })),
            "{err:?}"
        );
        let mut rhs = [1.0, 1.0];
        assert_eq!(lu.solve_in_place(&mut rhs), Err(LinalgError::NotFactored));
        // A regular matrix afterwards factors, then replays its schedule.
        for a in [
            [1.0, 2.0, 3.0, 4.0],
            [1.0, 2.0, 3.0, 5.0],
            [3.0, 2.0, 1.0, 4.0],
        ] {
            lu.factor(&a, 1e-12)?;
            let mut x = [a[0] + a[1], a[2] + a[3]];
            lu.solve_in_place(&mut x)?;
            assert!(
                (x[0] - 1.0).abs() < 1e-14 && (x[1] - 1.0).abs() < 1e-14,
                "{x:?}"
            );
        }
        Ok(())
    }

    #[test]
    fn rejects_bad_patterns_and_sizes() {
        assert!(matches!(
            DenseLu::<2>::analyze(3, &[]),
            Err(LinalgError::Dimension { .. })
        ));
        assert!(matches!(
            DynDenseLu::analyze(2, &[(0, 0), (2, 1)]),
            Err(LinalgError::OutOfRange { index: 1, .. })
        ));
        assert!(matches!(
            DynDenseLu::analyze(2, &[(0, 0), (1, 1), (0, 0)]),
            Err(LinalgError::Duplicate {
                first: 0,
                second: 2,
                ..
            })
        ));
    }
}
