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
    LinearSolverFor, ModelDiagnostic, ModelError, Options, PivotReport, PointKinematics, Precision,
    PrecisionScope, Rank, RankError, SingularEvent, SingularKind, Solver, SparseLu, State,
    StepStats, System, Trajectory, Undefined, diagnose, integrate, locate_undefined,
    point_kinematics, undefined_between,
};
pub use kinema_runtime::{Motion, OutputKink, Outputs, Table};

#[cfg(feature = "model")]
pub mod columns;
#[cfg(feature = "model")]
pub mod dynamics;
pub mod equilibrium;
#[cfg(feature = "model")]
pub mod forward;
#[cfg(feature = "jit")]
mod jit;
#[cfg(feature = "model")]
mod linkage;
#[cfg(feature = "model")]
mod model;
#[cfg(feature = "model")]
pub use model::{Backend, Model, ModelSolver, TapeSystem, UnknownParam};
#[cfg(feature = "model")]
mod domains;
#[cfg(feature = "model")]
mod kinks;
#[cfg(feature = "model")]
mod model_outputs;
#[cfg(feature = "model")]
mod precision;
#[cfg(feature = "parallel")]
pub mod sweep;

/// What generated code refers to. Not public API: paths may change.
#[doc(hidden)]
pub mod __private {
    pub use kinema_runtime::{
        Auto, DenseLu, DenseScratch, Dynamics, Error, ForwardStructure, ForwardSystem, Kink,
        LinalgError, LinearSolver, LinearSolverFor, Motion, Options, OutputKink, Outputs,
        PivotReport, ReactionSpec, Solver, SparseLu, State, System,
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
}
