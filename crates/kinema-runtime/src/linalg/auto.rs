//! Size-based choice between dense and sparse LU: [`Auto`].

use super::{DynDenseLu, FoldedLu, LinalgError, LinearSolver, PivotReport, SparseLu};

/// Dense LU ([`DynDenseLu`]) for n below [`Auto::DEFAULT_THRESHOLD`], sparse
/// LU ([`SparseLu`]) from there on. The default linear solver of
/// [`Solver`](crate::Solver).
///
/// Both replay a recorded elimination at every step (see the [module
/// docs](super#refactorization)); they differ in who chooses the pivot order
/// (dense partial pivoting, or faer's COLAMD column ordering with partial
/// pivoting) and in the memory reserved. Measured per step on the
/// benchmark mechanisms (`BENCHMARKS-runtime.md`), dense wins on the
/// slider-crank (n = 9), sparse from the chain of 5 links (n = 15) on —
/// COLAMD's ordering gives less fill — hence the threshold 12. Override it with
/// [`Auto::with_threshold`] and
/// [`Solver::with_linear_solver`](crate::Solver::with_linear_solver), or name
/// the solver type directly (`Solver<S, SparseLu>`).
#[derive(Debug)]
// One per solver, built once: boxing the larger variant would add an
// indirection to every factorization and solve.
#[allow(clippy::large_enum_variant)]
pub enum Auto {
    /// Dense LU, chosen for small n.
    Dense(DynDenseLu),
    /// Sparse LU, chosen for large n.
    Sparse(SparseLu),
    /// A fixed order planned for one system, with its constant entries
    /// folded ([`FoldedLu`]): chosen by
    /// [`analyze_system`](LinearSolver::analyze_system) up to
    /// [`Auto::MAX_FOLDED`] coordinates.
    Folded(Box<FoldedLu>),
}

impl Auto {
    /// Dimension from which [`Auto`] picks the sparse solver.
    pub const DEFAULT_THRESHOLD: usize = 12;

    /// Largest dimension for which [`analyze_system`](LinearSolver::analyze_system)
    /// plans a [`FoldedLu`]. The plan itself gives up past a bound on its
    /// pivot search and on its operations (then the general solver runs);
    /// this bounds the dense work of setting it up. A mechanism's folded
    /// plan beats the sparse LU's replay at every size measured: the chain
    /// N = 200 (n = 600) needs no factorization arithmetic at all, where the
    /// replay computes every L and U entry (`BENCHMARKS.md`, issue 20).
    pub const MAX_FOLDED: usize = 10_000;

    /// Analyses the pattern with dense LU if `n < threshold`, else sparse LU.
    pub fn with_threshold(
        n: usize,
        pattern: &[(u32, u32)],
        threshold: usize,
    ) -> Result<Self, LinalgError> {
        if n < threshold {
            DynDenseLu::analyze(n, pattern).map(Self::Dense)
        } else {
            SparseLu::analyze(n, pattern).map(Self::Sparse)
        }
    }

    /// `true` if the sparse solver was chosen.
    #[must_use]
    pub fn is_sparse(&self) -> bool {
        matches!(self, Self::Sparse(_))
    }
}

impl LinearSolver for Auto {
    fn analyze(n: usize, pattern: &[(u32, u32)]) -> Result<Self, LinalgError> {
        Self::with_threshold(n, pattern, Self::DEFAULT_THRESHOLD)
    }

