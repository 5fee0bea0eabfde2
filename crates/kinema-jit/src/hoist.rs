//! The part of a tape that reads neither q nor q̇ — a driver's function of
//! time, an expression of the parameters — computed at most once per
//! (t, parameters) and kept in the cache slice, as generated code keeps
//! its time terms: Newton's iterations, the velocity and the acceleration
//! analyses at one time read it back instead of computing it again.
//!
//! A compiled tape with a hoisted part keeps a key in the cache slice —
//! t's bits, the same bits XORed with the compilation's salt, and the bits
//! of each parameter the part reads — and starts by comparing it with its
//! arguments: equal, it loads the kept values; else it first calls its
//! part's own function, which computes the part, stores the values the
//! rest of the tape reads and then the key. Only tapes evaluated several
//! times at one (t, parameters) gain (Newton's Φ and Φ_q; see
//! `compile_iterated`): one evaluated once per time would miss every
//! time. (Sharing one part between tapes gains nothing either: their sines
//! and cosines are shared through the memo already.) The salt (never zero,
//! distinct per compilation in the process) makes a key that a new
//! NaN-filled slice holds never match: both words would have to equal t's
//! bits and t's bits XOR the salt. The arithmetic is the tape's, in its
//! order, so the values are the interpreter's bit for bit whether computed
//! or read back.

use std::sync::atomic::{AtomicU64, Ordering};

use kinema_expr::{Instr, Tape};

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
    /// check, or one of more than `most` instructions (it is compiled as one
    /// function, whose compile time grows faster than its size).
    pub(crate) fn new(tape: &Tape, most: usize) -> Option<Hoisted> {
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
            let (srcs, n) = ins.sources();
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
        let size = place.iter().filter(|p| **p != Place::Rest).count();
        if cost < WORTH || size > most || !keep.contains(&true) {
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

    /// Whether instruction `i` is emitted in the hoisted part only.
    pub(crate) fn is_hoisted(&self, i: usize) -> bool {
        self.place.get(i) == Some(&Place::Hoisted)
    }

    /// Whether instruction `i` is emitted in the hoisted part (only, or in
    /// both parts).
    pub(crate) fn in_hoisted(&self, i: usize) -> bool {
        self.place.get(i).is_some_and(|p| *p != Place::Rest)
    }

    /// Where instruction `i`'s value is kept: its index among the kept
    /// values.
    pub(crate) fn kept(&self, i: usize) -> Option<usize> {
        self.kept.get(i).copied().flatten()
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

/// A salt for one compilation: never zero, distinct for each call in the
/// process (a counter through SplitMix64's finalizer, a bijection).
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

/// A tape's hoisted part and where it lives in the cache slice: its key at
/// `key_at` (t's bits, t's bits XOR the salt, then the bits of each
/// parameter in `params`), its kept values from `kept_at`.
#[derive(Debug)]
pub(crate) struct Part {
    pub(crate) hoisted: Hoisted,
    pub(crate) key_at: usize,
    pub(crate) kept_at: usize,
}

impl Part {
    /// The parameters its key holds, in order.
    pub(crate) fn params(&self) -> &[u32] {
        &self.hoisted.params
    }

    /// Whether its key holds t.
    pub(crate) fn reads_t(&self) -> bool {
        self.hoisted.reads_t
    }

    /// The end of its entries.
    pub(crate) fn end(&self) -> usize {
        self.kept_at + self.hoisted.kept_len
    }
}

/// The hoisted parts of tapes compiled together, one after the other in
/// the cache slice, and the end of the last.
#[derive(Debug)]
pub(crate) struct Layout {
    /// Per tape, its part, if it has one.
    pub(crate) parts: Vec<Option<Part>>,
    /// The end of the last part's entries.
    pub(crate) end: usize,
}

impl Layout {
    /// The parts of `tapes` (none for a tape where `hoist(k)` is false),
    /// each of at most `most` instructions, their entries from `at` on;
    /// `None` if the end overflows.
    pub(crate) fn new(
        tapes: &[&Tape],
        at: usize,
        most: usize,
        hoist: impl Fn(usize) -> bool,
    ) -> Option<Layout> {
        let mut end = at;
        let mut parts = Vec::with_capacity(tapes.len());
        for (k, tape) in tapes.iter().enumerate() {
            let hoisted = if hoist(k) {
                Hoisted::new(tape, most)
            } else {
                None
            };
            parts.push(match hoisted {
                Some(hoisted) => {
                    let key_at = end;
                    let kept_at = key_at.checked_add(2 + hoisted.params.len())?;
                    end = kept_at.checked_add(hoisted.kept_len)?;
                    Some(Part {
                        hoisted,
                        key_at,
                        kept_at,
                    })
                }
                None => None,
            });
        }
        Some(Layout { parts, end })
    }
}
