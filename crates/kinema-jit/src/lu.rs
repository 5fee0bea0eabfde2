//! A [`FoldedLu`](kinema_runtime::FoldedLu)'s solves to native code: the
//! gather, both sweeps and the scatter of each direction as one
//! straight-line function over SSA values.

use std::collections::HashMap;

use cranelift_codegen::Context;
use cranelift_codegen::ir::{
    AbiParam, BlockArg, InstBuilder, MemFlagsData, Signature, Value, condcodes::IntCC, types::F64,
    types::I64,
};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::{FuncId, Linkage, Module};
use kinema_runtime::linalg::{
    CompiledFactor, CompiledSolves, FactorScan, FoldedFactor, FoldedSolves, INFINITY_BITS,
    MAGNITUDE_MASK, MASK_ALL, Op, RawScan, SolveOp, scale_and_masked_max,
};

use crate::JitError;
use crate::code::{Code, FactorFn, FactorNeeds, SCAN, SolveFn, SolveNeeds};

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
/// gather to the scatter (one function, [`emit`]); above, y lives in the
/// solve's scratch (see [`Resident`]), as it does in a solve of more than
/// [`LU_CHUNK`] items.
pub const REGISTER_SOLVE: usize = 32;

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
    fn solve(&self, v: &[f64], rhs: &mut [f64], work: &mut [f64], transpose: bool) -> bool {
        if transpose {
            self.transpose.call(v, rhs, work)
        } else {
            self.solve.call(v, rhs, work)
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
    compile_solves_chunked(plan, LU_CHUNK, REGISTER_SOLVE)
}

/// [`compile_solves`] with a direction longer than `chunk` operations
/// (with its scatter) compiled in chunks of at most `chunk` (at least 1),
/// and y resident in the scratch above dimension `register` (instead of
/// [`REGISTER_SOLVE`]): for tests, which force small chunks and both
/// forms. Not a stable interface.
///
/// # Errors
/// As [`compile_solves`].
#[doc(hidden)]
pub fn compile_solves_chunked(
    plan: &FoldedSolves<'_>,
    chunk: usize,
    register: usize,
) -> Result<JitSolves, JitError> {
    let operations =
        plan.forward.len() + plan.backward.len() + plan.forward_t.len() + plan.backward_t.len();
    if operations > MAX_SOLVE_OPERATIONS {
        return Err(JitError::TooLarge {
            instructions: operations,
        });
    }
    let chunk = chunk.max(1);
    let mut module = crate::tape::new_module()?;
    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    let one = SolveNeeds {
        v: plan.values,
        rhs: plan.n,
        work: 0,
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
    let ptr = module.target_config().pointer_type();
    let mut sig = module.make_signature();
    for _ in 0..3 {
        sig.params.push(AbiParam::new(ptr));
    }
    let mut fns = Vec::with_capacity(2);
    for (i, (gather, first, second, scatter)) in directions.into_iter().enumerate() {
        let name = format!("solve{i}");
        let items = first.len() + second.len() + plan.n;
        if plan.n <= register && items <= chunk {
            let id = define(&mut module, &mut ctx, &mut fctx, &sig, &name, |b, _| {
                emit(b, one, gather, [first, second], scatter)
            })?;
            fns.push((id, one));
            continue;
        }
        let needs = SolveNeeds {
            work: plan.n,
            ..one
        };
        let resident = Resident::new(needs, gather, [first, second], scatter, chunk)?;
        let items = resident.items.len();
        if items <= chunk {
            let id = define(&mut module, &mut ctx, &mut fctx, &sig, &name, |b, _| {
                resident.emit(b, 0..items)
            })?;
            fns.push((id, needs));
            continue;
        }
        let mut parts = Vec::with_capacity(items.div_ceil(chunk));
        for (c, s) in (0..items).step_by(chunk).enumerate() {
            parts.push(define(
                &mut module,
                &mut ctx,
                &mut fctx,
                &sig,
                &format!("{name}_{c}"),
                |b, _| resident.emit(b, s..(s + chunk).min(items)),
            )?);
        }
        let id = define(
            &mut module,
            &mut ctx,
            &mut fctx,
            &sig,
            &name,
            |b, module| calls(b, module, &parts),
        )?;
        fns.push((id, needs));
    }
    module
        .finalize_definitions()
        .map_err(|e| JitError::Compile(e.to_string()))?;
    let code = Code::new(module);
    let [(solve, solve_needs), (transpose, transpose_needs)] = fns[..] else {
        return Err(JitError::Compile("two solves".into()));
    };
    Ok(JitSolves {
        solve: SolveFn::new(&code, solve, solve_needs)?,
        transpose: SolveFn::new(&code, transpose, transpose_needs)?,
    })
}

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

/// What a resident solve does, item by item.
#[derive(Clone, Copy, Debug)]
enum Item {
    /// One of the sweeps' operations.
    Op(SolveOp),
    /// y[k], never written by an operation, copied from b into the
    /// scratch before the scatter may overwrite its place in b.
    Park(usize),
    /// b[scatter[k]] = y[k].
    Scatter(usize),
}

impl Item {
    /// The y entries the item reads: the first `len` of the array.
    fn reads(self) -> ([usize; 2], usize) {
        match self {
            Item::Op(op) => match op.src() {
                Some(src) => ([op.dst() as usize, src as usize], 2),
                None => ([op.dst() as usize, 0], 1),
            },
            Item::Park(_) => ([0, 0], 0),
            Item::Scatter(k) => ([k, 0], 1),
        }
    }

    /// The y entry the item writes.
    fn writes(self) -> Option<usize> {
        match self {
            Item::Op(op) => Some(op.dst() as usize),
            Item::Park(k) => Some(k),
            Item::Scatter(_) => None,
        }
    }
}

/// One direction of a solve with y resident in memory, for systems above
/// [`REGISTER_SOLVE`] or solves longer than a chunk: y[k] is read from b
/// (at `gather[k]`) until an operation writes it; an operation's result is
/// stored in the scratch (`work`, n values) only if a read of it is too
/// far for its register or in a later chunk; the last items scatter y back
/// into b.
///
/// Keeping every y in a register for the whole solve, as [`emit`] does,
/// makes Cranelift spill most of them (the chain N = 200's forward solve:
/// 10 500 instructions moving spills). Here a value is reused from its
/// register only within [`WINDOW`] items of where it was last loaded or
/// computed, and read back from memory after that, so few values are
/// ever live and nothing spills; a chain of dependent operations, the
/// latency that matters, stays in registers.
struct Resident<'p> {
    gather: &'p [u32],
    scatter: &'p [u32],
    items: Vec<Item>,
    /// Per item, whether the value it writes is stored in the scratch.
    store: Vec<bool>,
    /// Per y entry, the first item writing it: a read at or before it
    /// reads b.
    first_write: Vec<usize>,
}

/// How many items a resident solve reuses a value's register for.
const WINDOW: usize = 8;

impl<'p> Resident<'p> {
    /// Checks every index against `needs` (n = `needs.rhs`, the factors'
    /// values `needs.v`) before anything is emitted; the items will be
    /// emitted in chunks of `chunk`.
    fn new(
        needs: SolveNeeds,
        gather: &'p [u32],
        sweeps: [&[SolveOp]; 2],
        scatter: &'p [u32],
        chunk: usize,
    ) -> Result<Resident<'p>, JitError> {
        let n = needs.rhs;
        if gather.len() != n || scatter.len() != n || needs.work < n {
            return Err(JitError::Compile("orders of another length than n".into()));
        }
        let entry = |k: u32| -> Result<(), JitError> {
            if (k as usize) < n {
                Ok(())
            } else {
                Err(JitError::Compile(format!("solve entry {k} beyond n = {n}")))
            }
        };
        for &k in gather.iter().chain(scatter) {
            entry(k)?;
        }
        let mut items = Vec::new();
        for &op in sweeps.into_iter().flatten() {
            entry(op.dst())?;
            if let Some(src) = op.src() {
                entry(src)?;
            }
            if let SolveOp::MulSub { s, .. } | SolveOp::Scale { s, .. } = op
                && s as usize >= needs.v
            {
                return Err(JitError::Compile(format!(
                    "factor value {s} beyond {}",
                    needs.v
                )));
            }
            items.push(Item::Op(op));
        }
        let mut first_write = vec![usize::MAX; n];
        for (i, item) in items.iter().enumerate() {
            if let Some(d) = item.writes() {
                first_write[d] = first_write[d].min(i);
            }
        }
        for (k, first) in first_write.iter_mut().enumerate() {
            if *first == usize::MAX {
                *first = items.len();
                items.push(Item::Park(k));
            }
        }
        items.extend((0..n).map(Item::Scatter));
        // A value is stored if a read of it (before its entry's next
        // write) is beyond the window or in another chunk; a parked one
        // always.
        let chunk = chunk.max(1);
        let mut store = vec![false; items.len()];
        let mut written: Vec<Option<usize>> = vec![None; n];
        for (r, &item) in items.iter().enumerate() {
            let (reads, len) = item.reads();
            for &k in &reads[..len] {
                if let Some(w) = written[k]
                    && (r - w > WINDOW || r / chunk != w / chunk)
                {
                    store[w] = true;
                }
            }
            if let Some(k) = item.writes() {
                written[k] = Some(r);
            }
            if let Item::Park(_) = item {
                store[r] = true;
            }
        }
        Ok(Resident {
            gather,
            scatter,
            items,
            store,
            first_write,
        })
    }

    /// Emits the items `range` (a chunk of the `chunk` given to
    /// [`new`](Self::new)) as one function `(v, rhs, work)`.
    fn emit(
        &self,
        b: &mut FunctionBuilder<'_>,
        range: std::ops::Range<usize>,
    ) -> Result<(), JitError> {
        let block = b.create_block();
        b.append_block_params_for_function_params(block);
        b.switch_to_block(block);
        let [v, rhs, work] = b.block_params(block)[..] else {
            return Err(JitError::Compile("signature".into()));
        };
        let flags = MemFlagsData::trusted();
        let start = range.start;
        let items = self
            .items
            .get(range)
            .ok_or_else(|| JitError::Compile("chunk out of range".into()))?;
        // y[k]'s register and the item it was last loaded or computed at.
        let mut recent: Vec<Option<(Value, usize)>> = vec![None; self.first_write.len()];
        // y[k] at item `at`: from its register within the window, else
        // from b until its first write, from the scratch after.
        let get = |b: &mut FunctionBuilder<'_>,
                   recent: &mut [Option<(Value, usize)>],
                   k: usize,
                   at: usize|
         -> Result<Value, JitError> {
            if let Some((x, t)) = recent[k]
                && at - t <= WINDOW
            {
                return Ok(x);
            }
            let x = if start + at <= self.first_write[k] {
                b.ins()
                    .load(F64, flags, rhs, offset(self.gather[k] as usize)?)
            } else {
                b.ins().load(F64, flags, work, offset(k)?)
            };
            recent[k] = Some((x, at));
            Ok(x)
        };
        let factor = |b: &mut FunctionBuilder<'_>, s: u32| -> Result<Value, JitError> {
            Ok(b.ins()
                .load(F64, flags.with_readonly(), v, offset(s as usize)?))
        };
        for (at, &item) in items.iter().enumerate() {
            let op = match item {
                Item::Op(op) => op,
                Item::Park(k) => {
                    let x = b
                        .ins()
                        .load(F64, flags, rhs, offset(self.gather[k] as usize)?);
                    b.ins().store(flags, x, work, offset(k)?);
                    recent[k] = Some((x, at));
                    continue;
                }
                Item::Scatter(k) => {
                    let x = get(b, &mut recent, k, at)?;
                    b.ins()
                        .store(flags, x, rhs, offset(self.scatter[k] as usize)?);
                    continue;
                }
            };
            let dst = op.dst() as usize;
            let d = get(b, &mut recent, dst, at)?;
            let r = match op.src() {
                Some(k) => Some(get(b, &mut recent, k as usize, at)?),
                None => None,
            };
            let x = apply(b, op, d, r, factor)?;
            if self.store[start + at] {
                b.ins().store(flags, x, work, offset(dst)?);
            }
            recent[dst] = Some((x, at));
        }
        b.ins().return_(&[]);
        Ok(())
    }
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
    let [v, rhs, _work] = b.block_params(block)[..] else {
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
    for &op in sweeps.into_iter().flatten() {
        let d = y_index(op.dst())?;
        let r = op.src().map(|k| y_index(k).map(|k| y[k])).transpose()?;
        y[d] = apply(b, op, y[d], r, &mut value)?;
    }
    for (&yk, &c) in y.iter().zip(scatter) {
        let at = offset(y_index(c)?)?;
        b.ins().store(flags, yk, rhs, at);
    }
    b.ins().return_(&[]);
    Ok(())
}

