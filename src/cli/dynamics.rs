//! `kinema run` of a model with inertia: λ, reactions and driver efforts
//! after the kinematic columns (DYNAMICS.md, "CSV columns").

use kinema::{Auto, Error, InverseDynamics, Solver, System, TapeSystem};

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
    pub fn new(system: &TapeSystem, adm: bool) -> Option<DynamicsColumns> {
        if !system.has_dynamics() {
            return None;
        }
        let n = system.len();
        let mut names: Vec<String> = (0..n)
            .map(|i| format!("lambda.{}", system.equation_name(i)))
            .collect();
        for r in system.reaction_names() {
            let body = if adm {
                format!("body{}", r.slot + 1)
            } else {
                r.body.clone()
            };
            for c in ["Fx", "Fy", "T"] {
                names.push(format!("reaction.{}.{body}.{c}", r.element));
            }
        }
        for i in kinema::Dynamics::driving_start(system)..n {
            names.push(format!("driver.{}", system.equation_name(i)));
        }
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

    /// The reactions' and efforts' column indices among [`names`](Self::names)
    /// (for plots): reaction force components, then efforts.
    pub fn plotted(&self) -> (Vec<usize>, Vec<usize>) {
        let forces = self
            .names
            .iter()
            .enumerate()
            .filter(|(_, n)| n.starts_with("reaction.") && !n.ends_with(".T"))
            .map(|(i, _)| i)
            .collect();
        let efforts = self
            .names
            .iter()
            .enumerate()
            .filter(|(_, n)| n.starts_with("driver."))
            .map(|(i, _)| i)
            .collect();
        (forces, efforts)
    }
}
