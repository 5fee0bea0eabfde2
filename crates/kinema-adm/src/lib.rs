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
//! 4. [`parsed`] makes the model's parsed form for kinema-model's front
//!    door ([`build()`] its syntax tree) directly, every name and
//!    expression at the place in the ADM file it comes from, so messages
//!    point there (`kinema run`); [`to_kin`] prints that syntax tree as
//!    `.kin` text with kinema-model's printer (`kinema import`). [`Names`] gives its
//!    identifiers (bodies in order: the order of q; equations in order: the
//!    order of Φ's rows).
//!
//! Drawing data for plots is in [`Model::vis`] (limits, background) and
//! [`Body::vis`] (colour, rectangles, points).
//!
//! Errors and warnings are kinema-model's diagnostics: every mistake found,
//! each at its line and column in the file's text, rendered with the file
//! (a [`Report`]) as every message about a `.kin` model is. Nothing in the
//! crate panics on any input.
//!
//! ```
//! let adm = kinema_adm::Source::new("pendulum.adm", r#"{
//!   "name": "pendulum",
//!   "bodies": [ { "name": "rod", "id": 1, "mass": 1, "jbar": 1, "q0": [1, 0, 0], "qd0": [0, 0, 0] } ],
//!   "constraints": [
//!     { "name": "pin x", "id": 1, "type": "AbsoluteX", "body1": 1, "sP1": [-1, 0], "fun": "0" },
//!     { "name": "pin y", "id": 2, "type": "AbsoluteY", "body1": 1, "sP1": [-1, 0], "fun": "0" },
//!     { "name": "swing", "id": 3, "type": "AbsoluteAngle", "body1": 1, "fun": "pi/2 + 2*pi*t" }
//!   ]
//! }"#);
//! let model = kinema_adm::Model::parse(&adm).unwrap();
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
pub mod fun;
pub mod json;
pub mod pos;

pub use acf::{Analysis, Simulation, TimesError};
pub use adm::{
    Body, BodyVis, Constraint, ConstraintKind, Fields, Force, ForceKind, Model, Rect, SceneVis,
};
pub use build::{build, parsed};
pub use check::{Counts, Refusal, check_kinematic, ignored_by_kinematics};
pub use emit::{Names, RowOrigin, to_kin};
// The types of this crate's API: its sources, and the reports of its
// errors against them.
pub use kinema_model::{Diagnostic, Diagnostics, Report, Severity, Source};
pub use pos::Pos;