/// The value operation `op` writes, from y[dst] (`d`), y[src] (`r`, for
/// the operations that read it) and the factors' values (`factor`),
/// rounded as the interpreter's sweep rounds it: both solve emitters use it.
fn apply(
    b: &mut FunctionBuilder<'_>,
    op: SolveOp,
    d: Value,
    r: Option<Value>,
    mut factor: impl FnMut(&mut FunctionBuilder<'_>, u32) -> Result<Value, JitError>,
) -> Result<Value, JitError> {
    let src = || r.ok_or_else(|| JitError::Compile("an operation without its source".into()));
    Ok(match op {
        SolveOp::MulSub { s, .. } => {
            let x = factor(b, s)?;
            let p = b.ins().fmul(x, src()?);
            b.ins().fsub(d, p)
        }
        SolveOp::ConstMulSub { c, .. } => {
            let c = b.ins().f64const(c);
            let p = b.ins().fmul(c, src()?);
            b.ins().fsub(d, p)
        }
        SolveOp::Sub { .. } => b.ins().fsub(d, src()?),
        SolveOp::Add { .. } => b.ins().fadd(d, src()?),
        SolveOp::Scale { s, .. } => {
            let x = factor(b, s)?;
            b.ins().fmul(d, x)
        }
        SolveOp::ConstScale { c, .. } => {
            let c = b.ins().f64const(c);
            b.ins().fmul(d, c)
        }
    })
}

/// The scan's entries: where the compiled factorization writes each (the
/// runtime's [`RawScan`] layout).
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

/// The per-entry start of a large factorization, as loops over tables:
/// emitted straight-line, the chain N = 200's 1 000 constants and 800
/// copies were 13 000 instructions of code run once per factorization,
/// more than the instruction caches keep (the generated LU loops over
/// tables beyond a few entries for the same reason). The loops compute
/// the interpreter's numbers — the constants' differences or-ed; integer
/// maxima and minima of magnitude bits, which no order changes, in four
/// lanes; the sign bits' parity — and leave the running folds in the
/// scan, where the compiled part (the operations) reads them.
#[derive(Clone, Debug)]
struct Prologue {
    /// Pattern position and bits of each constant entry.
    constants: Box<[(u32, u64)]>,
    /// Pattern position of each run-time entry (value array entry i).
    inputs: Box<[u32]>,
    /// Value array entries among the run-time entries that are pivots.
    pivots: Box<[u32]>,
    /// Per run-time entry, [`MASK_ALL`] if it is a multiplier, else 0: the
    /// multipliers' fold is taken in the scale's pass (in a mechanism most
    /// entries are multipliers: the pivots are the joints' ±1).
    multiplier_mask: Box<[u64]>,
    /// The folds' starts: the constants' scale, smallest pivot and largest
    /// multiplier (magnitude bits).
    scale: u64,
    min_pivot: u64,
    max_multiplier: u64,
}

impl Prologue {
    /// The prologue of `plan`, its indices checked against `needs`.
    fn new(plan: &FoldedFactor<'_>, needs: FactorNeeds) -> Result<Prologue, JitError> {
        let inside = |k: u32| -> Result<u32, JitError> {
            if (k as usize) < needs.values {
                Ok(k)
            } else {
                Err(JitError::Compile(format!(
                    "Jacobian value index {k} beyond {}",
                    needs.values
                )))
            }
        };
        let ni = plan.inputs.len();
        if ni > needs.v {
            return Err(JitError::Compile("more entries than values".into()));
        }
        let copied = |vars: &[u32]| -> Box<[u32]> {
            vars.iter()
                .copied()
                .filter(|&k| (k as usize) < ni)
                .collect()
        };
        Ok(Prologue {
            constants: plan
                .constants
                .iter()
                .map(|&(k, c)| Ok((inside(k)?, c.to_bits())))
                .collect::<Result<_, JitError>>()?,
            inputs: plan
                .inputs
                .iter()
                .map(|&k| inside(k))
                .collect::<Result<_, JitError>>()?,
            pivots: copied(plan.pivot_vars),
            multiplier_mask: {
                let mut mask = vec![0; ni];
                for &l in plan.multiplier_vars {
                    if let Some(m) = mask.get_mut(l as usize) {
                        *m = MASK_ALL;
                    }
                }
                mask.into_boxed_slice()
            },
            scale: plan.const_scale.to_bits() & MAGNITUDE_MASK,
            min_pivot: plan.const_min_pivot.to_bits() & MAGNITUDE_MASK,
            max_multiplier: plan.const_max_multiplier.to_bits() & MAGNITUDE_MASK,
        })
    }

    /// Checks the constants (if `check`), copies the run-time entries into
    /// `v` and folds them; writes into `scan` the scan the compiled part
    /// starts from (final scale, finiteness and constants' check; the
    /// pivots' and multipliers' folds as running state, raw bits). The caller has
    /// checked `values` and `v` against the needs the indices were checked
    /// with. Out of line: the small systems' factorization, which has no
    /// prologue, stays lean.
    #[inline(never)]
    fn run(&self, values: &[f64], v: &mut [f64], check: bool, scan: &mut RawScan) {
        let bits = |x: f64| x.to_bits();
        let mut diff = 0;
        for &(k, c) in if check { &self.constants[..] } else { &[] } {
            diff |= bits(values[k as usize]) ^ c;
        }
        let ni = self.inputs.len();
        for (x, &k) in v[..ni].iter_mut().zip(&*self.inputs) {
            *x = values[k as usize];
        }
        // Scale, finiteness and the multipliers among the entries in one
        // pass over the contiguous copy (it vectorizes; gathering does
        // not). Not finite, the order is refused whatever the maxima.
        let (most, multipliers, finite) = scale_and_masked_max(&v[..ni], &self.multiplier_mask);
        let (scale, max_multiplier) = if finite {
            (
                self.scale.max(most.to_bits()),
                self.max_multiplier.max(multipliers.to_bits()),
            )
        } else {
            (INFINITY_BITS, INFINITY_BITS)
        };
        let v = &*v;
        let mut signs = 0;
        // A NaN pivot counts as zero.
        let pivot = |p: u32| {
            let m = bits(v[p as usize]) & MAGNITUDE_MASK;
            if m > INFINITY_BITS { 0 } else { m }
        };
        let min_pivot = fold4(&self.pivots, self.min_pivot, u64::MAX, u64::min, |p| {
            signs ^= bits(v[p as usize]);
            pivot(p)
        });
        scan[SCAN_SAME] = if diff == 0 { 1.0 } else { 0.0 };
        scan[SCAN_SCALE] = f64::from_bits(scale);
        scan[SCAN_FINITE] = if finite { 1.0 } else { 0.0 };
        scan[SCAN_NEGATIVE] = f64::from_bits(signs);
        scan[SCAN_MIN_PIVOT] = f64::from_bits(min_pivot);
        scan[SCAN_MAX_MULTIPLIER] = f64::from_bits(max_multiplier);
    }
}

/// `f` of the four lanes, pairwise.
#[inline]
fn lanes(x: [u64; 4], f: fn(u64, u64) -> u64) -> u64 {
    f(f(x[0], x[1]), f(x[2], x[3]))
}

/// `fold` (min or max, order-free) of `map` over `items` from `start`, in
/// four independent lanes (`identity` the others' start) so the folds do
/// not wait on each other.
#[inline]
fn fold4(
    items: &[u32],
    start: u64,
    identity: u64,
    fold: fn(u64, u64) -> u64,
    mut map: impl FnMut(u32) -> u64,
) -> u64 {
    let mut m = [start, identity, identity, identity];
    let chunks = items.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for lane in 0..4 {
            m[lane] = fold(m[lane], map(c[lane]));
        }
    }
    rest.iter()
        .fold(lanes(m, fold), |acc, &k| fold(acc, map(k)))
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

/// A factorization compiled in chunks: the items of [`emit_factor`] in its
/// order (the constants' check, the entries copied to the value array,
/// the copied entries folded, the operations), numbered; a chunk reads the
/// values array's earlier entries from memory, and the running folds
/// (raw bits) from the scan, where the chunk before left them.
struct FactorChunks<'p> {
    plan: &'p FoldedFactor<'p>,
    needs: FactorNeeds,
    /// Number of items.
    total: usize,
    /// (pivot, multiplier) roles of each value.
    role: Vec<(bool, bool)>,
    /// Whether a [`Prologue`] checks the constants, copies the entries and
    /// folds them (the compiled items then start at
    /// [`FactorChunks::operations_at`]).
    looped: bool,
}

impl<'p> FactorChunks<'p> {
    fn new(
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
    fn operations_at(&self) -> usize {
        self.plan.constants.len() + 2 * self.plan.inputs.len()
    }

    /// Emits items `range` as one function `(values, v, scan)`.
    #[allow(clippy::too_many_lines)] // one pass over the items, as emit_factor
    fn emit(
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
