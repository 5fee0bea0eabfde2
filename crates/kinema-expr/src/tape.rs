//! Tapes: outputs compiled to a flat instruction list over registers.
//!
//! A tape is built once from a [`Schedule`] and then evaluated any number of
//! times with no allocation: the caller owns the register file. Registers are
//! reused once a value is dead, so the register file stays small. Arithmetic
//! follows the order documented in [`crate::eval`], so a tape and the tree
//! evaluator agree bit for bit.

use crate::arena::Arena;
use crate::build::is_int;
use crate::eval::{accumulate, scaled};
use crate::node::{ExprId, NodeRef, SymKind, UnaryOp};

/// Where a tape reads its inputs from.
#[derive(Clone, Copy, Debug)]
pub struct TapeInputs<'a> {
    /// Generalized coordinates `q`, indexed by [`SymKind::Coordinate`].
    pub q: &'a [f64],
    /// Velocities `q̇`, indexed by [`SymKind::Velocity`].
    pub qd: &'a [f64],
    /// Parameters, indexed by [`SymKind::Parameter`].
    pub params: &'a [f64],
    /// Time.
    pub t: f64,
}

/// Why a tape could not be evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TapeError {
    /// An input or output slice is shorter than the tape needs.
    ShortSlice {
        /// Which slice: `"q"`, `"qd"`, `"params"`, `"registers"` or `"outputs"`.
        which: &'static str,
        /// Length the tape needs.
        needed: usize,
        /// Length given.
        given: usize,
    },
}

impl std::fmt::Display for TapeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TapeError::ShortSlice {
                which,
                needed,
                given,
            } => write!(f, "tape needs {needed} values in `{which}`, got {given}"),
        }
    }
}

impl std::error::Error for TapeError {}

type Reg = u32;

#[derive(Clone, Copy, Debug)]
enum Instr {
    Const { dst: Reg, v: f64 },
    Q { dst: Reg, i: u32 },
    Qd { dst: Reg, i: u32 },
    P { dst: Reg, i: u32 },
    T { dst: Reg },
    Copy { dst: Reg, a: Reg },
    Scale { dst: Reg, a: Reg, k: f64 },
    Acc { dst: Reg, acc: Reg, a: Reg, k: f64 },
    AddConst { dst: Reg, a: Reg, c: f64 },
    Mul { dst: Reg, a: Reg, b: Reg },
    Div { dst: Reg, a: Reg, b: Reg },
    Recip { dst: Reg, a: Reg },
    Square { dst: Reg, a: Reg },
    Sqrt { dst: Reg, a: Reg },
    PowI { dst: Reg, a: Reg, n: i32 },
    PowF { dst: Reg, a: Reg, p: f64 },
    Unary { dst: Reg, op: UnaryOp, a: Reg },
    Pow { dst: Reg, a: Reg, b: Reg },
    Atan2 { dst: Reg, y: Reg, x: Reg },
    Store { out: u32, a: Reg },
}

/// A compiled list of instructions computing a vector of outputs.
#[derive(Clone, Debug)]
pub struct Tape {
    instrs: Vec<Instr>,
    registers: usize,
    outputs: usize,
    need_q: usize,
    need_qd: usize,
    need_params: usize,
}

/// Register allocation: a free list over a growing register file.
struct Regs {
    free: Vec<Reg>,
    count: u32,
}

impl Regs {
    fn take(&mut self) -> Reg {
        self.free.pop().unwrap_or_else(|| {
            self.count += 1;
            self.count - 1
        })
    }
}

impl Tape {
    /// Compiles `outputs` of `arena` into a tape. Output `k` of
    /// [`eval`](Self::eval) is the value of `outputs[k]`.
    #[must_use]
    pub fn compile(arena: &Arena, outputs: &[ExprId]) -> Tape {
        let schedule = arena.schedule(outputs);
        let nodes = schedule.nodes();
        let mut reg_of: Vec<Reg> = vec![0; nodes.len()];
        let mut regs = Regs {
            free: Vec::new(),
            count: 0,
        };
        let mut stores: Vec<Vec<u32>> = vec![Vec::new(); nodes.len()];
        for (k, o) in outputs.iter().enumerate() {
            if let Some(p) = schedule.position(*o) {
                stores[p].push(k as u32);
            }
        }
        let mut tape = Tape {
            instrs: Vec::with_capacity(nodes.len() * 2),
            registers: 0,
            outputs: outputs.len(),
            need_q: 0,
            need_qd: 0,
            need_params: 0,
        };
        let mut kids: Vec<ExprId> = Vec::new();
        for (i, &n) in nodes.iter().enumerate() {
            let reg = |e: ExprId| -> Reg { schedule.position(e).map_or(0, |p| reg_of[p]) };
            // The destination is taken before any operand is freed, so it never
            // aliases a live operand.
            let dst = regs.take();
            tape.node(arena, n, dst, &reg, &mut regs);
            reg_of[i] = dst;
            for &out in &stores[i] {
                tape.instrs.push(Instr::Store { out, a: dst });
            }
            // Free operands whose last use is this node, then this node if unused.
            kids.clear();
            arena.children(n, &mut kids);
            kids.sort_unstable();
            kids.dedup();
            for c in &kids {
                if let Some(p) = schedule.position(*c)
                    && schedule.last_use()[p] as usize == i
                {
                    regs.free.push(reg_of[p]);
                }
            }
            if schedule.parent_uses()[i] == 0 {
                regs.free.push(dst);
            }
        }
        tape.registers = regs.count as usize;
        tape
    }

