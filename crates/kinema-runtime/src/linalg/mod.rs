//! Linear solvers for Φ_q x = b with a structure fixed for the system's life.
//!
//! Every solver follows the same life cycle, in the manner of sparse direct
//! solvers: [`LinearSolver::analyze`] once from the pattern (validation,
//! orderings, buffers), then per Newton iteration [`LinearSolver::factor`]
//! with new values and one or more [`LinearSolver::solve_in_place`]. Neither
//! `factor` nor `solve_in_place` allocates (see each type for the one
//! exception of [`SparseLu`]).
//!
//! | type | chooses pivots with | for |
//! |---|---|---|
//! | [`DenseLu<N>`] | dense partial pivoting on an inline `[[f64; N]; N]` | generated solvers of small mechanisms |
//! | [`DynDenseLu`] | the same, matrix on the heap | small systems whose n is known only at run time |
//! | [`SparseLu`] | faer's sparse LU (COLAMD ordering, partial pivoting) | large mechanisms (chains of hundreds of bodies) |
//! | [`FoldedLu`] | Markowitz and threshold pivoting on the values at the initial guess, fixed; constant entries folded | systems that say which Jacobian entries are constant (model files' tapes) |
//! | [`Auto`] | [`FoldedLu`] when the system allows, else dense or sparse LU by size | the default |
//!
//! # Refactorization
//!
//! The Jacobian's structure never changes, and along a motion its row pivots
//! rarely do. So once a pivoting factorization P A Q = L U has chosen the
//! order, every solver computes the filled structure of L + U and records the
//! whole elimination as a list of storage slots: for step k, each row i with
//! l_ik ≠ 0 gets a_ij −= l_ik u_kj for the u_kj ≠ 0 of row k. Each later
//! factorization only replays that list — its cost is the number of
//! structural multiply-adds, with no pivot search, no row swaps and no
//! symbolic work (the idea of KLU's refactorization). The solves run over L
//! and U packed in the order they are read.
//!
//! A replay is accepted only if every multiplier satisfies |l_ik| ≤ 1/θ
//! (θ = 0.1: the threshold test |u_kk| ≥ θ |a_ik| of threshold partial
//! pivoting, which bounds element growth) and every pivot passes the
//! singularity test below; otherwise the solver repivots with its pivoting
//! factorization and records the new order. So the singularity verdict is
//! always that of partial pivoting.
//!
//! # Singularity criterion
//!
//! Let s = maxᵢⱼ |aᵢⱼ| be the matrix scale. The matrix is declared
//! numerically singular when the partial-pivoting LU meets a pivot u_kk with
//! |u_kk| ≤ τ · s, τ being the `singular_tolerance` passed to
//! [`LinearSolver::factor`] (see [`Options::singular_tolerance`]). An exactly
//! singular matrix gives a pivot at roundoff level (≈ 1e-16 · s), so any τ
//! well above machine precision detects it; a larger τ also flags
//! near-singular matrices (toggle positions approached within τ).
//!
//! [`Options::singular_tolerance`]: crate::Options::singular_tolerance

mod auto;
mod dense;
mod equilibrate;
mod folded;
mod schedule;
mod sparse;

pub use auto::Auto;
pub use dense::{DenseLu, DynDenseLu};
pub use folded::{
    CompiledFactor, CompiledSolves, FactorScan, FoldedFactor, FoldedLu, FoldedSolves, Op, RawScan,
    SolveOp,
};
pub use sparse::SparseLu;

pub(crate) use equilibrate::{Equilibration, permutation_sign};
pub use schedule::{
    INFINITY_BITS, MAGNITUDE_MASK, MASK_ALL, scale_and_finite, scale_and_finite_array,
    scale_and_finite_at, scale_and_masked_max,
};

/// θ of the threshold test |u_kk| ≥ θ |a_ik| on a factorization with a
/// recorded pivot order (see "Refactorization" above): its multipliers must
/// satisfy |l_ik| ≤ 1/θ.
pub const PIVOT_THRESHOLD: f64 = 0.1;

/// The runtime's one acceptance rule for a factorization in a pivot order
/// chosen beforehand — a replay of a recorded elimination, or a generated
/// LU's static order: every input value finite, every multiplier
/// |l_ik| ≤ 1/θ ([`PIVOT_THRESHOLD`]) and every pivot |u_kk| > τ · scale,
/// `scale` = maxᵢⱼ |aᵢⱼ| from [`scale_and_finite`]. A NaN multiplier or
/// pivot fails. When it fails, the solver factors again with partial
/// pivoting, whose verdict on singularity is the one reported.
#[inline]
#[must_use]
pub fn order_accepted(
    finite: bool,
    max_multiplier: f64,
    min_pivot: f64,
    singular_tolerance: f64,
    scale: f64,
) -> bool {
    finite && max_multiplier <= 1.0 / PIVOT_THRESHOLD && min_pivot > singular_tolerance * scale
}

