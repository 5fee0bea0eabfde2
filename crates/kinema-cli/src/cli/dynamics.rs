//! `kinema run` of a model with inertia: λ, reactions and driver efforts
//! after the kinematic columns (docs/src/dynamics.md, "Inverse dynamics").

pub use kinema::dynamics::DynamicsColumns;

/// Rule: a simEngine2D `PointForceFile` cannot be run (its force is a
/// MATLAB function of the engine's user).
///   error: force "force" (id 1, PointForceFile) of `project2.adm` computes its force with the MATLAB function `pistonForce` (pistonForce.m), which kinema cannot run
///
/// # Errors
/// [`super::Failure::Input`] naming the first such element and its m-file.
pub fn refuse_point_force_files(
    model: &kinema_adm::Model,
    path: &std::path::Path,
) -> Result<(), super::Failure> {
    let Some((name, id, mfile)) = kinema_adm::dynamics::point_force_files(model)
        .into_iter()
        .next()
    else {
        return Ok(());
    };
    Err(super::Failure::usage(format_args!(
        "force \"{name}\" (id {id}, PointForceFile) of `{}` computes its force with the MATLAB \
         function `{mfile}` ({mfile}.m), which kinema cannot run\n  = help: write the force as a \
         `force` item of the model's .kin text (`kinema import {}` prints the rest)",
        path.display(),
        path.display()
    )))
}
