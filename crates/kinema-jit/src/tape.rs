//! Tapes to Cranelift IR: one straight-line function per tape.

use std::collections::{HashMap, HashSet};

use cranelift_codegen::ir::{
    AbiParam, FuncRef, InstBuilder, MemFlagsData, Signature, Value, condcodes::IntCC, types::F64,
    types::I32, types::I64,
};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{FuncId, Linkage, Module};
use kinema_expr::{Instr, Tape, TapeInputs};

use crate::JitError;
use crate::code::{Code, Needs, TapeFn};
use crate::hoist::{self, Layout, Part};
use crate::shims::{self, Shape, Which};

/// The most instructions (all tapes of one [`compile`] together) the JIT
/// compiles. Above it [`compile`] returns [`JitError::TooLarge`] and the
/// caller runs the interpreter. A tape longer than [`CHUNK_INSTRUCTIONS`]
/// is compiled in chunks (see there), so Cranelift's time and memory grow
/// about linearly with the tapes: measured (release, 2 shared cores, the
/// background compilation of a chain's five hot tapes), N = 100 (6 586
/// instructions) 110–250 ms, N = 200 (≈ 13 000) 335–385 ms, N = 1000
/// (65 986) 1.74–1.87 s, ≈ 27 µs per instruction, the process's peak
/// memory 50 MB against the tape's 27 MB at N = 1000. So this bound caps
/// a hostile model's compilation at ≈ 7 s and ≈ 100 MB on the compiling
/// thread (the run meanwhile on the tape).
pub const MAX_INSTRUCTIONS: usize = 250_000;

/// The most instructions of a tape compiled as one function. Cranelift's
/// time grows faster than a function's size (its register allocator and
/// optimizer see every value at once), so a longer tape is cut into chunks
/// of this many instructions, each a function of its own, the values
/// crossing a cut passed through the scratch after the memo (see
/// [`cache_len_bound`]), and one function calls the chunks in order.
/// Every tape of the benchmark's mechanisms up to chain N = 50 fits in one
/// (single functions took, before chunking, 6 ms for 646 instructions,
/// 114 ms for 6 586, over 1 s for 65 986 and growing faster).
pub const CHUNK_INSTRUCTIONS: usize = 2_000;

/// When an input or a coordinate's sine or cosine, once loaded, is loaded
/// again rather than kept in a register: in functions of more than
/// `from` instructions, at a use more than `window` instructions after
/// its last load. Kept live any longer across a long tape, it would be
/// spilled to the stack by Cranelift's register allocator (a store and a
/// reload) or, for the sines and cosines computed at a chunk's start, all
/// of them would be (the chain N = 100's Φ and Φ_q: 1 571 stack moves,
/// 312 this way). A short function's values fit in the registers: there a
/// reload is one instruction more (the slider-crank's step +0.7 %).
#[doc(hidden)]
#[derive(Clone, Copy, Debug)]
pub struct Reloads {
    /// Instructions a loaded value is reused for.
    pub window: usize,
    /// Functions of at most this many instructions keep every value.
    pub from: usize,
}

impl Reloads {
    /// What [`compile_split_memo_at`] uses.
    pub const DEFAULT: Reloads = Reloads {
        window: 8,
        from: 256,
    };
}

/// A tape compiled to native code. Cloning shares the code.
#[derive(Clone)]
pub struct JitTape {
    f: TapeFn,
    outputs: usize,
    sizes: (usize, usize, usize),
    trig: usize,
}

impl std::fmt::Debug for JitTape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JitTape")
            .field("outputs", &self.outputs)
            .field("input_sizes", &self.sizes)
            .finish_non_exhaustive()
    }
}

impl JitTape {
    /// Evaluates: `out[k]` becomes output `k`, as [`Tape::eval`] computes
    /// it. Allocates a sin/cos cache for the call: in a loop, use
    /// [`eval_with_cache`](Self::eval_with_cache).
    ///
    /// # Errors
    /// [`JitError::ShortSlice`] if a slice is shorter than the tape needs
    /// (checked before anything runs).
    pub fn eval(&self, inputs: &TapeInputs<'_>, out: &mut [f64]) -> Result<(), JitError> {
        let mut trig = vec![f64::NAN; self.trig];
        self.eval_with_cache(inputs, &mut trig, out)
    }

    /// [`eval`](Self::eval) through a cache of the coordinates' sines and
    /// cosines, laid out as [`Tape::eval_with_cache`]'s (`trig[3k..3k + 3]`
    /// = (q_k, sin q_k, cos q_k), fill a new one with NaN), at least
    /// [`trig_len`](Self::trig_len) long. Does not allocate.
    ///
    /// # Errors
    /// [`JitError::ShortSlice`] as [`eval`](Self::eval), and for a short
    /// cache.
    #[inline]
    pub fn eval_with_cache(
        &self,
        inputs: &TapeInputs<'_>,
        trig: &mut [f64],
        out: &mut [f64],
    ) -> Result<(), JitError> {
        self.f.call(inputs, out, &mut [], trig)
    }

    /// Evaluates a tape compiled by [`compile_split`]: outputs before its
    /// split go to `first`, the others to `second` (from index 0), through
    /// the cache of [`eval_with_cache`](Self::eval_with_cache). Does not
    /// allocate.
    ///
    /// # Errors
    /// [`JitError::ShortSlice`] as [`eval_with_cache`](Self::eval_with_cache).
    #[inline]
    pub fn eval_split(
        &self,
        inputs: &TapeInputs<'_>,
        trig: &mut [f64],
        first: &mut [f64],
        second: &mut [f64],
    ) -> Result<(), JitError> {
        self.f.call(inputs, first, second, trig)
    }

    /// Length the sin/cos cache must have at least.
    #[must_use]
    pub fn trig_len(&self) -> usize {
        self.trig
    }

