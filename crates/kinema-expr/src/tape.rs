//! Tapes: outputs compiled to a flat instruction list over registers.
//!
//! A tape is built once from a [`Schedule`] and then evaluated any number of
//! times with no allocation: the caller owns the register file. Outputs,
//! inputs and constants have registers of their own (see [`Tape`]);
//! temporaries are reused once a value is dead. Arithmetic
//! follows the order documented in [`crate::eval`], so a tape and the tree
//! evaluator agree bit for bit.

use crate::arena::Arena;
use crate::build::is_int;
use crate::node::{ExprId, Factor, NodeRef, SymKind, Term, UnaryOp};

mod domain;
mod kink;

pub use domain::{Domain, TapeUndefined};
pub use kink::TapeKink;

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

/// A register of a tape's register file (see [`Tape`]).
pub type Reg = u32;

/// One instruction of a tape, as [`Tape::instructions`] shows it: what a
/// compiler of tapes reads. Registers are indices into the layout of
/// [`Tape`]; arithmetic is IEEE, in the order written, with no fused
/// multiply-add.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Instr {
    /// `dst = v`.
    Const {
        /// Destination register.
        dst: Reg,
        /// The value.
        v: f64,
    },
    /// `dst = a`.
    Copy {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
    },
    /// `dst = -a`.
    Neg {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
    },
    /// `dst = k · a`.
    Scale {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// The factor.
        k: f64,
    },
    /// `dst = a + b`.
    Add {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// Second operand register.
        b: Reg,
    },
    /// `dst = a - b`.
    Sub {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// Second operand register.
        b: Reg,
    },
    /// `dst = acc + k · a` (the product rounded first: no fused multiply-add).
    MulAdd {
        /// Destination register.
        dst: Reg,
        /// The accumulator.
        acc: Reg,
        /// Operand register.
        a: Reg,
        /// The factor.
        k: f64,
    },
    /// `dst = a + c`.
    AddConst {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// The constant.
        c: f64,
    },
    /// `dst = a · b`.
    Mul {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// Second operand register.
        b: Reg,
    },
    /// `dst = a / b`.
    Div {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// Second operand register.
        b: Reg,
    },
    /// `dst = 1 / a`.
    Recip {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
    },
    /// `dst = a · a`.
    Square {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
    },
    /// `dst = √a`.
    Sqrt {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
    },
    /// `dst = a.powi(n)`.
    PowI {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// The integer exponent.
        n: i32,
    },
    /// `dst = a.powf(p)`, `p` a constant.
    PowF {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// The exponent.
        p: f64,
    },
    /// `dst = sin a`.
    Sin {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
    },
    /// `dst = cos a`.
    Cos {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
    },
    /// sin of coordinate `k` (in register `a`), through the caller's cache.
    SinQ {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// The coordinate's index.
        k: u32,
    },
    /// cos of coordinate `k` (in register `a`), through the caller's cache.
    CosQ {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// The coordinate's index.
        k: u32,
    },
    /// `dst = op(a)`.
    Unary {
        /// Destination register.
        dst: Reg,
        /// The function.
        op: UnaryOp,
        /// Operand register.
        a: Reg,
    },
    /// `dst = a.powf(b)`.
    Pow {
        /// Destination register.
        dst: Reg,
        /// Operand register.
        a: Reg,
        /// Second operand register.
        b: Reg,
    },
    /// `dst = y.atan2(x)`.
    Atan2 {
        /// Destination register.
        dst: Reg,
        /// Register of the ordinate.
        y: Reg,
        /// Register of the abscissa.
        x: Reg,
    },
}

impl Instr {
    /// The registers the instruction reads: the first `n` of the array.
    #[must_use]
    pub fn sources(&self) -> ([Reg; 2], usize) {
        match *self {
            Instr::Const { .. } => ([0, 0], 0),
            Instr::Copy { a, .. }
            | Instr::Neg { a, .. }
            | Instr::Scale { a, .. }
            | Instr::AddConst { a, .. }
            | Instr::Recip { a, .. }
            | Instr::Square { a, .. }
            | Instr::Sqrt { a, .. }
            | Instr::PowI { a, .. }
            | Instr::PowF { a, .. }
            | Instr::Sin { a, .. }
            | Instr::Cos { a, .. }
            | Instr::SinQ { a, .. }
            | Instr::CosQ { a, .. }
            | Instr::Unary { a, .. } => ([a, 0], 1),
            Instr::Add { a, b, .. }
            | Instr::Sub { a, b, .. }
            | Instr::Mul { a, b, .. }
            | Instr::Div { a, b, .. }
            | Instr::Pow { a, b, .. } => ([a, b], 2),
            Instr::MulAdd { acc, a, .. } => ([acc, a], 2),
            Instr::Atan2 { y, x, .. } => ([y, x], 2),
        }
    }

