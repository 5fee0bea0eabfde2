//! Reads simEngine2D model files (ADM) and analysis files (ACF), builds the
//! model kinema checks, and prints it in kinema's model language.
//!
//! simEngine2D is the MATLAB engine of the ME451 course; its files and their
//! meaning are described in `docs/src/simengine2d.md`. The command line uses it
//! for `kinema run model.adm [--acf analysis.acf]` and `kinema import
//! model.adm`:
//!
//! 1. [`Model::read`] / [`Model::parse`] read and check an ADM file
//!    (a tolerant JSON reader with positions, [`json`]; the MATLAB `fun`
//!    language, [`fun`]).
//! 2. [`Analysis::read`] / [`Analysis::parse`] read an ACF file (JSON or the
//!    older plain text); [`Analysis::default`] is the engine's
//!    `kinematics.acf`, and [`Analysis::output_times`] the output grid.
//! 3. [`check_kinematic`] refuses a Dynamics analysis or a model with
//!    NDOF ≠ 0, with the counts; [`ignored_by_kinematics`] lists the force
//!    elements and keys a kinematic run ignores.
//! 4. [`build()`] makes the model's syntax tree for kinema-model's checker
//!    directly, every name and expression at the place in the ADM file it
//!    comes from, so messages point there (`kinema run`); [`to_kin`] prints
//!    the same model as `.kin` text (`kinema import`). [`Names`] gives its
//!    identifiers (bodies in order: the order of q; equations in order: the
//!    order of Φ's rows).
//!
//! Drawing data for plots is in [`Model::vis`] (limits, background) and
//! [`Body::vis`] (colour, rectangles, points).
//!
//! Errors are [`Error`]s: every mistake found, each rendered as
//! `file:line:col: message` with the source line and a caret. Nothing in the
//! crate panics on any input.
//!
//! ```
//! let adm = r#"{
//!   "name": "pendulum",
//!   "bodies": [ { "name": "rod", "id": 1, "mass": 1, "jbar": 1, "q0": [1, 0, 0], "qd0": [0, 0, 0] } ],
//!   "constraints": [
//!     { "name": "pin x", "id": 1, "type": "AbsoluteX", "body1": 1, "sP1": [-1, 0], "fun": "0" },
//!     { "name": "pin y", "id": 2, "type": "AbsoluteY", "body1": 1, "sP1": [-1, 0], "fun": "0" },
//!     { "name": "swing", "id": 3, "type": "AbsoluteAngle", "body1": 1, "fun": "pi/2 + 2*pi*t" }
//!   ]
//! }"#;
//! let model = kinema_adm::Model::parse(adm, "pendulum.adm").unwrap();
//! let counts = kinema_adm::check_kinematic(&model, &kinema_adm::Analysis::default()).unwrap();
//! assert_eq!((counts.n, counts.m), (3, 3));
//! let kin = kinema_adm::to_kin(&model);
//! assert!(kin.contains("constraint pin_x: abs_x(rod(-1, 0), 0);"));
//! assert!(kin.contains("driver swing: abs_angle(rod, pi / 2 + 2 * pi * t);"));
//! ```

pub mod acf;
pub mod adm;
pub mod build;
pub mod check;
mod defined;
pub mod dynamics;
pub mod emit;
pub mod error;
pub mod fun;
pub mod json;

pub use acf::{Analysis, Simulation, TimesError};
pub use adm::{
    Body, BodyVis, Constraint, ConstraintKind, Fields, Force, ForceKind, Model, Rect, SceneVis,
};
pub use build::build;
pub use check::{Counts, Refusal, check_kinematic, ignored_by_kinematics};
pub use emit::{Names, RowOrigin, to_kin};
pub use error::{Diagnostic, Error, MAX_FILE_BYTES, Pos, ReadError, read_text};
