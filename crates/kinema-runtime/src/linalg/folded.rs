//! A fixed-order LU specialised for one system when it is analysed:
//! [`FoldedLu`], the run-time counterpart of a generated LU.
//!
//! A generated LU chooses its pivot order at generation time and emits the
//! elimination as straight-line code with the constant entries of Φ_q (the
//! ±1 of every joint's x and y rows) folded away. A system known only at run
//! time (a model file's tapes) gets the same plan here, at analysis: the
//! order chosen by Markowitz's criterion under threshold partial pivoting on
//! the values at the initial guess, constants preferred among equals; the
//! elimination simulated with every entry either a number known now or a
//! value computed at run time; and what remains recorded as one flat list
//! of operations, each writing the next value. A factorization copies the
//! run-time entries in and runs that list; the solves run lists of the same
//! kind. No index lists per step, no structural zeros, no multiplication by
//! a unit pivot.
//!
//! The acceptance rule and the fallback are the generated LU's: every input
//! finite, every constant entry still its constant, every pivot
//! |u_kk| > τ · maxᵢⱼ |aᵢⱼ| and every multiplier |l_ik| ≤ 1/θ
//! ([`order_accepted`](super::order_accepted)); otherwise the
//! factorization is done by the general solver it holds ([`Auto`]'s dense
//! or sparse LU), whose partial pivoting gives the singularity verdict.
//!
//! Here the types and the [`LinearSolver`] interface; the plan is made in
//! `plan` (at analysis), run in `interpret` (at every factorization and
//! solve), and handed to a compiler through the read-only views and
//! traits of `compiled` (re-exported here).

mod compiled;
mod interpret;
mod plan;

pub use compiled::{
    CompiledFactor, CompiledSolves, FactorScan, FoldedFactor, FoldedSolves, Op, RawScan, SolveOp,
};

use super::{Auto, LinalgError, LinearSolver, PivotReport, check_len};

/// A value during the simulated elimination.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Val {
    /// Known at analysis.
    Const(f64),
    /// Computed at run time: index into the value array.
    Var(u32),
}
/// Which factorization the solves use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Current {
    None,
    Folded,
    Fallback,
}

/// LU with a pivot order fixed at analysis and the system's constant
/// Jacobian entries folded out (see the module `linalg::folded`). Built by
/// [`Auto`]'s [`LinearSolver::analyze_system`] for systems that say which
/// entries are constant ([`System::jacobian_constant`]); falls back to a
/// general [`Auto`] at any factorization the fixed order does not accept.
///
/// [`System::jacobian_constant`]: crate::System::jacobian_constant
#[derive(Debug)]
pub struct FoldedLu {
    n: usize,
    nnz: usize,
    /// The fixed order's plan; `None` when there is none (always the
    /// general solver).
    folded: Option<Box<Folded>>,
    current: Current,
    /// The general solver for orders the fixed one does not accept.
    fallback: Auto,
}