    /// The register the instruction writes.
    #[must_use]
    pub fn dst(&self) -> Reg {
        match *self {
            Instr::Const { dst, .. }
            | Instr::Copy { dst, .. }
            | Instr::Neg { dst, .. }
            | Instr::Scale { dst, .. }
            | Instr::Add { dst, .. }
            | Instr::Sub { dst, .. }
            | Instr::MulAdd { dst, .. }
            | Instr::AddConst { dst, .. }
            | Instr::Mul { dst, .. }
            | Instr::Div { dst, .. }
            | Instr::Recip { dst, .. }
            | Instr::Square { dst, .. }
            | Instr::Sqrt { dst, .. }
            | Instr::PowI { dst, .. }
            | Instr::PowF { dst, .. }
            | Instr::Sin { dst, .. }
            | Instr::Cos { dst, .. }
            | Instr::SinQ { dst, .. }
            | Instr::CosQ { dst, .. }
            | Instr::Unary { dst, .. }
            | Instr::Pow { dst, .. }
            | Instr::Atan2 { dst, .. } => dst,
        }
    }
}

/// A compiled list of instructions computing a vector of outputs.
#[derive(Clone, Debug)]
///
/// The register file is laid out as `[outputs | q | q̇ | params | t |
/// constants | temporaries]`: evaluation copies the inputs and constants in,
/// runs the instructions (which compute outputs straight into their
/// registers), and copies the outputs out, so leaves cost no instruction.
pub struct Tape {
    instrs: Vec<Instr>,
    registers: usize,
    outputs: usize,
    need_q: usize,
    need_qd: usize,
    need_params: usize,
    /// Register of `t`, if the tape reads it.
    t_reg: Option<usize>,
    /// Values of the constants' registers, from `consts_base`.
    consts: Vec<f64>,
    consts_base: usize,
}

/// The register file's layout of a [`Tape`] (see [`Tape::layout`]):
/// outputs at `0..outputs`, then `q`, `q̇` and the parameters at their bases
/// (as many as [`Tape::input_sizes`] says), `t`, and the constants.
#[derive(Clone, Copy, Debug)]
pub struct TapeLayout<'a> {
    /// Number of outputs: registers `0..outputs`.
    pub outputs: usize,
    /// Register of `q[0]`.
    pub q_base: usize,
    /// Register of `q̇[0]`.
    pub qd_base: usize,
    /// Register of the first parameter.
    pub params_base: usize,
    /// Register of `t`, if the tape reads it.
    pub t_register: Option<usize>,
    /// Register of the first constant.
    pub consts_base: usize,
    /// The constants' values, from `consts_base` on.
    pub consts: &'a [f64],
}

/// Register allocation: a free list over a growing register file. The
/// registers below `reserved` (outputs, inputs, constants) are never reused.
struct Regs {
    free: Vec<Reg>,
    count: u32,
    reserved: u32,
}

impl Regs {
    fn take(&mut self) -> Reg {
        self.free.pop().unwrap_or_else(|| {
            let r = self.count;
            self.count = r.checked_add(1).expect("a tape's registers fit in u32");
            r
        })
    }

