//! The one place of the workspace that calls machine code: finalized
//! Cranelift functions turned into callable pointers, behind wrappers that
//! check every slice's length on every call.
//!
//! The invariant every `unsafe` block here relies on: a function is wrapped
//! only with the slice lengths its compiler validated every offset against
//! (the compiler in [`crate::tape`] reads `q[i]` only for `i < needs.q`,
//! and so on, and writes `out[k]` only for `k < needs.out`); the wrapper
//! refuses shorter slices. So safe code cannot make the function read or
//! write outside the slices it is handed.
#![allow(unsafe_code)]

use std::sync::{Arc, Mutex};

use cranelift_jit::JITModule;
use cranelift_module::FuncId;

use kinema_expr::TapeInputs;
use kinema_runtime::linalg::{FactorScan, RawScan};

use crate::JitError;

/// Owns the executable memory of one module; frees it when the last
/// function compiled into it is dropped.
pub(crate) struct Code {
    /// `None` only while dropping. A mutex because `JITModule` is `Send` but
    /// not `Sync` (it is never used again after finalization).
    module: Mutex<Option<JITModule>>,
}

impl Code {
    /// Takes ownership of a module whose definitions are finalized.
    pub(crate) fn new(module: JITModule) -> Arc<Code> {
        Arc::new(Code {
            module: Mutex::new(Some(module)),
        })
    }

    /// The finalized address of `id`, null if the module is gone.
    fn address(&self, id: FuncId) -> *const u8 {
        // A poisoned lock still guards a valid module: nothing mutates it.
        let guard = self
            .module
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        guard
            .as_ref()
            .map_or(std::ptr::null(), |m| m.get_finalized_function(id))
    }
}

impl Drop for Code {
    fn drop(&mut self) {
        let module = self
            .module
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .take();
        if let Some(module) = module {
            // SAFETY: every pointer into this module's memory is held by a
            // `TapeFn` together with an `Arc<Code>`; this runs when the last
            // of those is gone, so no function of the module is executing or
            // can be called afterwards.
            unsafe { module.free_memory() };
        }
    }
}

impl std::fmt::Debug for Code {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Code")
    }
}

/// The lengths a compiled tape function was validated against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Needs {
    /// Values read from `q`.
    pub(crate) q: usize,
    /// Values read from `q̇`.
    pub(crate) qd: usize,
    /// Values read from the parameters.
    pub(crate) params: usize,
    /// Values written to `out`.
    pub(crate) out: usize,
    /// Values written to `out2`.
    pub(crate) out2: usize,
    /// Values read and written in the sin/cos cache.
    pub(crate) trig: usize,
}

type Raw =
    unsafe extern "C" fn(*const f64, *const f64, *const f64, f64, *mut f64, *mut f64, *mut f64);

/// A compiled tape: `(q, q̇, params, t, trig) → (out, out2)`, `trig` the
/// sin/cos cache (read and written).
#[derive(Clone)]
pub(crate) struct TapeFn {
    f: Raw,
    needs: Needs,
    /// Keeps the code alive while `f` may be called.
    _code: Arc<Code>,
}

impl TapeFn {
    /// Wraps function `id` of `code`, compiled from a tape whose every load
    /// and store the compiler checked against `needs` (the module invariant).
    pub(crate) fn new(code: &Arc<Code>, id: FuncId, needs: Needs) -> Result<TapeFn, JitError> {
        let p = code.address(id);
        if p.is_null() {
            return Err(JitError::Compile("no address for a compiled tape".into()));
        }
        // SAFETY: `p` is the finalized entry of a function that the
        // compiler declared with exactly this signature (three pointers, an
        // f64, three pointers; no result; the platform's C convention), and the
        // memory stays mapped while `_code` lives.
        let f = unsafe { std::mem::transmute::<*const u8, Raw>(p) };
        Ok(TapeFn {
            f,
            needs,
            _code: Arc::clone(code),
        })
    }

    /// Runs the function. Does not allocate.
    #[inline]
    pub(crate) fn call(
        &self,
        inputs: &TapeInputs<'_>,
        out: &mut [f64],
        out2: &mut [f64],
        trig: &mut [f64],
    ) -> Result<(), JitError> {
        let TapeInputs { q, qd, params, t } = *inputs;
        let given = Needs {
            q: q.len(),
            qd: qd.len(),
            params: params.len(),
            out: out.len(),
            out2: out2.len(),
            trig: trig.len(),
        };
        if !self.needs.fits(&given) {
            // By value: the lengths are put in memory on this cold path
            // only.
            return Err(self.needs.short_slice(given));
        }
        // SAFETY: the function reads only q[..n.q], qd[..n.qd],
        // params[..n.params], writes only out[..n.out] and out2[..n.out2],
        // and reads and writes only trig[..n.trig] (checked when it was
        // compiled; the slices are distinct: `&mut` borrows), and the lengths
        // were just checked; the shims it calls are safe Rust functions.
        // The code is alive (`_code`).
        unsafe {
            (self.f)(
                q.as_ptr(),
                qd.as_ptr(),
                params.as_ptr(),
                t,
                out.as_mut_ptr(),
                out2.as_mut_ptr(),
                trig.as_mut_ptr(),
            );
        }
        Ok(())
    }
}

impl Needs {
    /// Every length of `given` at least the one needed (no branch per
    /// length: they almost always all fit).
    #[inline]
    fn fits(&self, given: &Needs) -> bool {
        (given.q >= self.q)
            & (given.qd >= self.qd)
            & (given.params >= self.params)
            & (given.out >= self.out)
            & (given.out2 >= self.out2)
            & (given.trig >= self.trig)
    }