/// The fixed order's factorization and solves, as operation lists.
#[derive(Debug)]
struct Folded {
    /// Pattern positions of the run-time entries: value i is `values[inputs[i]]`.
    inputs: Vec<u32>,
    /// Pattern positions and values of the constant entries.
    constants: Vec<(u32, f64)>,
    /// Whether the constants are trusted as written (see
    /// [`FoldedLu::trust_constants`]).
    trusted: bool,
    /// The factorization: op k writes value `inputs.len() + k`.
    ops: Vec<Op>,
    /// Inputs, then the ops' results.
    v: Vec<f64>,
    /// Run-time pivots and multipliers (checked), and the constants' worst.
    pivot_vars: Vec<u32>,
    multiplier_vars: Vec<u32>,
    const_min_pivot: f64,
    const_max_multiplier: f64,
    /// The constant entries' largest magnitude.
    const_scale: f64,
    /// 1 / u_kk per position k.
    inv: Vec<Val>,
    /// Original row and column at each position of P A Q.
    row_order: Vec<u32>,
    col_order: Vec<u32>,
    /// L y = P b, U x = y; Uᵀ z = Qᵀ b, Lᵀ x = z.
    forward: Vec<SolveOp>,
    backward: Vec<SolveOp>,
    forward_t: Vec<SolveOp>,
    backward_t: Vec<SolveOp>,
    /// sign(P) sign(Q) ∏ sign(constant pivots): the determinant's sign
    /// but for the run-time pivots'.
    fixed_sign: f64,
    /// The last factorization's scan (the pivot report's numbers).
    scan: RawScan,
    work: Vec<f64>,
    /// The solves compiled to native code, if they were.
    compiled: Option<Box<dyn CompiledSolves>>,
    /// The factorization compiled to native code, if it was.
    compiled_factor: Option<Box<dyn CompiledFactor>>,
}
impl FoldedLu {
    /// Plans the factorization of the n × n matrix with nonzeros `pattern`,
    /// `constants[k]` the value of entry k if it never changes, `values` the
    /// entries at the initial guess (they choose the order). Without a
    /// usable fixed order (a constant pivot of zero, a constant multiplier
    /// over 1/θ, slices of other lengths than the pattern) or with one too
    /// large, every factorization is the general solver's.
    ///
    /// # Errors
    /// The general solver's analysis errors (an invalid pattern).
    pub fn new(
        n: usize,
        pattern: &[(u32, u32)],
        constants: &[Option<f64>],
        values: &[f64],
    ) -> Result<FoldedLu, LinalgError> {
        let fallback = Auto::analyze(n, pattern)?;
        let folded = if constants.len() == pattern.len() && values.len() == pattern.len() {
            Folded::plan(n, pattern, constants, values).map(Box::new)
        } else {
            None
        };
        Ok(FoldedLu {
            n,
            nnz: pattern.len(),
            folded,
            current: Current::None,
            fallback,
        })
    }

    /// Whether a fixed order was planned (else every factorization is the
    /// general solver's).
    #[must_use]
    pub fn is_planned(&self) -> bool {
        self.folded.is_some()
    }

    /// The solves' operation lists, read-only (see [`FoldedSolves`]);
    /// `None` without a plan.
    #[must_use]
    pub fn solves(&self) -> Option<FoldedSolves<'_>> {
        self.folded.as_ref().map(|f| FoldedSolves {
            n: self.n,
            values: f.v.len(),
            row_order: &f.row_order,
            col_order: &f.col_order,
            forward: &f.forward,
            backward: &f.backward,
            forward_t: &f.forward_t,
            backward_t: &f.backward_t,
        })
    }

    /// Plugs in compiled solves (see [`CompiledSolves`]); without a plan
    /// they are dropped. The factorization, its acceptance test and the
    /// fallback are unchanged.
    pub fn set_compiled_solves(&mut self, solves: Box<dyn CompiledSolves>) {
        if let Some(f) = &mut self.folded {
            f.compiled = Some(solves);
        }
    }

    /// The factorization's operation lists, read-only (see
    /// [`FoldedFactor`]); `None` without a plan.
    #[must_use]
    pub fn factorization(&self) -> Option<FoldedFactor<'_>> {
        self.folded.as_ref().map(|f| FoldedFactor {
            nnz: self.nnz,
            values: f.v.len(),
            inputs: &f.inputs,
            constants: &f.constants,
            ops: &f.ops,
            pivot_vars: &f.pivot_vars,
            multiplier_vars: &f.multiplier_vars,
            const_min_pivot: f.const_min_pivot,
            const_max_multiplier: f.const_max_multiplier,
            const_scale: f.const_scale,
        })
    }

    /// Stops checking the constant entries in
    /// [`factor_as_written`](LinearSolver::factor_as_written): the system
    /// vouches that its Jacobian has them bit for bit (see
    /// [`System::jacobian_constants_exact`](crate::System::jacobian_constants_exact)).
    /// [`factor`](LinearSolver::factor) still checks them: its values may
    /// be the equilibrated R Φ_q C.
    pub fn trust_constants(&mut self) {
        if let Some(f) = &mut self.folded {
            f.trusted = true;
        }
    }

    /// Plugs in a compiled factorization (see [`CompiledFactor`]); without
    /// a plan it is dropped. The acceptance rule, the pivot report and the
    /// fallback are unchanged.
    pub fn set_compiled_factor(&mut self, factor: Box<dyn CompiledFactor>) {
        if let Some(f) = &mut self.folded {
            f.compiled_factor = Some(factor);
        }
    }

    /// Whether a compiled factorization is plugged in.
    #[must_use]
    pub fn has_compiled_factor(&self) -> bool {
        self.folded
            .as_ref()
            .is_some_and(|f| f.compiled_factor.is_some())
    }

    /// Whether compiled solves are plugged in.
    #[must_use]
    pub fn has_compiled_solves(&self) -> bool {
        self.folded.as_ref().is_some_and(|f| f.compiled.is_some())
    }

    /// Number of operations a factorization in the fixed order runs (after
    /// the copy of the run-time entries); 0 without a plan.
    #[must_use]
    pub fn operations(&self) -> usize {
        self.folded.as_ref().map_or(0, |f| f.ops.len())
    }
}
impl FoldedLu {
    /// [`factor`](LinearSolver::factor), checking the constant entries if
    /// `check`.
    #[inline(always)]
    fn factor_checking(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
        check: bool,
    ) -> Result<(), LinalgError> {
        check_len("Jacobian values", self.nnz, values.len())?;
        self.current = Current::None;
        if let Some(folded) = &mut self.folded
            && folded.factor(values, singular_tolerance, check)
        {
            self.current = Current::Folded;
            return Ok(());
        }
        self.factor_fallback(values, singular_tolerance)
    }