    /// Returns `r` to the pool unless it is reserved.
    fn free(&mut self, r: Reg) {
        if r >= self.reserved {
            self.free.push(r);
        }
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
        // Sizes of the input regions, and the constants.
        let (mut need_q, mut need_qd, mut need_params, mut uses_t) = (0, 0, 0, false);
        let mut consts = Vec::new();
        for &n in nodes {
            match arena.node(n) {
                NodeRef::Sym(s) => match arena.symbol(s).kind {
                    SymKind::Coordinate(i) => need_q = need_q.max(i as usize + 1),
                    SymKind::Velocity(i) => need_qd = need_qd.max(i as usize + 1),
                    SymKind::Parameter(i) => need_params = need_params.max(i as usize + 1),
                    SymKind::Time => uses_t = true,
                },
                NodeRef::Num(v) => consts.push(v),
                _ => {}
            }
        }
        let q_base = outputs.len();
        let qd_base = q_base + need_q;
        let p_base = qd_base + need_qd;
        let t_reg = uses_t.then_some(p_base + need_params);
        let consts_base = p_base + need_params + usize::from(uses_t);
        let reserved = consts_base + consts.len();
        let as_reg = |r: usize| Reg::try_from(r).expect("a tape's registers fit in u32");
        let mut regs = Regs {
            free: Vec::new(),
            count: as_reg(reserved),
            reserved: as_reg(reserved),
        };
        let mut next_const = consts_base;
        let mut stores: Vec<Vec<u32>> = vec![Vec::new(); nodes.len()];
        for (k, o) in outputs.iter().enumerate() {
            if let Some(p) = schedule.position(*o) {
                stores[p].push(as_reg(k));
            }
        }
        let mut tape = Tape {
            instrs: Vec::with_capacity(nodes.len() * 2),
            registers: 0,
            outputs: outputs.len(),
            need_q,
            need_qd,
            need_params,
            t_reg,
            consts,
            consts_base,
        };
        let mut kids: Vec<ExprId> = Vec::new();
        for (i, &n) in nodes.iter().enumerate() {
            let reg = |e: ExprId| -> Reg {
                let p = schedule.position(e);
                reg_of[p.expect("operands are scheduled before their users")]
            };
            // An output is computed straight into its own register; a
            // temporary is taken before any operand is freed, so it never
            // aliases a live operand.
            // A leaf lives in its reserved register and is copied to the
            // outputs it is.
            let leaf = match arena.node(n) {
                NodeRef::Sym(s) => Some(match arena.symbol(s).kind {
                    SymKind::Coordinate(k) => q_base + k as usize,
                    SymKind::Velocity(k) => qd_base + k as usize,
                    SymKind::Parameter(k) => p_base + k as usize,
                    SymKind::Time => t_reg.expect("t has a register when the tape reads it"),
                }),
                NodeRef::Num(_) => {
                    next_const += 1;
                    Some(next_const - 1)
                }
                _ => None,
            };
            let (dst, copies) = match leaf {
                Some(r) => (as_reg(r), &stores[i][..]),
                None => {
                    let dst = stores[i].first().copied().unwrap_or_else(|| regs.take());
                    tape.node(arena, n, dst, &reg, &mut regs);
                    (dst, stores[i].get(1..).unwrap_or(&[]))
                }
            };
            reg_of[i] = dst;
            for &out in copies {
                tape.instrs.push(Instr::Copy { dst: out, a: dst });
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
                    regs.free(reg_of[p]);
                }
            }
            if schedule.parent_uses()[i] == 0 {
                regs.free(dst);
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
            // Leaves live in reserved registers (see `compile`).
            NodeRef::Num(_) | NodeRef::Sym(_) => {}
            NodeRef::Add { constant, terms } => self.sum(dst, constant, terms, reg),
            NodeRef::Mul { coeff, factors } => self.product(dst, coeff, factors, reg, regs),
            NodeRef::Unary(op, x) => {
                let a = reg(x);
                let coordinate = match arena.node(x) {
                    NodeRef::Sym(s) => match arena.symbol(s).kind {
                        SymKind::Coordinate(k) => Some(k),
                        _ => None,
                    },
                    _ => None,
                };
                self.instrs.push(match (op, coordinate) {
                    (UnaryOp::Sin, Some(k)) => Instr::SinQ { dst, a, k },
                    (UnaryOp::Cos, Some(k)) => Instr::CosQ { dst, a, k },
                    (UnaryOp::Sin, None) => Instr::Sin { dst, a },
                    (UnaryOp::Cos, None) => Instr::Cos { dst, a },
                    (op, _) => Instr::Unary { dst, op, a },
                });
            }
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

    /// Emits `dst = constant + Σ coeff · term` (the order of [`crate::eval`]).
    fn sum(&mut self, dst: Reg, constant: f64, terms: &[Term], reg: &dyn Fn(ExprId) -> Reg) {
        let first = terms[0];
        let mut acc = reg(first.expr);
        if first.coeff != 1.0 {
            self.instrs.push(scale(dst, acc, first.coeff));
            acc = dst;
        }
        for t in &terms[1..] {
            self.instrs
                .push(accumulate_into(dst, acc, reg(t.expr), t.coeff));
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

    /// Emits `dst = coeff · Π base^exp`: the numerator into `dst`, the
    /// denominator into a scratch register.
    fn product(
        &mut self,
        dst: Reg,
        coeff: f64,
        factors: &[Factor],
        reg: &dyn Fn(ExprId) -> Reg,
        regs: &mut Regs,
    ) {
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
            self.instrs.push(scale(dst, r, coeff));
        } else if r != dst {
            self.instrs.push(Instr::Copy { dst, a: r });
        }
        for r in den_reg.into_iter().chain(tmp) {
            regs.free(r);
        }
    }

    /// The instructions, in order: a read-only view for compilers of tapes
    /// (kinema-jit). Registers follow [`layout`](Self::layout).
    #[must_use]
    pub fn instructions(&self) -> &[Instr] {
        &self.instrs
    }

    /// Where the outputs, inputs and constants live in the register file.
    #[must_use]
    pub fn layout(&self) -> TapeLayout<'_> {
        let q_base = self.outputs;
        let qd_base = q_base + self.need_q;
        let params_base = qd_base + self.need_qd;
        TapeLayout {
            outputs: self.outputs,
            q_base,
            qd_base,
            params_base,
            t_register: self.t_reg,
            consts_base: self.consts_base,
            consts: &self.consts,
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
        self.eval_with_cache(inputs, registers, &mut [], out)
    }

    /// [`eval`](Self::eval) with a cache of the sines and cosines of the
    /// coordinates, shared by the tapes of one system: `trig[3k..3k + 3]` =
    /// (q_k, sin q_k, cos q_k) of the last q_k seen. An evaluation at an
    /// angle already seen (bit for bit) reuses its sin and cos, so results
    /// do not change; a coordinate beyond `trig` is computed directly. Fill
    /// a new cache with NaN. Does not allocate.
    ///
    /// # Errors
    /// [`TapeError::ShortSlice`] as [`eval`](Self::eval).
    pub fn eval_with_cache(
        &self,
        inputs: &TapeInputs<'_>,
        registers: &mut [f64],
        trig: &mut [f64],
        out: &mut [f64],
    ) -> Result<(), TapeError> {
        self.check_inputs(inputs, registers)?;
        check("outputs", self.outputs, out.len())?;
        self.run(inputs, registers, trig);
        out[..self.outputs].copy_from_slice(&registers[..self.outputs]);
        Ok(())
    }

    /// Evaluates the tape and returns the outputs where it computed them, the
    /// first [`outputs`](Self::outputs) registers: [`eval`](Self::eval)
    /// without the copy, for callers that split the outputs themselves.
    ///
    /// # Errors
    /// [`TapeError::ShortSlice`] as [`eval`](Self::eval).
    pub fn eval_in_registers<'r>(
        &self,
        inputs: &TapeInputs<'_>,
        registers: &'r mut [f64],
    ) -> Result<&'r [f64], TapeError> {
        self.eval_in_registers_with_cache(inputs, registers, &mut [])
    }

    /// [`eval_in_registers`](Self::eval_in_registers) with the cache of
    /// [`eval_with_cache`](Self::eval_with_cache).
    ///
    /// # Errors
    /// [`TapeError::ShortSlice`] as [`eval`](Self::eval).
    pub fn eval_in_registers_with_cache<'r>(
        &self,
        inputs: &TapeInputs<'_>,
        registers: &'r mut [f64],
        trig: &mut [f64],
    ) -> Result<&'r [f64], TapeError> {
        self.check_inputs(inputs, registers)?;
        self.run(inputs, registers, trig);
        Ok(&registers[..self.outputs])
    }

    fn check_inputs(&self, inputs: &TapeInputs<'_>, registers: &[f64]) -> Result<(), TapeError> {
        check("q", self.need_q, inputs.q.len())?;
        check("qd", self.need_qd, inputs.qd.len())?;
        check("params", self.need_params, inputs.params.len())?;
        check("registers", self.registers, registers.len())
    }

    /// Loads the inputs and constants into their registers (slices checked
    /// by the caller); no instruction writes these registers.
    fn load(&self, inputs: &TapeInputs<'_>, r: &mut [f64]) {
        let (q, qd, p) = (
            self.outputs,
            self.outputs + self.need_q,
            self.outputs + self.need_q + self.need_qd,
        );
        r[q..qd].copy_from_slice(&inputs.q[..self.need_q]);
        r[qd..p].copy_from_slice(&inputs.qd[..self.need_qd]);
        r[p..p + self.need_params].copy_from_slice(&inputs.params[..self.need_params]);
        if let Some(t) = self.t_reg {
            r[t] = inputs.t;
        }
        r[self.consts_base..self.consts_base + self.consts.len()].copy_from_slice(&self.consts);
    }

    /// Loads the inputs and constants, then runs the instructions (slices
    /// checked by the caller).
    fn run(&self, inputs: &TapeInputs<'_>, r: &mut [f64], trig: &mut [f64]) {
        self.load(inputs, r);
        for ins in &self.instrs {
            match *ins {
                Instr::Const { dst, v } => r[dst as usize] = v,
                Instr::Copy { dst, a } => r[dst as usize] = r[a as usize],
                Instr::Neg { dst, a } => r[dst as usize] = -r[a as usize],
                Instr::Scale { dst, a, k } => r[dst as usize] = k * r[a as usize],
                Instr::Add { dst, a, b } => r[dst as usize] = r[a as usize] + r[b as usize],
                Instr::Sub { dst, a, b } => r[dst as usize] = r[a as usize] - r[b as usize],
                Instr::MulAdd { dst, acc, a, k } => {
                    r[dst as usize] = r[acc as usize] + k * r[a as usize];
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
                Instr::Sin { dst, a } => r[dst as usize] = r[a as usize].sin(),
                Instr::Cos { dst, a } => r[dst as usize] = r[a as usize].cos(),
                Instr::SinQ { dst, a, k } => {
                    let x = r[a as usize];
                    r[dst as usize] = cached(trig, k, x).map_or_else(|| x.sin(), |c| c.0);
                }
                Instr::CosQ { dst, a, k } => {
                    let x = r[a as usize];
                    r[dst as usize] = cached(trig, k, x).map_or_else(|| x.cos(), |c| c.1);
                }
                Instr::Unary { dst, op, a } => r[dst as usize] = op.apply(r[a as usize]),
                Instr::Pow { dst, a, b } => r[dst as usize] = r[a as usize].powf(r[b as usize]),
                Instr::Atan2 { dst, y, x } => r[dst as usize] = r[y as usize].atan2(r[x as usize]),
            }
        }
    }
}

