//! A [`FoldedLu`](kinema_runtime::FoldedLu)'s solves to native code: the
//! gather, both sweeps and the scatter of each direction as one
//! straight-line function over SSA values.

use std::collections::HashMap;

use cranelift_codegen::ir::{
    AbiParam, InstBuilder, MemFlagsData, Value, condcodes::IntCC, types::F64, types::I64,
};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_module::{Linkage, Module};
use kinema_runtime::linalg::{
    CompiledFactor, CompiledSolves, FactorScan, FoldedFactor, FoldedSolves, Op, SolveOp,
};

use crate::JitError;
use crate::code::{Code, FactorFn, FactorNeeds, SCAN, SolveFn, SolveNeeds};

/// The most solve operations (both directions; for the factorization, its
/// operations and entries) the JIT compiles; above, they stay interpreted
/// (as [`crate::MAX_INSTRUCTIONS`], for the same reason).
pub const MAX_SOLVE_OPERATIONS: usize = 16_000;

/// The largest dimension whose folded LU the JIT compiles: measured
/// (release, 2 shared cores), the factorization and solves of the chain
/// N = 20 (n = 60) compile in 21 ms, N = 50 (n = 150) in 68 ms, N = 100
/// (n = 300) in 223 ms. Callers check it (the dimension is the system's).
pub const MAX_LU_DIMENSION: usize = 160;

/// A folded LU's solves compiled to native code (see [`compile_solves`]).
#[derive(Clone)]
pub struct JitSolves {
    solve: SolveFn,
    transpose: SolveFn,
}

impl std::fmt::Debug for JitSolves {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("JitSolves")
    }
}

impl CompiledSolves for JitSolves {
    #[inline]
    fn solve(&self, v: &[f64], rhs: &mut [f64], transpose: bool) -> bool {
        if transpose {
            self.transpose.call(v, rhs)
        } else {
            self.solve.call(v, rhs)
        }
    }
}

/// Compiles both solves of a planned folded LU.
///
/// # Errors
/// [`JitError::Host`] if Cranelift cannot target this machine,
/// [`JitError::TooLarge`] above [`MAX_SOLVE_OPERATIONS`],
/// [`JitError::Compile`] for an index outside the plan's lengths or a
/// function Cranelift refuses.
pub fn compile_solves(plan: &FoldedSolves<'_>) -> Result<JitSolves, JitError> {
    let operations =
        plan.forward.len() + plan.backward.len() + plan.forward_t.len() + plan.backward_t.len();
    if operations > MAX_SOLVE_OPERATIONS {
        return Err(JitError::TooLarge {
            instructions: operations,
        });
    }
    let mut module = crate::tape::new_module()?;
    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    let needs = SolveNeeds {
        v: plan.values,
        rhs: plan.n,
    };
    let directions = [
        (plan.row_order, plan.forward, plan.backward, plan.col_order),
        (
            plan.col_order,
            plan.forward_t,
            plan.backward_t,
            plan.row_order,
        ),
    ];
    let mut ids = Vec::with_capacity(2);
    for (i, (gather, first, second, scatter)) in directions.into_iter().enumerate() {
        let ptr = module.target_config().pointer_type();
        let mut sig = module.make_signature();
        sig.params.push(AbiParam::new(ptr));
        sig.params.push(AbiParam::new(ptr));
        let id = module
            .declare_function(&format!("solve{i}"), Linkage::Local, &sig)
            .map_err(|e| JitError::Compile(e.to_string()))?;
        ctx.func.signature = sig;
        {
            let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
            emit(&mut b, needs, gather, [first, second], scatter)?;
            b.seal_all_blocks();
            b.finalize(module.isa().frontend_config());
        }
        module
            .define_function(id, &mut ctx)
            .map_err(|e| JitError::Compile(format!("{e:?}")))?;
        module.clear_context(&mut ctx);
        ids.push(id);
    }
    module
        .finalize_definitions()
        .map_err(|e| JitError::Compile(e.to_string()))?;
    let code = Code::new(module);
    let [solve, transpose] = ids[..] else {
        return Err(JitError::Compile("two solves".into()));
    };
    Ok(JitSolves {
        solve: SolveFn::new(&code, solve, needs)?,
        transpose: SolveFn::new(&code, transpose, needs)?,
    })
}

