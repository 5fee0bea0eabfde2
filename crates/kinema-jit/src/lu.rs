//! A [`FoldedLu`](kinema_runtime::FoldedLu)'s solves to native code: the
//! gather, both sweeps and the scatter of each direction as one
//! straight-line function over SSA values.

use std::collections::HashMap;

use cranelift_codegen::ir::{AbiParam, InstBuilder, MemFlagsData, Value, types::F64};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_module::{Linkage, Module};
use kinema_runtime::linalg::{CompiledSolves, FoldedSolves, SolveOp};

use crate::JitError;
use crate::code::{Code, SolveFn, SolveNeeds};

/// The most solve operations (both directions) the JIT compiles; above,
/// the solves stay interpreted (the bound of [`crate::MAX_INSTRUCTIONS`],
/// for the same reason).
pub const MAX_SOLVE_OPERATIONS: usize = 16_000;

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

fn offset(k: usize) -> Result<i32, JitError> {
    k.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| JitError::Compile("a slice too long for the JIT".into()))
}
