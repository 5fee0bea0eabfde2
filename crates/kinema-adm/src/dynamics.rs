//! The dynamics part of an imported model: masses and `jbar` as body
//! inertia, `gravity`, and the force elements as kinema `force` items
//! (docs/src/simengine2d.md, "Force elements"):
//!
//! | ADM | kinema |
//! |---|---|
//! | `PointForce`, `frame` "GRF" | `point_force(B(sx, sy), (funX, funY))` |
//! | `PointForce`, other frame | `point_force_local(B(sx, sy), (funX, funY))` |
//! | `Torque` | `torque(B, fun)` |
//! | `RSDA1` | `rsda(ground, B, k, c, theta0, fun)` |
//! | `RSDA2` | `rsda(Bi, Bj, k, c, theta0, fun)` |
//! | `PointForceFile` | none: a MATLAB function; a run is refused naming it |
//!
//! The model has dynamics when every body has both `mass` and `jbar` (the
//! engine needs them for any dynamics); otherwise it is imported as
//! kinematics alone, its forces ignored as before.

use std::collections::HashSet;

use crate::adm::{Body, ForceKind, Model};
use crate::emit::identifier;

/// True when the model is imported with its dynamics: it has bodies and
/// every one has a `mass` and a `jbar`.
#[must_use]
pub fn has_dynamics(model: &Model) -> bool {
    !model.bodies.is_empty()
        && model
            .bodies
            .iter()
            .all(|b| b.mass.is_some() && b.jbar.is_some())
}

/// A body's initial velocity `qd0` as the `.kin` model states it: in a
/// model with dynamics, when the file gives one that is not zero (a zero
/// `qd0` is the language's default, so the text stays as it was). The
/// engine's Dynamics analysis starts from it; kinematics does not read it.
pub(crate) fn stated_velocity(model: &Model, body: &Body) -> Option<[f64; 3]> {
    body.qd0
        .filter(|v| has_dynamics(model) && v.iter().any(|x| *x != 0.0))
}

/// The `PointForceFile` elements of a model: (name, id, m-file), which no
/// model-file tool can run.
#[must_use]
pub fn point_force_files(model: &Model) -> Vec<(String, usize, String)> {
    model
        .forces
        .iter()
        .filter_map(|f| match &f.kind {
            ForceKind::PointForceFile { mfile, .. } => Some((f.name.clone(), f.id, mfile.clone())),
            _ => None,
        })
        .collect()
}

/// The identifiers of the force elements (their own namespace).
#[must_use]
pub fn force_names(model: &Model) -> Vec<String> {
    let mut used: HashSet<String> = HashSet::new();
    model
        .forces
        .iter()
        .map(|f| {
            let base = identifier(&f.name, "f", f.id);
            let mut name = base.clone();
            let mut k = 2;
            while used.contains(&name) {
                name = format!("{base}_{k}");
                k += 1;
            }
            used.insert(name.clone());
            name
        })
        .collect()
}