    /// A [`FoldedLu`] planned on the system's constant entries and its
    /// Jacobian at the initial guess (t = 0) when the system declares some
    /// ([`System::jacobian_constant`](crate::System::jacobian_constant)),
    /// n ≤ [`Auto::MAX_FOLDED`] and a fixed order exists; else as
    /// [`analyze`](LinearSolver::analyze).
    fn analyze_system<S: crate::System + ?Sized>(system: &S) -> Result<Self, LinalgError> {
        let (n, pattern) = (system.len(), system.jacobian_pattern());
        if n > Self::MAX_FOLDED {
            return Self::analyze(n, pattern);
        }
        let constants: Vec<Option<f64>> = (0..pattern.len())
            .map(|k| system.jacobian_constant(k))
            .collect();
        // A system that declares no constant (generated code, which has its
        // own LU; hand-written systems) keeps the general solvers.
        if constants.iter().all(Option::is_none) {
            return Self::analyze(n, pattern);
        }
        let mut q = vec![0.0; n];
        system.initial_guess(&mut q);
        let mut values = vec![0.0; pattern.len()];
        system.jacobian(&mut system.scratch(), &q, 0.0, &mut values);
        let mut lu = FoldedLu::new(n, pattern, &constants, &values)?;
        if system.jacobian_constants_exact() {
            lu.trust_constants();
        }
        if let Some(compiled) = lu
            .solves()
            .and_then(|plan| system.compile_folded_solves(&plan))
        {
            lu.set_compiled_solves(compiled);
        }
        if let Some(compiled) = lu
            .factorization()
            .and_then(|plan| system.compile_folded_factor(&plan))
        {
            lu.set_compiled_factor(compiled);
        }
        if lu.is_planned() {
            Ok(Self::Folded(Box::new(lu)))
        } else {
            Self::analyze(n, pattern)
        }
    }

    #[inline]
    fn dim(&self) -> usize {
        match self {
            Self::Dense(lu) => lu.dim(),
            Self::Sparse(lu) => lu.dim(),
            Self::Folded(lu) => lu.dim(),
        }
    }

    // The folded LU's calls are inlined, the general solvers' are calls
    // (`general`): inlined, their code made every call through `Auto` save
    // and restore the registers they use, the folded LU's small steps
    // included (a third of the chain N = 2's factorization wrapper).

    #[inline]
    fn factor(&mut self, values: &[f64], singular_tolerance: f64) -> Result<(), LinalgError> {
        match self {
            Self::Folded(lu) => lu.factor(values, singular_tolerance),
            general => general::factor(general, values, singular_tolerance),
        }
    }

    #[inline]
    fn factor_as_written(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
    ) -> Result<(), LinalgError> {
        match self {
            Self::Folded(lu) => lu.factor_as_written(values, singular_tolerance),
            general => general::factor(general, values, singular_tolerance),
        }
    }

    #[inline]
    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        match self {
            Self::Folded(lu) => lu.solve_in_place(rhs),
            general => general::solve(general, rhs, false),
        }
    }

    #[inline]
    fn solve_transpose_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        match self {
            Self::Folded(lu) => lu.solve_transpose_in_place(rhs),
            general => general::solve(general, rhs, true),
        }
    }

    #[inline]
    fn pivot_report(&self) -> Option<PivotReport> {
        match self {
            Self::Dense(lu) => lu.pivot_report(),
            Self::Sparse(lu) => lu.pivot_report(),
            Self::Folded(lu) => lu.pivot_report(),
        }
    }
}

/// [`Auto`]'s dense and sparse arms, out of line (see the note in
/// `impl LinearSolver for Auto`). They take the whole `Auto`, so that its
/// methods pass it on in one catch-all arm; measured, that is 41
/// instructions a step lighter on the chain N = 2 than a generic helper
/// per arm. The folded arms are never taken from there and answer as
/// `Auto` would.
mod general {
    use super::{Auto, LinalgError, LinearSolver};

    #[inline(never)]
    pub(super) fn factor(
        lu: &mut Auto,
        values: &[f64],
        singular_tolerance: f64,
    ) -> Result<(), LinalgError> {
        match lu {
            Auto::Dense(lu) => lu.factor(values, singular_tolerance),
            Auto::Sparse(lu) => lu.factor(values, singular_tolerance),
            Auto::Folded(lu) => lu.factor(values, singular_tolerance),
        }
    }

    #[inline(never)]
    pub(super) fn solve(
        lu: &mut Auto,
        rhs: &mut [f64],
        transpose: bool,
    ) -> Result<(), LinalgError> {
        match (lu, transpose) {
            (Auto::Dense(lu), false) => lu.solve_in_place(rhs),
            (Auto::Dense(lu), true) => lu.solve_transpose_in_place(rhs),
            (Auto::Sparse(lu), false) => lu.solve_in_place(rhs),
            (Auto::Sparse(lu), true) => lu.solve_transpose_in_place(rhs),
            (Auto::Folded(lu), false) => lu.solve_in_place(rhs),
            (Auto::Folded(lu), true) => lu.solve_transpose_in_place(rhs),
        }
    }
}
