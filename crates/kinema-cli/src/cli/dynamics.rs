//! `kinema run` of a model with inertia: λ, reactions and driver efforts
//! after the kinematic columns (docs/src/dynamics.md, "Inverse dynamics").

use kinema::{Auto, Error, InverseDynamics, Solver, TapeSystem};

/// The extra columns of a dynamics run and the buffers that fill them.
pub struct DynamicsColumns {
    id: InverseDynamics,
    names: Vec<String>,
    values: Vec<f64>,
}

impl DynamicsColumns {
    /// The columns for `system`, or `None` for a kinematic model. `adm`:
    /// name a reaction's body `body1`/`body2` as in the simEngine2D
    /// element, not by the body's name.
    pub fn new(system: &TapeSystem, rows: usize, adm: bool) -> Option<DynamicsColumns> {
        if !system.has_dynamics() {
            return None;
        }
        let names = system.dynamics_column_names(rows, adm);
        let values = vec![0.0; names.len()];
        Some(DynamicsColumns {
            id: InverseDynamics::new(system),
            names,
            values,
        })
    }

    /// The column names, in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Inverse dynamics at the solver's state: the row's values.
    ///
    /// # Errors
    /// As [`Solver::inverse_dynamics`].
    pub fn compute(&mut self, solver: &mut Solver<TapeSystem, Auto>) -> Result<&[f64], Error> {
        solver.inverse_dynamics(&mut self.id)?;
        let flat = self
            .id
            .lambda()
            .iter()
            .chain(self.id.reactions().iter().flatten())
            .chain(self.id.efforts());
        for (v, &x) in self.values.iter_mut().zip(flat) {
            *v = x;
        }
        Ok(&self.values)
    }
}

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