/// One direction: y = gathered b, the sweeps, b = scattered y. Every index
/// is checked against `needs` here, before any instruction uses it.
fn emit(
    b: &mut FunctionBuilder<'_>,
    needs: SolveNeeds,
    gather: &[u32],
    sweeps: [&[SolveOp]; 2],
    scatter: &[u32],
) -> Result<(), JitError> {
    let n = needs.rhs;
    if gather.len() != n || scatter.len() != n {
        return Err(JitError::Compile("orders of another length than n".into()));
    }
    let block = b.create_block();
    b.append_block_params_for_function_params(block);
    b.switch_to_block(block);
    let [v, rhs] = b.block_params(block)[..] else {
        return Err(JitError::Compile("signature".into()));
    };
    let y_index = |k: u32| -> Result<usize, JitError> {
        let k = k as usize;
        if k < n {
            Ok(k)
        } else {
            Err(JitError::Compile(format!("solve entry {k} beyond n = {n}")))
        }
    };
    let flags = MemFlagsData::trusted();
    let mut y: Vec<Value> = Vec::with_capacity(n);
    for &r in gather {
        let at = offset(y_index(r)?)?;
        y.push(b.ins().load(F64, flags, rhs, at));
    }
    // The factors' values, loaded once each.
    let mut vals: HashMap<u32, Value> = HashMap::new();
    let mut value = |b: &mut FunctionBuilder<'_>, s: u32| -> Result<Value, JitError> {
        if let Some(&x) = vals.get(&s) {
            return Ok(x);
        }
        if s as usize >= needs.v {
            return Err(JitError::Compile(format!(
                "factor value {s} beyond {}",
                needs.v
            )));
        }
        let x = b
            .ins()
            .load(F64, flags.with_readonly(), v, offset(s as usize)?);
        vals.insert(s, x);
        Ok(x)
    };
    for op in sweeps.into_iter().flatten() {
        match *op {
            SolveOp::MulSub { dst, src, s } => {
                let (d, r) = (y_index(dst)?, y_index(src)?);
                let x = value(b, s)?;
                let p = b.ins().fmul(x, y[r]);
                y[d] = b.ins().fsub(y[d], p);
            }
            SolveOp::ConstMulSub { dst, src, c } => {
                let (d, r) = (y_index(dst)?, y_index(src)?);
                let c = b.ins().f64const(c);
                let p = b.ins().fmul(c, y[r]);
                y[d] = b.ins().fsub(y[d], p);
            }
            SolveOp::Sub { dst, src } => {
                let (d, r) = (y_index(dst)?, y_index(src)?);
                y[d] = b.ins().fsub(y[d], y[r]);
            }
            SolveOp::Add { dst, src } => {
                let (d, r) = (y_index(dst)?, y_index(src)?);
                y[d] = b.ins().fadd(y[d], y[r]);
            }
            SolveOp::Scale { dst, s } => {
                let d = y_index(dst)?;
                let x = value(b, s)?;
                y[d] = b.ins().fmul(y[d], x);
            }
            SolveOp::ConstScale { dst, c } => {
                let d = y_index(dst)?;
                let c = b.ins().f64const(c);
                y[d] = b.ins().fmul(y[d], c);
            }
        }
    }
    for (&yk, &c) in y.iter().zip(scatter) {
        let at = offset(y_index(c)?)?;
        b.ins().store(flags, yk, rhs, at);
    }
    b.ins().return_(&[]);
    Ok(())
}

/// The scan's entries: where the compiled factorization writes each.
const SCAN_SCALE: usize = 0;
const SCAN_FINITE: usize = 1;
const SCAN_SAME: usize = 2;
const SCAN_NEGATIVE: usize = 3;
const SCAN_MIN_PIVOT: usize = 4;
const SCAN_MAX_MULTIPLIER: usize = 5;

/// The bits of `x` as Cranelift's signed immediate.
fn bits_of(x: f64) -> i64 {
    i64::from_ne_bytes(x.to_bits().to_ne_bytes())
}

fn offset(k: usize) -> Result<i32, JitError> {
    k.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| JitError::Compile("a slice too long for the JIT".into()))
}

/// A folded LU's factorization compiled to native code (see
/// [`compile_factor`]).
#[derive(Clone)]
pub struct JitFactor {
    f: FactorFn,
}

impl std::fmt::Debug for JitFactor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("JitFactor")
    }
}

