//! A factorization compiled in chunks ([`FactorChunks`]): its items
//! numbered, each chunk a function reading the earlier values and the
//! running folds from memory.

use cranelift_codegen::ir::{
    InstBuilder, MemFlagsData, Value, condcodes::IntCC, types::F64, types::I64,
};
use cranelift_frontend::FunctionBuilder;
use kinema_runtime::linalg::{FoldedFactor, Op};

use super::super::{
    SCAN_FINITE, SCAN_MAX_MULTIPLIER, SCAN_MIN_PIVOT, SCAN_NEGATIVE, SCAN_SAME, SCAN_SCALE, WINDOW,
    bits_of, offset,
};
use super::constants_check;
use crate::JitError;
use crate::code::{FactorNeeds, SCAN};

/// A factorization compiled in chunks: the items of [`emit_factor`] in its
/// order (the constants' check, the entries copied to the value array,
/// the copied entries folded, the operations), numbered; a chunk reads the
/// values array's earlier entries from memory, and the running folds
/// (raw bits) from the scan, where the chunk before left them.
///
/// [`emit_factor`]: super::emit_factor
pub(super) struct FactorChunks<'p> {
    plan: &'p FoldedFactor<'p>,
    needs: FactorNeeds,
    /// Number of items.
    pub(super) total: usize,
    /// (pivot, multiplier) roles of each value.
    role: Vec<(bool, bool)>,
    /// Whether a [`Prologue`] checks the constants, copies the entries and
    /// folds them (the compiled items then start at
    /// [`FactorChunks::operations_at`]).
    ///
    /// [`Prologue`]: super::Prologue
    looped: bool,
}

