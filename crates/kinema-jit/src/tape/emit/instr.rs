//! One instruction of a tape emitted: its arithmetic, and the sines and
//! cosines through the coordinates' cache, the memo of other values'
//! (see [`compile_split_memo_at`](crate::compile_split_memo_at)) and the
//! shims.

use cranelift_codegen::ir::{
    InstBuilder, MemFlagsData, Value, condcodes::IntCC, types::F64, types::I32, types::I64,
};
use cranelift_frontend::FunctionBuilder;
use kinema_expr::Instr;

use super::{Emitter, offset};
use crate::JitError;
use crate::shims::{self, Which};

impl<'t> Emitter<'t> {
    /// `shim(args)`.
    fn call(&mut self, b: &mut FunctionBuilder<'_>, which: Which, args: &[Value]) -> Value {
        let call = b.ins().call(self.shims[which as usize], args);
        b.inst_results(call)[0]
    }

    /// (sin x, cos x) of a value other than a coordinate: once per value in
    /// this function, and through a memo entry of the cache slice across
    /// calls (see [`compile_split_memo_at`]).
    ///
    /// [`compile_split_memo_at`]: crate::compile_split_memo_at
    fn sin_cos(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        x: Value,
    ) -> Result<(Value, Value), JitError> {
        if let Some(&sc) = self.memo.get(&x) {
            return Ok(sc);
        }
        let at = self.memo_next;
        self.memo_next = at
            .checked_add(3)
            .ok_or_else(|| JitError::Compile("memo too large".into()))?;
        let sc = self.memoized(b, x, at)?;
        self.memo.insert(x, sc);
        Ok(sc)
    }

    /// Brings the cache entry of coordinate `k` (in register `a`) up to
    /// date, as the tape's `cached`: kept when its angle has the bits of
    /// the coordinate, else (sin, cos) computed and stored with it. Once
    /// per function and coordinate.
    pub(super) fn fill(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        a: u32,
        k: u32,
    ) -> Result<(), JitError> {
        if !self.filled.insert(k) {
            return Ok(());
        }
        let x = self.get(b, a)?;
        self.refresh(b, x, 3 * k as usize)?;
        Ok(())
    }

    /// sin (`cos` false) or cos of coordinate `k` (in register `a`), read
    /// from its cache entry once [`fill`](Self::fill)ed.
    fn cached(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        a: u32,
        k: u32,
        cos: bool,
    ) -> Result<Value, JitError> {
        if let Some(&(v, at)) = self.loaded.get(&(k, cos))
            && self.tick.saturating_sub(at) <= self.window
        {
            return Ok(v);
        }
        self.fill(b, a, k)?;
        let trig = self
            .trig
            .ok_or_else(|| JitError::Compile("no cache pointer".into()))?;
        let at = 3 * k as usize + 1 + usize::from(cos);
        let v = b
            .ins()
            .load(F64, MemFlagsData::trusted(), trig, offset(at)?);
        self.loaded.insert((k, cos), (v, self.tick));
        Ok(v)
    }

    /// (sin x, cos x) through the cache entries `at..at + 3` = (x, sin x,
    /// cos x) (see [`refresh`](Self::refresh)).
    fn memoized(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        x: Value,
        at: usize,
    ) -> Result<(Value, Value), JitError> {
        let trig = self.refresh(b, x, at)?;
        let flags = MemFlagsData::trusted();
        let s = b.ins().load(F64, flags, trig, offset(at + 1)?);
        let c = b.ins().load(F64, flags, trig, offset(at + 2)?);
        Ok((s, c))
    }

    /// Brings the cache entries `at..at + 3` = (x, sin x, cos x) up to date
    /// for `x`: kept when the entry's x has the same bits, else x stored
    /// and both computed by one call into the entry (x stored first, so it
    /// is not live across the call). Returns the cache's pointer.
    fn refresh(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        x: Value,
        at: usize,
    ) -> Result<Value, JitError> {
        let trig = self
            .trig
            .ok_or_else(|| JitError::Compile("no cache pointer".into()))?;
        let (o0, o1) = (offset(at)?, offset(at + 1)?);
        let flags = MemFlagsData::trusted();
        let seen = b.ins().load(F64, flags, trig, o0);
        let xi = b.ins().bitcast(I64, MemFlagsData::new(), x);
        let si = b.ins().bitcast(I64, MemFlagsData::new(), seen);
        let hit = b.ins().icmp(IntCC::Equal, xi, si);
        let (miss, join) = (b.create_block(), b.create_block());
        b.ins().brif(hit, join, &[], miss, &[]);
        b.switch_to_block(miss);
        b.ins().store(flags, x, trig, o0);
        let at_sin = b.ins().iadd_imm_s(trig, i64::from(o1));
        b.ins()
            .call(self.shims[Which::SinCos as usize], &[x, at_sin]);
        b.ins().jump(join, &[]);
        b.switch_to_block(join);
        Ok(trig)
    }