impl CompiledFactor for JitFactor {
    #[inline]
    fn factor(&self, values: &[f64], v: &mut [f64]) -> Option<FactorScan> {
        let scan = self.f.call(values, v)?;
        Some(FactorScan {
            scale: scan[SCAN_SCALE],
            finite: scan[SCAN_FINITE] != 0.0,
            same: scan[SCAN_SAME] != 0.0,
            negative: scan[SCAN_NEGATIVE] != 0.0,
            min_pivot: scan[SCAN_MIN_PIVOT],
            max_multiplier: scan[SCAN_MAX_MULTIPLIER],
        })
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
pub fn compile_factor(plan: &FoldedFactor<'_>) -> Result<JitFactor, JitError> {
    let size = plan.ops.len() + plan.nnz;
    if size > MAX_SOLVE_OPERATIONS {
        return Err(JitError::TooLarge { instructions: size });
    }
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
    let id = module
        .declare_function("factor", Linkage::Local, &sig)
        .map_err(|e| JitError::Compile(e.to_string()))?;
    ctx.func.signature = sig;
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        emit_factor(&mut b, plan, needs)?;
        b.seal_all_blocks();
        b.finalize(module.isa().frontend_config());
    }
    module
        .define_function(id, &mut ctx)
        .map_err(|e| JitError::Compile(format!("{e:?}")))?;
    module.clear_context(&mut ctx);
    module
        .finalize_definitions()
        .map_err(|e| JitError::Compile(e.to_string()))?;
    let code = Code::new(module);
    Ok(JitFactor {
        f: FactorFn::new(&code, id, needs)?,
    })
}

/// The factorization's body; every index checked against `needs`.
fn emit_factor(
    b: &mut FunctionBuilder<'_>,
    plan: &FoldedFactor<'_>,
    needs: FactorNeeds,
) -> Result<(), JitError> {
    let block = b.create_block();
    b.append_block_params_for_function_params(block);
    b.switch_to_block(block);
    let [values, v_ptr, scan] = b.block_params(block)[..] else {
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
    // Each entry of the scan is stored as soon as it is known: the store
    // pins its computation there, so the values it reads die early (pure
    // instructions are otherwise placed at their use, keeping every load
    // alive to the end).
    let put = |b: &mut FunctionBuilder<'_>, k: usize, x: Value| -> Result<(), JitError> {
        b.ins()
            .store(flags, x, scan, offset(check(k, SCAN, "scan")?)?);
        Ok(())
    };
    // A running integer value into entry k (overwritten by the final one).
    let put_bits = put;
    let (one, zero) = (b.ins().f64const(1.0), b.ins().f64const(0.0));
    // Every constant still its constant, bit for bit: the differences'
    // bits ORed together are zero. Read as integers, straight from memory.
    let mut diff = b.ins().iconst(I64, 0);
    for &(k, c) in plan.constants {
        let k = check(k as usize, needs.values, "Jacobian value")?;
        let x = b.ins().load(I64, read, values, offset(k)?);
        let c = b.ins().iconst(I64, bits_of(c));
        let d = b.ins().bxor(x, c);
        diff = b.ins().bor(diff, d);
    }
    let same = b.ins().icmp_imm_s(IntCC::Equal, diff, 0);
    let same = b.ins().select(same, one, zero);
    put(b, SCAN_SAME, same)?;
    // Scale and finiteness: the largest magnitude's bits (integer order is
    // the order of |x|) over the run-time entries, from the constants'.
    // Each input is copied to the value array as it is loaded, and the
    // running maximum stored (raw bits) to pin it there.
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
        put_bits(b, SCAN_SCALE, max_bits)?;
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
    let mut fold = |b: &mut FunctionBuilder<'_>, k: usize, x: Value| -> Result<(), JitError> {
        let (pivot, multiplier) = role[k];
        if !(pivot || multiplier) {
            return Ok(());
        }
        let bits = b.ins().bitcast(I64, MemFlagsData::new(), x);
        let magnitude = b.ins().band(bits, abs_mask);
        if pivot {
            signs = b.ins().bxor(signs, bits);
            put_bits(b, SCAN_NEGATIVE, signs)?;
            let nan = b
                .ins()
                .icmp(IntCC::UnsignedGreaterThan, magnitude, inf_bits);
            let counted = b.ins().select(nan, zero_bits, magnitude);
            min_bits = b.ins().umin(min_bits, counted);
            put_bits(b, SCAN_MIN_PIVOT, min_bits)?;
        }
        if multiplier {
            mult_bits = b.ins().umax(mult_bits, magnitude);
            put_bits(b, SCAN_MAX_MULTIPLIER, mult_bits)?;
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