/// What the pivots of the last factorization P A Q = L U say about A's
/// distance to singularity, for the runtime's monitor (see
/// [`LinearSolver::pivot_report`]).
///
/// * `ratio` = minₖ |u_kk| / maxᵢⱼ |aᵢⱼ|. A small ratio bounds the smallest
///   singular value: σ_min ≤ ‖L‖₂ minₖ |u_kk|, and ‖L‖₂ ≤ n/θ under the
///   threshold test. (The converse does not hold in general, which is why
///   the runtime confirms a small ratio with the equilibrated SVD.)
/// * `det_sign` = sign of det A = sign(P) sign(Q) ∏ₖ sign(u_kk). Along a
///   continuous motion it changes exactly where Φ_q passes a singular
///   configuration, whatever the grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PivotReport {
    /// minₖ |u_kk| / maxᵢⱼ |aᵢⱼ| (0 for a zero matrix).
    pub ratio: f64,
    /// +1 or −1: the sign of det A.
    pub det_sign: f64,
}

impl PivotReport {
    /// The report from the reciprocals of the pivots, the matrix scale and
    /// the sign of the permutations. O(n).
    pub(crate) fn from_inverse_pivots(inv_diag: &[f64], scale: f64, permutation_sign: f64) -> Self {
        Self::from_inverse_pivot_values(inv_diag.iter().copied(), scale, permutation_sign)
    }

    /// [`from_inverse_pivots`](Self::from_inverse_pivots) of values read
    /// one by one.
    /// The report from the smallest pivot magnitude minₖ |u_kk|, bit for
    /// bit what [`from_inverse_pivot_values`](Self::from_inverse_pivot_values)
    /// computes from the 1 / u_kk (the largest |1 / u_kk| is 1 / minₖ |u_kk|
    /// rounded once, rounding being monotone); `det_sign` given.
    pub(crate) fn from_smallest_pivot(min_pivot: f64, scale: f64, det_sign: f64) -> Self {
        let largest_inverse = 1.0 / min_pivot;
        let ratio = if scale > 0.0 && largest_inverse > 0.0 {
            1.0 / (largest_inverse * scale)
        } else {
            0.0
        };
        Self { ratio, det_sign }
    }

    pub(crate) fn from_inverse_pivot_values(
        inv_diag: impl Iterator<Item = f64>,
        scale: f64,
        permutation_sign: f64,
    ) -> Self {
        let mut largest_inverse = 0.0_f64;
        let mut sign = permutation_sign;
        for inv in inv_diag {
            largest_inverse = largest_inverse.max(inv.abs());
            if inv < 0.0 {
                sign = -sign;
            }
        }
        let ratio = if scale > 0.0 && largest_inverse > 0.0 {
            1.0 / (largest_inverse * scale)
        } else {
            0.0
        };
        Self {
            ratio,
            det_sign: sign,
        }
    }
}

/// Why a linear solver could not be built, factor or solve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LinalgError {
    /// A pivot fell below the singularity threshold (see the [module
    /// docs](self)): |pivot| ≤ τ · scale.
    #[error(
        "numerically singular matrix: pivot {pivot:e} at elimination step {step} \
         (matrix scale {scale:e})"
    )]
    Singular {
        /// Elimination step (0-based) at which the pivot was found too small.
        step: usize,
        /// The pivot's absolute value.
        pivot: f64,
        /// The matrix scale maxᵢⱼ |aᵢⱼ|.
        scale: f64,
    },
    /// A slice had the wrong length.
    #[error("{what} has length {found}, expected {expected}")]
    Dimension {
        /// Which argument.
        what: &'static str,
        /// The length required.
        expected: usize,
        /// The length given.
        found: usize,
    },
    /// A pattern entry lies outside the n × n matrix.
    #[error("Jacobian pattern entry {index} = ({row}, {col}) lies outside the {n} × {n} matrix")]
    OutOfRange {
        /// Position of the entry in the pattern.
        index: usize,
        /// Its row.
        row: u32,
        /// Its column.
        col: u32,
        /// Matrix dimension.
        n: usize,
    },
    /// The same (row, column) appears twice in the pattern.
    #[error("Jacobian pattern lists ({row}, {col}) twice (entries {first} and {second})")]
    Duplicate {
        /// Row of the repeated entry.
        row: u32,
        /// Column of the repeated entry.
        col: u32,
        /// Position of its first occurrence.
        first: usize,
        /// Position of its second occurrence.
        second: usize,
    },
    /// `solve_in_place` was called without a successful `factor` before it.
    #[error("solve requested before a successful factorization")]
    NotFactored,
    /// The sparse back end failed for a reason of its own (out of memory,
    /// index overflow).
    #[error("sparse LU back end: {0}")]
    Backend(String),
}

/// A direct solver for A x = b, A = Φ_q an n × n matrix whose nonzeros come
/// in the fixed order of a [`System::jacobian_pattern`].
///
/// [`System::jacobian_pattern`]: crate::System::jacobian_pattern
pub trait LinearSolver: Sized {
    /// Validates the pattern (indices below n, no duplicates) and does all
    /// the work that depends on the structure only: orderings, symbolic
    /// factorization, buffers. May allocate; called once.
    fn analyze(n: usize, pattern: &[(u32, u32)]) -> Result<Self, LinalgError>;

