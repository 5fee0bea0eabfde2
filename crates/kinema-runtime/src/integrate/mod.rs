//! Forward dynamics: integrating M q̈ + Φ_qᵀλ = Q_A(q, q̇, t), Φ(q, t) = 0
//! from initial conditions (DYNAMICS.md).
//!
//! The integrators see the model through [`ForwardSystem`] (dense
//! matrices: the models of the course engine have tens of coordinates) and
//! keep every buffer they need from construction on, so a step does not
//! allocate.
//!
//! | module | job |
//! |---|---|
//! | [`hht`] | [`Hht`]: fixed-step HHT-α on the index-3 DAE, Newton on [q̈; λ] |
//! | [`rk`] | [`Accurate`]: error-controlled Dormand–Prince 5(4) on the index-1 form with projection |
//! | [`dense`] | the dense LU they factor with |

pub mod dense;
pub mod hht;
pub mod rk;

pub use hht::{Consistency, Hht, HhtOptions, HhtStats};
pub use rk::{Accurate, AccurateStats};

/// ½ q̇ᵀ M q̇ for a diagonal M (`mass`, one entry per coordinate).
fn kinetic_energy(mass: &[f64], qd: &[f64]) -> f64 {
    0.5 * mass.iter().zip(qd).map(|(m, v)| m * v * v).sum::<f64>()
}

/// A constrained mechanical system with inertia, as forward dynamics needs
/// it: n coordinates, m ≤ n rows of Φ. Every matrix is dense, row-major.
///
/// Methods take `&mut self` so an implementation keeps its evaluation
/// registers in itself; they must not allocate. A slice of the wrong length
/// or a failed evaluation gives NaN outputs, which the integrators report.
pub trait ForwardSystem {
    /// Number of coordinates n.
    fn coords(&self) -> usize;
    /// Number of rows m of Φ.
    fn rows(&self) -> usize;
    /// Name of coordinate `i` (diagnostics).
    fn coordinate_name(&self, i: usize) -> &str;
    /// Name of row `i` of Φ (diagnostics).
    fn equation_name(&self, i: usize) -> &str;
    /// Φ(q, t) (m).
    fn phi(&mut self, q: &[f64], t: f64, out: &mut [f64]);
    /// Φ_q(q, t) (m × n).
    fn jacobian(&mut self, q: &[f64], t: f64, out: &mut [f64]);
    /// ν(q, t) = −Φ_t (m).
    fn nu(&mut self, q: &[f64], t: f64, out: &mut [f64]);
    /// γ(q, q̇, t) (m).
    fn gamma(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]);
    /// diag M(q) (n).
    fn mass(&mut self, q: &[f64], out: &mut [f64]);
    /// Q_A(q, q̇, t) (n).
    fn applied(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]);
    /// ∂Q_A/∂q (n × n).
    fn applied_q(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]);
    /// ∂Q_A/∂q̇ (n × n).
    fn applied_qd(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]);
    /// ∂(Φ_qᵀλ)/∂q (n × n) at `lambda` (m).
    fn constraint_hessian(&mut self, q: &[f64], lambda: &[f64], t: f64, out: &mut [f64]);

    /// Where the matrices can be nonzero, for a sparse factorization of
    /// HHT's Newton matrix ([`HhtOptions::sparse_from`]); `None` (the
    /// default): dense. Called once, at the integrator's construction (it
    /// may allocate).
    fn structure(&self) -> Option<ForwardStructure> {
        None
    }
}

/// The structural nonzeros of a [`ForwardSystem`]'s matrices; entries
/// outside them must be zero at every state.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ForwardStructure {
    /// (row, column) of Φ_q's nonzeros (m × n).
    pub jacobian: Vec<(u32, u32)>,
    /// (row, column) of the n × n block's nonzeros off the diagonal of M:
    /// every entry where ∂Q_A/∂q, ∂Q_A/∂q̇ or ∂(Φ_qᵀλ)/∂q (any λ) can be
    /// nonzero. Repeats are allowed.
    pub block: Vec<(u32, u32)>,
}

/// Why forward dynamics stopped.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IntegrateError {
    /// Newton on [q̈; λ] did not converge in a step.
    #[error(
        "the step from t = {t} did not converge in {iterations} Newton iterations: \
         the largest residual ({residual:.3e}) is in {equation}; try a smaller step"
    )]
    NoConvergence {
        /// Start of the step.
        t: f64,
        /// Iterations done.
        iterations: usize,
        /// Which equation (an equation of motion or a row of Φ).
        equation: String,
        /// Its residual.
        residual: f64,
    },
    /// A matrix the integrator factors is singular.
    #[error(
        "at t = {t}: {what} is singular (no pivot at {at}): dependent constraints or zero inertia"
    )]
    Singular {
        /// When.
        t: f64,
        /// Which matrix.
        what: &'static str,
        /// The unknown without a pivot.
        at: String,
    },
    /// A value is NaN or infinite.
    #[error("at t = {t}: a non-finite value of {what}")]
    NonFinite {
        /// When.
        t: f64,
        /// Which quantity (and where).
        what: String,
    },
    /// The initial configuration cannot be brought onto Φ = 0.
    #[error(
        "the initial configuration cannot be projected onto Φ = 0 (‖Φ‖∞ = {residual:.3e} after {iterations} iterations)"
    )]
    NoAssembly {
        /// ‖Φ‖∞ where the projection stopped.
        residual: f64,
        /// Iterations done.
        iterations: usize,
    },
    /// Wrong sizes or options.
    #[error("{0}")]
    Setup(String),
}
