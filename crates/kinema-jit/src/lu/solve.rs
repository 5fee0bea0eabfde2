//! The solves compiled: per direction the gather, both sweeps and the
//! scatter, every y in a register for small systems ([`emit`]) or
//! resident in memory for large ones and for chunks ([`Resident`]).

use std::collections::HashMap;

use cranelift_codegen::ir::{AbiParam, InstBuilder, MemFlagsData, Value, types::F64};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_module::Module;
use kinema_runtime::linalg::{CompiledSolves, FoldedSolves, SolveOp};

use super::{LU_CHUNK, MAX_SOLVE_OPERATIONS, REGISTER_SOLVE, WINDOW, calls, define, offset};
use crate::JitError;
use crate::code::{Code, SolveFn, SolveNeeds};

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