    /// [`analyze`](Self::analyze) for the Jacobian of `system`, which may
    /// also read what the system says of its entries (which are constant,
    /// their values at the initial guess) to specialise itself: [`Auto`]
    /// plans a [`FoldedLu`] this way. The default analyses the pattern only.
    /// Called once, by [`Solver::with_options`](crate::Solver::with_options).
    ///
    /// # Errors
    /// As [`analyze`](Self::analyze).
    fn analyze_system<S: crate::System + ?Sized>(system: &S) -> Result<Self, LinalgError> {
        Self::analyze(system.len(), system.jacobian_pattern())
    }

    /// The dimension n.
    fn dim(&self) -> usize;

    /// Factors A (PA = LU) from `values`, the nonzeros in pattern order.
    ///
    /// Fails with [`LinalgError::Singular`] when a pivot is at most
    /// `singular_tolerance` times the largest |aᵢⱼ| (see the [module
    /// docs](self)). Does not allocate.
    fn factor(&mut self, values: &[f64], singular_tolerance: f64) -> Result<(), LinalgError>;

    /// [`factor`](Self::factor) of the system's Φ_q values exactly as its
    /// [`jacobian`](crate::System::jacobian) wrote them (not equilibrated,
    /// not modified): a solver planned on a system whose constant entries
    /// are exact ([`System::jacobian_constants_exact`](crate::System::jacobian_constants_exact))
    /// need not check them. The default: [`factor`](Self::factor).
    #[inline]
    fn factor_as_written(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
    ) -> Result<(), LinalgError> {
        self.factor(values, singular_tolerance)
    }

    /// Overwrites `rhs` = b with x = A⁻¹ b, using the last successful
    /// factorization. Does not allocate.
    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError>;

    /// Overwrites `rhs` = b with x = A⁻ᵀ b (solves Aᵀ x = b) with the same
    /// factorization [`solve_in_place`](Self::solve_in_place) uses: no
    /// second factorization (inverse dynamics, Φ_qᵀ λ = Q − M q̈). Does not
    /// allocate.
    fn solve_transpose_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError>;

    /// The pivots of the last successful factorization (see
    /// [`PivotReport`]), or `None` if the solver does not track them or
    /// nothing is factored. O(n) at most; does not allocate.
    ///
    /// The runtime's singularity monitor reads it after every step; a solver
    /// that returns `None` leaves the monitor blind (the runtime's own
    /// solvers and generated ones all report).
    fn pivot_report(&self) -> Option<PivotReport> {
        None
    }
}

/// Checks that every pattern entry lies inside the n × n matrix and that none
/// repeats. O(nnz log nnz); allocates (analysis time only).
pub(crate) fn validate_pattern(n: usize, pattern: &[(u32, u32)]) -> Result<(), LinalgError> {
    for (index, &(row, col)) in pattern.iter().enumerate() {
        if row as usize >= n || col as usize >= n {
            return Err(LinalgError::OutOfRange { index, row, col, n });
        }
    }
    let mut order: Vec<usize> = (0..pattern.len()).collect();
    order.sort_unstable_by_key(|&k| (pattern[k], k));
    for w in order.windows(2) {
        if pattern[w[0]] == pattern[w[1]] {
            let (row, col) = pattern[w[0]];
            return Err(LinalgError::Duplicate {
                row,
                col,
                first: w[0],
                second: w[1],
            });
        }
    }
    Ok(())
}

/// Returns an error unless `found == expected`.
#[inline]
pub(crate) fn check_len(
    what: &'static str,
    expected: usize,
    found: usize,
) -> Result<(), LinalgError> {
    if expected == found {
        Ok(())
    } else {
        Err(LinalgError::Dimension {
            what,
            expected,
            found,
        })
    }
}

/// A [`LinearSolver`] that may factor the Jacobian of system `S`.
///
/// The runtime's solvers factor any matrix of the pattern they were analysed
/// for, so they implement it for every system. A generated LU (the
/// `SliderCrankLu` beside a generated `SliderCrank`) folds that system's
/// constant Jacobian entries into its code and factors only that system's
/// Jacobian, so it implements it for its own system alone: a
/// [`Solver`](crate::Solver) for another system with the same pattern does
/// not compile instead of solving the wrong matrix.
pub trait LinearSolverFor<S: ?Sized>: LinearSolver {}

impl<S: ?Sized, const N: usize> LinearSolverFor<S> for DenseLu<N> {}
impl<S: ?Sized> LinearSolverFor<S> for DynDenseLu {}
impl<S: ?Sized> LinearSolverFor<S> for SparseLu {}
impl<S: ?Sized> LinearSolverFor<S> for Auto {}
impl<S: ?Sized> LinearSolverFor<S> for FoldedLu {}
