//! One tape's function emitted as Cranelift IR: the emitter's state (what
//! each register holds, where the outputs go, the memo, the reloads),
//! a function's start and its chunks, the hoisted part and the key that
//! guards it. The instructions themselves are emitted in `instr`.

mod instr;

use std::collections::{HashMap, HashSet};

use cranelift_codegen::ir::{
    FuncRef, InstBuilder, MemFlagsData, Value, condcodes::IntCC, types::F64, types::I64,
};
use cranelift_frontend::FunctionBuilder;
use kinema_expr::{Instr, Tape};

use super::Reloads;
use super::layout::{SpillPlan, trig_len};
use crate::JitError;
use crate::code::Needs;
use crate::hoist::Part;

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
pub(super) struct Emitter<'t> {
    tape: &'t Tape,
    pub(super) shims: [FuncRef; 5],
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
    pub(super) hoist: Option<(&'t Part, &'t Key<'t>, FuncRef)>,
    /// Per register, where its value is kept if a hoisted instruction
    /// wrote it last (a later chunk reads it there).
    kept_def: Vec<Option<usize>>,
}

/// The key of a tape's hoisted part in the cache slice (see
/// [`crate::hoist`]).
pub(super) struct Key<'a> {
    /// Where it starts.
    pub(super) at: usize,
    /// The parameters it holds after t's two words.
    pub(super) params: &'a [u32],
    /// Whether it holds t (else 0 in its place).
    pub(super) reads_t: bool,
    /// The compilation's salt.
    pub(super) salt: u64,
}

/// The key's words as they should be for the arguments `p` (parameters)
/// and `t`: t's bits, the same XORed with the salt, each parameter's bits.
pub(super) fn key_words(
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
pub(super) fn emit_key_check(
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
    pub(super) fn new(
        tape: &'t Tape,
        shims: [FuncRef; 5],
        memo_next: usize,
        reloads: Reloads,
    ) -> Emitter<'t> {
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
    pub(super) fn emit(
        &mut self,
        b: &mut FunctionBuilder<'_>,
        split: usize,
    ) -> Result<Needs, JitError> {
        self.emit_range(b, split, 0..self.tape.len(), None)
    }

    /// Emits chunk `c` of `plan` (the emitter is used for the chunks in
    /// order): its instructions, reading the values earlier chunks left in
    /// the scratch and leaving there those later ones read.
    pub(super) fn emit_chunk(
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
    pub(super) fn emit_time_part(
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
}

fn register(k: usize) -> Result<u32, JitError> {
    u32::try_from(k).map_err(|_| JitError::Compile("too many outputs".into()))
}

/// Byte offset of element `k` of an f64 slice.
pub(super) fn offset(k: usize) -> Result<i32, JitError> {
    k.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| JitError::Compile("a slice too long for the JIT".into()))
}