    /// Number of outputs.
    #[must_use]
    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// Length each input slice must have at least: `(q, qd, params)`, as
    /// [`Tape::input_sizes`].
    #[must_use]
    pub fn input_sizes(&self) -> (usize, usize, usize) {
        self.sizes
    }
}

/// Compiles tapes to native code, all into one module (one finalization).
///
/// # Errors
/// [`JitError::Host`] if Cranelift cannot target this machine,
/// [`JitError::TooLarge`] above [`MAX_INSTRUCTIONS`], [`JitError::Compile`]
/// if Cranelift refuses a function or a tape reads a register it never
/// wrote.
pub fn compile(tapes: &[&Tape]) -> Result<Vec<JitTape>, JitError> {
    let split: Vec<(&Tape, usize)> = tapes.iter().map(|t| (*t, t.outputs())).collect();
    compile_split(&split)
}

/// Where the memo of sines and cosines of other values than coordinates
/// starts in the cache slice by default: after the coordinates' entries of
/// every tape.
fn default_memo_base(tapes: &[(&Tape, usize)]) -> Result<usize, JitError> {
    tapes
        .iter()
        .try_fold(0, |m, (t, _)| Ok(m.max(trig_len(t)?)))
}

/// [`compile`] with each tape's outputs split in two at the given index,
/// for [`JitTape::eval_split`] (a split beyond the outputs is the number of
/// outputs: nothing goes to the second slice).
///
/// # Errors
/// As [`compile`].
pub fn compile_split(tapes: &[(&Tape, usize)]) -> Result<Vec<JitTape>, JitError> {
    compile_split_memo_at(tapes, default_memo_base(tapes)?)
}

/// [`compile_split`] with the memo at `memo_base` in the cache slice.
///
/// Besides the coordinates' (sin, cos) at `3k..3k + 3` (as
/// [`Tape::eval_with_cache`]), the j-th value other than a coordinate
/// whose sin or cos a tape takes (a driver's `sin(2πt + k)`, say) has
/// (x, sin x, cos x) in entries `memo_base + 3j..` : a later call with the
/// same x (the same t in the next Newton iteration, or another tape of
/// the same equations taking the same values in the same order, as Φ, ν
/// and γ of one model do) reads them back instead of calling. An entry
/// whose x differs is recomputed and rewritten (a miss, never a wrong
/// value). After the memo and the values crossing chunks, a tape keeps the
/// part of it that reads neither q nor q̇ (a driver's functions of t, the
/// parameters' expressions) with its key, t and the parameters it reads:
/// computed once per (t, parameters) by a function of its own, read back
/// at the next call with the same ones (see `hoist.rs`). A caller whose
/// cache slice holds other things up to some index puts the memo after
/// them; the slice must be
/// [`JitTape::trig_len`] long, filled with NaN when new, and is the cache
/// of the tapes of one compilation: another compilation's functions (or
/// an interpreter's registers) may leave values there that these would
/// misread (a new slice for each, or one filled with NaN again).
///
/// # Errors
/// As [`compile`]; [`JitError::Compile`] if `memo_base` lies inside the
/// coordinates' entries.
pub fn compile_split_memo_at(
    tapes: &[(&Tape, usize)],
    memo_base: usize,
) -> Result<Vec<JitTape>, JitError> {
    compile_chunked(tapes, memo_base, CHUNK_INSTRUCTIONS, Reloads::DEFAULT)
}

/// [`compile_split_memo_at`] with the part that reads neither q nor q̇
/// kept across calls only in the tapes marked `iterated` (a tape past the
/// slice's end counts as marked): those evaluated several times at one
/// (t, parameters) — Newton's Φ and Φ_q. A tape evaluated once per time
/// (ν, γ) would check its key, miss, and compute the part anyway.
///
/// # Errors
/// As [`compile_split_memo_at`].
pub fn compile_iterated(
    tapes: &[(&Tape, usize)],
    memo_base: usize,
    iterated: &[bool],
) -> Result<Vec<JitTape>, JitError> {
    compile_with(
        tapes,
        memo_base,
        CHUNK_INSTRUCTIONS,
        Reloads::DEFAULT,
        iterated,
    )
}

/// [`compile_split_memo_at`] with tapes longer than `chunk` instructions
/// compiled in chunks of at most `chunk` (at least 1), and values loaded
/// from memory reloaded as `reloads` says: for tests, which force small
/// chunks so that values cross their boundaries, and small windows so
/// that values are reloaded. Not a stable interface.
///
/// # Errors
/// As [`compile_split_memo_at`].
#[doc(hidden)]
pub fn compile_chunked(
    tapes: &[(&Tape, usize)],
    memo_base: usize,
    chunk: usize,
    reloads: Reloads,
) -> Result<Vec<JitTape>, JitError> {
    compile_with(tapes, memo_base, chunk, reloads, &[])
}

