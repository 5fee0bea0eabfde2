//! kinema: planar kinematic analysis of mechanisms in absolute coordinates.
//!
//! This is the facade crate. It re-exports the pieces a user needs; see
//! `ARCHITECTURE.md` for how the crates fit together.
