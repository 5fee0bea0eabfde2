//! Settings of the analysis: [`Options`].

/// Settings of position, velocity and acceleration analysis.
///
/// Position analysis solves Φ(q, t) = 0 by Newton–Raphson,
/// Φ_q(qᵏ) Δq = −Φ(qᵏ), qᵏ⁺¹ = qᵏ + Δq, from a starting guess q⁰:
///
/// * q⁰ is the previous step's q, or with [`predictor`](Self::predictor) the
///   Taylor predictor q + h q̇ + h²/2 q̈ of the previous step (h the time
///   step). Assembly (the first step) starts from the system's initial guess.
/// * Before each update the residual is checked: the iteration has converged
///   when ‖Φ(qᵏ)‖∞ ≤ [`residual_tolerance`](Self::residual_tolerance) (each
///   equation's bound scaled down to the model's size where that is below
///   1, see the field), or
///   when the update just taken was ‖Δq‖∞ ≤
///   [`update_tolerance`](Self::update_tolerance) · (1 + ‖q‖∞) (the roundoff
///   floor of models whose residual cannot reach the absolute tolerance). A
///   guess that already satisfies the test costs no update.
/// * At most [`max_iterations`](Self::max_iterations) updates, else
///   [`Error::NoConvergence`](crate::Error::NoConvergence).
/// * With [`modified_newton`](Self::modified_newton) the last factorization
///   of Φ_q (from the previous step, or earlier in this one) is reused while
///   each update reduces ‖Φ‖∞ at least fivefold; when one does not, Φ_q is
///   evaluated and factored afresh at the current iterate.
///
/// Velocity Φ_q q̇ = ν and acceleration Φ_q q̈ = γ are then solved with one
/// factorization of Φ_q at the converged q.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Tolerance on ‖Φ(q, t)‖∞: absolute for a model of unit size or
    /// larger. For a smaller one each equation's bound is tightened to its
    /// size, measured at assembly from Φ_q at the initial guess — L for a
    /// joint's position rows, where L is the model's length scale, 1 for an
    /// angle, L² for a squared distance — so that a mechanism drawn in
    /// micrometres (or at 10⁻¹⁴) is solved to the same relative accuracy as
    /// in metres, rather than passing at its initial guess. Parameters
    /// changed between steps keep the size assembly measured: after a
    /// change of scale, [`Solver::reset`](crate::Solver::reset) and
    /// assemble again (a sweep does, at every row).
    pub residual_tolerance: f64,
    /// Relative tolerance on the Newton update, ‖Δq‖∞ ≤ tol · (1 + ‖q‖∞);
    /// `0` disables the test.
    pub update_tolerance: f64,
    /// Maximum number of Newton updates per step.
    pub max_iterations: usize,
    /// Start Newton from q + h q̇ + h²/2 q̈ of the previous step instead of
    /// its q.
    pub predictor: bool,
    /// Reuse a factorization of Φ_q while it still converges (see above).
    pub modified_newton: bool,
    /// τ of the singularity test: Φ_q is declared singular when an LU pivot
    /// satisfies |u_kk| ≤ τ · maxᵢⱼ |∂Φᵢ/∂qⱼ| of the equilibrated Φ_q (see
    /// [`crate::linalg`]); a configuration is *near* singular when the
    /// equilibrated condition number reaches τ^−0.4 (see
    /// [`Solver`](crate::Solver), "Singular configurations").
    pub singular_tolerance: f64,
    /// Stop at the first singular configuration (bifurcation or toggle)
    /// with [`Error::SingularConfiguration`](crate::Error::SingularConfiguration)
    /// instead of passing it on the analytic continuation.
    pub stop_at_singular: bool,
    /// Positions only: no velocity or acceleration solve (for synthesis
    /// loops that read q alone). Each step then costs Newton's updates and
    /// nothing more: Φ_q is not evaluated or factored again at the converged
    /// q, and ν and γ are never evaluated. The states' q̇ and q̈ are **not**
    /// the rates but estimates the solver's predictor and branch test use in
    /// their place: the derivatives at t of the quadratic through the last
    /// three positions (on a uniform grid q̇ = (3q − 4q₋₁ + q₋₂)/2h and
    /// q̈ = (q − 2q₋₁ + q₋₂)/h²), so the prediction is second order as with
    /// the rates; after assembly, or where the last two steps differ by
    /// more than 4×, the backward difference (q − q₋₁)/h and q̈ zero; zero
    /// at assembly.
    /// A row flagged near singular, interpolated between regular states on
    /// either side, is interpolated with those slopes: its positions then
    /// agree with the full analysis's to about 1e-5, not to Newton's
    /// tolerance (4e-6 on the change-point linkage of `tests/singular/`),
    /// a bifurcation is located less precisely (2e-4 s off there), and the
    /// approach to one may be recorded as a toggle too.
    /// The singular-configuration monitor reads the pivots of the last
    /// factorization Newton made (at its last iterate, or an earlier step's
    /// when no update was needed).
    pub positions_only: bool,
    /// With [`positions_only`](Self::positions_only), place the bodies in
    /// closed form where the system has one ([`System::linkage`]: a linkage
    /// of cranks and dyads) instead of iterating: no iteration, one
    /// evaluation of Φ to check each placement, Φ_q factored only now and
    /// then to read its pivots. Newton solves, as before, the first step
    /// after assembly or a change of the system, any step whose placement
    /// fails its residual or branch test, lies near a dyad's singular
    /// configuration (its links within about 0.6° of a line) or would cross
    /// one on the predicted motion, and any step whose pivot ratio, when
    /// read, is below twice the monitor's gate: singular
    /// configurations are met, located and reported as without it (see
    /// [`Solver`](crate::Solver)). Off: Newton always.
    ///
    /// [`System::linkage`]: crate::System::linkage
    pub closed_form: bool,
}