    /// Emits the instructions of node `n` into `dst`.
    fn node(
        &mut self,
        arena: &Arena,
        n: ExprId,
        dst: Reg,
        reg: &dyn Fn(ExprId) -> Reg,
        regs: &mut Regs,
    ) {
        match arena.node(n) {
            NodeRef::Num(v) => self.instrs.push(Instr::Const { dst, v }),
            NodeRef::Sym(s) => {
                let instr = match arena.symbol(s).kind {
                    SymKind::Coordinate(i) => {
                        self.need_q = self.need_q.max(i as usize + 1);
                        Instr::Q { dst, i }
                    }
                    SymKind::Velocity(i) => {
                        self.need_qd = self.need_qd.max(i as usize + 1);
                        Instr::Qd { dst, i }
                    }
                    SymKind::Parameter(i) => {
                        self.need_params = self.need_params.max(i as usize + 1);
                        Instr::P { dst, i }
                    }
                    SymKind::Time => Instr::T { dst },
                };
                self.instrs.push(instr);
            }
            NodeRef::Add { constant, terms } => {
                let first = terms[0];
                let mut acc = reg(first.expr);
                if first.coeff != 1.0 {
                    self.instrs.push(Instr::Scale {
                        dst,
                        a: acc,
                        k: first.coeff,
                    });
                    acc = dst;
                }
                for t in &terms[1..] {
                    self.instrs.push(Instr::Acc {
                        dst,
                        acc,
                        a: reg(t.expr),
                        k: t.coeff,
                    });
                    acc = dst;
                }
                if constant != 0.0 {
                    self.instrs.push(Instr::AddConst {
                        dst,
                        a: acc,
                        c: constant,
                    });
                    acc = dst;
                }
                if acc != dst {
                    self.instrs.push(Instr::Copy { dst, a: acc });
                }
            }
            NodeRef::Mul { coeff, factors } => {
                // Numerator into dst, denominator into a scratch register.
                let mut num: Option<Reg> = None;
                let mut den: Option<Reg> = None;
                let mut den_reg: Option<Reg> = None;
                let mut tmp: Option<Reg> = None;
                for f in factors {
                    let base = reg(f.base);
                    let into_num = f.exp > 0.0;
                    let p = f.exp.abs();
                    let cur = if into_num { num } else { den };
                    let target = if into_num {
                        dst
                    } else {
                        *den_reg.get_or_insert_with(|| regs.take())
                    };
                    let value = if p == 1.0 {
                        base
                    } else {
                        // The power goes straight into the target when it is the
                        // first factor, else into a temporary.
                        let into = if cur.is_none() {
                            target
                        } else {
                            *tmp.get_or_insert_with(|| regs.take())
                        };
                        self.instrs.push(power(into, base, p));
                        into
                    };
                    let next = match cur {
                        None => value,
                        Some(c) => {
                            self.instrs.push(Instr::Mul {
                                dst: target,
                                a: c,
                                b: value,
                            });
                            target
                        }
                    };
                    if into_num {
                        num = Some(next);
                    } else {
                        den = Some(next);
                    }
                }
                let r = match (num, den) {
                    (Some(a), None) => a,
                    (Some(a), Some(b)) => {
                        self.instrs.push(Instr::Div { dst, a, b });
                        dst
                    }
                    (None, Some(b)) => {
                        self.instrs.push(Instr::Recip { dst, a: b });
                        dst
                    }
                    (None, None) => {
                        self.instrs.push(Instr::Const { dst, v: 1.0 });
                        dst
                    }
                };
                if coeff != 1.0 {
                    self.instrs.push(Instr::Scale {
                        dst,
                        a: r,
                        k: coeff,
                    });
                } else if r != dst {
                    self.instrs.push(Instr::Copy { dst, a: r });
                }
                regs.free.extend(den_reg);
                regs.free.extend(tmp);
            }
            NodeRef::Unary(op, a) => self.instrs.push(Instr::Unary { dst, op, a: reg(a) }),
            NodeRef::Pow(a, b) => self.instrs.push(Instr::Pow {
                dst,
                a: reg(a),
                b: reg(b),
            }),
            NodeRef::Atan2(y, x) => self.instrs.push(Instr::Atan2 {
                dst,
                y: reg(y),
                x: reg(x),
            }),
        }
    }

