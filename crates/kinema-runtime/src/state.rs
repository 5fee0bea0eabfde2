//! The result of one step: [`State`] and [`StepStats`].

use kinema_index::Body;

use crate::kinematics::{PointKinematics, point_kinematics};

/// Work done by one step's position analysis.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StepStats {
    /// Newton updates Δq taken (0 when the starting guess already satisfied
    /// the convergence test).
    pub iterations: usize,
    /// Evaluations of Φ_q during the Newton iteration (the one at the
    /// converged q for velocity and acceleration not counted).
    pub jacobian_evaluations: usize,
    /// LU factorizations of Φ_q during the Newton iteration (the one at the
    /// converged q not counted).
    pub factorizations: usize,
    /// ‖Φ(q, t)‖∞ at the converged q.
    pub residual: f64,
    /// The monitor's pivot ratio minₖ |u_kk| / maxᵢⱼ |aᵢⱼ| of Φ_q at the
    /// converged q (see [`PivotReport`](crate::PivotReport); 1 when the
    /// linear solver does not report it).
    pub pivot_ratio: f64,
    /// Φ_q is singular or within the threshold of it here (equilibrated
    /// condition ≥ τ^−0.4): Φ_q q̇ = ν does not determine q̇, so q, q̇ and q̈
    /// are not a solve but the branch's values, interpolated between
    /// regular states of the branch on either side (at a singular start,
    /// extrapolated back from the states just after it).
    pub near_singular: bool,
    /// Internal sub-steps (not output) taken to reach this time: the step
    /// was refined near a singular configuration or where a full step left
    /// the branch.
    pub substeps: usize,
    /// The bodies were placed in closed form ([`Options::closed_form`]),
    /// not by Newton: `iterations` is 0, `residual` the placement's and
    /// `pivot_ratio` that of the last factorization (at this placement or
    /// an earlier state: the solver reads the pivots again whenever a dyad
    /// nears its singular configuration, and now and then).
    ///
    /// [`Options::closed_form`]: crate::Options::closed_form
    pub closed_form: bool,
}

/// A function of an equation at a point where it is not differentiable,
/// within the uncertainty of its argument ([`State::kink`]): the norm
/// of a vector that is zero but for roundoff, say, whose derivative is the
/// direction of the rounding errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Kink {
    /// The equation (its index in Φ); `None` if the system could not tell
    /// which.
    pub equation: Option<usize>,
    /// The function, as the model language spells it: `"sqrt"` (a square
    /// root or a norm), `"power"` (a fractional power), `"abs"`,
    /// `"atan2"`, `"asin"`, `"acos"`, `"ln"` or `"smoothstep"` (the ends
    /// of a cubic step).
    pub function: &'static str,
}

/// How a function left its domain ([`Undefined`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Domain {
    /// At a pole: a division by 0, a negative power of 0, `ln` of 0, `tan`
    /// at an odd multiple of π/2. The equation is unbounded there.
    Pole,
    /// Outside the domain: `sqrt`, `ln` or a fractional power of a
    /// negative number, `asin` or `acos` beyond ±1.
    Outside,
    /// At the edge of the domain, where the derivative is unbounded:
    /// `sqrt` or a fractional power of 0, `asin` or `acos` of ±1, with the
    /// domain left right after.
    Edge,
    /// `atan2(0, 0)`: no angle.
    NoAngle,
    /// The value overflows f64 (`exp` of a large number).
    Overflow,
}

/// A function of an equation evaluated outside its domain or at a pole
/// ([`System::undefined`](crate::System::undefined)): the equation has no
/// value, or no finite one, there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Undefined {
    /// The equation (its index in Φ).
    pub equation: usize,
    /// The function as the model language names it (`"ln"`, `"sqrt"`,
    /// `"atan2"`, `"tan"`, `"pow"`, `"exp"` …) or `"division"`.
    pub function: &'static str,
    /// How it left its domain.
    pub domain: Domain,
    /// Its argument there (for `atan2`, y; for a division, the divisor).
    pub argument: f64,
}