    /// A factorization the fixed order refused, by the general solver. Out
    /// of line: inlined, its code made every factorization save and
    /// restore the registers it uses.
    #[cold]
    #[inline(never)]
    fn factor_fallback(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
    ) -> Result<(), LinalgError> {
        self.fallback.factor(values, singular_tolerance)?;
        self.current = Current::Fallback;
        Ok(())
    }

    /// A solve with the general solver's factorization (out of line, as
    /// [`factor_fallback`](Self::factor_fallback)).
    #[inline(never)]
    fn solve_fallback(&mut self, rhs: &mut [f64], transpose: bool) -> Result<(), LinalgError> {
        if transpose {
            self.fallback.solve_transpose_in_place(rhs)
        } else {
            self.fallback.solve_in_place(rhs)
        }
    }
}

impl LinearSolver for FoldedLu {
    /// Without the system's constants and values: every entry a run-time
    /// value, the order chosen on a matrix of ones. A factorization the
    /// order does not accept is the general solver's.
    fn analyze(n: usize, pattern: &[(u32, u32)]) -> Result<Self, LinalgError> {
        FoldedLu::new(
            n,
            pattern,
            &vec![None; pattern.len()],
            &vec![1.0; pattern.len()],
        )
    }

    #[inline]
    fn dim(&self) -> usize {
        self.n
    }

    #[inline]
    fn factor(&mut self, values: &[f64], singular_tolerance: f64) -> Result<(), LinalgError> {
        self.factor_checking(values, singular_tolerance, true)
    }

    /// Skips the constants' check if they are trusted
    /// ([`trust_constants`](FoldedLu::trust_constants)).
    #[inline]
    fn factor_as_written(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
    ) -> Result<(), LinalgError> {
        let check = !self.folded.as_ref().is_some_and(|f| f.trusted);
        self.factor_checking(values, singular_tolerance, check)
    }

    #[inline]
    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", self.n, rhs.len())?;
        match (self.current, &mut self.folded) {
            (Current::Folded, Some(folded)) => {
                folded.solve(rhs, false);
                Ok(())
            }
            (Current::Fallback, _) => self.solve_fallback(rhs, false),
            _ => Err(LinalgError::NotFactored),
        }
    }

    #[inline]
    fn solve_transpose_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", self.n, rhs.len())?;
        match (self.current, &mut self.folded) {
            (Current::Folded, Some(folded)) => {
                folded.solve(rhs, true);
                Ok(())
            }
            (Current::Fallback, _) => self.solve_fallback(rhs, true),
            _ => Err(LinalgError::NotFactored),
        }
    }

    #[inline]
    fn pivot_report(&self) -> Option<PivotReport> {
        match (self.current, &self.folded) {
            (Current::Folded, Some(f)) => Some(PivotReport::from_smallest_pivot(
                f.scan[FactorScan::MIN_PIVOT],
                f.scan[FactorScan::SCALE],
                if f.scan[FactorScan::NEGATIVE] != 0.0 {
                    -f.fixed_sign
                } else {
                    f.fixed_sign
                },
            )),
            (Current::Fallback, _) => self.fallback.pivot_report(),
            _ => None,
        }
    }
}
#[cfg(test)]
mod tests;
