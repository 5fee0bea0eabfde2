//! The factorization compiled: the copy of the run-time entries, the
//! operations and the scan, as one straight-line function
//! ([`emit_factor`]), or for a large plan in chunks (`chunks`) after a
//! looped prologue (`prologue`).

mod chunks;
mod prologue;

use cranelift_codegen::ir::{
    AbiParam, BlockArg, InstBuilder, MemFlagsData, Value, condcodes::IntCC, types::F64, types::I64,
};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_module::Module;
use kinema_runtime::linalg::{CompiledFactor, FoldedFactor, Op, RawScan};

use super::{
    LOOPED_ENTRIES, LU_CHUNK, MAX_SOLVE_OPERATIONS, SCAN_FINITE, SCAN_MAX_MULTIPLIER,
    SCAN_MIN_PIVOT, SCAN_NEGATIVE, SCAN_SAME, SCAN_SCALE, bits_of, calls, define, offset,
};
use crate::JitError;
use crate::code::{Code, FactorFn, FactorNeeds, SCAN};

use chunks::FactorChunks;
use prologue::Prologue;

/// A folded LU's factorization compiled to native code (see
/// [`compile_factor`]).
#[derive(Clone)]
pub struct JitFactor {
    f: FactorFn,
    /// For a factorization of more than [`LOOPED_ENTRIES`] entries: the
    /// constants' check and the run-time entries' copy, run as loops here
    /// before `f`.
    prologue: Option<Prologue>,
}
impl std::fmt::Debug for JitFactor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("JitFactor")
    }
}

impl CompiledFactor for JitFactor {
    #[inline]
    fn factor(&self, values: &[f64], v: &mut [f64], check: bool, scan: &mut RawScan) -> bool {
        match &self.prologue {
            None => self.f.call(values, v, scan, check),
            Some(p) => self.factor_after(p, values, v, check, scan),
        }
    }
}

impl JitFactor {
    /// [`CompiledFactor::factor`] of a large factorization: the prologue,
    /// then the compiled part. Out of line: the small systems' call, which
    /// has no prologue, then needs no saved registers.
    #[inline(never)]
    fn factor_after(
        &self,
        prologue: &Prologue,
        values: &[f64],
        v: &mut [f64],
        check: bool,
        scan: &mut RawScan,
    ) -> bool {
        if !self.f.fits(values, v) {
            return false;
        }
        prologue.run(values, v, check, scan);
        self.f.call(values, v, scan, check)
    }
}

/// Compiles a planned folded LU's factorization: the copy of the run-time
/// entries, the operations, and the scan (scale and finiteness as integer
/// maxima of the run-time entries' magnitude bits from the constants', the
/// constants' check bit for bit, the run-time pivots' sign parity, the
/// pivots' and multipliers' folds in the interpreter's order), so the
/// acceptance test and the pivot report see the interpreter's numbers.
///
/// # Errors
/// As [`compile_solves`].
///
/// [`compile_solves`]: super::compile_solves
pub fn compile_factor(plan: &FoldedFactor<'_>) -> Result<JitFactor, JitError> {
    compile_factor_chunked(plan, LU_CHUNK, LOOPED_ENTRIES)
}

