//! Precision lost to rounding on the tape back end: an equation of Φ
//! whose value, at a solution, its own roundoff does not determine (see
//! [`TapeSystem::imprecision`]). The decision is the runtime's
//! ([`kinema_runtime::precision`], which generated systems run through
//! [`System::phi_error_bounds`](kinema_runtime::System::phi_error_bounds));
//! the tape back end checks the drives' rows alone on tapes of their own.

use kinema_expr::{ExprId, Tape};
use kinema_model::Derivation;
use kinema_runtime::precision::{Imprecision, PrecisionScope};

use crate::model::{TapeSystem, grow};

/// The equations of Φ that read t, and their rows of Φ_q, compiled apart
/// for [`PrecisionScope::Timed`].
#[derive(Clone, Debug)]
pub(crate) struct TimedTapes {
    /// The equation of each output of `phi`.
    equations: Vec<usize>,
    phi: Tape,
    jacobian: Tape,
    /// The output of `phi` (its position in `equations`) of each output of
    /// `jacobian`.
    entry_rows: Vec<u32>,
}

impl TimedTapes {
    /// `None` if no equation reads t.
    pub(crate) fn new(d: &Derivation) -> Option<TimedTapes> {
        let equations: Vec<usize> = (0..d.phi.len())
            .filter(|&i| d.arena.depends_on(d.phi[i], d.time))
            .collect();
        if equations.is_empty() {
            return None;
        }
        let mut local = vec![u32::MAX; d.phi.len()];
        for (k, &i) in equations.iter().enumerate() {
            local[i] = u32::try_from(k).ok()?;
        }
        let (mut entries, mut entry_rows): (Vec<ExprId>, Vec<u32>) = (Vec::new(), Vec::new());
        for e in &d.phi_q.entries {
            let row = local[e.row as usize];
            if row != u32::MAX {
                entries.push(e.expr);
                entry_rows.push(row);
            }
        }
        let phi: Vec<ExprId> = equations.iter().map(|&i| d.phi[i]).collect();
        Some(TimedTapes {
            phi: Tape::compile(&d.arena, &phi),
            jacobian: Tape::compile(&d.arena, &entries),
            equations,
            entry_rows,
        })
    }
}

/// Equations to check: their Φ tape, their Φ_q entries' tape, the output
/// of the former that each entry of the latter belongs to, and the
/// equation of each output of the former.
struct Equations<'a> {
    phi: &'a Tape,
    jacobian: &'a Tape,
    entry_row: &'a dyn Fn(usize) -> usize,
    equation: &'a dyn Fn(usize) -> usize,
}

impl TapeSystem {
    /// The equation of Φ that, at `state`, its own arithmetic determines
    /// least, if it moves the coordinates by more than
    /// [`Imprecision::THRESHOLD`] of their scale (`size`, the model's, plus
    /// ‖q‖∞): an argument beyond f64's precision (`sin(1e30 * t)`,
    /// uncertain by 10¹⁴ radians; `sin(1e20 + t)`, which does not move with
    /// t at all), a difference of two large numbers that cancel. Each
    /// equation's error is bounded as
    /// [`Tape::error_bounds`](kinema_expr::Tape::error_bounds) does (the
    /// coordinates uncertain by the state's residual and their roundoff),
    /// and divided by its largest partial derivative, the equation's lever
    /// on q. `None` if every equation in `scope` is determined, or the
    /// bound could not be computed. Only q is judged: a term too small to
    /// move q whose derivative in t is large (`1e-20 * sin(1e30 * t)`)
    /// leaves q̇ and q̈ to the rounding unflagged.
    ///
    /// Not part of a step: call it on the states you keep. With
    /// [`PrecisionScope::All`] it costs an evaluation of Φ with its bounds
    /// and one of Φ_q on the tape, about a step; with
    /// [`PrecisionScope::Timed`] the drives' rows alone. `kinema run`
    /// checks every equation on the first output row and the timed ones on
    /// each row after it. Allocates only the first time (the scratch).
    pub fn imprecision(
        &self,
        scratch: &mut Vec<f64>,
        state: &kinema_runtime::State,
        size: f64,
        scope: PrecisionScope,
    ) -> Option<Imprecision> {
        let (q, t, residual) = (state.q(), state.t(), state.stats().residual);
        self.imprecision_at(scratch, q, t, residual, size, scope)
    }

