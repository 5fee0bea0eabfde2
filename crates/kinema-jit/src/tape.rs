//! Tapes to Cranelift IR: one straight-line function per tape.
//!
//! Here the public interface and the compilation's driver (a module, the
//! functions defined in it, chunked or not, their hoisted parts); where
//! values live in the cache slice is decided in `layout`, and a tape's
//! instructions become IR in `emit`.

mod emit;
mod layout;

use emit::{Emitter, Key, emit_key_check, key_words, offset};
use layout::{SpillPlan, hoisting, memo_bound, trig_len};

pub use layout::{cache_len_bound, cache_len_bound_chunked, cache_len_bound_iterated, memo_end};

use cranelift_codegen::ir::{
    AbiParam, InstBuilder, MemFlagsData, Signature, types::F64, types::I32,
};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{FuncId, Linkage, Module};
use kinema_expr::{Tape, TapeInputs};

use crate::JitError;
use crate::code::{Code, Needs, TapeFn};
use crate::hoist::{self};
use crate::shims::{self, Shape};

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
///
/// [`Which`]: crate::shims::Which
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