    /// Emits one instruction; returns the value it writes.
    pub(super) fn instr(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        ins: Instr,
    ) -> Result<Value, JitError> {
        let (dst, v) = match ins {
            Instr::Const { dst, v } => (dst, b.ins().f64const(v)),
            Instr::Copy { dst, a } => (dst, self.get(b, a)?),
            Instr::Neg { dst, a } => {
                let x = self.get(b, a)?;
                (dst, b.ins().fneg(x))
            }
            Instr::Scale { dst, a, k } => {
                let x = self.get(b, a)?;
                let k = b.ins().f64const(k);
                (dst, b.ins().fmul(k, x))
            }
            Instr::Add { dst, a, b: c } => {
                let (x, y) = (self.get(b, a)?, self.get(b, c)?);
                (dst, b.ins().fadd(x, y))
            }
            Instr::Sub { dst, a, b: c } => {
                let (x, y) = (self.get(b, a)?, self.get(b, c)?);
                (dst, b.ins().fsub(x, y))
            }
            Instr::MulAdd { dst, acc, a, k } => {
                let (x, acc) = (self.get(b, a)?, self.get(b, acc)?);
                let k = b.ins().f64const(k);
                let prod = b.ins().fmul(k, x);
                (dst, b.ins().fadd(acc, prod))
            }
            Instr::AddConst { dst, a, c } => {
                let x = self.get(b, a)?;
                let c = b.ins().f64const(c);
                (dst, b.ins().fadd(x, c))
            }
            Instr::Mul { dst, a, b: c } => {
                let (x, y) = (self.get(b, a)?, self.get(b, c)?);
                (dst, b.ins().fmul(x, y))
            }
            Instr::Div { dst, a, b: c } => {
                let (x, y) = (self.get(b, a)?, self.get(b, c)?);
                (dst, b.ins().fdiv(x, y))
            }
            Instr::Recip { dst, a } => {
                let x = self.get(b, a)?;
                let one = b.ins().f64const(1.0);
                (dst, b.ins().fdiv(one, x))
            }
            Instr::Square { dst, a } => {
                let x = self.get(b, a)?;
                (dst, b.ins().fmul(x, x))
            }
            Instr::Sqrt { dst, a } => {
                let x = self.get(b, a)?;
                (dst, b.ins().sqrt(x))
            }
            Instr::PowI { dst, a, n } => {
                let n = b.ins().iconst(I32, i64::from(n));
                let x = self.get(b, a)?;
                (dst, self.call(b, Which::PowI, &[x, n]))
            }
            Instr::PowF { dst, a, p } => {
                let p = b.ins().f64const(p);
                let x = self.get(b, a)?;
                (dst, self.call(b, Which::PowF, &[x, p]))
            }
            Instr::Sin { dst, a } => {
                let x = self.get(b, a)?;
                (dst, self.sin_cos(b, x)?.0)
            }
            Instr::Cos { dst, a } => {
                let x = self.get(b, a)?;
                (dst, self.sin_cos(b, x)?.1)
            }
            Instr::SinQ { dst, a, k } => (dst, self.cached(b, a, k, false)?),
            Instr::CosQ { dst, a, k } => (dst, self.cached(b, a, k, true)?),
            Instr::Unary { dst, op, a } => {
                let x = self.get(b, a)?;
                let v = match op {
                    kinema_expr::UnaryOp::Abs => b.ins().fabs(x),
                    kinema_expr::UnaryOp::Sin => self.sin_cos(b, x)?.0,
                    kinema_expr::UnaryOp::Cos => self.sin_cos(b, x)?.1,
                    op => {
                        let code = shims::unary_code(op).ok_or_else(|| {
                            JitError::Compile(format!("no compiled form of `{}`", op.name()))
                        })?;
                        let code = b.ins().iconst(I32, i64::from(code));
                        self.call(b, Which::Unary, &[code, x])
                    }
                };
                (dst, v)
            }
            Instr::Pow { dst, a, b: c } => {
                let (x, y) = (self.get(b, a)?, self.get(b, c)?);
                (dst, self.call(b, Which::PowF, &[x, y]))
            }
            Instr::Atan2 { dst, y, x } => {
                let (y, x) = (self.get(b, y)?, self.get(b, x)?);
                (dst, self.call(b, Which::Atan2, &[y, x]))
            }
        };
        self.set(dst as usize, v)?;
        Ok(v)
    }
}