/// [`compile_chunked`], the parts that read neither q nor q̇ kept where
/// `iterated` says (see [`compile_iterated`]).
fn compile_with(
    tapes: &[(&Tape, usize)],
    memo_base: usize,
    chunk: usize,
    reloads: Reloads,
    iterated: &[bool],
) -> Result<Vec<JitTape>, JitError> {
    if memo_base < default_memo_base(tapes)? {
        return Err(JitError::Compile(
            "the sin/cos memo overlaps the coordinates' cache".into(),
        ));
    }
    let instructions: usize = tapes.iter().map(|(t, _)| t.len()).sum();
    if instructions > MAX_INSTRUCTIONS {
        return Err(JitError::TooLarge { instructions });
    }
    let chunk = chunk.max(1);
    // Values crossing a chunk boundary go through the scratch after the
    // memo's last possible entry (and after `memo_base`: the caller's own
    // values lie below it): register r at `spill_base + r`.
    let spill_base = memo_bound(tapes, memo_base)?.max(memo_base);
    let layout = hoisting(tapes, memo_base, chunk, iterated)?;
    let salt = hoist::salt();
    let mut module = new_module()?;
    let shims = declare_shims(&mut module)?;
    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    let mut compiled = Vec::with_capacity(tapes.len());
    let ptr = module.target_config().pointer_type();
    let mut sig = module.make_signature();
    for ty in [ptr, ptr, ptr, F64, ptr, ptr, ptr] {
        sig.params.push(AbiParam::new(ty));
    }
    let mut define = |module: &mut JITModule,
                      name: String,
                      body: &mut dyn FnMut(
        &mut JITModule,
        &mut FunctionBuilder<'_>,
    ) -> Result<Needs, JitError>|
     -> Result<(FuncId, Needs), JitError> {
        let id = module
            .declare_function(&name, Linkage::Local, &sig)
            .map_err(|e| JitError::Compile(e.to_string()))?;
        ctx.func.signature = sig.clone();
        let needs = {
            let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
            let needs = body(module, &mut b)?;
            b.seal_all_blocks();
            b.finalize(module.isa().frontend_config());
            needs
        };
        module
            .define_function(id, &mut ctx)
            .map_err(|e| JitError::Compile(format!("{e:?}")))?;
        module.clear_context(&mut ctx);
        Ok((id, needs))
    };
    for (i, &(tape, split)) in tapes.iter().enumerate() {
        let part = layout.parts.get(i).and_then(Option::as_ref);
        let key = part.map(|part| Key {
            at: part.key_at,
            params: part.params(),
            reads_t: part.reads_t(),
            salt,
        });
        // The function computing the tape's hoisted part, then the key.
        let time = match (part, &key) {
            (Some(part), Some(key)) => Some(define(
                &mut module,
                format!("tape{i}_time"),
                &mut |module, b| {
                    let block = b.create_block();
                    b.append_block_params_for_function_params(block);
                    b.switch_to_block(block);
                    let args = b.block_params(block).to_vec();
                    let [_, _, p, t, _, _, trig] = args[..] else {
                        return Err(JitError::Compile("signature".into()));
                    };
                    let refs = shims.map(|(id, _)| module.declare_func_in_func(id, b.func));
                    let mut emitter = Emitter::new(tape, refs, memo_base, reloads);
                    let needs = emitter.emit_time_part(b, part, [p, t, trig])?;
                    for (j, &w) in key_words(b, key, p, t)?.iter().enumerate() {
                        b.ins()
                            .store(MemFlagsData::trusted(), w, trig, offset(key.at + j)?);
                    }
                    b.ins().return_(&[]);
                    Ok(needs)
                },
            )?),
            _ => None,
        };
        let hoisted = match (part, &key, time) {
            (Some(part), Some(key), Some((time, _))) => Some((part, key, time)),
            _ => None,
        };
        let (id, needs) = if tape.len() <= chunk {
            define(&mut module, format!("tape{i}"), &mut |module, b| {
                let refs = shims.map(|(id, _)| module.declare_func_in_func(id, b.func));
                let mut emitter = Emitter::new(tape, refs, memo_base, reloads);
                if let Some((part, key, time)) = hoisted {
                    let time = module.declare_func_in_func(time, b.func);
                    emitter.hoist = Some((part, key, time));
                }
                emitter.emit(b, split)
            })?
        } else {
            // Chunks, then a function calling them in order with its own
            // arguments.
            let plan = SpillPlan::new(tape, chunk, spill_base)?;
            let mut emitter: Option<Emitter<'_>> = None;
            let mut parts = Vec::with_capacity(plan.chunks.len());
            for c in 0..plan.chunks.len() {
                let part = define(&mut module, format!("tape{i}_{c}"), &mut |module, b| {
                    let refs = shims.map(|(id, _)| module.declare_func_in_func(id, b.func));
                    let e =
                        emitter.get_or_insert_with(|| Emitter::new(tape, refs, memo_base, reloads));
                    e.shims = refs;
                    if let Some((part, key, time)) = hoisted {
                        let time = module.declare_func_in_func(time, b.func);
                        e.hoist = Some((part, key, time));
                    }
                    e.emit_chunk(b, split, &plan, c)
                })?;
                parts.push(part);
            }
            let needs = parts
                .iter()
                .map(|&(_, n)| n)
                .reduce(widest)
                .ok_or_else(|| JitError::Compile("no chunk".into()))?;
            define(&mut module, format!("tape{i}"), &mut |module, b| {
                let block = b.create_block();
                b.append_block_params_for_function_params(block);
                b.switch_to_block(block);
                let args = b.block_params(block).to_vec();
                if let Some((_, key, time)) = hoisted {
                    let time = module.declare_func_in_func(time, b.func);
                    emit_key_check(b, key, time, &args)?;
                }
                for &(part, _) in &parts {
                    let f = module.declare_func_in_func(part, b.func);
                    b.ins().call(f, &args);
                }
                b.ins().return_(&[]);
                Ok(needs)
            })?
        };
        // A tape that calls its part's function needs that one's slices
        // too.
        let needs = match time {
            Some((_, t)) => widest(needs, t),
            None => needs,
        };
        compiled.push((id, needs, tape));
    }
    module
        .finalize_definitions()
        .map_err(|e| JitError::Compile(e.to_string()))?;
    let code = Code::new(module);
    compiled
        .into_iter()
        .map(|(id, needs, tape)| {
            Ok(JitTape {
                f: TapeFn::new(&code, id, needs)?,
                outputs: tape.outputs(),
                sizes: tape.input_sizes(),
                trig: needs.trig,
            })
        })
        .collect()
}