    /// [`imprecision`](Self::imprecision) at coordinates `q` (all of them, also for a system with degrees of
    /// freedom, as forward dynamics integrates) and time `t`, each
    /// coordinate uncertain by `uncertainty` besides its roundoff at
    /// `size`.
    pub fn imprecision_at(
        &self,
        scratch: &mut Vec<f64>,
        q: &[f64],
        t: f64,
        uncertainty: f64,
        size: f64,
        scope: PrecisionScope,
    ) -> Option<Imprecision> {
        let all = |k: usize| self.pattern[k].0 as usize;
        let equations = match scope {
            PrecisionScope::All => Equations {
                phi: &self.phi,
                jacobian: &self.jacobian,
                entry_row: &all,
                equation: &|i| i,
            },
            PrecisionScope::Timed => {
                let timed = self.timed.as_deref()?;
                Equations {
                    phi: &timed.phi,
                    jacobian: &timed.jacobian,
                    entry_row: &|k| timed.entry_rows[k] as usize,
                    equation: &|k| timed.equations[k],
                }
            }
        };
        self.worst(&equations, scratch, (q, t, uncertainty), size)
    }

    /// The check of [`imprecision`](Self::imprecision) over `equations` at
    /// (q, t) with the coordinates' uncertainty, in the scratch after the
    /// kink checks' part.
    fn worst(
        &self,
        equations: &Equations<'_>,
        scratch: &mut Vec<f64>,
        (q, t, uncertainty): (&[f64], f64, f64),
        size: f64,
    ) -> Option<Imprecision> {
        let Equations { phi, jacobian, .. } = *equations;
        let (m, nnz) = (phi.outputs(), jacobian.outputs());
        let registers = phi.registers().max(jacobian.registers());
        let base = self.kink_base() + self.kink_len();
        let need = base + 2 * registers + nnz + m;
        if scratch.len() < need {
            grow(scratch, need);
        }
        let (start, rest) = scratch.split_at_mut(base);
        let trig = &mut start[..self.trig_len()];
        let (r, rest) = rest.split_at_mut(registers);
        let (e, rest) = rest.split_at_mut(registers);
        let (jac, lever) = rest[..nnz + m].split_at_mut(nnz);
        let inputs = self.inputs(q, &self.zeros, t);
        jacobian.eval_with_cache(&inputs, r, trig, jac).ok()?;
        phi.error_bounds(&inputs, uncertainty, size, r, e, trig)
            .ok()?;
        kinema_runtime::precision::levers(jac, equations.entry_row, lever);
        kinema_runtime::precision::worst(&e[..m], lever, equations.equation, q, size)
    }

    /// Whether equation `i` of Φ reads t (see
    /// [`System::equation_reads_time`](kinema_runtime::System::equation_reads_time)).
    pub(crate) fn reads_time(&self, i: usize) -> bool {
        self.timed
            .as_deref()
            .is_some_and(|timed| timed.equations.binary_search(&i).is_ok())
    }

    /// Φ's error bounds on its tape (see
    /// [`System::phi_error_bounds`](kinema_runtime::System::phi_error_bounds)),
    /// in the scratch after the kink checks' part.
    pub(crate) fn phi_bounds(
        &self,
        scratch: &mut Vec<f64>,
        (q, t, uncertainty): (&[f64], f64, f64),
        size: f64,
        errors: &mut [f64],
    ) -> bool {
        let registers = self.phi.registers();
        let base = self.kink_base() + self.kink_len();
        let need = base + 2 * registers;
        if errors.len() != self.phi.outputs() {
            return false;
        }
        if scratch.len() < need {
            grow(scratch, need);
        }
        let (start, rest) = scratch.split_at_mut(base);
        let trig = &mut start[..self.trig_len()];
        let (r, rest) = rest.split_at_mut(registers);
        let e = &mut rest[..registers];
        let inputs = self.inputs(q, &self.zeros, t);
        if self
            .phi
            .error_bounds(&inputs, uncertainty, size, r, e, trig)
            .is_err()
        {
            return false;
        }
        errors.copy_from_slice(&e[..errors.len()]);
        true
    }
}
