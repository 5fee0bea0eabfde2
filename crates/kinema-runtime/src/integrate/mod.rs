//! Forward dynamics: integrating M q̈ + Φ_qᵀλ = Q_A(q, q̇, t), Φ(q, t) = 0
//! from initial conditions (docs/src/dynamics.md).
//!
//! The integrators see the model through [`ForwardSystem`] (dense
//! matrices for the models of the course engine, which have tens of
//! coordinates; values on a fixed sparse structure for large ones) and
//! keep every buffer they need from construction on, so a step does not
//! allocate.
//!
//! | module | job |
//! |---|---|
//! | [`hht`] | [`Hht`]: fixed-step HHT-α on the index-3 DAE, Newton on [q̈; λ] |
//! | [`rk`] | [`Accurate`]: error-controlled Dormand–Prince 5(4) on the index-1 form with projection |
//! | [`prescribed`] | [`Prescribed`]: kinematics and inverse dynamics of a driven model with redundant rows |
//! | [`monitor`] | [`Monitor`]: redundant rows at the start, singular configurations passed |
//! | `saddle` | the regularized saddle-point systems every solve goes through |
//! | [`dense`] | the dense LU they factor with |
//! | `kkt` | HHT's Newton matrix on a sparse pattern, from the system's sparse values |

pub mod dense;
pub mod hht;
mod kkt;
pub mod monitor;
pub mod prescribed;
pub mod rk;
mod saddle;

pub use hht::{Consistency, Hht, HhtOptions, HhtStats};
pub use monitor::{Monitor, Passage};
pub use prescribed::{Prescribed, assemble};
pub use rk::{Accurate, AccurateStats};

/// ½ q̇ᵀ M q̇ for a diagonal M (`mass`, one entry per coordinate).
fn kinetic_energy(mass: &[f64], qd: &[f64]) -> f64 {
    0.5 * mass.iter().zip(qd).map(|(m, v)| m * v * v).sum::<f64>()
}

/// A constrained mechanical system with inertia, as forward dynamics needs
/// it: n coordinates, m ≤ n rows of Φ. The matrix methods write dense
/// row-major matrices; a system that gives its [`structure`] also writes
/// the sparse matrices' values in that structure's order (the `*_values`
/// methods, which HHT's sparse Newton matrix reads; their defaults gather
/// from the dense methods).
///
/// [`structure`]: ForwardSystem::structure
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

    /// The start the model states, at the system's parameters: its initial
    /// configuration q⁰ (the guesses) into `q` and its initial velocities
    /// q̇⁰ (the `velocity` items, zero elsewhere) into `qd`, both of length
    /// [`coords`](ForwardSystem::coords) (NaN on a wrong length). Not
    /// necessarily consistent: the integrators' constructors project it
    /// onto Φ = 0, Φ_q q̇ = ν and report the correction.
    fn initial_state(&mut self, q: &mut [f64], qd: &mut [f64]);

    /// Where the matrices can be nonzero, for a sparse factorization of
    /// HHT's Newton matrix ([`HhtOptions::sparse_from`]); `None` (the
    /// default): dense. Called once, at the integrator's construction (it
    /// may allocate). With a structure, HHT's sparse path reads the
    /// matrices through the `*_values` methods below, in the order of the
    /// structure's lists.
    fn structure(&self) -> Option<ForwardStructure> {
        None
    }

    /// Φ_q's values at the positions of [`ForwardStructure::jacobian`], in
    /// its order. The default evaluates the dense [`jacobian`] into the
    /// scratch and gathers from it; a sparse system overrides it (so no
    /// m × n buffer is touched).
    ///
    /// [`jacobian`]: ForwardSystem::jacobian
    fn jacobian_values(&mut self, q: &[f64], t: f64, dense: DenseScratch<'_>, out: &mut [f64]) {
        self.jacobian(q, t, dense.buffer);
        dense.gather(out);
    }
    /// ∂Q_A/∂q's values at the positions of [`ForwardStructure::applied_q`]
    /// (default: the dense [`applied_q`](ForwardSystem::applied_q) gathered).
    fn applied_q_values(
        &mut self,
        q: &[f64],
        qd: &[f64],
        t: f64,
        dense: DenseScratch<'_>,
        out: &mut [f64],
    ) {
        self.applied_q(q, qd, t, dense.buffer);
        dense.gather(out);
    }
    /// ∂Q_A/∂q̇'s values at the positions of
    /// [`ForwardStructure::applied_qd`] (default: the dense
    /// [`applied_qd`](ForwardSystem::applied_qd) gathered).
    fn applied_qd_values(
        &mut self,
        q: &[f64],
        qd: &[f64],
        t: f64,
        dense: DenseScratch<'_>,
        out: &mut [f64],
    ) {
        self.applied_qd(q, qd, t, dense.buffer);
        dense.gather(out);
    }
    /// ∂(Φ_qᵀλ)/∂q's terms at the positions of
    /// [`ForwardStructure::hessian`] (terms at a repeated position add up;
    /// default: the dense
    /// [`constraint_hessian`](ForwardSystem::constraint_hessian) gathered).
    fn constraint_hessian_values(
        &mut self,
        q: &[f64],
        lambda: &[f64],
        t: f64,
        dense: DenseScratch<'_>,
        out: &mut [f64],
    ) {
        self.constraint_hessian(q, lambda, t, dense.buffer);
        dense.gather(out);
    }
}