/// Which registers each chunk of a tape stores into the scratch for later
/// chunks: those it writes that a later chunk reads before writing them
/// (live across the boundary), found by one backward scan.
struct SpillPlan {
    /// The chunks' instruction ranges, in order.
    chunks: Vec<std::ops::Range<usize>>,
    /// Per chunk, the registers it stores at their last write in it.
    out: Vec<Vec<u32>>,
    /// Where register 0 goes in the scratch.
    base: usize,
    /// Registers of the tape: the scratch holds `base + registers` values.
    registers: usize,
}

impl SpillPlan {
    fn new(tape: &Tape, chunk: usize, base: usize) -> Result<SpillPlan, JitError> {
        let instrs = tape.instructions();
        let registers = tape.registers();
        let chunks: Vec<_> = (0..instrs.len())
            .step_by(chunk)
            .map(|s| s..(s + chunk).min(instrs.len()))
            .collect();
        let mut live = vec![false; registers];
        let mut out = vec![Vec::new(); chunks.len()];
        let reg = |r: u32| -> Result<usize, JitError> {
            let r = r as usize;
            if r < registers {
                Ok(r)
            } else {
                Err(JitError::Compile(format!("register {r} out of range")))
            }
        };
        for (c, range) in chunks.iter().enumerate().rev() {
            let mut written = Vec::new();
            for ins in instrs[range.clone()].iter().rev() {
                let d = reg(ins.dst())?;
                if live[d] {
                    written.push(ins.dst());
                }
                live[d] = false;
                let (srcs, n) = ins.sources();
                for &s in &srcs[..n] {
                    live[reg(s)?] = true;
                }
            }
            // A register written twice in the chunk and live after it is
            // listed once: only its last value is stored.
            written.sort_unstable();
            written.dedup();
            out[c] = written;
        }
        Ok(SpillPlan {
            chunks,
            out,
            base,
            registers,
        })
    }
}

/// The lengths a function calling two others needs.
fn widest(a: Needs, b: Needs) -> Needs {
    Needs {
        q: a.q.max(b.q),
        qd: a.qd.max(b.qd),
        params: a.params.max(b.params),
        out: a.out.max(b.out),
        out2: a.out2.max(b.out2),
        trig: a.trig.max(b.trig),
    }
}

/// The length of cache slice that tapes compiled by
/// [`compile_split_memo_at`] with this `memo_base` need at most, known
/// without compiling them (each sin or cos of a value other than a
/// coordinate counted as a memo entry of its own).
///
/// # Errors
/// [`JitError::Compile`] if the length does not fit a `usize`.
pub fn cache_len_bound(tapes: &[(&Tape, usize)], memo_base: usize) -> Result<usize, JitError> {
    cache_len_bound_chunked(tapes, memo_base, CHUNK_INSTRUCTIONS)
}

/// [`cache_len_bound`] for [`compile_chunked`] with this `chunk`: past the
/// memo's entries, a tape compiled in chunks keeps the values crossing
/// their boundaries at `spill + r` for its register r. Not a stable
/// interface.
///
/// # Errors
/// As [`cache_len_bound`].
#[doc(hidden)]
pub fn cache_len_bound_chunked(
    tapes: &[(&Tape, usize)],
    memo_base: usize,
    chunk: usize,
) -> Result<usize, JitError> {
    Ok(hoisting(tapes, memo_base, chunk, &[])?.end)
}

/// [`cache_len_bound`] for [`compile_iterated`].
///
/// # Errors
/// As [`cache_len_bound`].
pub fn cache_len_bound_iterated(
    tapes: &[(&Tape, usize)],
    memo_base: usize,
    iterated: &[bool],
) -> Result<usize, JitError> {
    Ok(hoisting(tapes, memo_base, CHUNK_INSTRUCTIONS, iterated)?.end)
}

/// The tapes' hoisted parts (see [`crate::hoist`]), where `iterated` says
/// (a tape past its end counts as marked), after the memo and the values
/// crossing chunks.
fn hoisting(
    tapes: &[(&Tape, usize)],
    memo_base: usize,
    chunk: usize,
    iterated: &[bool],
) -> Result<Layout, JitError> {
    // Never below `memo_base`: the caller's own values lie there.
    let at = spill_end(tapes, memo_base, chunk)?.max(memo_base);
    let tapes: Vec<&Tape> = tapes.iter().map(|(t, _)| *t).collect();
    // A hoisted part is one function: up to four chunks' size it compiles
    // in about a tenth of a second (one function of 6 586 instructions:
    // 114 ms; the chain N = 1000's part is about 5 000), beyond it stays in
    // place.
    let most = chunk.max(1).saturating_mul(4);
    Layout::new(&tapes, at, most, |k| {
        iterated.get(k).copied().unwrap_or(true)
    })
    .ok_or_else(|| JitError::Compile("cache too large".into()))
}

/// The end of the memo's entries and of the values crossing chunks.
fn spill_end(tapes: &[(&Tape, usize)], memo_base: usize, chunk: usize) -> Result<usize, JitError> {
    let memo = memo_bound(tapes, memo_base)?;
    let spill = memo.max(memo_base);
    let chunk = chunk.max(1);
    tapes.iter().try_fold(memo, |m, (tape, _)| {
        if tape.len() <= chunk {
            return Ok(m);
        }
        spill
            .checked_add(tape.registers())
            .map(|n| m.max(n))
            .ok_or_else(|| JitError::Compile("cache too large".into()))
    })
}

/// Where the memo of tapes compiled with this `memo_base` ends at most in
/// the cache slice (the entries after it hold other values): for tests,
/// which check every memo entry. Not a stable interface.
///
/// # Errors
/// As [`cache_len_bound`].
#[doc(hidden)]
pub fn memo_end(tapes: &[(&Tape, usize)], memo_base: usize) -> Result<usize, JitError> {
    Ok(memo_bound(tapes, memo_base)?.max(memo_base))
}

