//! The part of a tape that reads neither q nor q̇ — a driver's function of
//! time, an expression of the parameters — computed at most once per
//! (t, parameters) and kept in the cache slice, as generated code keeps
//! its time terms: a Newton iteration, the velocity and the acceleration
//! analyses at one time read it back instead of computing it again.
//!
//! A compiled function with a hoisted part starts by comparing its key in
//! the cache slice — t's bits, the same bits XORed with the function's
//! salt, and the bits of each parameter the part reads — with its
//! arguments. Equal, it loads the kept values; else it computes the part,
//! stores the values the rest of the function reads and then the key. The
//! salt (never zero, distinct per compiled function in the process) makes
//! a key another function or a new NaN-filled slice left there never
//! match: both words would have to equal t's bits and t's bits XOR the
//! salt. The arithmetic is the tape's, in its order, so the values are
//! the interpreter's bit for bit whether computed or read back.

use std::sync::atomic::{AtomicU64, Ordering};

use kinema_expr::{Instr, Tape};

use crate::tape::sources;

/// A hoisted part's estimated cost below which it is left in place: the
/// key's check costs about as much as a few arithmetic instructions.
const WORTH: usize = 8;

/// The hoisted part of one tape.
#[derive(Clone, Debug)]
pub(crate) struct Hoisted {
    /// Per instruction: where it is emitted.
    place: Vec<Place>,
    /// Per instruction: the index among the kept values of a hoisted
    /// instruction whose value the rest of the function reads (or which
    /// last writes an output).
    kept: Vec<Option<usize>>,
    /// Number of kept values.
    kept_len: usize,
    /// The parameters (indices) the hoisted part reads.
    params: Vec<u32>,
    /// Whether the hoisted part reads t.
    reads_t: bool,
}

/// Where an instruction is emitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Place {
    /// In the rest of the function only.
    Rest,
    /// In the hoisted part only (its value, if the rest reads it, kept).
    Hoisted,
    /// In both: a constant, or a copy of a parameter, t or a constant
    /// (free, so re-emitted rather than kept).
    Both,
}

/// What the register holds at a point of the tape.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Def {
    /// A value the function's start provides: a parameter, t or a
    /// constant (available in both the hoisted part and the rest).
    Start,
    /// A coordinate or velocity, or a value computed from one.
    Varying,
    /// The value of hoisted instruction i.
    Hoisted(usize),
    /// A constant or a copy of a start value, written by an instruction
    /// emitted in both parts.
    Both,
}

impl Hoisted {
    /// The hoisted part of `tape`, or `None` if it has none worth the key's
    /// check.
    pub(crate) fn new(tape: &Tape) -> Option<Hoisted> {
        let layout = tape.layout();
        let (_, _, np) = tape.input_sizes();
        let instrs = tape.instructions();
        let mut def = vec![Def::Varying; tape.registers()];
        for r in layout.params_base..layout.params_base + np {
            *def.get_mut(r)? = Def::Start;
        }
        if let Some(r) = layout.t_register {
            *def.get_mut(r)? = Def::Start;
        }
        for r in layout.consts_base..layout.consts_base + layout.consts.len() {
            *def.get_mut(r)? = Def::Start;
        }
        let params = layout.params_base..layout.params_base + np;
        let mut place = vec![Place::Rest; instrs.len()];
        let mut keep = vec![false; instrs.len()];
        let mut read_params = vec![false; np];
        let (mut reads_t, mut cost) = (false, 0);
        for (i, ins) in instrs.iter().enumerate() {
            let (srcs, n) = sources(ins);
            let srcs = &srcs[..n];
            let dst = ins.dst() as usize;
            let free = match ins {
                Instr::Const { .. } => true,
                Instr::Copy { a, .. } => {
                    matches!(def.get(*a as usize), Some(Def::Start | Def::Both))
                }
                _ => false,
            };
            if free {
                place[i] = Place::Both;
                *def.get_mut(dst)? = Def::Both;
                continue;
            }
            let time = srcs
                .iter()
                .all(|&s| def.get(s as usize).is_some_and(|d| *d != Def::Varying));
            if time {
                place[i] = Place::Hoisted;
                cost += weight(ins);
                for &s in srcs {
                    let s = s as usize;
                    if params.contains(&s) {
                        read_params[s - layout.params_base] = true;
                    }
                    reads_t |= layout.t_register == Some(s);
                }
            } else {
                // The hoisted values the rest reads are kept.
                for &s in srcs {
                    if let Some(&Def::Hoisted(h)) = def.get(s as usize) {
                        keep[h] = true;
                    }
                }
            }
            *def.get_mut(dst)? = if time { Def::Hoisted(i) } else { Def::Varying };
        }
        // An output whose last value is hoisted is stored from its kept
        // value.
        for d in def.iter().take(layout.outputs) {
            if let Def::Hoisted(h) = *d {
                keep[h] = true;
            }
        }
        if cost < WORTH || !keep.contains(&true) {
            return None;
        }
        let mut kept_len = 0;
        let kept = keep
            .iter()
            .map(|&k| {
                k.then(|| {
                    kept_len += 1;
                    kept_len - 1
                })
            })
            .collect();
        let params = (0..np)
            .filter(|&k| read_params[k])
            .map(|k| u32::try_from(k).ok())
            .collect::<Option<Vec<u32>>>()?;
        Some(Hoisted {
            place,
            kept,
            kept_len,
            params,
            reads_t,
        })
    }

    /// Entries of the cache slice it uses: the key (t, t salted, the
    /// parameters read), then the kept values.
    pub(crate) fn len(&self) -> usize {
        2 + self.params.len() + self.kept_len
    }

    /// Whether instruction `i` is emitted in the hoisted part only.
    pub(crate) fn is_hoisted(&self, i: usize) -> bool {
        self.place.get(i) == Some(&Place::Hoisted)
    }

    /// Whether instruction `i` is emitted in the hoisted part (only, or in
    /// both parts).
    pub(crate) fn in_hoisted(&self, i: usize) -> bool {
        self.place.get(i).is_some_and(|p| *p != Place::Rest)
    }

    /// Where instruction `i`'s value is kept, after the key: its index
    /// among the kept values.
    pub(crate) fn kept(&self, i: usize) -> Option<usize> {
        self.kept.get(i).copied().flatten()
    }

    /// The parameters the key holds, in its order.
    pub(crate) fn params(&self) -> &[u32] {
        &self.params
    }

    /// Whether the key holds t.
    pub(crate) fn reads_t(&self) -> bool {
        self.reads_t
    }
}

/// An instruction's rough cost: a call or a division is worth several
/// arithmetic instructions.
fn weight(ins: &Instr) -> usize {
    match ins {
        Instr::Sin { .. }
        | Instr::Cos { .. }
        | Instr::Unary { .. }
        | Instr::Pow { .. }
        | Instr::PowF { .. }
        | Instr::PowI { .. }
        | Instr::Atan2 { .. }
        | Instr::Sqrt { .. }
        | Instr::Div { .. }
        | Instr::Recip { .. } => WORTH,
        _ => 1,
    }
}

/// A salt for one compiled function: never zero, distinct for each call in
/// the process (a counter through SplitMix64's finalizer, a bijection).
pub(crate) fn salt() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let mut z = NEXT
        .fetch_add(1, Ordering::Relaxed)
        .wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    if z == 0 { 1 } else { z }
}
