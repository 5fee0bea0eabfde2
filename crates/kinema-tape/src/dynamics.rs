//! The tape back end's inverse dynamics: diag M, Q_A and the reactions'
//! arms compiled to one tape, and the names of the output columns
//! (docs/src/dynamics.md, "Inverse dynamics").

use kinema_expr::{ExprId, Tape, TapeInputs};
use kinema_model::{Derivation, RowKind};
use kinema_runtime::{
    Auto, Body, Dynamics, Error, InverseDynamics, Motion, Outputs, ReactionSpec, RowRange, Solver,
    System,
};

use crate::model::TapeSystem;

/// One reaction's names: the element, its body's name and its position
/// among the element's body arguments (`slot` 0 is simEngine2D's `body1`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReactionName {
    /// The element (equation) name.
    pub element: String,
    /// The body's name.
    pub body: String,
    /// The body's position among the element's body arguments (ground
    /// counted), from 0.
    pub slot: usize,
}

/// What [`TapeSystem`] needs for inverse dynamics.
#[derive(Clone, Debug)]
pub(crate) struct TapeDynamics {
    /// `None` for a kinematic model.
    tape: Option<Tape>,
    specs: Vec<ReactionSpec>,
    names: Vec<ReactionName>,
    driving_start: usize,
}

impl TapeDynamics {
    pub(crate) fn new(d: &Derivation) -> Self {
        let driving_start = d
            .rows
            .iter()
            .position(|r| r.kind == RowKind::Driving)
            .unwrap_or(d.rows.len());
        let Some(dy) = &d.dynamics else {
            return TapeDynamics {
                tape: None,
                specs: Vec::new(),
                names: Vec::new(),
                driving_start,
            };
        };
        let mut outputs: Vec<ExprId> = dy.mass.iter().chain(&dy.applied).copied().collect();
        for r in &dy.reactions {
            outputs.extend(r.arm);
        }
        let tape = Tape::compile(&d.arena, &outputs);
        let u = |i: usize| kinema_index::u32_of(i, "a reaction's row");
        TapeDynamics {
            tape: Some(tape),
            specs: dy
                .reactions
                .iter()
                .map(|r| ReactionSpec {
                    rows: RowRange {
                        start: u(r.rows.start),
                        end: u(r.rows.end),
                    },
                    body: Body::new(r.body),
                })
                .collect(),
            names: dy
                .reactions
                .iter()
                .map(|r| ReactionName {
                    element: r.element.clone(),
                    body: d.bodies.get(r.body).cloned().unwrap_or_default(),
                    slot: r.slot,
                })
                .collect(),
            driving_start,
        }
    }

    pub(crate) fn registers(&self) -> usize {
        self.tape.as_ref().map_or(0, Tape::registers)
    }
}

impl TapeSystem {
    /// Whether the model has inertia, gravity or forces (then `kinema run`
    /// writes λ, reactions and efforts).
    #[must_use]
    pub fn has_dynamics(&self) -> bool {
        self.dynamics_part().tape.is_some()
    }

    /// The names of the reactions, in [`Dynamics::reactions`] order.
    #[must_use]
    pub fn reaction_names(&self) -> &[ReactionName] {
        &self.dynamics_part().names
    }

    /// The dynamics columns of a model with `rows` rows of Φ, as the CSV
    /// contract names them (docs/src/cli.md): `lambda.<row>`,
    /// `reaction.<element>.<body>.Fx/Fy/T`, `driver.<row>`; with
    /// `by_slot`, a reaction's body is named by its place among the
    /// element's bodies (`body1`, `body2`: a simEngine2D file's naming).
    #[must_use]
    pub fn dynamics_column_names(&self, rows: usize, by_slot: bool) -> Vec<String> {
        let mut names: Vec<String> = (0..rows)
            .map(|i| format!("lambda.{}", self.equation_name(i)))
            .collect();
        for r in self.reaction_names() {
            let body = if by_slot {
                format!("body{}", r.slot + 1)
            } else {
                r.body.clone()
            };
            for c in ["Fx", "Fy", "T"] {
                names.push(format!("reaction.{}.{body}.{c}", r.element));
            }
        }
        for i in self.driving_start().min(rows)..rows {
            names.push(format!("driver.{}", self.equation_name(i)));
        }
        names
    }
}