/// The structural nonzeros of a [`ForwardSystem`]'s matrices, each list in
/// the order of its `*_values` method; entries outside them must be zero at
/// every state. A position may repeat in the lists of the n × n matrices
/// (the values there add up), not in Φ_q's.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ForwardStructure {
    /// (row, column) of Φ_q's nonzeros (m × n), distinct.
    pub jacobian: Vec<(u32, u32)>,
    /// (row, column) of ∂Q_A/∂q's nonzeros (n × n).
    pub applied_q: Vec<(u32, u32)>,
    /// (row, column) of ∂Q_A/∂q̇'s nonzeros (n × n).
    pub applied_qd: Vec<(u32, u32)>,
    /// (row, column) of ∂(Φ_qᵀλ)/∂q's terms (n × n, any λ).
    pub hessian: Vec<(u32, u32)>,
}

/// A dense row-major matrix buffer and the positions to gather from it:
/// the scratch of [`ForwardSystem`]'s default `*_values` methods (a system
/// that writes its values directly ignores it).
#[derive(Debug)]
pub struct DenseScratch<'a> {
    /// The dense matrix (rows × `cols`), written by the dense method.
    pub buffer: &'a mut [f64],
    /// Its number of columns.
    pub cols: usize,
    /// The positions to gather, in the values' order.
    pub positions: &'a [(u32, u32)],
}

impl DenseScratch<'_> {
    /// `out[k]` ← the buffer at `positions[k]`; a repeated position gives
    /// its value once (later repeats 0, as the values add up). A position
    /// outside the buffer gives NaN.
    pub fn gather(self, out: &mut [f64]) {
        for (o, &(r, c)) in out.iter_mut().zip(self.positions) {
            let k = r as usize * self.cols + c as usize;
            *o = match self.buffer.get_mut(k) {
                Some(v) => std::mem::take(v),
                None => f64::NAN,
            };
        }
    }

    /// The other way: `out` (rows × cols, row-major) ← zero, plus each of
    /// `values` at its position (repeats add up), as a sparse system's dense
    /// methods write. A wrong length of `out` or `values`, or a position
    /// outside, gives NaN throughout.
    pub fn scatter(
        values: &[f64],
        positions: &[(u32, u32)],
        (rows, cols): (usize, usize),
        out: &mut [f64],
    ) {
        let inside = positions
            .iter()
            .all(|&(r, c)| (r as usize) < rows && (c as usize) < cols);
        if out.len() != rows * cols || values.len() != positions.len() || !inside {
            out.fill(f64::NAN);
            return;
        }
        out.fill(0.0);
        for (&v, &(r, c)) in values.iter().zip(positions) {
            out[r as usize * cols + c as usize] += v;
        }
    }
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

