//! [`Backend::Jit`](crate::Backend::Jit): the hot path's tapes and the
//! folded LU compiled to native code in the background.
//!
//! Building a system queues the compilation on the process's compiling
//! thread (one for all systems) and returns at once; until the code is
//! ready every evaluation runs on the tape, then on the compiled code. The two compute the same numbers bit for bit
//! (kinema-jit's property tests, `tests/backends.rs`), so results do not
//! depend on when the switch happens, and a run is never slower than the
//! interpreter's by more than the compiler's share of the cores: a short run
//! (the Strider's 360 steps take 1.5 ms on the tape; Cranelift takes about
//! 8 ms on its tapes and LU) finishes on the tape, a long one or a sweep
//! spends nearly all its steps in compiled code.

use std::sync::mpsc::{self, Sender};
use std::sync::{Arc, Condvar, Mutex, OnceLock, PoisonError};

use kinema_expr::{Tape, TapeInputs};
use kinema_jit::{JitError, JitTape};
use kinema_runtime::linalg::{
    CompiledFactor, CompiledSolves, FoldedFactor, FoldedSolves, Op, RawScan, SolveOp,
};

/// The tapes of the runtime's hot path, compiled.
#[derive(Clone, Debug)]
pub(crate) struct Compiled {
    pub(crate) phi: JitTape,
    pub(crate) jacobian: JitTape,
    /// Φ then Φ_q's values, split between the two.
    pub(crate) both: JitTape,
    pub(crate) nu: JitTape,
    pub(crate) gamma: JitTape,
}

/// The hot path's tapes (Φ, Φ_q, both, ν, γ) and where Φ ends in `both`.
pub(crate) struct HotTapes<'t> {
    pub(crate) phi: &'t Tape,
    pub(crate) jacobian: &'t Tape,
    pub(crate) both: &'t Tape,
    pub(crate) nu: &'t Tape,
    pub(crate) gamma: &'t Tape,
    pub(crate) n_phi: usize,
}

/// Which of [`HotTapes::splits`] a step evaluates several times at one
/// time (Φ, Φ_q, both: each Newton iteration), and so keep their part that
/// reads neither q nor q̇ across calls; ν and γ are evaluated once per
/// time.
const ITERATED: [bool; 5] = [true, true, true, false, false];

impl HotTapes<'_> {
    fn splits(&self) -> [(&Tape, usize); 5] {
        [
            (self.phi, self.phi.outputs()),
            (self.jacobian, self.jacobian.outputs()),
            (self.both, self.n_phi),
            (self.nu, self.nu.outputs()),
            (self.gamma, self.gamma.outputs()),
        ]
    }
}

impl Compiled {
    fn new(splits: &[(&Tape, usize)], memo_base: usize) -> Result<Compiled, JitError> {
        let mut all = kinema_jit::compile_iterated(splits, memo_base, &ITERATED)?.into_iter();
        let mut next = || {
            all.next()
                .ok_or_else(|| JitError::Compile("a tape is missing".into()))
        };
        Ok(Compiled {
            phi: next()?,
            jacobian: next()?,
            both: next()?,
            nu: next()?,
            gamma: next()?,
        })
    }
}

/// A compilation to run on the JIT's thread.
type Job = Box<dyn FnOnce() + Send>;

/// The compilations submitted and not finished, with a signal at each end.
#[derive(Debug, Default)]
struct Progress {
    pending: Mutex<usize>,
    done: Condvar,
}

impl Progress {
    fn add(&self) {
        *self.pending.lock().unwrap_or_else(PoisonError::into_inner) += 1;
    }

    fn finish(&self) {
        let mut pending = self.pending.lock().unwrap_or_else(PoisonError::into_inner);
        *pending = pending.saturating_sub(1);
        self.done.notify_all();
    }

    /// Runs `job` (a panic in it is contained: that work stays the
    /// interpreter's) and counts it finished.
    fn run(&self, job: Job) {
        drop(std::panic::catch_unwind(std::panic::AssertUnwindSafe(job)));
        self.finish();
    }
}

/// A compilation and the progress it counts toward.
struct Queued {
    job: Job,
    progress: Arc<Progress>,
}

/// The process's compiling thread, shared by every system: compilations run
/// one at a time, in the order asked, on one core, and a run keeps the
/// others. `None` if the thread could not be started (jobs then run in
/// place).
fn queue() -> Option<&'static Mutex<Sender<Queued>>> {
    static QUEUE: OnceLock<Option<Mutex<Sender<Queued>>>> = OnceLock::new();
    QUEUE
        .get_or_init(|| {
            let (sender, jobs) = mpsc::channel::<Queued>();
            std::thread::Builder::new()
                .name("kinema-jit".into())
                .spawn(move || {
                    for queued in jobs {
                        queued.progress.run(queued.job);
                    }
                })
                .ok()
                .map(|_| Mutex::new(sender))
        })
        .as_ref()
}