impl<'p> FactorChunks<'p> {
    pub(super) fn new(
        plan: &'p FoldedFactor<'p>,
        needs: FactorNeeds,
        looped: bool,
    ) -> Result<FactorChunks<'p>, JitError> {
        let mut role = vec![(false, false); needs.v];
        for &p in plan.pivot_vars {
            role.get_mut(p as usize)
                .ok_or_else(|| JitError::Compile(format!("pivot {p} beyond the values")))?
                .0 = true;
        }
        for &l in plan.multiplier_vars {
            role.get_mut(l as usize)
                .ok_or_else(|| JitError::Compile(format!("multiplier {l} beyond the values")))?
                .1 = true;
        }
        if plan.inputs.len() + plan.ops.len() != needs.v {
            return Err(JitError::Compile("value array of another length".into()));
        }
        let total = plan.constants.len() + 2 * plan.inputs.len() + plan.ops.len();
        Ok(FactorChunks {
            plan,
            needs,
            total,
            role,
            looped,
        })
    }

    /// The first operation's item, after the constants' check, the copies
    /// and their folds.
    pub(super) fn operations_at(&self) -> usize {
        self.plan.constants.len() + 2 * self.plan.inputs.len()
    }

    /// Emits items `range` as one function `(values, v, scan)`.
    #[allow(clippy::too_many_lines)] // one pass over the items, as emit_factor
    pub(super) fn emit(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        range: std::ops::Range<usize>,
    ) -> Result<(), JitError> {
        let plan = self.plan;
        let needs = self.needs;
        let block = b.create_block();
        b.append_block_params_for_function_params(block);
        b.switch_to_block(block);
        let [values, v_ptr, scan, checking] = b.block_params(block)[..] else {
            return Err(JitError::Compile("signature".into()));
        };
        let flags = MemFlagsData::trusted();
        let read = flags.with_readonly();
        let check = |k: usize, len: usize, what: &str| -> Result<usize, JitError> {
            if k < len {
                Ok(k)
            } else {
                Err(JitError::Compile(format!("{what} index {k} beyond {len}")))
            }
        };
        let put = |b: &mut FunctionBuilder<'_>, k: usize, x: Value| -> Result<(), JitError> {
            b.ins()
                .store(flags, x, scan, offset(check(k, SCAN, "scan")?)?);
            Ok(())
        };
        let (nc, ni) = (plan.constants.len(), plan.inputs.len());
        let (same_at, scale_at) = (nc, nc + ni);
        let fold_end = nc + 2 * ni;
        let start = range.start;
        let (one, zero) = (b.ins().f64const(1.0), b.ins().f64const(0.0));
        let abs_mask = b.ins().iconst(I64, i64::MAX);
        let inf_bits = b.ins().iconst(I64, bits_of(f64::INFINITY));
        let zero_bits = b.ins().iconst(I64, 0);
        // The running state: from its start at the first chunk, else from
        // the scan (raw bits) where the chunk before left it.
        let state = |b: &mut FunctionBuilder<'_>, k: usize, init: i64| -> Result<Value, JitError> {
            if start == 0 {
                Ok(b.ins().iconst(I64, init))
            } else {
                Ok(b.ins()
                    .load(I64, flags, scan, offset(check(k, SCAN, "scan")?)?))
            }
        };
        let mut diff = state(b, SCAN_SAME, 0)?;
        let mut max_bits = state(b, SCAN_SCALE, bits_of(plan.const_scale.abs()))?;
        let mut signs = state(b, SCAN_NEGATIVE, 0)?;
        let mut min_bits = state(b, SCAN_MIN_PIVOT, bits_of(plan.const_min_pivot.abs()))?;
        let mut mult_bits = state(
            b,
            SCAN_MAX_MULTIPLIER,
            bits_of(plan.const_max_multiplier.abs()),
        )?;
        // The value array's entries: earlier chunks' from memory.
        // A value's register and the item it was last loaded or computed
        // at: reused within [`WINDOW`] items, else read back (every value
        // is stored), so few values stay live (see [`Resident`]).
        let mut v: Vec<Option<(Value, usize)>> = vec![None; needs.v];
        let mut written =
            start.saturating_sub(nc).min(ni) + start.saturating_sub(fold_end).min(plan.ops.len());
        let get = |b: &mut FunctionBuilder<'_>,
                   v: &mut [Option<(Value, usize)>],
                   (written, at): (usize, usize),
                   a: u32|
         -> Result<Value, JitError> {
            let a = a as usize;
            if a >= written {
                return Err(JitError::Compile(format!(
                    "value {a} read before it is written"
                )));
            }
            if let Some((x, t)) = v[a]
                && at - t <= WINDOW
            {
                return Ok(x);
            }
            let x = b.ins().load(F64, flags, v_ptr, offset(a)?);
            v[a] = Some((x, at));
            Ok(x)
        };
        let role = &self.role;
        let fold = |b: &mut FunctionBuilder<'_>,
                    k: usize,
                    x: Value,
                    signs: &mut Value,
                    min_bits: &mut Value,
                    mult_bits: &mut Value|
         -> Result<(), JitError> {
            let (pivot, multiplier) = role[k];
            if !(pivot || multiplier) {
                return Ok(());
            }
            let bits = b.ins().bitcast(I64, MemFlagsData::new(), x);
            let magnitude = b.ins().band(bits, abs_mask);
            if pivot {
                *signs = b.ins().bxor(*signs, bits);
                put(b, SCAN_NEGATIVE, *signs)?;
                let nan = b
                    .ins()
                    .icmp(IntCC::UnsignedGreaterThan, magnitude, inf_bits);
                let counted = b.ins().select(nan, zero_bits, magnitude);
                *min_bits = b.ins().umin(*min_bits, counted);
                put(b, SCAN_MIN_PIVOT, *min_bits)?;
            }
            if multiplier {
                *mult_bits = b.ins().umax(*mult_bits, magnitude);
                put(b, SCAN_MAX_MULTIPLIER, *mult_bits)?;
            }
            Ok(())
        };
        // This chunk's constants (the first items) checked as one block,
        // if asked for.
        let constants = start.min(nc)..range.end.min(nc);
        if !self.looped {
            diff = constants_check(b, checking, diff, &plan.constants[constants], values, needs)?;
        }
        let last = range.end >= self.total;
        let end = if last { self.total + 1 } else { range.end };
        for p in start.max(nc)..end {
            if p == same_at && !self.looped {
                let same = b.ins().icmp_imm_s(IntCC::Equal, diff, 0);
                let same = b.ins().select(same, one, zero);
                put(b, SCAN_SAME, same)?;
            }
            if p == scale_at && !self.looped {
                let scale = b.ins().bitcast(F64, MemFlagsData::new(), max_bits);
                put(b, SCAN_SCALE, scale)?;
                let finite = b.ins().icmp(IntCC::UnsignedLessThan, max_bits, inf_bits);
                let finite = b.ins().select(finite, one, zero);
                put(b, SCAN_FINITE, finite)?;
            }
            if p >= self.total {
                break;
            }
            if p < scale_at {
                let k = check(plan.inputs[p - nc] as usize, needs.values, "Jacobian value")?;
                let x = b.ins().load(F64, read, values, offset(k)?);
                b.ins().store(flags, x, v_ptr, offset(written)?);
                v[written] = Some((x, p));
                written += 1;
                let bits = b.ins().bitcast(I64, MemFlagsData::new(), x);
                let bits = b.ins().band(bits, abs_mask);
                max_bits = b.ins().umax(max_bits, bits);
                put(b, SCAN_SCALE, max_bits)?;
            } else if p < fold_end {
                let k = p - scale_at;
                let x = get(
                    b,
                    &mut v,
                    (written, p),
                    kinema_index::u32_of(k, "a folded LU's pivot"),
                )?;
                fold(b, k, x, &mut signs, &mut min_bits, &mut mult_bits)?;
            } else {
                let x = match plan.ops[p - fold_end] {
                    Op::Recip(a) => {
                        let a = get(b, &mut v, (written, p), a)?;
                        b.ins().fdiv(one, a)
                    }
                    Op::Neg(a) => {
                        let a = get(b, &mut v, (written, p), a)?;
                        b.ins().fneg(a)
                    }
                    Op::Scale(c, a) => {
                        let c = b.ins().f64const(c);
                        let a = get(b, &mut v, (written, p), a)?;
                        b.ins().fmul(c, a)
                    }
                    Op::Mul(a, c) => {
                        let (a, c) = (
                            get(b, &mut v, (written, p), a)?,
                            get(b, &mut v, (written, p), c)?,
                        );
                        b.ins().fmul(a, c)
                    }
                    Op::SubConst(a, c) => {
                        let c = b.ins().f64const(c);
                        let a = get(b, &mut v, (written, p), a)?;
                        b.ins().fsub(a, c)
                    }
                    Op::Sub(o, a) => {
                        let (o, a) = (
                            get(b, &mut v, (written, p), o)?,
                            get(b, &mut v, (written, p), a)?,
                        );
                        b.ins().fsub(o, a)
                    }
                    Op::Add(o, a) => {
                        let (o, a) = (
                            get(b, &mut v, (written, p), o)?,
                            get(b, &mut v, (written, p), a)?,
                        );
                        b.ins().fadd(o, a)
                    }
                    Op::SubScaled(o, c, a) => {
                        let c = b.ins().f64const(c);
                        let a = get(b, &mut v, (written, p), a)?;
                        let product = b.ins().fmul(c, a);
                        let o = get(b, &mut v, (written, p), o)?;
                        b.ins().fsub(o, product)
                    }
                    Op::SubMul(o, a, c) => {
                        let (a, c) = (
                            get(b, &mut v, (written, p), a)?,
                            get(b, &mut v, (written, p), c)?,
                        );
                        let product = b.ins().fmul(a, c);
                        let o = get(b, &mut v, (written, p), o)?;
                        b.ins().fsub(o, product)
                    }
                    Op::ConstSubScaled(o, c, a) => {
                        let c = b.ins().f64const(c);
                        let a = get(b, &mut v, (written, p), a)?;
                        let product = b.ins().fmul(c, a);
                        let o = b.ins().f64const(o);
                        b.ins().fsub(o, product)
                    }
                    Op::ConstSubMul(o, a, c) => {
                        let (a, c) = (
                            get(b, &mut v, (written, p), a)?,
                            get(b, &mut v, (written, p), c)?,
                        );
                        let product = b.ins().fmul(a, c);
                        let o = b.ins().f64const(o);
                        b.ins().fsub(o, product)
                    }
                };
                let k = written;
                b.ins()
                    .store(flags, x, v_ptr, offset(check(k, needs.v, "value")?)?);
                v[k] = Some((x, p));
                written += 1;
                fold(b, k, x, &mut signs, &mut min_bits, &mut mult_bits)?;
            }
        }
        if last {
            let negative = b.ins().icmp_imm_s(IntCC::SignedLessThan, signs, 0);
            let negative = b.ins().select(negative, one, zero);
            put(b, SCAN_NEGATIVE, negative)?;
            let min_pivot = b.ins().bitcast(F64, MemFlagsData::new(), min_bits);
            put(b, SCAN_MIN_PIVOT, min_pivot)?;
            let nan = b
                .ins()
                .icmp(IntCC::UnsignedGreaterThan, mult_bits, inf_bits);
            let max_multiplier = b.ins().bitcast(F64, MemFlagsData::new(), mult_bits);
            let inf = b.ins().f64const(f64::INFINITY);
            let max_multiplier = b.ins().select(nan, inf, max_multiplier);
            put(b, SCAN_MAX_MULTIPLIER, max_multiplier)?;
        } else {
            // The running state for the next chunk (raw bits; the scan's
            // final values are written by the last chunk).
            if range.end <= same_at {
                put(b, SCAN_SAME, diff)?;
            }
            if range.end <= scale_at {
                put(b, SCAN_SCALE, max_bits)?;
            }
            put(b, SCAN_NEGATIVE, signs)?;
            put(b, SCAN_MIN_PIVOT, min_bits)?;
            put(b, SCAN_MAX_MULTIPLIER, mult_bits)?;
        }
        b.ins().return_(&[]);
        Ok(())
    }
}