    /// The error for the first slice of `given` shorter than needed.
    #[cold]
    #[inline(never)]
    fn short_slice(&self, given: Needs) -> JitError {
        [
            ("q", self.q, given.q),
            ("qd", self.qd, given.qd),
            ("params", self.params, given.params),
            ("outputs", self.out, given.out),
            ("second outputs", self.out2, given.out2),
            ("sin/cos cache", self.trig, given.trig),
        ]
        .into_iter()
        .find(|&(_, needed, given)| given < needed)
        .map_or(
            JitError::Compile("no slice is short".into()),
            |(which, needed, given)| JitError::ShortSlice {
                which,
                needed,
                given,
            },
        )
    }
}

/// The lengths a compiled solve was validated against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct SolveNeeds {
    /// Values read from the factors' value array.
    pub(crate) v: usize,
    /// Values read and written in the right-hand side.
    pub(crate) rhs: usize,
    /// Values read and written in the scratch (a solve in chunks keeps
    /// there what one chunk leaves to the next).
    pub(crate) work: usize,
}

type RawSolve = unsafe extern "C" fn(*const f64, *mut f64, *mut f64);

/// A compiled triangular solve: `(v, rhs, work) → rhs`.
#[derive(Clone)]
pub(crate) struct SolveFn {
    f: RawSolve,
    needs: SolveNeeds,
    /// Keeps the code alive while `f` may be called.
    _code: Arc<Code>,
}

impl SolveFn {
    /// Wraps function `id` of `code`, compiled from a solve whose every
    /// load and store the compiler checked against `needs`.
    pub(crate) fn new(
        code: &Arc<Code>,
        id: FuncId,
        needs: SolveNeeds,
    ) -> Result<SolveFn, JitError> {
        let p = code.address(id);
        if p.is_null() {
            return Err(JitError::Compile("no address for a compiled solve".into()));
        }
        // SAFETY: `p` is the finalized entry of a function declared with
        // exactly this signature (three pointers; no result; the C
        // convention), and the memory stays mapped while `_code` lives.
        let f = unsafe { std::mem::transmute::<*const u8, RawSolve>(p) };
        Ok(SolveFn {
            f,
            needs,
            _code: Arc::clone(code),
        })
    }

    /// Runs the solve in place; `false` (nothing done) on short slices.
    #[inline]
    pub(crate) fn call(&self, v: &[f64], rhs: &mut [f64], work: &mut [f64]) -> bool {
        if v.len() < self.needs.v || rhs.len() < self.needs.rhs || work.len() < self.needs.work {
            return false;
        }
        // SAFETY: the function reads only v[..needs.v], reads and writes
        // only rhs[..needs.rhs] and work[..needs.work] (checked when it was
        // compiled; `rhs` and `work` are distinct: `&mut` borrows), and the
        // lengths were just checked. The code is alive (`_code`).
        unsafe { (self.f)(v.as_ptr(), rhs.as_mut_ptr(), work.as_mut_ptr()) };
        true
    }
}

/// The lengths a compiled factorization was validated against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct FactorNeeds {
    /// Jacobian values read.
    pub(crate) values: usize,
    /// Entries of the value array written (and read back).
    pub(crate) v: usize,
}

/// Entries of the scan a compiled factorization writes, at
/// [`FactorScan`]'s indices.
pub(crate) const SCAN: usize = FactorScan::LEN;

type RawFactor = unsafe extern "C" fn(*const f64, *mut f64, *mut f64, u64);

/// A compiled factorization: `values → (v, scan)`.
#[derive(Clone)]
pub(crate) struct FactorFn {
    f: RawFactor,
    needs: FactorNeeds,
    /// Keeps the code alive while `f` may be called.
    _code: Arc<Code>,
}

impl FactorFn {
    /// Wraps function `id` of `code`, compiled from a factorization whose
    /// every load and store the compiler checked against `needs` (and the
    /// scan's [`SCAN`] entries).
    pub(crate) fn new(
        code: &Arc<Code>,
        id: FuncId,
        needs: FactorNeeds,
    ) -> Result<FactorFn, JitError> {
        let p = code.address(id);
        if p.is_null() {
            return Err(JitError::Compile(
                "no address for a compiled factorization".into(),
            ));
        }
        // SAFETY: `p` is the finalized entry of a function declared with
        // exactly this signature (three pointers and a 64-bit integer; no
        // result; the C convention), and the memory stays mapped while
        // `_code` lives.
        let f = unsafe { std::mem::transmute::<*const u8, RawFactor>(p) };
        Ok(FactorFn {
            f,
            needs,
            _code: Arc::clone(code),
        })
    }

    /// Whether `values` and `v` are long enough for the factorization.
    #[inline]
    pub(crate) fn fits(&self, values: &[f64], v: &[f64]) -> bool {
        values.len() >= self.needs.values && v.len() >= self.needs.v
    }

    /// Runs the factorization, checking the constants if `check`,
    /// writing every entry of `scan`; `false` (nothing done) on short
    /// slices. With a prologue, `scan` holds the running folds it left,
    /// which the function starts from.
    #[inline]
    pub(crate) fn call(
        &self,
        values: &[f64],
        v: &mut [f64],
        scan: &mut RawScan,
        check: bool,
    ) -> bool {
        if !self.fits(values, v) {
            return false;
        }
        // SAFETY: the function reads only values[..needs.values], writes
        // and reads only v[..needs.v] and writes and reads only
        // scan[..SCAN] (checked when it was compiled; `scan` is SCAN long,
        // and distinct from `v`: `&mut` borrows); the other lengths were
        // just checked. The code is alive (`_code`).
        unsafe {
            (self.f)(
                values.as_ptr(),
                v.as_mut_ptr(),
                scan.as_mut_ptr(),
                u64::from(check),
            );
        };
        true
    }
}