/// [`compile_factor`] with a factorization of more than `chunk` items
/// (constants, entries copied, entries folded, operations) compiled in
/// chunks of at most `chunk` (at least 1), its entries looped above
/// `looped` of them (instead of [`LOOPED_ENTRIES`]): for tests, which force
/// small chunks and both forms. Not a stable interface.
///
/// # Errors
/// As [`compile_factor`].
#[doc(hidden)]
pub fn compile_factor_chunked(
    plan: &FoldedFactor<'_>,
    chunk: usize,
    looped: usize,
) -> Result<JitFactor, JitError> {
    let size = plan.ops.len() + plan.nnz;
    if size > MAX_SOLVE_OPERATIONS {
        return Err(JitError::TooLarge { instructions: size });
    }
    let chunk = chunk.max(1);
    let mut module = crate::tape::new_module()?;
    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    let needs = FactorNeeds {
        values: plan.nnz,
        v: plan.values,
    };
    let ptr = module.target_config().pointer_type();
    let mut sig = module.make_signature();
    for _ in 0..3 {
        sig.params.push(AbiParam::new(ptr));
    }
    // Whether to check the constants (0: no).
    sig.params.push(AbiParam::new(I64));
    let looped = plan.constants.len() + plan.inputs.len() > looped;
    let mut chunks = FactorChunks::new(plan, needs, looped)?;
    let id = if !looped && chunks.total <= chunk {
        define(&mut module, &mut ctx, &mut fctx, &sig, "factor", |b, _| {
            emit_factor(b, plan, needs)
        })?
    } else {
        // A looped factorization compiles the operations (at least one
        // function, which writes the scan's final values).
        let from = if looped { chunks.operations_at() } else { 0 };
        let total = chunks.total;
        let mut ranges: Vec<_> = (from..total)
            .step_by(chunk)
            .map(|s| s..(s + chunk).min(total))
            .collect();
        if ranges.is_empty() {
            ranges.push(total..total);
        }
        if let [range] = &ranges[..] {
            define(&mut module, &mut ctx, &mut fctx, &sig, "factor", |b, _| {
                chunks.emit(b, range.clone())
            })?
        } else {
            let mut parts = Vec::with_capacity(ranges.len());
            for (c, range) in ranges.iter().enumerate() {
                parts.push(define(
                    &mut module,
                    &mut ctx,
                    &mut fctx,
                    &sig,
                    &format!("factor_{c}"),
                    |b, _| chunks.emit(b, range.clone()),
                )?);
            }
            define(
                &mut module,
                &mut ctx,
                &mut fctx,
                &sig,
                "factor",
                |b, module| calls(b, module, &parts),
            )?
        }
    };
    let prologue = if looped {
        Some(Prologue::new(plan, needs)?)
    } else {
        None
    };
    module
        .finalize_definitions()
        .map_err(|e| JitError::Compile(e.to_string()))?;
    let code = Code::new(module);
    Ok(JitFactor {
        f: FactorFn::new(&code, id, needs)?,
        prologue,
    })
}
/// The factorization's body; every index checked against `needs`.
/// `diff` ORed with the differences between the bits of `constants`'
/// entries in `values` (read as integers, straight from memory) and their
/// planned bits, if `checking` (an I64 argument) is not zero; else `diff`:
/// the constants' check, done only when the caller asks for it.
fn constants_check(
    b: &mut FunctionBuilder<'_>,
    checking: Value,
    diff: Value,
    constants: &[(u32, f64)],
    values: Value,
    needs: FactorNeeds,
) -> Result<Value, JitError> {
    if constants.is_empty() {
        return Ok(diff);
    }
    let (checked, joined) = (b.create_block(), b.create_block());
    b.append_block_param(joined, I64);
    b.ins()
        .brif(checking, checked, &[], joined, &[BlockArg::Value(diff)]);
    b.switch_to_block(checked);
    let read = MemFlagsData::trusted().with_readonly();
    let mut diff = diff;
    for &(k, c) in constants {
        let k = k as usize;
        if k >= needs.values {
            return Err(JitError::Compile(format!(
                "Jacobian value index {k} beyond {}",
                needs.values
            )));
        }
        let x = b.ins().load(I64, read, values, offset(k)?);
        let c = b.ins().iconst(I64, bits_of(c));
        let d = b.ins().bxor(x, c);
        diff = b.ins().bor(diff, d);
    }
    b.ins().jump(joined, &[BlockArg::Value(diff)]);
    b.switch_to_block(joined);
    Ok(b.block_params(joined)[0])
}

/// A straight-line factorization stores each running fold (scale, pivots,
/// multipliers) every this many entries: the store pins the fold's
/// computation there, so the values it reads die early (pure instructions
/// are otherwise placed at their use, keeping every load alive to the
/// end), and a small factorization stores only the final values.
const PIN: usize = 8;

