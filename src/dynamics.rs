//! The tape back end's inverse dynamics: diag M, Q_A and the reactions'
//! arms compiled to one tape, and the names of the output columns
//! (docs/src/dynamics.md, "Inverse dynamics").

use kinema_expr::{ExprId, Tape, TapeInputs};
use kinema_model::{Derivation, RowKind};
use kinema_runtime::{Dynamics, ReactionSpec, System};

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
        let u = |i: usize| kinema_index::u32_of(i, "a reaction's row or body");
        TapeDynamics {
            tape: Some(tape),
            specs: dy
                .reactions
                .iter()
                .map(|r| ReactionSpec {
                    rows: (u(r.rows.0), u(r.rows.1)),
                    body: u(r.body),
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
