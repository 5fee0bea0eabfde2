//! A [`FoldedLu`](kinema_runtime::FoldedLu)'s solves to native code: the
//! gather, both sweeps and the scatter of each direction as one
//! straight-line function over SSA values.
//!
//! The factorization too: its operations, the scan the acceptance test
//! reads, and for large systems a looped prologue and chunks. Here the
//! limits and the helpers both share; the solves are compiled in
//! `solve`, the factorization in `factor`.

mod factor;
mod solve;

pub use factor::{JitFactor, compile_factor, compile_factor_chunked};
pub use solve::{JitSolves, compile_solves, compile_solves_chunked};

use cranelift_codegen::Context;
use cranelift_codegen::ir::{InstBuilder, Signature};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::{FuncId, Linkage, Module};
use kinema_runtime::linalg::FactorScan;

use crate::JitError;

/// The most solve operations (both directions; for the factorization, its
/// operations and entries) the JIT compiles; above, they stay interpreted.
/// Longer lists than [`LU_CHUNK`] are compiled in chunks, so Cranelift's
/// time and memory grow about linearly: the chain N = 100's (n = 300)
/// factorization and solves compile in 93–145 ms (one function each:
/// 223 ms). This caps a hostile plan at a few seconds on the compiling
/// thread, as [`crate::MAX_INSTRUCTIONS`] does for tapes.
pub const MAX_SOLVE_OPERATIONS: usize = 250_000;

/// The largest dimension whose folded LU the JIT compiles (callers check
/// it: the dimension is the system's). With the factorization and solves
/// compiled in chunks the operations' count is what costs, and
/// [`MAX_SOLVE_OPERATIONS`] bounds it; this only keeps the scratch of a
/// solve (n values) and the plan's orders sane. (The runtime plans a
/// folded LU up to `Auto::MAX_FOLDED` = 10 000 anyway: above, the sparse
/// LU runs, interpreted.)
pub const MAX_LU_DIMENSION: usize = 100_000;

/// The most operations (or items: a factorization's entries, a solve's
/// scatter) compiled into one function; longer lists are cut into chunks
/// of this many, each a function, the values crossing a cut passed
/// through memory (the factorization's value array and scan, the solve's
/// scratch), one function calling the chunks in order. Measured (release,
/// 2 shared cores), one function of the chain N = 100's LU (n = 300)
/// took 223 ms to compile; the chain N = 50's (n = 150) 68 ms.
pub const LU_CHUNK: usize = 2_000;

/// Above this many constant and run-time entries, a factorization checks
/// the constants and copies the entries in loops before its compiled part
/// (see [`JitFactor`]'s prologue); up to it, straight-line code does.
pub const LOOPED_ENTRIES: usize = 256;

/// The largest dimension whose solves keep every y in a register from the
/// gather to the scatter (one function, `solve::emit`); above, y lives in
/// the solve's scratch (see `solve::Resident`), as it does in a solve of
/// more than [`LU_CHUNK`] items.
pub const REGISTER_SOLVE: usize = 32;

/// How many items a resident solve reuses a value's register for.
const WINDOW: usize = 8;
/// Declares and defines function `name` of `sig`, its body emitted by
/// `body` (given the module to declare callees in).
fn define(
    module: &mut JITModule,
    ctx: &mut Context,
    fctx: &mut FunctionBuilderContext,
    sig: &Signature,
    name: &str,
    body: impl FnOnce(&mut FunctionBuilder<'_>, &mut JITModule) -> Result<(), JitError>,
) -> Result<FuncId, JitError> {
    let id = module
        .declare_function(name, Linkage::Local, sig)
        .map_err(|e| JitError::Compile(e.to_string()))?;
    ctx.func.signature = sig.clone();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, fctx);
        body(&mut b, module)?;
        b.seal_all_blocks();
        b.finalize(module.isa().frontend_config());
    }
    module
        .define_function(id, ctx)
        .map_err(|e| JitError::Compile(format!("{e:?}")))?;
    module.clear_context(ctx);
    Ok(id)
}

/// A function's body calling `parts` in order with its own arguments.
fn calls(
    b: &mut FunctionBuilder<'_>,
    module: &mut JITModule,
    parts: &[FuncId],
) -> Result<(), JitError> {
    let block = b.create_block();
    b.append_block_params_for_function_params(block);
    b.switch_to_block(block);
    let args = b.block_params(block).to_vec();
    for &part in parts {
        let f = module.declare_func_in_func(part, b.func);
        b.ins().call(f, &args);
    }
    b.ins().return_(&[]);
    Ok(())
}

/// The scan's entries: where the compiled factorization writes each (the
/// runtime's [`RawScan`] layout).
///
/// [`RawScan`]: kinema_runtime::linalg::RawScan
const SCAN_SCALE: usize = FactorScan::SCALE;
const SCAN_FINITE: usize = FactorScan::FINITE;
const SCAN_SAME: usize = FactorScan::SAME;
const SCAN_NEGATIVE: usize = FactorScan::NEGATIVE;
const SCAN_MIN_PIVOT: usize = FactorScan::MIN_PIVOT;
const SCAN_MAX_MULTIPLIER: usize = FactorScan::MAX_MULTIPLIER;

/// The bits of `x` as Cranelift's signed immediate.
fn bits_of(x: f64) -> i64 {
    i64::from_ne_bytes(x.to_bits().to_ne_bytes())
}

fn offset(k: usize) -> Result<i32, JitError> {
    k.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| JitError::Compile("a slice too long for the JIT".into()))
}
