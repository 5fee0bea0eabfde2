//! The runtime of kinema's generated solvers: kinematic analysis of a planar
//! constraint system Φ(q, t) = 0 over time.
//!
//! Given a [`System`] — Φ, the nonzeros of Φ_q in a fixed pattern, ν = −Φ_t
//! and γ = −(Φ_q q̇)_q q̇ − 2Φ_qt q̇ − Φ_tt, as generated code or a tape
//! interpreter evaluates them — a [`Solver`] computes at each time
//!
//! * the position q: Φ(q, t) = 0, by Newton–Raphson;
//! * the velocity q̇: Φ_q q̇ = ν;
//! * the acceleration q̈: Φ_q q̈ = γ,
//!
//! with one factorization of Φ_q at the converged q for the last two. It
//! knows nothing of symbolic expressions: an application embedding a
//! generated solver depends on this crate, nalgebra and faer only.
//!
//! | module | job |
//! |---|---|
//! | [`system`] | the [`System`] trait |
//! | [`linalg`] | dense and sparse LU behind the [`LinearSolver`] trait |
//! | [`solver`] | [`Solver`]: assembly, stepping, runs over a time grid |
//! | [`options`] | [`Options`]: tolerances, predictor, full or modified Newton |
//! | [`linkage`] | [`Linkage`]: closed-form positions of linkages of cranks and dyads |
//! | [`error`] | [`Error`]: typed diagnostics (singular Φ_q with the equations involved, no convergence, non-finite values, bad time grids) |
//! | [`diagnose`], [`event`] | the one rank rule (equilibrated SVD); singular configurations met during a run |
//! | [`integrate`] | forward dynamics: HHT-α ([`Hht`]) over a [`ForwardSystem`] |
//! | [`roundoff`], [`precision`] | error bounds of straight-line arithmetic, the kink test, the precision check |
//! | [`equilibrium`] | the stable static equilibrium of a [`ForwardSystem`] and its stability |
//! | [`trajectory`], [`state`], [`kinematics`], [`csv`] | results: states, body-point kinematics, CSV |
//! | `handwritten` | reference mechanisms of the benchmarks (feature `handwritten`) |
//!
//! ```
//! # #[cfg(feature = "handwritten")] {
//! use kinema_runtime::{Body, Options, Solver, handwritten::SliderCrank};
//!
//! let mut solver: Solver<SliderCrank> = Solver::with_options(SliderCrank::default(), Options::default())?;
//! let times: Vec<f64> = (0..=100).map(|k| k as f64 / 100.0).collect();
//! let trajectory = solver.run(&times)?;
//! // Velocity of the crank pin A, at s′ = (0.15, 0) on the crank (body 0).
//! let pin = trajectory.point(0, Body::new(0), [0.15, 0.0]).ok_or("in range")?;
//! let speed = pin.velocity[0].hypot(pin.velocity[1]);
//! assert!((speed - 0.3 * 2.0 * std::f64::consts::PI).abs() < 1e-9);
//! let mut csv = Vec::new();
//! trajectory.write_csv(&mut csv)?;
//! # }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod csv;
pub mod diagnose;
pub mod dynamics;
pub mod equilibrium;
pub mod error;
pub mod event;
#[cfg(feature = "handwritten")]
pub mod handwritten;
pub mod integrate;
pub mod kinematics;
pub mod linalg;
pub mod linkage;
mod newton;
pub mod options;
pub mod outputs;
pub mod precision;
pub mod roundoff;
pub mod sensitivity;
pub mod solver;
pub mod state;
pub mod system;
pub mod trajectory;

pub use csv::{CsvLine, CsvWriter};
pub use diagnose::{Rank, RankError};
pub use dynamics::{Dynamics, InverseDynamics, ReactionSpec, RowRange};
pub use error::{Dependency, Error, Quantity, Time};
pub use event::{SingularEvent, SingularKind};
pub use integrate::{
    Accurate, DenseScratch, ForwardStructure, ForwardSystem, Hht, HhtOptions, IntegrateError,
};
pub use kinema_index::{Axis, Body, Coord};
pub use kinematics::{PointKinematics, point_kinematics};
pub use linalg::{
    Auto, CompiledSolves, DenseLu, DynDenseLu, FoldedLu, FoldedSolves, LinalgError, LinearSolver,
    LinearSolverFor, PivotReport, SparseLu,
};
pub use linkage::{DrivenAngle, Linkage, Pin};
pub use options::Options;
pub use outputs::{Motion, OutputKink, Outputs, Table};
pub use precision::{Imprecision, Precision, PrecisionScope};
pub use sensitivity::{Augmented, Sensitivities, SensitivitySystem};
pub use solver::{Solver, locate_undefined, undefined_between};
pub use state::{Domain, Kink, State, StepStats, Undefined};
pub use system::System;
pub use trajectory::{Trajectory, uniform_times};
