//! kinema: planar kinematic analysis of mechanisms in absolute coordinates.
//!
//! Describe a mechanism once — bodies with q = (x, y, φ), joints from the
//! constraint library, your own constraint equations, drivers as functions of
//! time — and kinema differentiates the constraints symbolically (Φ_q, ν, γ),
//! then solves position (Newton–Raphson), velocity (Φ_q q̇ = ν) and
//! acceleration (Φ_q q̈ = γ) over time.
//!
//! Two back ends run the same derivation:
//! - [`mechanism!`] generates specialized, allocation-free Rust at compile
//!   time (also available from a build script through `kinema-codegen` and
//!   on the command line as `kinema codegen`);
//! - [`Model`] reads a model from text or a file at run time and evaluates it
//!   through compiled tapes: no compiler needed.
//!
//! ```
//! kinema::mechanism! {
//!     mechanism Pendulum {
//!         /// bar half-length [m]
//!         param l = 1.0;
//!         body bar { guess: (0.5, 0.8, 1.0) }
//!         joint pin: revolute(ground(0, 0), bar(-l, 0));
//!         driver swing: bar.phi == 4 * t * t;
//!     }
//! }
//!
//! let mut solver = Pendulum::default().solver(kinema::Options::default())?;
//! let state = solver.step(0.5)?;
//! assert!((state.q()[2] - 1.0).abs() < 1e-12); // φ = 4t² at t = 0.5
//! # Ok::<(), kinema::Error>(())
//! ```
//!
//! The user guide is in `docs/` (an mdBook: `mdbook build docs`); see
//! `ARCHITECTURE.md` for how the crates fit together.

pub use kinema_macros::mechanism;
pub use kinema_runtime::{
    Accurate, Auto, Axis, Body, Coord, CsvLine, CsvWriter, DenseLu, DenseScratch, Dependency,
    Domain, DynDenseLu, Dynamics, Error, FoldedLu, ForwardStructure, ForwardSystem, Hht,
    HhtOptions, Imprecision, IntegrateError, InverseDynamics, Kink, LinalgError, LinearSolver,
    LinearSolverFor, Options, PivotReport, PointKinematics, Precision, PrecisionScope, Rank,
    RankError, SingularEvent, SingularKind, Solver, SparseLu, State, StepStats, System, Trajectory,
    Undefined, diagnose, integrate, locate_undefined, point_kinematics, undefined_between,
    uniform_times,
};
/// Parameter sensitivities of any back end: generated code implements
/// [`SensitivitySystem`] for the params it was generated with, and
/// [`Solver::sensitivities`] fills [`Sensitivities`].
pub use kinema_runtime::{Augmented, Sensitivities, SensitivitySystem};
pub use kinema_runtime::{Motion, OutputKink, Outputs, Table};

/// Static equilibrium of a system with inertia: the runtime's descent over
/// any [`ForwardSystem`] — a generated one (`Name::default().forward()`,
/// see [`equilibrium_from_start`](equilibrium::equilibrium_from_start)) or a
/// model file's (`Model::equilibrium`, with the feature `model`).
pub mod equilibrium {
    pub use kinema_runtime::equilibrium::{
        Equilibrium, EquilibriumError, Stability, equilibrium, equilibrium_from_start,
    };
    #[cfg(feature = "model")]
    pub use kinema_tape::equilibrium::equilibrium_from;
}

// The tape back end (kinema-tape): models read at run time.
/// Dimensional synthesis: a model's params fitted to target results (see
/// the crate's documentation).
#[cfg(feature = "fit")]
pub use kinema_fit as fit;
/// The model language (kinema-model): the front door's types, the checked
/// model and the derivation, for programs that look inside a [`Model`].
#[cfg(feature = "model")]
pub use kinema_model as lang;
/// A model's diagnostics with the source they point into: what loading a
/// model fails with, and its warnings.
#[cfg(feature = "model")]
pub use kinema_model::{Report, Source};
#[cfg(feature = "parallel")]
pub use kinema_tape::sweep;
#[cfg(feature = "model")]
pub use kinema_tape::{
    Backend, Format, Model, ModelFile, ModelSolver, TapeSystem, UnknownParam, columns, dynamics,
    dynamics_sensitivity, forward, sensitivity,
};

/// What generated code refers to. Not public API: paths may change.
#[doc(hidden)]
pub mod __private {
    pub use kinema_runtime::{Augmented, Sensitivities, SensitivitySystem};
    pub use kinema_runtime::{
        Auto, Body, DenseLu, DenseScratch, Dynamics, Error, ForwardStructure, ForwardSystem, Kink,
        LinalgError, LinearSolver, LinearSolverFor, Motion, Options, OutputKink, Outputs,
        PivotReport, ReactionSpec, RowRange, Solver, SparseLu, State, System,
    };
    pub use kinema_runtime::{linalg, roundoff};
}

/// The README's Rust examples, compiled and run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// The user guide's Rust examples (docs/src), compiled and run as doc
/// tests: one module per chapter with Rust code.
#[cfg(doctest)]
mod guide {
    #[doc = include_str!("../docs/src/rust-api.md")]
    mod rust_api {}
    #[doc = include_str!("../docs/src/dynamics.md")]
    mod dynamics {}
    #[doc = include_str!("../docs/src/design.md")]
    mod design {}
}