fn emit_factor(
    b: &mut FunctionBuilder<'_>,
    plan: &FoldedFactor<'_>,
    needs: FactorNeeds,
) -> Result<(), JitError> {
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
    // The Jacobian's values, loaded once each.
    let mut loaded: Vec<Option<Value>> = vec![None; needs.values];
    let mut load = |b: &mut FunctionBuilder<'_>, k: usize| -> Result<Value, JitError> {
        let k = check(k, needs.values, "Jacobian value")?;
        if let Some(x) = loaded[k] {
            return Ok(x);
        }
        let x = b.ins().load(F64, read, values, offset(k)?);
        loaded[k] = Some(x);
        Ok(x)
    };
    // Each final entry of the scan is stored as soon as it is known, each
    // running one every [`PIN`] entries.
    let put = |b: &mut FunctionBuilder<'_>, k: usize, x: Value| -> Result<(), JitError> {
        b.ins()
            .store(flags, x, scan, offset(check(k, SCAN, "scan")?)?);
        Ok(())
    };
    // A running integer value into entry k (overwritten by the final one).
    let (one, zero) = (b.ins().f64const(1.0), b.ins().f64const(0.0));
    let none = b.ins().iconst(I64, 0);
    let diff = constants_check(b, checking, none, plan.constants, values, needs)?;
    let same = b.ins().icmp_imm_s(IntCC::Equal, diff, 0);
    let same = b.ins().select(same, one, zero);
    put(b, SCAN_SAME, same)?;
    // Scale and finiteness: the largest magnitude's bits (integer order is
    // the order of |x|) over the run-time entries, from the constants'.
    // Each input is copied to the value array as it is loaded, and the
    // running maximum stored (raw bits) every [`PIN`] entries to pin it
    // there.
    let abs_mask = b.ins().iconst(I64, i64::MAX);
    let inf_bits = b.ins().iconst(I64, bits_of(f64::INFINITY));
    let mut max_bits = b.ins().iconst(I64, bits_of(plan.const_scale.abs()));
    let mut v: Vec<Value> = Vec::with_capacity(needs.v);
    for &k in plan.inputs {
        let x = load(b, k as usize)?;
        b.ins().store(flags, x, v_ptr, offset(v.len())?);
        v.push(x);
        let bits = b.ins().bitcast(I64, MemFlagsData::new(), x);
        let bits = b.ins().band(bits, abs_mask);
        max_bits = b.ins().umax(max_bits, bits);
        if v.len().is_multiple_of(PIN) {
            put(b, SCAN_SCALE, max_bits)?;
        }
    }
    let scale = b.ins().bitcast(F64, MemFlagsData::new(), max_bits);
    put(b, SCAN_SCALE, scale)?;
    let finite = b.ins().icmp(IntCC::UnsignedLessThan, max_bits, inf_bits);
    let finite = b.ins().select(finite, one, zero);
    put(b, SCAN_FINITE, finite)?;
    // The folds over the run-time pivots and multipliers, on magnitude bits
    // (order-free, so each value is folded as it is made, its running
    // result stored to pin it): the smallest pivot with a NaN as zero, the
    // largest multiplier with a NaN above every number (made ∞ at the end),
    // and the pivots' sign bits XORed.
    let mut role = vec![(false, false); needs.v];
    for &p in plan.pivot_vars {
        let r = role
            .get_mut(p as usize)
            .ok_or_else(|| JitError::Compile(format!("pivot {p} beyond the values")))?;
        r.0 = true;
    }
    for &l in plan.multiplier_vars {
        let r = role
            .get_mut(l as usize)
            .ok_or_else(|| JitError::Compile(format!("multiplier {l} beyond the values")))?;
        r.1 = true;
    }
    let zero_bits = b.ins().iconst(I64, 0);
    let mut min_bits = b.ins().iconst(I64, bits_of(plan.const_min_pivot.abs()));
    let mut signs = zero_bits;
    let mut mult_bits = b
        .ins()
        .iconst(I64, bits_of(plan.const_max_multiplier.abs()));
    let (mut pivots, mut multipliers) = (0usize, 0usize);
    let mut fold = |b: &mut FunctionBuilder<'_>, k: usize, x: Value| -> Result<(), JitError> {
        let (pivot, multiplier) = role[k];
        if !(pivot || multiplier) {
            return Ok(());
        }
        let bits = b.ins().bitcast(I64, MemFlagsData::new(), x);
        let magnitude = b.ins().band(bits, abs_mask);
        if pivot {
            signs = b.ins().bxor(signs, bits);
            let nan = b
                .ins()
                .icmp(IntCC::UnsignedGreaterThan, magnitude, inf_bits);
            let counted = b.ins().select(nan, zero_bits, magnitude);
            min_bits = b.ins().umin(min_bits, counted);
            pivots += 1;
            if pivots.is_multiple_of(PIN) {
                put(b, SCAN_NEGATIVE, signs)?;
                put(b, SCAN_MIN_PIVOT, min_bits)?;
            }
        }
        if multiplier {
            mult_bits = b.ins().umax(mult_bits, magnitude);
            multipliers += 1;
            if multipliers.is_multiple_of(PIN) {
                put(b, SCAN_MAX_MULTIPLIER, mult_bits)?;
            }
        }
        Ok(())
    };
    for (k, &x) in v.iter().enumerate() {
        fold(b, k, x)?;
    }
    let get = |v: &[Value], a: u32| -> Result<Value, JitError> {
        v.get(a as usize)
            .copied()
            .ok_or_else(|| JitError::Compile(format!("value {a} read before it is written")))
    };
    // The operations, each result stored and folded as it is made.
    for op in plan.ops {
        let x = match *op {
            Op::Recip(a) => {
                let a = get(&v, a)?;
                b.ins().fdiv(one, a)
            }
            Op::Neg(a) => b.ins().fneg(get(&v, a)?),
            Op::Scale(c, a) => {
                let c = b.ins().f64const(c);
                b.ins().fmul(c, get(&v, a)?)
            }
            Op::Mul(a, c) => {
                let (a, c) = (get(&v, a)?, get(&v, c)?);
                b.ins().fmul(a, c)
            }
            Op::SubConst(a, c) => {
                let c = b.ins().f64const(c);
                b.ins().fsub(get(&v, a)?, c)
            }
            Op::Sub(o, a) => {
                let (o, a) = (get(&v, o)?, get(&v, a)?);
                b.ins().fsub(o, a)
            }
            Op::Add(o, a) => {
                let (o, a) = (get(&v, o)?, get(&v, a)?);
                b.ins().fadd(o, a)
            }
            Op::SubScaled(o, c, a) => {
                let c = b.ins().f64const(c);
                let p = b.ins().fmul(c, get(&v, a)?);
                b.ins().fsub(get(&v, o)?, p)
            }
            Op::SubMul(o, a, c) => {
                let (a, c) = (get(&v, a)?, get(&v, c)?);
                let p = b.ins().fmul(a, c);
                b.ins().fsub(get(&v, o)?, p)
            }
            Op::ConstSubScaled(o, c, a) => {
                let c = b.ins().f64const(c);
                let p = b.ins().fmul(c, get(&v, a)?);
                let o = b.ins().f64const(o);
                b.ins().fsub(o, p)
            }
            Op::ConstSubMul(o, a, c) => {
                let (a, c) = (get(&v, a)?, get(&v, c)?);
                let p = b.ins().fmul(a, c);
                let o = b.ins().f64const(o);
                b.ins().fsub(o, p)
            }
        };
        let k = v.len();
        b.ins().store(flags, x, v_ptr, offset(k)?);
        v.push(x);
        fold(b, k, x)?;
    }
    if v.len() != needs.v {
        return Err(JitError::Compile("value array of another length".into()));
    }
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
    b.ins().return_(&[]);
    Ok(())
}
