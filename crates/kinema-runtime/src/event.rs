//! Singular configurations met during a run: [`SingularEvent`],
//! [`SingularKind`].

use std::fmt;

use crate::error::Dependency;

/// What happened at a singular configuration (Φ_q singular or within the
/// threshold of it: equilibrated condition ≥ τ^−0.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum SingularKind {
    /// det Φ_q changed sign along the motion: two branches of solutions
    /// cross there (a change point, a dyad straightening and bending the
    /// other way). The run kept the analytic continuation, the branch on
    /// which q and q̇ are continuous.
    Bifurcation,
    /// Φ_q came within the threshold of singular without det Φ_q changing
    /// sign: the motion touched a singular configuration (or started at one)
    /// and left it on the same side.
    Toggle,
    /// No continuation: past this time the constraints have no solution
    /// near the motion (a dead point). The run stops here.
    LockUp,
    /// The run ended within the threshold of a singular configuration: past
    /// its last time the motion was not computed, so whether it would turn
    /// back (a toggle), cross over (a bifurcation) or have no continuation
    /// (a lock-up) is not known.
    AtEnd,
}

impl fmt::Display for SingularKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Bifurcation => "bifurcation",
            Self::Toggle => "toggle",
            Self::LockUp => "lock-up",
            Self::AtEnd => "singular configuration",
        })
    }
}

/// A singular configuration met during a run.
#[derive(Debug, Clone, PartialEq)]
pub struct SingularEvent {
    /// When: for a bifurcation, where det Φ_q changes sign, located by
    /// bisection along the branch; for a toggle, the time of the worst
    /// condition among the solves near it; for a lock-up, the last time
    /// with a solution, located by bisection.
    pub t: f64,
    /// What kind.
    pub kind: SingularKind,
    /// The equilibrated diagnosis of Φ_q there: dependent equations,
    /// coordinates left free, condition estimate.
    pub dependency: Dependency,
}

impl fmt::Display for SingularEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} at t = {}: {}", self.kind, self.t, self.dependency)?;
        match self.kind {
            SingularKind::Bifurcation => f.write_str("; kept the branch on which q̇ is continuous"),
            SingularKind::Toggle => f.write_str("; the motion continues on the same side"),
            SingularKind::LockUp => f.write_str("; the motion has no continuation"),
            SingularKind::AtEnd => f.write_str(
                "; the run ends there, so whether the motion turns back, crosses over or locks up is not known (run past it to see)",
            ),
        }
    }
}