/// The end of the coordinates' cache and the memo's last possible entry.
fn memo_bound(tapes: &[(&Tape, usize)], memo_base: usize) -> Result<usize, JitError> {
    let too_large = || JitError::Compile("cache too large".into());
    tapes.iter().try_fold(0, |m, (tape, _)| {
        let sites = tape
            .instructions()
            .iter()
            .filter(|i| {
                matches!(
                    i,
                    Instr::Sin { .. }
                        | Instr::Cos { .. }
                        | Instr::Unary {
                            op: kinema_expr::UnaryOp::Sin | kinema_expr::UnaryOp::Cos,
                            ..
                        }
                )
            })
            .count();
        let memo = if sites == 0 {
            0
        } else {
            sites
                .checked_mul(3)
                .and_then(|k| k.checked_add(memo_base))
                .ok_or_else(too_large)?
        };
        Ok(m.max(trig_len(tape)?).max(memo))
    })
}

/// Whether Cranelift can generate code for this machine.
///
/// # Errors
/// [`JitError::Host`] if it cannot.
pub fn host_supported() -> Result<(), JitError> {
    cranelift_native::builder()
        .map(|_| ())
        .map_err(|e| JitError::Host(e.to_owned()))
}

/// A JIT module for the host, with the shims as symbols.
pub(crate) fn new_module() -> Result<JITModule, JitError> {
    let mut flags = settings::builder();
    // Cranelift's IR verifier checks the emitters' functions in debug
    // builds (every test); in release it was a third of the compile time
    // (perf of the chain N = 1000's background compilation) spent
    // re-checking IR that the same emitters produce.
    let verify = if cfg!(debug_assertions) {
        "true"
    } else {
        "false"
    };
    for (k, v) in [
        ("is_pic", "false"),
        ("opt_level", "speed"),
        ("enable_verifier", verify),
    ] {
        flags
            .set(k, v)
            .map_err(|e| JitError::Host(format!("{k}={v}: {e}")))?;
    }
    let isa = cranelift_native::builder()
        .map_err(|e| JitError::Host(e.to_owned()))?
        .finish(settings::Flags::new(flags))
        .map_err(|e| JitError::Host(e.to_string()))?;
    let mut builder = JITBuilder::with_isa(isa, cranelift_module::default_libcall_names());
    for s in shims::all() {
        builder.symbol(s.name, s.address);
    }
    Ok(JITModule::new(builder))
}

/// Declares the shims as imports: (id, signature) by [`Which`].
fn declare_shims(module: &mut JITModule) -> Result<[(FuncId, ()); 5], JitError> {
    let all = shims::all();
    let ptr = module.target_config().pointer_type();
    let mut ids = Vec::with_capacity(all.len());
    for s in &all {
        let mut sig: Signature = module.make_signature();
        let params: &[_] = match s.shape {
            Shape::FI => &[F64, I32],
            Shape::FF => &[F64, F64],
            Shape::IF => &[I32, F64],
            Shape::FP => &[F64, ptr],
        };
        sig.params.extend(params.iter().map(|&t| AbiParam::new(t)));
        if !matches!(s.shape, Shape::FP) {
            sig.returns.push(AbiParam::new(F64));
        }
        let id = module
            .declare_function(s.name, Linkage::Import, &sig)
            .map_err(|e| JitError::Compile(e.to_string()))?;
        ids.push((id, ()));
    }
    ids.try_into()
        .map_err(|_| JitError::Compile("shim table".into()))
}

/// What a register holds while a tape's function is emitted.
#[derive(Clone, Copy)]
enum Slot {
    /// Nothing yet: reading it is an error.
    Empty,
    /// An SSA value.
    Ready(Value),
    /// An input: (slice pointer, byte offset). Loaded at a read and reused
    /// within `window` instructions (see [`Reloads`]), so that it does not
    /// live (spilled across the sin/cos calls) from the function's start.
    Input(Value, i32),
    /// A value an earlier chunk left in the scratch at this byte offset,
    /// loaded at the first read.
    Spill(i32),
}

/// Where the outputs go: `out[k]` below the split, `out2[k - split]` above.
struct Sink {
    out: Value,
    out2: Value,
    split: usize,
    outputs: usize,
    /// Whether output k's current value is stored.
    stored: Vec<bool>,
}

/// Emits one tape's function.
struct Emitter<'t> {
    tape: &'t Tape,
    shims: [FuncRef; 5],
    /// What each register holds now.
    vals: Vec<Slot>,
    /// The outputs' destinations (set at the function's start).
    sink: Option<Sink>,
    /// (sin, cos) of values other than coordinates, already computed
    /// through the memo.
    memo: HashMap<Value, (Value, Value)>,
    /// The memo's next free entry in the cache slice.
    memo_next: usize,
    /// The sin/cos cache's pointer.
    trig: Option<Value>,
    /// Coordinates whose cache entry this function has brought up to date.
    filled: HashSet<u32>,
    /// sin (false) or cos (true) of coordinate k as last loaded from the
    /// cache, with the instruction it was loaded at: reused within
    /// `window` instructions, loaded again after (a value kept live across
    /// a long tape is spilled to the stack and reloaded anyway, at the
    /// price of a store; see [`Reloads`]).
    loaded: HashMap<(u32, bool), (Value, usize)>,
    /// The instruction being emitted (index in the function).
    tick: usize,
    /// When values loaded from memory are loaded again.
    reloads: Reloads,
    /// How many instructions a value loaded from memory is reused for in
    /// this function.
    window: usize,
    /// Per register holding an input, its value as last loaded and the
    /// instruction it was loaded at (reused within `window` instructions,
    /// as `loaded`).
    inputs: HashMap<u32, (Value, usize)>,
    /// Where the memo starts.
    memo_start: usize,
    /// Index of the last instruction writing each output (filled once).
    last_write: Vec<usize>,
    /// Registers written by the chunks emitted so far (chunked tapes).
    written: Vec<bool>,
    /// The tape's hoisted part, its key, and the function computing it.
    hoist: Option<(&'t Part, &'t Key<'t>, FuncRef)>,
    /// Per register, where its value is kept if a hoisted instruction
    /// wrote it last (a later chunk reads it there).
    kept_def: Vec<Option<usize>>,
}

