//! A large factorization's start as loops over tables ([`Prologue`]):
//! the constants' check, the run-time entries' copy and their folds, run
//! before the compiled operations.

use kinema_runtime::linalg::{
    FoldedFactor, INFINITY_BITS, MAGNITUDE_MASK, MASK_ALL, RawScan, scale_and_masked_max,
};

use super::super::{
    SCAN_FINITE, SCAN_MAX_MULTIPLIER, SCAN_MIN_PIVOT, SCAN_NEGATIVE, SCAN_SAME, SCAN_SCALE,
};
use crate::JitError;
use crate::code::FactorNeeds;

/// The per-entry start of a large factorization, as loops over tables:
/// emitted straight-line, the chain N = 200's 1 000 constants and 800
/// copies were 13 000 instructions of code run once per factorization,
/// more than the instruction caches keep (the generated LU loops over
/// tables beyond a few entries for the same reason). The loops compute
/// the interpreter's numbers — the constants' differences or-ed; integer
/// maxima and minima of magnitude bits, which no order changes, in four
/// lanes; the sign bits' parity — and leave the running folds in the
/// scan, where the compiled part (the operations) reads them.
#[derive(Clone, Debug)]
pub(super) struct Prologue {
    /// Pattern position and bits of each constant entry.
    constants: Box<[(u32, u64)]>,
    /// Pattern position of each run-time entry (value array entry i).
    inputs: Box<[u32]>,
    /// Value array entries among the run-time entries that are pivots.
    pivots: Box<[u32]>,
    /// Per run-time entry, [`MASK_ALL`] if it is a multiplier, else 0: the
    /// multipliers' fold is taken in the scale's pass (in a mechanism most
    /// entries are multipliers: the pivots are the joints' ±1).
    multiplier_mask: Box<[u64]>,
    /// The folds' starts: the constants' scale, smallest pivot and largest
    /// multiplier (magnitude bits).
    scale: u64,
    min_pivot: u64,
    max_multiplier: u64,
}

impl Prologue {
    /// The prologue of `plan`, its indices checked against `needs`.
    pub(super) fn new(plan: &FoldedFactor<'_>, needs: FactorNeeds) -> Result<Prologue, JitError> {
        let inside = |k: u32| -> Result<u32, JitError> {
            if (k as usize) < needs.values {
                Ok(k)
            } else {
                Err(JitError::Compile(format!(
                    "Jacobian value index {k} beyond {}",
                    needs.values
                )))
            }
        };
        let ni = plan.inputs.len();
        if ni > needs.v {
            return Err(JitError::Compile("more entries than values".into()));
        }
        let copied = |vars: &[u32]| -> Box<[u32]> {
            vars.iter()
                .copied()
                .filter(|&k| (k as usize) < ni)
                .collect()
        };
        Ok(Prologue {
            constants: plan
                .constants
                .iter()
                .map(|&(k, c)| Ok((inside(k)?, c.to_bits())))
                .collect::<Result<_, JitError>>()?,
            inputs: plan
                .inputs
                .iter()
                .map(|&k| inside(k))
                .collect::<Result<_, JitError>>()?,
            pivots: copied(plan.pivot_vars),
            multiplier_mask: {
                let mut mask = vec![0; ni];
                for &l in plan.multiplier_vars {
                    if let Some(m) = mask.get_mut(l as usize) {
                        *m = MASK_ALL;
                    }
                }
                mask.into_boxed_slice()
            },
            scale: plan.const_scale.to_bits() & MAGNITUDE_MASK,
            min_pivot: plan.const_min_pivot.to_bits() & MAGNITUDE_MASK,
            max_multiplier: plan.const_max_multiplier.to_bits() & MAGNITUDE_MASK,
        })
    }

    /// Checks the constants (if `check`), copies the run-time entries into
    /// `v` and folds them; writes into `scan` the scan the compiled part
    /// starts from (final scale, finiteness and constants' check; the
    /// pivots' and multipliers' folds as running state, raw bits). The caller has
    /// checked `values` and `v` against the needs the indices were checked
    /// with. Out of line: the small systems' factorization, which has no
    /// prologue, stays lean.
    #[inline(never)]
    pub(super) fn run(&self, values: &[f64], v: &mut [f64], check: bool, scan: &mut RawScan) {
        let bits = |x: f64| x.to_bits();
        let mut diff = 0;
        for &(k, c) in if check { &self.constants[..] } else { &[] } {
            diff |= bits(values[k as usize]) ^ c;
        }
        let ni = self.inputs.len();
        for (x, &k) in v[..ni].iter_mut().zip(&*self.inputs) {
            *x = values[k as usize];
        }
        // Scale, finiteness and the multipliers among the entries in one
        // pass over the contiguous copy (it vectorizes; gathering does
        // not). Not finite, the order is refused whatever the maxima.
        let (most, multipliers, finite) = scale_and_masked_max(&v[..ni], &self.multiplier_mask);
        let (scale, max_multiplier) = if finite {
            (
                self.scale.max(most.to_bits()),
                self.max_multiplier.max(multipliers.to_bits()),
            )
        } else {
            (INFINITY_BITS, INFINITY_BITS)
        };
        let v = &*v;
        let mut signs = 0;
        // A NaN pivot counts as zero.
        let pivot = |p: u32| {
            let m = bits(v[p as usize]) & MAGNITUDE_MASK;
            if m > INFINITY_BITS { 0 } else { m }
        };
        let min_pivot = fold4(&self.pivots, self.min_pivot, u64::MAX, u64::min, |p| {
            signs ^= bits(v[p as usize]);
            pivot(p)
        });
        scan[SCAN_SAME] = if diff == 0 { 1.0 } else { 0.0 };
        scan[SCAN_SCALE] = f64::from_bits(scale);
        scan[SCAN_FINITE] = if finite { 1.0 } else { 0.0 };
        scan[SCAN_NEGATIVE] = f64::from_bits(signs);
        scan[SCAN_MIN_PIVOT] = f64::from_bits(min_pivot);
        scan[SCAN_MAX_MULTIPLIER] = f64::from_bits(max_multiplier);
    }
}

/// `f` of the four lanes, pairwise.
#[inline]
fn lanes(x: [u64; 4], f: fn(u64, u64) -> u64) -> u64 {
    f(f(x[0], x[1]), f(x[2], x[3]))
}

/// `fold` (min or max, order-free) of `map` over `items` from `start`, in
/// four independent lanes (`identity` the others' start) so the folds do
/// not wait on each other.
#[inline]
fn fold4(
    items: &[u32],
    start: u64,
    identity: u64,
    fold: fn(u64, u64) -> u64,
    mut map: impl FnMut(u32) -> u64,
) -> u64 {
    let mut m = [start, identity, identity, identity];
    let chunks = items.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for lane in 0..4 {
            m[lane] = fold(m[lane], map(c[lane]));
        }
    }
    rest.iter()
        .fold(lanes(m, fold), |acc, &k| fold(acc, map(k)))
}