/// The kinematic state at time t: q with Φ(q, t) = 0, q̇ with Φ_q q̇ = ν,
/// q̈ with Φ_q q̈ = γ.
#[derive(Debug, Clone)]
pub struct State {
    pub(crate) t: f64,
    pub(crate) q: Vec<f64>,
    pub(crate) qd: Vec<f64>,
    pub(crate) qdd: Vec<f64>,
    pub(crate) stats: StepStats,
    /// Sign of det Φ_q at q (0 when unknown).
    pub(crate) det_sign: f64,
    /// See [`State::kink`].
    pub(crate) kink: Option<Kink>,
    /// The solver's tag of the factorization of Φ_q at this q (0: none):
    /// its LU still holds that factorization while the solver's
    /// `factored` tag equals this one. Bookkeeping, not part of the state's
    /// value (equality ignores it).
    pub(crate) tag: u64,
    /// With [`Options::positions_only`](crate::Options::positions_only):
    /// h₀ = t − t₋₁ when q̇ and q̈ are the derivatives at t of the quadratic
    /// through this state's q and the two positions before it (the
    /// solver's difference estimates); NaN when they came otherwise. The
    /// next estimate recovers the slope (q − q₋₁)/h₀ = q̇ − h₀/2 q̈ from it.
    pub(crate) h_back: f64,
}

/// Equal times, coordinates, rates, statistics, det sign and kink (the
/// factorization tag and `h_back` are bookkeeping).
impl PartialEq for State {
    fn eq(&self, other: &Self) -> bool {
        self.t == other.t
            && self.q == other.q
            && self.qd == other.qd
            && self.qdd == other.qdd
            && self.stats == other.stats
            && self.det_sign == other.det_sign
            && self.kink == other.kink
    }
}

impl State {
    pub(crate) fn zeros(n: usize) -> Self {
        Self {
            t: f64::NAN,
            q: vec![0.0; n],
            qd: vec![0.0; n],
            qdd: vec![0.0; n],
            stats: StepStats::default(),
            det_sign: 0.0,
            kink: None,
            tag: 0,
            h_back: f64::NAN,
        }
    }

    /// Time t.
    #[must_use]
    pub fn t(&self) -> f64 {
        self.t
    }

    /// Positions q.
    #[must_use]
    pub fn q(&self) -> &[f64] {
        &self.q
    }

    /// Velocities q̇.
    #[must_use]
    pub fn qd(&self) -> &[f64] {
        &self.qd
    }

    /// Accelerations q̈.
    #[must_use]
    pub fn qdd(&self) -> &[f64] {
        &self.qdd
    }

    /// Whether q̇ and q̈ are limits along the branch rather than solves
    /// (see [`StepStats::near_singular`]).
    #[must_use]
    pub fn near_singular(&self) -> bool {
        self.stats.near_singular
    }

    /// An equation that, at this q, goes through a function at a point
    /// where it is not differentiable, within roundoff and Newton's
    /// tolerance (see [`System::kink`](crate::System::kink)): its Φ_q, ν
    /// and γ there are the rounding errors', and so are q̇ and q̈; q itself
    /// is a solution. `None` for a near-singular state (whose q̇ and q̈ are
    /// limits, not solves), with [`Options::positions_only`](crate::Options::positions_only)
    /// (q̇ and q̈ are differences of positions) and for systems that cannot
    /// tell.
    #[must_use]
    pub fn kink(&self) -> Option<Kink> {
        self.kink
    }

    /// What the step's position analysis cost.
    #[must_use]
    pub fn stats(&self) -> &StepStats {
        &self.stats
    }

    /// Position, velocity and acceleration of the point with local
    /// coordinates `s` (s′) on `body` (whose (x, y, φ) are its
    /// [`Coord`](crate::Coord)s); `None` if the system has no such body. See
    /// [`point_kinematics`].
    #[must_use]
    pub fn point(&self, body: Body, s: [f64; 2]) -> Option<PointKinematics> {
        point_kinematics(&self.q, &self.qd, &self.qdd, body, s)
    }
}