/// The JIT of one system, shared by its clones (a sweep's workers). Its
/// compilations (the tapes', then each solver's LU) go to the process's
/// compiling thread; one whose result nobody holds any more when its turn
/// comes (a short run's system already dropped) is skipped.
#[derive(Debug)]
pub(crate) struct Jit {
    /// The compiled tapes, or why they could not be; empty while compiling.
    /// Inline, not behind an `Arc` of its own: every compiled evaluation
    /// reads it, and each pointer on the way is a load the call waits for
    /// (the compiling thread holds a weak reference to the whole `Jit`).
    tapes: OnceLock<Result<Compiled, String>>,
    /// The scratch the compiled tapes may use, known before they are: the
    /// coordinates' sin/cos cache and the memo after the interpreter's
    /// registers.
    cache_len: usize,
    /// This JIT's compilations not finished yet.
    progress: Arc<Progress>,
}

impl Jit {
    /// Starts compiling `hot` in the background, the memo of sines and
    /// cosines at `memo_base` in the scratch. `Err` (why) at once if the
    /// tapes are over the JIT's bound or the host cannot be targeted.
    pub(crate) fn start(hot: &HotTapes<'_>, memo_base: usize) -> Result<Arc<Jit>, String> {
        let splits = hot.splits();
        let instructions: usize = splits.iter().map(|(t, _)| t.len()).sum();
        if instructions > kinema_jit::MAX_INSTRUCTIONS {
            return Err(JitError::TooLarge { instructions }.to_string());
        }
        kinema_jit::host_supported().map_err(|e| e.to_string())?;
        let cache_len = kinema_jit::cache_len_bound_iterated(&splits, memo_base, &ITERATED)
            .map_err(|e| e.to_string())?;
        let jit = Arc::new(Jit {
            tapes: OnceLock::new(),
            cache_len,
            progress: Arc::new(Progress::default()),
        });
        let owned: Vec<(Tape, usize)> = splits.iter().map(|&(t, s)| (t.clone(), s)).collect();
        let target = Arc::downgrade(&jit);
        jit.submit(Box::new(move || {
            let Some(target) = target.upgrade() else {
                return;
            };
            let splits: Vec<(&Tape, usize)> = owned.iter().map(|(t, s)| (t, *s)).collect();
            let result = Compiled::new(&splits, memo_base).map_err(|e| e.to_string());
            let _ = target.tapes.set(result);
        }));
        Ok(jit)
    }

    /// The compiled tapes, once they are ready.
    #[inline]
    pub(crate) fn compiled(&self) -> Option<&Compiled> {
        self.tapes.get()?.as_ref().ok()
    }

    /// Why the compilation failed, once it has.
    pub(crate) fn failure(&self) -> Option<&str> {
        self.tapes.get()?.as_ref().err().map(String::as_str)
    }

    /// Length of the scratch the compiled tapes may use.
    pub(crate) fn cache_len(&self) -> usize {
        self.cache_len
    }

    /// Blocks until every compilation submitted so far has finished.
    pub(crate) fn wait(&self) {
        let mut pending = self
            .progress
            .pending
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        while *pending > 0 {
            pending = self
                .progress
                .done
                .wait(pending)
                .unwrap_or_else(PoisonError::into_inner);
        }
    }

    /// Queues `job` on the compiling thread (runs it in place if there is
    /// none).
    fn submit(&self, job: Job) {
        self.progress.add();
        let queued = Queued {
            job,
            progress: Arc::clone(&self.progress),
        };
        let refused = match queue() {
            Some(queue) => queue
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .send(queued)
                .err()
                .map(|e| e.0),
            None => Some(queued),
        };
        if let Some(queued) = refused {
            queued.progress.run(queued.job);
        }
    }

    /// Whether the tapes' compilation has finished (well or not).
    fn settled(&self) -> bool {
        self.tapes.get().is_some()
    }

    /// The folded LU's factorization compiled: at once if the tapes'
    /// compilation has finished (a solver built after
    /// [`wait`](Self::wait); `None` if that fails), else in the background,
    /// the interpreter factoring until it is ready.
    pub(crate) fn factor(&self, plan: &FoldedFactor<'_>) -> Option<Box<dyn CompiledFactor>> {
        if self.settled() {
            // Plugged in directly: no slot to look through at every call.
            let compiled = kinema_jit::compile_factor(plan).ok()?;
            return Some(Box::new(compiled));
        }
        let slot = self.later(OwnedFactor::new(plan), |owned| {
            kinema_jit::compile_factor(&owned.view()).ok()
        });
        Some(Box::new(LazyFactor { slot }))
    }

    /// The folded LU's solves compiled, as [`factor`](Self::factor).
    pub(crate) fn solves(&self, plan: &FoldedSolves<'_>) -> Option<Box<dyn CompiledSolves>> {
        if self.settled() {
            let compiled = kinema_jit::compile_solves(plan).ok()?;
            return Some(Box::new(compiled));
        }
        let slot = self.later(OwnedSolves::new(plan), |owned| {
            kinema_jit::compile_solves(&owned.view()).ok()
        });
        Some(Box::new(LazySolves { slot }))
    }

