//! A Cranelift JIT for kinema's tapes: what a [`kinema_expr::Tape`]
//! computes, compiled to native code at load time.
//!
//! [`compile`] turns tapes into [`JitTape`]s, straight-line functions
//! `(q, q̇, params, t) → out` with every value in an SSA register (Cranelift
//! allocates them), `sqrt` as an instruction and the transcendental
//! functions as calls to Rust's own (`f64::sin`, …), each of sin and cos of
//! one value computed once per call. The arithmetic is the tape's, in the
//! tape's order with no fused multiply-add, so a compiled tape agrees with
//! the interpreter bit for bit (NaN payloads aside).
//!
//! [`compile_factor`] and [`compile_solves`] do the same for a
//! [`FoldedLu`](kinema_runtime::FoldedLu)'s factorization (its value array
//! and the scan its acceptance test reads) and its solves, read from the
//! LU's views and plugged back in through its hooks.
//!
//! A tape or an LU list too long for one function (Cranelift's time grows
//! faster than a function's size) is compiled in chunks, one function
//! each, the values crossing a cut passed through memory; one function
//! calls the chunks in order (see [`CHUNK_INSTRUCTIONS`], [`LU_CHUNK`]).
//!
//! If Cranelift cannot target the host or a compilation fails, [`compile`]
//! returns a [`JitError`] and the caller keeps the tape. The crate's one
//! `unsafe` module (`code`) holds the call into machine code behind a
//! wrapper that checks every slice's length.

mod code;
mod hoist;
mod lu;
mod shims;
mod tape;

pub use lu::{
    JitFactor, JitSolves, LOOPED_ENTRIES, LU_CHUNK, MAX_LU_DIMENSION, MAX_SOLVE_OPERATIONS,
    REGISTER_SOLVE, compile_factor, compile_factor_chunked, compile_solves, compile_solves_chunked,
};

pub use tape::{
    CHUNK_INSTRUCTIONS, JitTape, MAX_INSTRUCTIONS, Reloads, cache_len_bound,
    cache_len_bound_chunked, cache_len_bound_iterated, compile, compile_chunked, compile_iterated,
    compile_split, compile_split_memo_at, host_supported, memo_end,
};

/// Why tapes could not be compiled, or a compiled tape not called.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum JitError {
    /// Cranelift cannot generate code for this machine.
    Host(String),
    /// Cranelift refused a function, or the tape is malformed (a register
    /// read before it is written).
    Compile(String),
    /// The tapes are larger than [`MAX_INSTRUCTIONS`] in all (or an LU's
    /// lists than [`MAX_SOLVE_OPERATIONS`]): compiling them would keep the
    /// compiling thread busy for too long.
    TooLarge {
        /// Instructions of the tapes.
        instructions: usize,
    },
    /// An input or output slice is shorter than the compiled tape needs.
    ShortSlice {
        /// Which slice: `"q"`, `"qd"`, `"params"` or `"outputs"`.
        which: &'static str,
        /// Length needed.
        needed: usize,
        /// Length given.
        given: usize,
    },
}

impl std::fmt::Display for JitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            JitError::Host(e) => write!(f, "the JIT cannot target this machine: {e}"),
            JitError::Compile(e) => write!(f, "the JIT could not compile the model: {e}"),
            JitError::TooLarge { instructions } => write!(
                f,
                "the model's tapes have {instructions} instructions, more than the JIT compiles \
                 ({MAX_INSTRUCTIONS})"
            ),
            JitError::ShortSlice {
                which,
                needed,
                given,
            } => write!(
                f,
                "compiled tape needs {needed} values in `{which}`, got {given}"
            ),
        }
    }
}

impl std::error::Error for JitError {}