/// The key of a tape's hoisted part in the cache slice (see
/// [`crate::hoist`]).
struct Key<'a> {
    /// Where it starts.
    at: usize,
    /// The parameters it holds after t's two words.
    params: &'a [u32],
    /// Whether it holds t (else 0 in its place).
    reads_t: bool,
    /// The compilation's salt.
    salt: u64,
}

/// The key's words as they should be for the arguments `p` (parameters)
/// and `t`: t's bits, the same XORed with the salt, each parameter's bits.
fn key_words(
    b: &mut FunctionBuilder<'_>,
    key: &Key<'_>,
    p: Value,
    t: Value,
) -> Result<Vec<Value>, JitError> {
    let t_bits = if key.reads_t {
        b.ins().bitcast(I64, MemFlagsData::new(), t)
    } else {
        b.ins().iconst(I64, 0)
    };
    let salt = b.ins().iconst(I64, key.salt.cast_signed());
    let salted = b.ins().bxor(t_bits, salt);
    let mut words = vec![t_bits, salted];
    for &k in key.params {
        words.push(
            b.ins()
                .load(I64, MemFlagsData::trusted(), p, offset(k as usize)?),
        );
    }
    Ok(words)
}

/// At a function's start (`args` its arguments): the key compared with
/// the arguments and, on a difference, `time` (the hoisted part's
/// function) called with them; the function goes on in a block after
/// both.
fn emit_key_check(
    b: &mut FunctionBuilder<'_>,
    key: &Key<'_>,
    time: FuncRef,
    args: &[Value],
) -> Result<(), JitError> {
    let [_, _, p, t, _, _, trig] = args[..] else {
        return Err(JitError::Compile("signature".into()));
    };
    let want = key_words(b, key, p, t)?;
    let mut same = None;
    for (j, &w) in want.iter().enumerate() {
        let seen = b
            .ins()
            .load(I64, MemFlagsData::trusted(), trig, offset(key.at + j)?);
        let eq = b.ins().icmp(IntCC::Equal, seen, w);
        same = Some(match same {
            Some(s) => b.ins().band(s, eq),
            None => eq,
        });
    }
    let same = same.ok_or_else(|| JitError::Compile("no key".into()))?;
    let (compute, rest) = (b.create_block(), b.create_block());
    b.ins().brif(same, rest, &[], compute, &[]);
    b.switch_to_block(compute);
    b.ins().call(time, args);
    b.ins().jump(rest, &[]);
    b.switch_to_block(rest);
    Ok(())
}

