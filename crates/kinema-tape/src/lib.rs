//! kinema's tape back end: a model read at run time — model text, a `.kin`
//! file or a simEngine2D `.adm` model ([`Model`], [`ModelFile`]) — derived
//! through kinema-model's front door, its expressions compiled to tapes
//! (interpreted, or compiled to native code by kinema-jit) and run through
//! kinema-runtime like generated code ([`TapeSystem`] is a
//! [`System`](kinema_runtime::System)). Around it: the result columns of a
//! run ([`columns`]), inverse and forward dynamics of a loaded model
//! ([`dynamics`], [`forward`]), its static equilibrium ([`equilibrium`]),
//! parameter sensitivities solved after each step ([`sensitivity`], and of
//! inverse dynamics: [`dynamics_sensitivity`]), and
//! parameter sweeps on every core ([`sweep`], feature `parallel`).
//!
//! Users reach all of it through the `kinema` facade (`kinema::Model`, …);
//! the tests and examples are written that way.

pub mod columns;
mod domains;
pub mod dynamics;
pub mod dynamics_sensitivity;
pub mod equilibrium;
mod file;
pub mod forward;
#[cfg(feature = "jit")]
mod jit;
mod kinks;
mod linkage;
mod model;
mod model_outputs;
mod precision;
pub mod sensitivity;
#[cfg(feature = "parallel")]
pub mod sweep;

pub use file::{Format, ModelFile};
pub use model::{Backend, Model, ModelSolver, TapeSystem, UnknownParam};
