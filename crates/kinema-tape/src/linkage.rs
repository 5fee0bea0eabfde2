//! A model's closed-form position solution (see [`kinema_runtime::Linkage`]):
//! its joints' local coordinates and driven angles as tapes, and the plan
//! at the system's parameters.

use kinema_expr::{ExprId, Tape, TapeInputs};
use kinema_model::Derivation;
use kinema_runtime::{DrivenAngle, Linkage, Pin};

/// The tapes behind a model's [`Linkage`]: the pins' local coordinates
/// (functions of the parameters, evaluated when they change) and the
/// driven angles (functions of time, evaluated at each step).
#[derive(Debug)]
pub(crate) struct LinkageTapes {
    bodies: usize,
    /// Each pin's two bodies.
    pins: Vec<[Option<u32>; 2]>,
    driven: Vec<DrivenAngle>,
    /// The pins' local coordinates, four per pin.
    locals: Tape,
    angles: Tape,
}

impl LinkageTapes {
    /// The tapes of a derivation that describes a linkage.
    pub(crate) fn new(d: &Derivation) -> Option<LinkageTapes> {
        let desc = d.linkage.as_ref()?;
        let locals: Vec<ExprId> = desc
            .pins
            .iter()
            .flat_map(|p| p.local.into_iter().flatten())
            .collect();
        let angles: Vec<ExprId> = desc.angles.iter().map(|a| a.angle).collect();
        Some(LinkageTapes {
            bodies: d.bodies.len(),
            pins: desc.pins.iter().map(|p| p.bodies).collect(),
            driven: desc
                .angles
                .iter()
                .map(|a| DrivenAngle {
                    body: a.body,
                    relative_to: a.relative_to,
                })
                .collect(),
            locals: Tape::compile(&d.arena, &locals),
            angles: Tape::compile(&d.arena, &angles),
        })
    }

    /// Registers the per-step tape needs.
    pub(crate) fn registers(&self) -> usize {
        self.angles.registers()
    }

    /// The driven angles' tape.
    pub(crate) fn angles(&self) -> &Tape {
        &self.angles
    }

    /// The plan at parameters `params` (`None`: no closed form there, or
    /// the local coordinates are not finite). Allocates: called when the
    /// parameters change, not per step.
    pub(crate) fn plan(&self, params: &[f64]) -> Option<Linkage> {
        let n = 3 * self.bodies;
        let zeros = vec![0.0; n];
        let inputs = TapeInputs {
            q: &zeros,
            qd: &zeros,
            params,
            t: 0.0,
        };
        let mut registers = vec![0.0; self.locals.registers()];
        // No coordinate: the sin/cos cache is never read.
        let mut trig = [];
        let mut out = vec![0.0; 4 * self.pins.len()];
        self.locals
            .eval_with_cache(&inputs, &mut registers, &mut trig, &mut out)
            .ok()?;
        let pins: Vec<Pin> = self
            .pins
            .iter()
            .zip(out.chunks_exact(4))
            .map(|(&bodies, v)| Pin {
                bodies,
                local: [[v[0], v[1]], [v[2], v[3]]],
            })
            .collect();
        Linkage::plan(self.bodies, &pins, &self.driven)
    }
}