impl<'t> Emitter<'t> {
    fn new(tape: &'t Tape, shims: [FuncRef; 5], memo_next: usize, reloads: Reloads) -> Emitter<'t> {
        Emitter {
            tape,
            shims,
            vals: vec![Slot::Empty; tape.registers()],
            sink: None,
            memo: HashMap::new(),
            memo_next,
            trig: None,
            filled: HashSet::new(),
            loaded: HashMap::new(),
            tick: 0,
            reloads,
            window: usize::MAX,
            inputs: HashMap::new(),
            memo_start: memo_next,
            last_write: Vec::new(),
            written: Vec::new(),
            hoist: None,
            kept_def: vec![None; tape.registers()],
        }
    }

    /// Emits the body; returns the slice lengths every load and store was
    /// checked against.
    fn emit(&mut self, b: &mut FunctionBuilder<'_>, split: usize) -> Result<Needs, JitError> {
        self.emit_range(b, split, 0..self.tape.len(), None)
    }

    /// Emits chunk `c` of `plan` (the emitter is used for the chunks in
    /// order): its instructions, reading the values earlier chunks left in
    /// the scratch and leaving there those later ones read.
    fn emit_chunk(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        split: usize,
        plan: &SpillPlan,
        c: usize,
    ) -> Result<Needs, JitError> {
        let range = plan
            .chunks
            .get(c)
            .cloned()
            .ok_or_else(|| JitError::Compile("no such chunk".into()))?;
        self.emit_range(b, split, range, Some((plan, c)))
    }

    /// Emits instructions `range` of the tape as one function.
    fn emit_range(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        split: usize,
        range: std::ops::Range<usize>,
        chunk: Option<(&SpillPlan, usize)>,
    ) -> Result<Needs, JitError> {
        let block = b.create_block();
        b.append_block_params_for_function_params(block);
        b.switch_to_block(block);
        let params = b.block_params(block).to_vec();
        let [q, qd, p, t, out, out2, trig] = params[..] else {
            return Err(JitError::Compile("signature".into()));
        };
        let (nq, nqd, np) = self.tape.input_sizes();
        let layout = self.tape.layout();
        let split = split.min(layout.outputs);
        let mut needs = Needs {
            q: nq,
            qd: nqd,
            params: np,
            out: split,
            out2: layout.outputs - split,
            trig: trig_len(self.tape)?,
        };
        // A new function: no value of the last one is visible here.
        self.vals.fill(Slot::Empty);
        self.memo.clear();
        self.filled.clear();
        self.loaded.clear();
        self.inputs.clear();
        self.tick = 0;
        self.window = if range.len() > self.reloads.from {
            self.reloads.window
        } else {
            usize::MAX
        };
        self.trig = Some(trig);
        let stored = match self.sink.take() {
            Some(sink) => sink.stored,
            None => vec![false; layout.outputs],
        };
        self.sink = Some(Sink {
            out,
            out2,
            split,
            outputs: layout.outputs,
            stored,
        });
        // Inputs where the tape's layout has them (loaded at their first
        // read; every offset below its slice's checked length), constants.
        self.start_registers(
            b,
            &[
                (layout.q_base, nq, q),
                (layout.qd_base, nqd, qd),
                (layout.params_base, np, p),
            ],
            t,
        )?;
        // Registers earlier chunks wrote: in the scratch if this chunk or
        // a later one reads them (else never read again).
        let mut spill_here = Vec::new();
        if let Some((plan, c)) = chunk {
            needs.trig = needs.trig.max(
                plan.base
                    .checked_add(plan.registers)
                    .ok_or_else(|| JitError::Compile("cache too large".into()))?,
            );
            for (r, slot) in self.vals.iter_mut().enumerate() {
                if self.written.get(r) == Some(&true) {
                    // A hoisted value where it is kept; others where the
                    // chunk that wrote them stored them.
                    let at = self.kept_def.get(r).copied().flatten();
                    *slot = Slot::Spill(offset(at.unwrap_or(plan.base + r))?);
                }
            }
            spill_here = vec![false; plan.registers];
            for &r in plan.out.get(c).map_or(&[][..], Vec::as_slice) {
                if let Some(s) = spill_here.get_mut(r as usize) {
                    *s = true;
                }
            }
            if self.written.is_empty() {
                self.written = vec![false; plan.registers];
            }
        }
        let instrs = self
            .tape
            .instructions()
            .get(range.clone())
            .ok_or_else(|| JitError::Compile("chunk out of range".into()))?;
        if let Some((part, key, time)) = self.hoist {
            needs.trig = needs.trig.max(part.end());
            // A chunk's caller checks the key.
            if chunk.is_none() {
                emit_key_check(b, key, time, &params)?;
            }
        }
        // The coordinates' cache entries brought up to date first, while
        // nothing is live: each may call out, and a call spills every live
        // value. Their uses load them from there.
        for ins in instrs {
            if let Instr::SinQ { k, .. } | Instr::CosQ { k, .. } = *ins
                && (k as usize) < nq
            {
                let a = register(layout.q_base + k as usize)?;
                self.fill(b, a, k)?;
            }
        }
        // Each output is stored once, by the last instruction writing it;
        // each register a later chunk reads, by the last writing it here.
        if self.last_write.is_empty() {
            self.last_write = vec![usize::MAX; layout.outputs];
            for (i, ins) in self.tape.instructions().iter().enumerate() {
                if let Some(w) = self.last_write.get_mut(ins.dst() as usize) {
                    *w = i;
                }
            }
        }
        let mut last_here = Vec::new();
        if !spill_here.is_empty() {
            last_here = vec![usize::MAX; spill_here.len()];
            for (i, ins) in instrs.iter().enumerate() {
                if let Some(w) = last_here.get_mut(ins.dst() as usize) {
                    *w = i;
                }
            }
        }
        for (i, ins) in instrs.iter().enumerate() {
            let dst = ins.dst() as usize;
            self.tick = i;
            let at = range.start + i;
            if let Some((part, _, _)) = self.hoist
                && part.hoisted.is_hoisted(at)
            {
                let (h, kept_at) = (&part.hoisted, part.kept_at);
                // Computed by the hoisted parts' function: its kept value
                // read from the cache where the rest reads it (never read
                // otherwise).
                let kept = h.kept(at).map(|e| kept_at + e);
                let slot = match kept {
                    Some(k) => Slot::Spill(offset(k)?),
                    None => Slot::Empty,
                };
                self.set_slot(dst, slot)?;
                if let Some(w) = self.written.get_mut(dst) {
                    *w = true;
                }
                if let Some(k) = self.kept_def.get_mut(dst) {
                    *k = kept;
                }
                if self.last_write.get(dst) == Some(&at) {
                    let v = self.get(b, ins.dst())?;
                    self.store_output(b, dst, v)?;
                }
                continue;
            }
            if let Some(k) = self.kept_def.get_mut(dst) {
                *k = None;
            }
            let v = self.instr(b, *ins)?;
            if self.last_write.get(dst) == Some(&(range.start + i)) {
                self.store_output(b, dst, v)?;
            }
            if last_here.get(dst) == Some(&i) && spill_here.get(dst) == Some(&true) {
                let (plan, _) = chunk.ok_or_else(|| JitError::Compile("no plan".into()))?;
                b.ins()
                    .store(MemFlagsData::trusted(), v, trig, offset(plan.base + dst)?);
            }
            if let Some(w) = self.written.get_mut(dst) {
                *w = true;
            }
        }
        // Outputs whose last value is not stored yet (each instruction's
        // result is stored as it is made: its value dies there).
        if range.end >= self.tape.len() {
            for k in 0..layout.outputs {
                if self.sink.as_ref().is_some_and(|s| s.stored[k]) {
                    continue;
                }
                let v = self.get(b, register(k)?)?;
                self.store_output(b, k, v)?;
            }
        }
        b.ins().return_(&[]);
        if self.memo_next > self.memo_start {
            needs.trig = needs.trig.max(self.memo_next);
        }
        Ok(needs)
    }

    /// The register file at a function's start: each input `(base, n,
    /// pointer)` in its registers (loaded at its first read), t and the
    /// constants.
    fn start_registers(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        inputs: &[(usize, usize, Value)],
        t: Value,
    ) -> Result<(), JitError> {
        let layout = self.tape.layout();
        for &(base, n, ptr) in inputs {
            for k in 0..n {
                let slot = self
                    .vals
                    .get_mut(base + k)
                    .ok_or_else(|| JitError::Compile("input register out of range".into()))?;
                *slot = Slot::Input(ptr, offset(k)?);
            }
        }
        if let Some(r) = layout.t_register {
            self.set(r, t)?;
        }
        for (k, &c) in layout.consts.iter().enumerate() {
            let v = b.ins().f64const(c);
            self.set(layout.consts_base + k, v)?;
        }
        Ok(())
    }

    fn set(&mut self, r: usize, v: Value) -> Result<(), JitError> {
        self.set_slot(r, Slot::Ready(v))
    }

    /// Register `r` now holds `slot` (a new value: its output, if it is
    /// one, not stored).
    fn set_slot(&mut self, r: usize, slot: Slot) -> Result<(), JitError> {
        let at = self
            .vals
            .get_mut(r)
            .ok_or_else(|| JitError::Compile(format!("register {r} out of range")))?;
        *at = slot;
        if let Some(stored) = self.sink.as_mut().and_then(|s| s.stored.get_mut(r)) {
            *stored = false;
        }
        Ok(())
    }

    /// The hoisted part `h` of this emitter's tape, as a part of the
    /// hoisted parts' function (arguments `params`, `t`, `trig`): computed
    /// on the tape's registers from the function's inputs, each value the
    /// rest of the tape reads stored at `kept_at` on. Returns the slice
    /// lengths its loads and stores were checked against.
    fn emit_time_part(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        part: &Part,
        [params, t, trig]: [Value; 3],
    ) -> Result<Needs, JitError> {
        let (h, kept_at) = (&part.hoisted, part.kept_at);
        let layout = self.tape.layout();
        let (_, _, np) = self.tape.input_sizes();
        self.vals.fill(Slot::Empty);
        self.memo.clear();
        self.inputs.clear();
        self.loaded.clear();
        self.filled.clear();
        self.tick = 0;
        self.window = usize::MAX;
        self.trig = Some(trig);
        self.sink = None;
        self.start_registers(b, &[(layout.params_base, np, params)], t)?;
        let flags = MemFlagsData::trusted();
        for (i, ins) in self.tape.instructions().iter().enumerate() {
            if !h.in_hoisted(i) {
                continue;
            }
            let v = self.instr(b, *ins)?;
            if let Some(e) = h.kept(i) {
                b.ins().store(flags, v, trig, offset(kept_at + e)?);
            }
        }
        Ok(Needs {
            q: 0,
            qd: 0,
            params: np,
            out: 0,
            out2: 0,
            trig: self.memo_next.max(part.end()),
        })
    }

    /// The value of register `r`, loading an input at its first read.
    fn get(&mut self, b: &mut FunctionBuilder<'_>, r: u32) -> Result<Value, JitError> {
        match self.vals.get(r as usize).copied() {
            Some(Slot::Ready(v)) => Ok(v),
            Some(Slot::Input(ptr, at)) => {
                // Not read-only, so that Cranelift does not merge a reload
                // with an earlier load (a value live from there).
                if let Some(&(v, loaded)) = self.inputs.get(&r)
                    && self.tick.saturating_sub(loaded) <= self.window
                {
                    return Ok(v);
                }
                let v = b.ins().load(F64, MemFlagsData::trusted(), ptr, at);
                self.inputs.insert(r, (v, self.tick));
                Ok(v)
            }
            Some(Slot::Spill(at)) => {
                let trig = self
                    .trig
                    .ok_or_else(|| JitError::Compile("no cache pointer".into()))?;
                // Not read-only: a later store of this chunk may rewrite it.
                let v = b.ins().load(F64, MemFlagsData::trusted(), trig, at);
                self.vals[r as usize] = Slot::Ready(v);
                Ok(v)
            }
            Some(Slot::Empty) | None => Err(JitError::Compile(format!(
                "register {r} read before it is written"
            ))),
        }
    }

    /// Stores output `k`'s value `v` unless it is stored already.
    fn store_output(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        k: usize,
        v: Value,
    ) -> Result<(), JitError> {
        let Some(sink) = self.sink.as_mut() else {
            return Ok(());
        };
        if k >= sink.outputs || sink.stored[k] {
            return Ok(());
        }
        let (ptr, at) = if k < sink.split {
            (sink.out, k)
        } else {
            (sink.out2, k - sink.split)
        };
        b.ins().store(MemFlagsData::trusted(), v, ptr, offset(at)?);
        sink.stored[k] = true;
        Ok(())
    }

    /// `shim(args)`.
    fn call(&mut self, b: &mut FunctionBuilder<'_>, which: Which, args: &[Value]) -> Value {
        let call = b.ins().call(self.shims[which as usize], args);
        b.inst_results(call)[0]
    }

    /// (sin x, cos x) of a value other than a coordinate: once per value in
    /// this function, and through a memo entry of the cache slice across
    /// calls (see [`compile_split_memo_at`]).
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
    fn fill(&mut self, b: &mut FunctionBuilder<'_>, a: u32, k: u32) -> Result<(), JitError> {
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
    fn instr(&mut self, b: &mut FunctionBuilder<'_>, ins: Instr) -> Result<Value, JitError> {
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

/// Length of the sin/cos cache a tape reads: 3 per coordinate up to the
/// last whose sin or cos it takes.
fn trig_len(tape: &Tape) -> Result<usize, JitError> {
    let last = tape
        .instructions()
        .iter()
        .filter_map(|i| match *i {
            Instr::SinQ { k, .. } | Instr::CosQ { k, .. } => Some(k as usize),
            _ => None,
        })
        .max();
    last.map_or(Ok(0), |k| {
        k.checked_add(1)
            .and_then(|n| n.checked_mul(3))
            .ok_or_else(|| JitError::Compile("cache too large".into()))
    })
}

fn register(k: usize) -> Result<u32, JitError> {
    u32::try_from(k).map_err(|_| JitError::Compile("too many outputs".into()))
}

/// Byte offset of element `k` of an f64 slice.
fn offset(k: usize) -> Result<i32, JitError> {
    k.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| JitError::Compile("a slice too long for the JIT".into()))
}
