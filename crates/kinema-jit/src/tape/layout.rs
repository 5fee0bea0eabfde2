//! Where a compilation's values live in the cache slice, known before
//! anything is emitted: the coordinates' sin/cos entries, the memo after
//! them, the values crossing chunk boundaries ([`SpillPlan`]), and the
//! hoisted parts with their keys; and the bounds on the slice's length
//! that callers allocate by ([`cache_len_bound`] and its variants).

use kinema_expr::{Instr, Tape};

use super::CHUNK_INSTRUCTIONS;
use crate::JitError;
use crate::hoist::Layout;

/// Which registers each chunk of a tape stores into the scratch for later
/// chunks: those it writes that a later chunk reads before writing them
/// (live across the boundary), found by one backward scan.
pub(super) struct SpillPlan {
    /// The chunks' instruction ranges, in order.
    pub(super) chunks: Vec<std::ops::Range<usize>>,
    /// Per chunk, the registers it stores at their last write in it.
    pub(super) out: Vec<Vec<u32>>,
    /// Where register 0 goes in the scratch.
    pub(super) base: usize,
    /// Registers of the tape: the scratch holds `base + registers` values.
    pub(super) registers: usize,
}

impl SpillPlan {
    pub(super) fn new(tape: &Tape, chunk: usize, base: usize) -> Result<SpillPlan, JitError> {
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

/// The length of cache slice that tapes compiled by
/// [`compile_split_memo_at`] with this `memo_base` need at most, known
/// without compiling them (each sin or cos of a value other than a
/// coordinate counted as a memo entry of its own).
///
/// # Errors
/// [`JitError::Compile`] if the length does not fit a `usize`.
///
/// [`compile_split_memo_at`]: super::compile_split_memo_at
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
///
/// [`compile_chunked`]: super::compile_chunked
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
///
/// [`compile_iterated`]: super::compile_iterated
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
pub(super) fn hoisting(
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
pub(super) fn memo_bound(tapes: &[(&Tape, usize)], memo_base: usize) -> Result<usize, JitError> {
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

/// Length of the sin/cos cache a tape reads: 3 per coordinate up to the
/// last whose sin or cos it takes.
pub(super) fn trig_len(tape: &Tape) -> Result<usize, JitError> {
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