    /// Number of registers [`eval`](Self::eval) needs.
    #[must_use]
    pub fn registers(&self) -> usize {
        self.registers
    }

    /// Number of outputs.
    #[must_use]
    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// Number of instructions.
    #[must_use]
    pub fn len(&self) -> usize {
        self.instrs.len()
    }

    /// Whether the tape has no instructions.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.instrs.is_empty()
    }

    /// Length each input slice must have at least: `(q, qd, params)`.
    #[must_use]
    pub fn input_sizes(&self) -> (usize, usize, usize) {
        (self.need_q, self.need_qd, self.need_params)
    }

    /// Evaluates the tape: `out[k]` becomes the value of output `k`.
    /// `registers` is scratch space of at least [`registers`](Self::registers)
    /// values. Does not allocate.
    ///
    /// # Errors
    /// [`TapeError::ShortSlice`] if any slice is shorter than the tape needs
    /// (checked once, before anything is computed).
    pub fn eval(
        &self,
        inputs: &TapeInputs<'_>,
        registers: &mut [f64],
        out: &mut [f64],
    ) -> Result<(), TapeError> {
        check("q", self.need_q, inputs.q.len())?;
        check("qd", self.need_qd, inputs.qd.len())?;
        check("params", self.need_params, inputs.params.len())?;
        check("registers", self.registers, registers.len())?;
        check("outputs", self.outputs, out.len())?;
        let r = registers;
        for ins in &self.instrs {
            match *ins {
                Instr::Const { dst, v } => r[dst as usize] = v,
                Instr::Q { dst, i } => r[dst as usize] = inputs.q[i as usize],
                Instr::Qd { dst, i } => r[dst as usize] = inputs.qd[i as usize],
                Instr::P { dst, i } => r[dst as usize] = inputs.params[i as usize],
                Instr::T { dst } => r[dst as usize] = inputs.t,
                Instr::Copy { dst, a } => r[dst as usize] = r[a as usize],
                Instr::Scale { dst, a, k } => r[dst as usize] = scaled(k, r[a as usize]),
                Instr::Acc { dst, acc, a, k } => {
                    r[dst as usize] = accumulate(r[acc as usize], k, r[a as usize]);
                }
                Instr::AddConst { dst, a, c } => r[dst as usize] = r[a as usize] + c,
                Instr::Mul { dst, a, b } => r[dst as usize] = r[a as usize] * r[b as usize],
                Instr::Div { dst, a, b } => r[dst as usize] = r[a as usize] / r[b as usize],
                Instr::Recip { dst, a } => r[dst as usize] = 1.0 / r[a as usize],
                Instr::Square { dst, a } => {
                    let x = r[a as usize];
                    r[dst as usize] = x * x;
                }
                Instr::Sqrt { dst, a } => r[dst as usize] = r[a as usize].sqrt(),
                Instr::PowI { dst, a, n } => r[dst as usize] = r[a as usize].powi(n),
                Instr::PowF { dst, a, p } => r[dst as usize] = r[a as usize].powf(p),
                Instr::Unary { dst, op, a } => r[dst as usize] = op.apply(r[a as usize]),
                Instr::Pow { dst, a, b } => r[dst as usize] = r[a as usize].powf(r[b as usize]),
                Instr::Atan2 { dst, y, x } => r[dst as usize] = r[y as usize].atan2(r[x as usize]),
                Instr::Store { out: k, a } => out[k as usize] = r[a as usize],
            }
        }
        Ok(())
    }
}

fn check(which: &'static str, needed: usize, given: usize) -> Result<(), TapeError> {
    if given < needed {
        Err(TapeError::ShortSlice {
            which,
            needed,
            given,
        })
    } else {
        Ok(())
    }
}

/// `dst = a^p` for `p > 0`, `p ≠ 1`, as [`crate::build::powv`] computes it.
fn power(dst: Reg, a: Reg, p: f64) -> Instr {
    if p == 2.0 {
        Instr::Square { dst, a }
    } else if p == 0.5 {
        Instr::Sqrt { dst, a }
    } else if is_int(p) {
        Instr::PowI {
            dst,
            a,
            n: p as i32,
        }
    } else {
        Instr::PowF { dst, a, p }
    }
}