/// What every motion engine of this module offers: the state after
/// [`advance_to`](Integrator::advance_to) an output time, the work
/// account, the monitor of singular configurations. [`Hht`], [`Accurate`]
/// and [`Prescribed`] implement it, so a caller runs any of them through
/// one interface.
pub trait Integrator<S> {
    /// Moves to `t_end` (after the current time); `h` is the largest step
    /// of a fixed-step integrator ([`Hht`]), which the others ignore.
    ///
    /// # Errors
    /// The integrator's: a step that cannot be completed, with its cause.
    fn advance_to(&mut self, t_end: f64, h: f64) -> Result<(), IntegrateError>;
    /// Current time.
    fn t(&self) -> f64;
    /// Positions.
    fn q(&self) -> &[f64];
    /// Velocities.
    fn qd(&self) -> &[f64];
    /// Accelerations.
    fn qdd(&self) -> &[f64];
    /// Lagrange multipliers, one per row of Φ.
    fn lambda(&self) -> &[f64];
    /// Work of Q_A and of the drivers since the start.
    fn work(&self) -> f64;
    /// Kinetic energy ½ q̇ᵀ M q̇ at the current state.
    fn kinetic_energy(&mut self) -> f64;
    /// Redundant rows at the start, singular configurations passed.
    fn monitor(&self) -> &Monitor;
    /// The system.
    fn system_mut(&mut self) -> &mut S;
    /// The run's counters in words (steps, iterations, evaluations).
    fn counters(&self) -> String;
}

macro_rules! delegate_integrator {
    () => {
        fn t(&self) -> f64 {
            Self::t(self)
        }
        fn q(&self) -> &[f64] {
            Self::q(self)
        }
        fn qd(&self) -> &[f64] {
            Self::qd(self)
        }
        fn qdd(&self) -> &[f64] {
            Self::qdd(self)
        }
        fn lambda(&self) -> &[f64] {
            Self::lambda(self)
        }
        fn work(&self) -> f64 {
            Self::work(self)
        }
        fn kinetic_energy(&mut self) -> f64 {
            Self::kinetic_energy(self)
        }
        fn monitor(&self) -> &Monitor {
            Self::monitor(self)
        }
        fn system_mut(&mut self) -> &mut S {
            Self::system_mut(self)
        }
    };
}

impl<S: ForwardSystem> Integrator<S> for Hht<S> {
    fn advance_to(&mut self, t_end: f64, h: f64) -> Result<(), IntegrateError> {
        Hht::advance_to(self, t_end, h)
    }
    delegate_integrator!();
    fn counters(&self) -> String {
        let stats = self.stats();
        format!(
            "{} steps, Newton iterations per step mean {:.2}, max {}, {} factorizations",
            stats.steps,
            if stats.steps == 0 {
                0.0
            } else {
                stats.iterations as f64 / stats.steps as f64
            },
            stats.max_iterations,
            stats.factorizations
        )
    }
}

impl<S: ForwardSystem> Integrator<S> for Accurate<S> {
    fn advance_to(&mut self, t_end: f64, _h: f64) -> Result<(), IntegrateError> {
        Accurate::advance_to(self, t_end)
    }
    delegate_integrator!();
    fn counters(&self) -> String {
        let stats = self.stats();
        format!(
            "{} steps accepted, {} rejected, {} evaluations",
            stats.accepted, stats.rejected, stats.evaluations
        )
    }
}

impl<S: ForwardSystem> Integrator<S> for Prescribed<S> {
    fn advance_to(&mut self, t_end: f64, _h: f64) -> Result<(), IntegrateError> {
        Prescribed::advance_to(self, t_end)
    }
    delegate_integrator!();
    fn counters(&self) -> String {
        format!("{} Newton iterations", self.iterations())
    }
}
