//! What can go wrong in an analysis: [`Error`], [`Dependency`], [`Quantity`].

use std::fmt;

use crate::linalg::LinalgError;

/// An analysis failure. Every variant carries the data a user needs to find
/// the cause, and its `Display` reads as a sentence.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Φ_q is singular or nearly so: a lock-up or toggle position, a
    /// bifurcation, or redundant constraints.
    ///
    /// Raised when a factorization of Φ_q fails the pivot test (see
    /// [`crate::linalg`]), or when Newton fails at a step whose solutions end
    /// at a limit point: bisecting the step finds the last time t* that
    /// still has a solution, and Φ_q there has σ_min/σ_max ≤ √τ. `t` is then
    /// t*, the time of the lock-up.
    #[error("lock-up, toggle position or redundant constraints at t = {}: {dependency}", Time(*.t))]
    Singular {
        /// Time of the failing step.
        t: f64,
        /// Which equations are dependent, from a rank-revealing factorization.
        dependency: Dependency,
    },
    /// A singular configuration (bifurcation or toggle) was reached with
    /// [`Options::stop_at_singular`](crate::Options::stop_at_singular) set.
    /// The solver's state is the last one before it.
    #[error("stopped at a singular configuration: {event}")]
    SingularConfiguration {
        /// What, where and when.
        event: Box<crate::event::SingularEvent>,
    },
    /// Newton–Raphson reached the iteration cap without converging.
    #[error(
        "position analysis did not converge at t = {}: ‖Φ‖∞ = {residual:e} after {iterations} \
         Newton updates, largest in equation {worst_equation}",
        Time(*.t)
    )]
    NoConvergence {
        /// Time of the failing step.
        t: f64,
        /// Newton updates taken.
        iterations: usize,
        /// ‖Φ‖∞ at the last iterate.
        residual: f64,
        /// Name of the equation with the largest |Φᵢ| at the last iterate.
        worst_equation: String,
    },
    /// The system returned NaN or ±∞, or a solve produced one.
    #[error("non-finite {quantity} at t = {}: {name}", Time(*.t))]
    NonFinite {
        /// Time of the failing step.
        t: f64,
        /// Which quantity.
        quantity: Quantity,
        /// The equation or coordinate (for the Jacobian, "equation / coordinate").
        name: String,
    },
    /// γ is not finite because the velocities it reads are so large that
    /// their products overflow (γ is quadratic in q̇): the root cause is the
    /// velocity, and the equation of ν that drives it (typically a driver
    /// growing too fast, such as `exp(1000 * t)`).
    #[error(
        "non-finite γ at t = {}: {equation}, because the velocities overflow it: \
         q̇ of {coordinate} = {}, from ν of {source_equation} = {}",
        Time(*.t),
        Short(*.velocity),
        Short(*.source_value)
    )]
    VelocityOverflow {
        /// Time of the failing step.
        t: f64,
        /// The equation whose γ is not finite.
        equation: String,
        /// The coordinate with the largest |q̇|.
        coordinate: String,
        /// Its velocity.
        velocity: f64,
        /// The equation with the largest |ν| (what the velocities come from).
        source_equation: String,
        /// Its ν.
        source_value: f64,
    },
    /// Newton converged at every internal sub-step tried, but none stayed
    /// on the branch predicted from the previous state, within the
    /// sub-step budget: the motion moves too far between two output times
    /// to be followed (a coordinate turns or grows by orders of magnitude
    /// per step), so which solution continues it cannot be told.
    #[error(
        "cannot follow the motion from t = {} to t = {}: after {substeps} internal sub-steps the \
         solutions still leave the branch predicted from the previous state (the motion changes \
         too much between output times); use more steps",
        Time(*.from),
        Time(*.t)
    )]
    BranchLost {
        /// The last time solved on the branch.
        from: f64,
        /// The output time aimed at.
        t: f64,
        /// Sub-steps tried.
        substeps: usize,
    },
    /// det Φ_q has opposite signs at two successive solutions, but no
    /// singular configuration lies between them: bisection along the branch
    /// narrowed the change down to roundoff of t, and Φ_q is well
    /// conditioned there. Newton reached the second solution on another
    /// assembly branch (a mirror image) from a step too long for the motion
    /// (a driver turning many times per output step, say).
    #[error(
        "the solution at t = {} is on another assembly branch than the one at t = {}: det Φ_q \
         changes sign between them, yet the branch followed from t = {} is regular up to \
         t = {} (Φ_q's condition number {condition:.1e}), with no singular configuration to \
         pass; the motion changes too much between output times to be followed; use more steps",
        Time(*.t),
        Time(*.from),
        Time(*.from),
        Time(*.at)
    )]
    BranchJump {
        /// The last time solved on the branch.
        from: f64,
        /// The time whose solution is on another branch.
        t: f64,
        /// Where bisection along the branch found det Φ_q still of the
        /// branch's sign, within roundoff of the change.
        at: f64,
        /// Condition number of Φ_q (equilibrated) there.
        condition: f64,
    },
    /// An equation has no value, or no finite one, at time `t`: a
    /// function of time in it is evaluated outside its domain or at a pole
    /// there (`atan2(t, t)` at t = 0, `1 / (t - 0.5)` at 0.5, `ln` or
    /// `sqrt` of a negative number, `exp` overflowing). Found before the
    /// step that would cross it (see
    /// [`System::undefined`](crate::System::undefined)); `t` is within
    /// roundoff of the point when it lies between two times of the grid.
    #[error("{}", UndefinedText(self))]
    Undefined {
        /// Where the equation is undefined.
        t: f64,
        /// The equation's name.
        equation: String,
        /// The function, as the model language names it, or `"division"`.
        function: &'static str,
        /// How it left its domain.
        domain: crate::state::Domain,
        /// Its argument there (for `atan2`, y; for a division, the
        /// divisor).
        argument: f64,
    },
    /// A time grid without any time.
    #[error("the time grid is empty")]
    EmptyTimeGrid,
    /// A time that is NaN or infinite.
    #[error("time {} is not finite", Time(*.t))]
    NonFiniteTime {
        /// The offending time.
        t: f64,
    },
    /// Times must increase strictly from step to step.
    #[error(
        "times must increase: t = {} (time index {index}) follows t = {}",
        Time(*.t),
        Time(*.previous)
    )]
    NonIncreasingTime {
        /// Index of the offending time in the grid (0 for a single `step`).
        index: usize,
        /// The previous time.
        previous: f64,
        /// The offending time.
        t: f64,
    },
    /// A buffer or system of the wrong size, or an invalid Jacobian pattern.
    #[error("invalid system or linear solver: {0}")]
    Setup(#[from] LinalgError),
    /// The model (a `.kin` file, model text, an imported simEngine2D model)
    /// could not be read: it has errors, or the file cannot be read. Lets
    /// `main() -> Result<(), kinema::Error>` use `?` on loading a model as on
    /// running it. The runtime never reads models: the report is plain data
    /// (kinema-report), which the language produces.
    #[error(transparent)]
    Model(#[from] kinema_report::Report),
}

/// A time in a message: the shortest text that reads back as the same
/// number (`0.35`, `1.0000000000000002`), in exponent form outside
/// [1e-4, 1e16) so that no time prints with hundreds of digits (`1e-300`).
#[derive(Clone, Copy, Debug)]
pub struct Time(pub f64);

impl fmt::Display for Time {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if self.0.is_finite() && a != 0.0 && !(1e-4..1e16).contains(&a) {
            write!(f, "{:e}", self.0)
        } else {
            write!(f, "{}", self.0)
        }
    }
}