/// (sin x, cos x) of coordinate k = x through the cache (see
/// [`Tape::eval_with_cache`]); `None` when the cache has no room for k.
#[inline]
fn cached(trig: &mut [f64], k: u32, x: f64) -> Option<(f64, f64)> {
    let at = 3 * k as usize;
    let c = trig.get_mut(at..at + 3)?;
    if c[0].to_bits() != x.to_bits() {
        c[0] = x;
        c[1] = x.sin();
        c[2] = x.cos();
    }
    Some((c[1], c[2]))
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

/// `dst = k a` for `k ≠ 1` (callers skip a unit coefficient), with the
/// special case of `eval::scaled` resolved at compile time, so the tape and the
/// tree evaluator agree bit for bit.
fn scale(dst: Reg, a: Reg, k: f64) -> Instr {
    if k == -1.0 {
        Instr::Neg { dst, a }
    } else {
        Instr::Scale { dst, a, k }
    }
}

/// `dst = acc + k a`, with the special cases of `eval::accumulate` resolved at
/// compile time.
fn accumulate_into(dst: Reg, acc: Reg, a: Reg, k: f64) -> Instr {
    if k == 1.0 {
        Instr::Add { dst, a: acc, b: a }
    } else if k == -1.0 {
        Instr::Sub { dst, a: acc, b: a }
    } else {
        Instr::MulAdd { dst, acc, a, k }
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