impl Dynamics for TapeSystem {
    fn reactions(&self) -> &[ReactionSpec] {
        &self.dynamics_part().specs
    }

    fn dynamics(&self, registers: &mut Vec<f64>, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        let Some(tape) = &self.dynamics_part().tape else {
            // A kinematic model: no mass, no force (λ = 0).
            out.fill(0.0);
            return;
        };
        let inputs = TapeInputs {
            q,
            qd,
            params: self.params(),
            t,
        };
        self.run(tape, registers, &inputs, out);
    }

    fn driving_start(&self) -> usize {
        self.dynamics_part().driving_start.min(self.len())
    }
}

/// One output row's derived values at a state with multipliers (forward
/// dynamics, a prescribed motion): the named points and outputs y, ẏ, ÿ,
/// and after them λ, the reactions and the driving efforts, in the order
/// of [`TapeSystem::dynamics_column_names`]. The command line and the
/// Python package fill their rows with it. Buffers sized once; a row
/// allocates nothing.
#[derive(Debug)]
pub struct DynamicsRow {
    outputs: [Vec<f64>; 3],
    id: InverseDynamics,
    jac: Vec<f64>,
    values: Vec<f64>,
    scratch: Vec<f64>,
}

impl DynamicsRow {
    /// Buffers for `system` with `rows` rows of Φ (allocates; once).
    #[must_use]
    pub fn new(system: &TapeSystem, rows: usize) -> DynamicsRow {
        let m = system.output_len();
        let id = InverseDynamics::with_rows(system, rows);
        let width = id.lambda().len() + 3 * id.reactions().len() + id.efforts().len();
        DynamicsRow {
            outputs: [vec![0.0; m], vec![0.0; m], vec![0.0; m]],
            id,
            jac: vec![0.0; system.jacobian_pattern().len()],
            values: Vec::with_capacity(width),
            scratch: system.scratch(),
        }
    }

    /// The row at the state `at` with multipliers `lambda` (one per row of
    /// Φ).
    ///
    /// # Errors
    /// As [`InverseDynamics::of_multipliers`]: a wrong length, a
    /// non-finite M, Q_A or arm (named).
    pub fn fill(
        &mut self,
        system: &TapeSystem,
        at: Motion<'_>,
        lambda: &[f64],
    ) -> Result<(), Error> {
        let [y, yd, ydd] = &mut self.outputs;
        system.outputs(&mut self.scratch, at, [y, yd, ydd]);
        self.id.of_multipliers(
            system,
            &mut self.scratch,
            (at.t, at.q, at.qd),
            lambda,
            &mut self.jac,
        )?;
        self.values.clear();
        self.values.extend_from_slice(self.id.lambda());
        self.values.extend(self.id.reactions().iter().flatten());
        self.values.extend_from_slice(self.id.efforts());
        Ok(())
    }

    /// y, ẏ, ÿ of the named points and outputs at the last state filled.
    #[must_use]
    pub fn outputs(&self) -> &[Vec<f64>; 3] {
        &self.outputs
    }

    /// λ, the reactions (Fx, Fy, T each) and the efforts at the last state
    /// filled.
    #[must_use]
    pub fn dynamics(&self) -> &[f64] {
        &self.values
    }

    /// The evaluation scratch, for other evaluations of the same system
    /// between rows.
    pub fn scratch(&mut self) -> &mut Vec<f64> {
        &mut self.scratch
    }
}

/// The inverse-dynamics columns of a kinematic run of a model with inertia
/// (λ, the joints' reactions, the drivers' efforts, named by
/// [`TapeSystem::dynamics_column_names`]) and the buffers that fill them:
/// what `kinema run` and the Python package write after the kinematic
/// columns.
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