/// The text of [`Error::Undefined`]: "equation `swing` is undefined at
/// t = 0: atan2(0, 0) has no angle".
struct UndefinedText<'a>(&'a Error);

impl fmt::Display for UndefinedText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use crate::state::Domain;
        let Error::Undefined {
            t,
            equation,
            function,
            domain,
            argument,
        } = self.0
        else {
            return Ok(());
        };
        let word = match domain {
            Domain::Pole | Domain::Overflow => "unbounded",
            Domain::Outside | Domain::NoAngle | Domain::Edge => "undefined",
        };
        write!(f, "equation `{equation}` is {word} at t = {}: ", Time(*t))?;
        let x = Time(*argument);
        match (domain, *function) {
            (Domain::NoAngle, _) => write!(f, "{function}(0, 0) has no angle"),
            (Domain::Pole, "division") => write!(f, "division by 0 (the divisor is {x})"),
            (Domain::Pole, "tan") => write!(
                f,
                "tan at a pole (its argument {x} is an odd multiple of π/2)"
            ),
            (Domain::Pole, "ln") => write!(f, "ln of 0 (its argument is {x})"),
            (Domain::Pole, _) => write!(f, "{function} of 0 to a negative power (its base is {x})"),
            (Domain::Outside, "asin" | "acos") => {
                write!(f, "{function} of a number beyond ±1 ({x})")
            }
            (Domain::Outside, "sqrt" | "ln" | "pow") => {
                write!(f, "{function} of a negative number ({x})")
            }
            (Domain::Outside, _) => write!(f, "{function} outside its domain (argument {x})"),
            (Domain::Edge, _) => write!(
                f,
                "{function} at the edge of its domain (its argument is {x}), where its \
                 derivative is unbounded and past which it has no value"
            ),
            (Domain::Overflow, _) => {
                write!(f, "{function} overflows f64's range (argument {x})")
            }
        }
    }
}