    /// A slot filled by `compile` on `owned` (a copy of the plan), queued
    /// on the compiling thread (skipped if nobody holds the slot by then).
    fn later<T: Send + Sync + 'static, O: Send + 'static>(
        &self,
        owned: O,
        compile: fn(&O) -> Option<T>,
    ) -> Arc<OnceLock<Option<T>>> {
        let slot = Arc::new(OnceLock::new());
        let target = Arc::downgrade(&slot);
        self.submit(Box::new(move || {
            if let Some(target) = target.upgrade() {
                let _ = target.set(compile(&owned));
            }
        }));
        slot
    }
}

/// Runs a compiled tape into `out` through the scratch `trig`; NaN on a
/// size mismatch (as the tape's run).
#[inline]
pub(crate) fn run(f: &JitTape, inputs: &TapeInputs<'_>, trig: &mut [f64], out: &mut [f64]) {
    if out.len() != f.outputs() || f.eval_with_cache(inputs, trig, out).is_err() {
        crate::model::poison(&mut [out]);
    }
}

/// A factorization compiled in the background.
#[derive(Debug)]
struct LazyFactor {
    slot: Arc<OnceLock<Option<kinema_jit::JitFactor>>>,
}

impl CompiledFactor for LazyFactor {
    #[inline]
    fn factor(&self, values: &[f64], v: &mut [f64], check: bool, scan: &mut RawScan) -> bool {
        match self.slot.get() {
            Some(Some(f)) => f.factor(values, v, check, scan),
            _ => false,
        }
    }
}

/// Solves compiled in the background.
#[derive(Debug)]
struct LazySolves {
    slot: Arc<OnceLock<Option<kinema_jit::JitSolves>>>,
}

impl CompiledSolves for LazySolves {
    #[inline]
    fn solve(&self, v: &[f64], rhs: &mut [f64], work: &mut [f64], transpose: bool) -> bool {
        match self.slot.get() {
            Some(Some(s)) => s.solve(v, rhs, work, transpose),
            _ => false,
        }
    }
}

/// A [`FoldedFactor`]'s lists, owned (for the compiling thread).
struct OwnedFactor {
    nnz: usize,
    values: usize,
    inputs: Vec<u32>,
    constants: Vec<(u32, f64)>,
    ops: Vec<Op>,
    pivot_vars: Vec<u32>,
    multiplier_vars: Vec<u32>,
    const_min_pivot: f64,
    const_max_multiplier: f64,
    const_scale: f64,
}

impl OwnedFactor {
    fn new(p: &FoldedFactor<'_>) -> OwnedFactor {
        OwnedFactor {
            nnz: p.nnz,
            values: p.values,
            inputs: p.inputs.to_vec(),
            constants: p.constants.to_vec(),
            ops: p.ops.to_vec(),
            pivot_vars: p.pivot_vars.to_vec(),
            multiplier_vars: p.multiplier_vars.to_vec(),
            const_min_pivot: p.const_min_pivot,
            const_max_multiplier: p.const_max_multiplier,
            const_scale: p.const_scale,
        }
    }

    fn view(&self) -> FoldedFactor<'_> {
        FoldedFactor {
            nnz: self.nnz,
            values: self.values,
            inputs: &self.inputs,
            constants: &self.constants,
            ops: &self.ops,
            pivot_vars: &self.pivot_vars,
            multiplier_vars: &self.multiplier_vars,
            const_min_pivot: self.const_min_pivot,
            const_max_multiplier: self.const_max_multiplier,
            const_scale: self.const_scale,
        }
    }
}

/// A [`FoldedSolves`]' lists, owned (for the compiling thread).
struct OwnedSolves {
    n: usize,
    values: usize,
    row_order: Vec<u32>,
    col_order: Vec<u32>,
    forward: Vec<SolveOp>,
    backward: Vec<SolveOp>,
    forward_t: Vec<SolveOp>,
    backward_t: Vec<SolveOp>,
}

impl OwnedSolves {
    fn new(p: &FoldedSolves<'_>) -> OwnedSolves {
        OwnedSolves {
            n: p.n,
            values: p.values,
            row_order: p.row_order.to_vec(),
            col_order: p.col_order.to_vec(),
            forward: p.forward.to_vec(),
            backward: p.backward.to_vec(),
            forward_t: p.forward_t.to_vec(),
            backward_t: p.backward_t.to_vec(),
        }
    }

    fn view(&self) -> FoldedSolves<'_> {
        FoldedSolves {
            n: self.n,
            values: self.values,
            row_order: &self.row_order,
            col_order: &self.col_order,
            forward: &self.forward,
            backward: &self.backward,
            forward_t: &self.forward_t,
            backward_t: &self.backward_t,
        }
    }
}
