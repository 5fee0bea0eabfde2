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
use std::fmt::Write as _;

use crate::adm::{Body, ForceKind, Model};
use crate::emit::identifier;
use crate::fun::format_number;

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

/// `, mass: m, inertia: J` for a body of a model with dynamics, and
/// `, velocity: (ẋ, ẏ, φ̇)` when its `qd0` is stated and not zero.
pub(crate) fn body_fields(model: &Model, body: &Body) -> String {
    match (has_dynamics(model), body.mass, body.jbar) {
        (true, Some(m), Some(j)) => {
            let mut out = format!(
                ", mass: {}, inertia: {}",
                format_number(m),
                format_number(j)
            );
            if let Some([vx, vy, w]) = stated_velocity(model, body) {
                let _ = write!(
                    out,
                    ", velocity: ({}, {}, {})",
                    format_number(vx),
                    format_number(vy),
                    format_number(w)
                );
            }
            out
        }
        _ => String::new(),
    }
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

/// Writes `gravity` and the force items of a model with dynamics.
pub(crate) fn emit(out: &mut String, model: &Model, bodies: &[String]) {
    if !has_dynamics(model) {
        return;
    }
    let body = |i: usize| crate::emit::body_name(bodies, i);
    let n = format_number;
    let _ = writeln!(
        out,
        "\n    gravity = ({}, {});",
        n(model.gravity[0]),
        n(model.gravity[1])
    );
    for (f, name) in model.forces.iter().zip(force_names(model)) {
        // A doc comment documents the item after it: none for a
        // PointForceFile, which is a plain comment.
        let doc = if matches!(f.kind, ForceKind::PointForceFile { .. }) {
            "//"
        } else {
            "///"
        };
        let _ = writeln!(
            out,
            "\n    {doc} force {} \"{}\": {}",
            f.id,
            f.name.replace(['\n', '\r'], " "),
            f.kind.type_name()
        );
        let line = match &f.kind {
            ForceKind::PointForce {
                body1,
                sp1,
                frame,
                fun_x,
                fun_y,
            } => format!(
                "force {name}: {}({}({}, {}), ({}, {}));",
                if frame == "GRF" {
                    "point_force"
                } else {
                    "point_force_local"
                },
                body(*body1),
                n(sp1[0]),
                n(sp1[1]),
                fun_x.to_kin(),
                fun_y.to_kin()
            ),
            ForceKind::PointForceFile { mfile, .. } => format!(
                "// not imported: its force comes from the MATLAB function `{mfile}` ({mfile}.m)"
            ),
            ForceKind::Torque { body1, fun } => {
                format!("force {name}: torque({}, {});", body(*body1), fun.to_kin())
            }
            ForceKind::Rsda1 {
                body1,
                theta0,
                k,
                c,
                fun,
            } => format!(
                "force {name}: rsda(ground, {}, {}, {}, {}, {});",
                body(*body1),
                n(*k),
                n(*c),
                n(*theta0),
                fun.to_kin()
            ),
            ForceKind::Rsda2 {
                body1,
                body2,
                theta0,
                k,
                c,
                fun,
            } => format!(
                "force {name}: rsda({}, {}, {}, {}, {}, {});",
                body(*body1),
                body(*body2),
                n(*k),
                n(*c),
                n(*theta0),
                fun.to_kin()
            ),
        };
        let _ = writeln!(out, "    {line}");
    }
}