/// A large or small value in a message: two significant digits (`1.4e155`).
#[derive(Clone, Copy, Debug)]
struct Short(f64);

impl fmt::Display for Short {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.1e}", self.0)
    }
}

/// The quantity in which a non-finite value appeared.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Quantity {
    /// The initial guess q⁰.
    InitialGuess,
    /// Φ(q, t).
    Phi,
    /// A nonzero of Φ_q.
    Jacobian,
    /// ν = −Φ_t.
    Nu,
    /// γ.
    Gamma,
    /// A Newton iterate q.
    Position,
    /// q̇.
    Velocity,
    /// q̈.
    Acceleration,
    /// An entry of M or Q_A (inverse dynamics).
    AppliedForce,
    /// A Lagrange multiplier λ (inverse dynamics).
    Multiplier,
}

impl fmt::Display for Quantity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::InitialGuess => "initial guess",
            Self::Phi => "Φ",
            Self::Jacobian => "Jacobian entry",
            Self::Nu => "ν",
            Self::Gamma => "γ",
            Self::Position => "position",
            Self::Velocity => "velocity",
            Self::Acceleration => "acceleration",
            Self::AppliedForce => "applied force or mass",
            Self::Multiplier => "Lagrange multiplier",
        })
    }
}

/// The outcome of a rank-revealing factorization (SVD) of a singular Φ_q.
///
/// The SVD is that of the equilibrated R Φ_q C (R, C diagonal powers of
/// two; see [`crate::diagnose`]), so rank, condition and the involvement of
/// equations and coordinates do not depend on units. With R Φ_q C = U Σ Vᵀ, the left singular vectors uₖ whose σₖ are negligible
/// (σₖ ≤ max(10 τ, n ε) σ₁, and always the smallest) span the combinations
/// of equations that vanish: ∑ᵢ uᵢₖ ∂Φᵢ/∂q ≈ 0. An equation is *dependent*
/// when it takes part in such a combination; the right singular vectors vₖ
/// give the motions δq that no equation resists to first order.
#[derive(Debug, Clone, PartialEq)]
pub struct Dependency {
    /// Numerical rank of Φ_q (`None` when n was too large for the dense
    /// diagnosis).
    pub rank: Option<usize>,
    /// 2-norm condition number σ_max/σ_min of Φ_q (∞ if exactly singular;
    /// `None` when not computed).
    pub condition: Option<f64>,
    /// n.
    pub dim: usize,
    /// Names of the equations in the dependent combinations.
    pub equations: Vec<String>,
    /// A smallest set of those equations whose removal restores full rank
    /// (one per null direction): the redundant ones.
    pub redundant: Vec<String>,
    /// Names of the coordinates that move along the null directions.
    pub coordinates: Vec<String>,
}

impl Dependency {
    /// A dependency not (yet) diagnosed: `rank` and `condition` `None`, no
    /// names.
    pub(crate) fn undiagnosed(dim: usize) -> Self {
        Self {
            rank: None,
            condition: None,
            dim,
            equations: Vec::new(),
            redundant: Vec::new(),
            coordinates: Vec::new(),
        }
    }
}

impl fmt::Display for Dependency {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Some(rank) = self.rank else {
            return if self.dim > crate::diagnose::MAX_DENSE_DIAGNOSIS {
                write!(
                    f,
                    "Φ_q is singular ({} × {}; too large for the dense rank-revealing diagnosis)",
                    self.dim, self.dim
                )
            } else {
                write!(
                    f,
                    "Φ_q is singular ({} × {}; the rank-revealing diagnosis failed on its values)",
                    self.dim, self.dim
                )
            };
        };
        write!(f, "equations {} are dependent", self.equations.join(", "))?;
        write!(f, " (rank {rank} of {}", self.dim)?;
        if let Some(condition) = self.condition {
            write!(f, ", condition number {condition:.1e}")?;
        }
        f.write_str(")")?;
        if !self.redundant.is_empty() {
            let s = if self.redundant.len() == 1 { "" } else { "s" };
            write!(
                f,
                "; removing equation{s} {} restores full rank",
                self.redundant.join(", ")
            )?;
        }
        if !self.coordinates.is_empty() {
            write!(
                f,
                "; coordinates left free or unbounded: {}",
                self.coordinates.join(", ")
            )?;
        }
        Ok(())
    }
}