impl Default for Options {
    /// Predictor on, full Newton; ‖Φ‖∞ ≤ 1e-12 or ‖Δq‖∞ ≤ 1e-14 (1 +
    /// ‖q‖∞); 20 updates at most; τ = 1e-10.
    ///
    /// Full rather than modified Newton: from the predictor one full update
    /// converges, and the factorization at the converged q is the one
    /// velocity and acceleration need anyway, while modified Newton takes
    /// two updates and still factors once. Measured per step on every
    /// benchmark mechanism and back end, full Newton was as fast or faster
    /// (`BENCHMARKS.md`).
    fn default() -> Self {
        Self {
            residual_tolerance: 1e-12,
            update_tolerance: 1e-14,
            max_iterations: 20,
            predictor: true,
            modified_newton: false,
            singular_tolerance: 1e-10,
            stop_at_singular: false,
            positions_only: false,
            closed_form: true,
        }
    }
}

impl Options {
    /// Exactly the peers' loop of the project benchmarks (`BENCHMARKS.md`):
    /// warm start from the previous converged q (no predictor), stop when
    /// ‖Φ(q, t)‖∞ ≤ 1e-12 checked before each update, at most 20 updates,
    /// full Newton (a fresh Φ_q at every iterate), then one factorization of
    /// Φ_q at the converged q reused for velocity and acceleration.
    #[must_use]
    pub fn same_algorithm() -> Self {
        Self {
            residual_tolerance: 1e-12,
            update_tolerance: 0.0,
            max_iterations: 20,
            predictor: false,
            modified_newton: false,
            singular_tolerance: Self::default().singular_tolerance,
            stop_at_singular: false,
            positions_only: false,
            closed_form: false,
        }
    }

    /// These options with the predictor switched on or off.
    #[must_use]
    pub fn with_predictor(self, predictor: bool) -> Self {
        Self { predictor, ..self }
    }

    /// These options with modified Newton switched on or off.
    #[must_use]
    pub fn with_modified_newton(self, modified_newton: bool) -> Self {
        Self {
            modified_newton,
            ..self
        }
    }

    /// These options stopping, or not, at the first singular configuration.
    #[must_use]
    pub fn with_stop_at_singular(self, stop_at_singular: bool) -> Self {
        Self {
            stop_at_singular,
            ..self
        }
    }

    /// These options computing positions only, or also velocities and
    /// accelerations (see [`positions_only`](Self::positions_only)).
    #[must_use]
    pub fn with_positions_only(self, positions_only: bool) -> Self {
        Self {
            positions_only,
            ..self
        }
    }

    /// These options placing linkages in closed form with positions only,
    /// or always iterating (see [`closed_form`](Self::closed_form)).
    #[must_use]
    pub fn with_closed_form(self, closed_form: bool) -> Self {
        Self {
            closed_form,
            ..self
        }
    }

    /// These options with another singularity tolerance τ.
    #[must_use]
    pub fn with_singular_tolerance(self, singular_tolerance: f64) -> Self {
        Self {
            singular_tolerance,
            ..self
        }
    }
}
