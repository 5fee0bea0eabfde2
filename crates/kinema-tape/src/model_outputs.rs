//! The tape back end's named results: [`Outputs`] for [`TapeSystem`].

use kinema_expr::{ExprId, Tape, TapeInputs};
use kinema_model::Derivation;
use kinema_runtime::{Motion, OutputKink, Outputs};

use crate::model::TapeSystem;

/// One tape evaluating, for every result column, y, ẏ, c (ÿ without its q̈
/// terms) and the nonzeros of y_q; ÿ = c + y_q q̈ is summed after.
#[derive(Clone, Debug)]
pub(crate) struct OutputTape {
    names: Vec<String>,
    tape: Tape,
    /// For each column, its y_q entries as (coordinate index, tape output).
    jacobian: Vec<Vec<(usize, usize)>>,
    /// The values' subexpressions with a function that can be at a kink
    /// (see [`TapeSystem::output_kink`]): the rates' formulas hold the
    /// same functions of the same arguments.
    kinks: Option<crate::kinks::KinkTape>,
}

impl OutputTape {
    pub(crate) fn new(d: &Derivation) -> OutputTape {
        let m = d.outputs.len();
        let mut exprs: Vec<ExprId> = Vec::with_capacity(3 * m);
        exprs.extend(d.outputs.iter().map(|o| o.value));
        exprs.extend(d.outputs.iter().map(|o| o.velocity));
        exprs.extend(d.outputs.iter().map(|o| o.acceleration));
        let mut jacobian = Vec::with_capacity(m);
        for o in &d.outputs {
            let mut row = Vec::with_capacity(o.jacobian.len());
            for &(k, e) in &o.jacobian {
                row.push((k as usize, exprs.len()));
                exprs.push(e);
            }
            jacobian.push(row);
        }
        OutputTape {
            names: d.outputs.iter().map(|o| o.name.clone()).collect(),
            tape: Tape::compile(&d.arena, &exprs),
            jacobian,
            kinks: crate::kinks::KinkTape::new(&d.arena, &exprs[..m]),
        }
    }

    pub(crate) fn registers(&self) -> usize {
        self.tape.registers()
    }

    /// Registers of the kink check (0 without a function that can be at
    /// one).
    pub(crate) fn kink_registers(&self) -> usize {
        self.kinks
            .as_ref()
            .map_or(0, crate::kinks::KinkTape::registers)
    }
}

impl TapeSystem {
    /// The first result column that, at `state`, goes through a function
    /// at a point where it is not differentiable (a distance between two
    /// points that coincide but for roundoff, `atan2(0, 0)`, `acos(±1)`),
    /// within a bound on its argument's error (the state's residual and
    /// roundoff, as [`System::kink`](kinema_runtime::System::kink) for Φ):
    /// its value is right, its rates ẏ and ÿ there are the rounding
    /// errors'. `None` if none is, or the model's results have no such
    /// function. Allocates only the first time (the scratch), and when one
    /// is found.
    pub fn output_kink(
        &self,
        scratch: &mut Vec<f64>,
        state: &kinema_runtime::State,
        size: f64,
    ) -> Option<OutputKink> {
        let kinks = self.outputs.kinks.as_ref()?;
        let inputs = TapeInputs {
            q: state.q(),
            qd: state.qd(),
            params: &self.params,
            t: state.t(),
        };
        let found = self.find_kink(kinks, scratch, &inputs, state.stats().residual, size)?;
        Some(OutputKink {
            column: found.root,
            function: found.function,
        })
    }
}

impl Outputs for TapeSystem {
    /// [`TapeSystem::output_kink`]: the results' kink tape.
    fn output_kink(
        &self,
        scratch: &mut Vec<f64>,
        state: &kinema_runtime::State,
        size: f64,
    ) -> Option<OutputKink> {
        TapeSystem::output_kink(self, scratch, state, size)
    }

    fn output_len(&self) -> usize {
        self.outputs.names.len()
    }

    fn output_name(&self, i: usize) -> &str {
        self.outputs.names.get(i).map_or("", String::as_str)
    }

    fn outputs(&self, registers: &mut Vec<f64>, at: Motion<'_>, out: [&mut [f64]; 3]) {
        let Motion { t, q, qd, qdd } = at;
        let [y, yd, ydd] = out;
        let o = &self.outputs;
        let m = o.names.len();
        let n = kinema_runtime::System::len(self);
        let sizes_ok = [y.len(), yd.len(), ydd.len()].iter().all(|&l| l == m)
            && [q.len(), qd.len(), qdd.len()].iter().all(|&l| l == n);
        let inputs = TapeInputs {
            q,
            qd,
            params: &self.params,
            t,
        };
        let registers = self.registers(registers, &o.tape);
        let values = match o.tape.eval_in_registers(&inputs, registers) {
            Ok(v) if sizes_ok && v.len() >= 3 * m => v,
            _ => {
                for out in [y, yd, ydd] {
                    out.fill(f64::NAN);
                }
                return;
            }
        };
        y.copy_from_slice(&values[..m]);
        yd.copy_from_slice(&values[m..2 * m]);
        for (i, (out, row)) in ydd.iter_mut().zip(&o.jacobian).enumerate() {
            *out = row.iter().fold(values[2 * m + i], |acc, &(k, j)| {
                acc + values.get(j).copied().unwrap_or(f64::NAN) * qdd[k]
            });
        }
    }
}

impl crate::Model {
    /// The index of the coordinate `name` (`"slider.x"`) in q, q̇ and q̈.
    #[must_use]
    pub fn coordinate_index(&self, name: &str) -> Option<usize> {
        self.derivation()
            .coordinates
            .iter()
            .position(|c| c.name == name)
    }

    /// The index of the result column `name` (`"crank.pin.x"`, `"reach"`)
    /// in what [`Outputs::outputs`] writes.
    #[must_use]
    pub fn output_index(&self, name: &str) -> Option<usize> {
        self.derivation()
            .outputs
            .iter()
            .position(|o| o.name == name)
    }
}
