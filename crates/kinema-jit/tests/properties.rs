//! The JIT against the tape interpreter on random expressions (the
//! generators of kinema-expr's property tests): every output of an
//! expression and its derivatives, bit for bit (NaN payloads aside), at
//! ordinary points and at non-finite ones.

use kinema_expr::{Arena, Tape, TapeInputs};
use kinema_jit::{
    JitError, Reloads, cache_len_bound_chunked, compile, compile_chunked, compile_split,
    compile_split_memo_at, memo_end,
};
use proptest::prelude::*;

/// kinema-expr's random expressions (the same generators as its property
/// tests).
#[path = "../../kinema-expr/tests/common/random_expr.rs"]
mod random_expr;
use random_expr::{build, expr, symbols};

/// A point, sometimes with a non-finite coordinate, parameter or time.
fn point() -> impl Strategy<Value = [f64; 5]> {
    let x = || {
        prop_oneof![
            12 => -2.0f64..2.0,
            1 => prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY), Just(0.0), Just(-0.0)],
        ]
    };
    [x(), x(), x(), x(), x()]
}

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, ..ProptestConfig::default() })]

    /// A compiled tape computes exactly what the tape computes.
    #[test]
    fn jit_equals_tape(t in expr(), x in point()) {
        let mut a = Arena::new();
        let syms = symbols(&mut a);
        let e = build(&mut a, &t, false);
        let mut outputs = vec![e];
        for &s in &syms {
            outputs.push(a.diff(e, s));
        }
        let tape = Tape::compile(&a, &outputs);
        // Also a tape of the derivatives alone, compiled into the same module.
        let second = Tape::compile(&a, &outputs[1..]);
        let jit = compile(&[&tape, &second]).expect("the host is supported");
        // And the first split after the value (as Φ then Φ_q), the memo of
        // other sines and cosines after the three coordinates' entries.
        let split = compile_split_memo_at(&[(&tape, 1)], 9).expect("the host is supported");
        let inputs = TapeInputs { q: &x[..3], qd: &[], params: &x[3..4], t: x[4] };
        for (tape, jit) in [(&tape, &jit[0]), (&second, &jit[1])] {
            let mut regs = vec![0.0; tape.registers()];
            let mut want = vec![0.0; tape.outputs()];
            prop_assert!(tape.eval(&inputs, &mut regs, &mut want).is_ok());
            let mut got = vec![7.0; tape.outputs()];
            prop_assert!(jit.eval(&inputs, &mut got).is_ok());
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                prop_assert!(same(*g, *w), "output {k}: jit {g:e} vs tape {w:e} for {}",
                    a.display(outputs[k]));
            }
        }
        let mut regs = vec![0.0; tape.registers()];
        let mut want = vec![0.0; tape.outputs()];
        prop_assert!(tape.eval(&inputs, &mut regs, &mut want).is_ok());
        // Through the sin/cos cache, split: primed at another point
        // (misses), then at this one twice (misses, then hits).
        let mut trig = vec![f64::NAN; split[0].trig_len().max(9)];
        let (mut first, mut rest) = ([7.0], vec![7.0; tape.outputs() - 1]);
        let q_other = [x[1], x[2], x[0]];
        let other = TapeInputs { q: &q_other, ..inputs };
        prop_assert!(split[0].eval_split(&other, &mut trig, &mut first, &mut rest).is_ok());
        for pass in 0..2 {
            prop_assert!(split[0].eval_split(&inputs, &mut trig, &mut first, &mut rest).is_ok());
            for (k, (g, w)) in first.iter().chain(&rest).zip(&want).enumerate() {
                prop_assert!(same(*g, *w), "split, pass {pass}, output {k}: jit {g:e} vs tape {w:e}");
            }
        }
        // The same through the default memo place (after the coordinates'
        // entries of its tapes), in a cache of exactly the length it asks.
        let default = compile_split(&[(&tape, 1)]).expect("the host is supported");
        let mut own = vec![f64::NAN; default[0].trig_len()];
        for pass in 0..2 {
            prop_assert!(default[0].eval_split(&inputs, &mut own, &mut first, &mut rest).is_ok());
            for (k, (g, w)) in first.iter().chain(&rest).zip(&want).enumerate() {
                prop_assert!(same(*g, *w), "default memo, pass {pass}, output {k}: jit {g:e} vs tape {w:e}");
            }
        }
        // The coordinates' cache holds what the tape's would, and every
        // memo entry is a value with its own sine and cosine.
        let mut tape_trig = vec![f64::NAN; 9];
        let mut out = vec![0.0; tape.outputs()];
        prop_assert!(tape.eval_with_cache(&inputs, &mut regs, &mut tape_trig, &mut out).is_ok());
        let needed = split[0].trig_len();
        for k in 0..9 {
            prop_assert!(same(trig[k], tape_trig[k]), "cache entry {k}");
        }
        // (After the memo: the key and values of the tape's part that
        // depends on t and the parameters alone.)
        let memo_end = memo_end(&[(&tape, 1)], 9).expect("a bound").min(trig.len());
        for (k, entry) in trig[9..memo_end].chunks(3).enumerate() {
            let x = entry[0];
            prop_assert!(
                entry.len() == 3 && same(entry[1], x.sin()) && same(entry[2], x.cos()),
                "memo entry {k}: {entry:?}"
            );
        }
        if needed > 0 {
            let short = split[0].eval_split(&inputs, &mut trig[..needed - 1], &mut first, &mut rest);
            prop_assert!(
                matches!(short, Err(JitError::ShortSlice { which: "sin/cos cache", .. })),
                "a short cache is refused"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// A tape compiled in chunks of at most `chunk` instructions (values
    /// crossing the cuts through the scratch) and with inputs and sines
    /// reloaded `window` instructions after their last load computes
    /// exactly what the tape computes, through a cache of the length the
    /// bound promises, at a first call (misses) and a second (hits), split
    /// as Φ then Φ_q.
    #[test]
    fn chunked_jit_equals_tape(
        t in expr(),
        x in point(),
        chunk in 1usize..6,
        memo in 9usize..20,
        window in 0usize..4,
    ) {
        let mut a = Arena::new();
        let syms = symbols(&mut a);
        let e = build(&mut a, &t, false);
        let mut outputs = vec![e];
        for &s in &syms {
            outputs.push(a.diff(e, s));
        }
        let tape = Tape::compile(&a, &outputs);
        let second = Tape::compile(&a, &outputs[1..]);
        let tapes = [(&tape, 1), (&second, second.outputs())];
        let jit = compile_chunked(&tapes, memo, chunk, Reloads { window, from: 0 }).expect("the host is supported");
        let len = cache_len_bound_chunked(&tapes, memo, chunk).expect("a bound");
        let inputs = TapeInputs { q: &x[..3], qd: &[], params: &x[3..4], t: x[4] };
        let mut trig = vec![f64::NAN; len];
        for ((tape, split), jit) in tapes.iter().zip(&jit) {
            prop_assert!(jit.trig_len() <= len, "{} > {len}", jit.trig_len());
            let mut regs = vec![0.0; tape.registers()];
            let mut want = vec![0.0; tape.outputs()];
            prop_assert!(tape.eval(&inputs, &mut regs, &mut want).is_ok());
            let split = (*split).min(tape.outputs());
            for pass in 0..2 {
                let mut first = vec![7.0; split];
                let mut rest = vec![7.0; tape.outputs() - split];
                prop_assert!(jit.eval_split(&inputs, &mut trig, &mut first, &mut rest).is_ok());
                for (k, (g, w)) in first.iter().chain(&rest).zip(&want).enumerate() {
                    prop_assert!(same(*g, *w),
                        "chunk {chunk}, window {window}, pass {pass}, output {k}: jit {g:e} vs tape {w:e}");
                }
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// A tape's part that depends on t and the parameter alone is computed
    /// once per (t, parameter) and read back after. Through one cache, at
    /// points changing t, the parameter and the coordinates in turn (and
    /// back), tapes of three expressions compiled together — the second
    /// the first scaled, the third another — take turns. Each call
    /// computes exactly what its tape computes: a key the cache just
    /// filled with NaN holds is never taken for a valid one, and each
    /// function reads its own values back.
    #[test]
    fn hoisted_parts_follow_time_and_parameters(
        t1 in expr(),
        t2 in expr(),
        x in point(),
        dt in -1.0f64..1.0,
        dp in -1.0f64..1.0,
    ) {
        let mut a = Arena::new();
        let _ = symbols(&mut a);
        let e1 = build(&mut a, &t1, false);
        let e3 = build(&mut a, &t2, false);
        let e2 = a.scale(3.0, e1);
        let tapes: Vec<Tape> = [e1, e2, e3].iter().map(|&e| Tape::compile(&a, &[e])).collect();
        let split: Vec<(&Tape, usize)> = tapes.iter().map(|t| (t, 1)).collect();
        let jits = compile_split_memo_at(&split, 9).expect("the host is supported");
        let len = jits.iter().map(|j| j.trig_len()).max().unwrap_or(0).max(9);
        let mut trig = vec![f64::NAN; len];
        let mut points = vec![x];
        for (k, d) in [(4, dt), (3, dp), (0, dt), (4, -dt), (3, -dp)] {
            let mut p = *points.last().unwrap_or(&x);
            p[k] += d;
            points.push(p);
        }
        points.push(x);
        for (step, p) in points.iter().enumerate() {
            let inputs = TapeInputs { q: &p[..3], qd: &[], params: &p[3..4], t: p[4] };
            for (which, (tape, jit)) in tapes.iter().zip(&jits).enumerate() {
                let mut regs = vec![0.0; tape.registers()];
                let mut want = vec![0.0];
                prop_assert!(tape.eval(&inputs, &mut regs, &mut want).is_ok());
                let mut got = vec![7.0];
                prop_assert!(jit.eval_with_cache(&inputs, &mut trig, &mut got).is_ok());
                prop_assert!(same(got[0], want[0]),
                    "point {step}, tape {which}: jit {:e} vs tape {:e}", got[0], want[0]);
            }
        }
    }
}

/// A new cache, filled with NaN, holds no valid key of the part that
/// depends on t and the parameters alone, even at t = NaN (whose bits the
/// filling NaN has): the part is computed, and an output of it that does
/// not read t is the tape's number, not the filling.
#[test]
fn a_new_cache_holds_no_valid_key() {
    let mut a = Arena::new();
    let x0 = a.coordinate("x0", 0);
    let x1 = a.coordinate("x1", 1);
    let p = a.parameter("p", 0);
    let t = a.time();
    let cos_p = a.cos(p);
    let first = a.mul(x0, cos_p);
    let sin_t = a.sin(t);
    let second = a.add(x1, sin_t);
    let tape = Tape::compile(&a, &[first, second]);
    let jit = compile(&[&tape]).expect("the host is supported");
    let inputs = TapeInputs {
        q: &[0.5, 0.25],
        qd: &[],
        params: &[0.3],
        t: f64::NAN,
    };
    let mut regs = vec![0.0; tape.registers()];
    let mut want = [0.0; 2];
    assert!(tape.eval(&inputs, &mut regs, &mut want).is_ok());
    assert_eq!(want[0], 0.5 * 0.3f64.cos());
    for _ in 0..2 {
        let mut trig = vec![f64::NAN; jit[0].trig_len()];
        let mut got = [7.0; 2];
        assert!(jit[0].eval_with_cache(&inputs, &mut trig, &mut got).is_ok());
        assert_eq!(got[0].to_bits(), want[0].to_bits());
        assert!(got[1].is_nan());
    }
}

/// A short slice is refused before anything runs, and the output is left
/// as it was.
#[test]
fn short_slices_are_refused() {
    let mut a = Arena::new();
    let x = a.coordinate("x", 2);
    let p = a.parameter("p", 1);
    let s = a.sin(x);
    let e = a.mul(s, p);
    let tape = Tape::compile(&a, &[e, x]);
    let jit = compile(&[&tape]).expect("the host is supported");
    let q = [0.0, 0.0, 0.5];
    let params = [0.0, 2.0];
    let mut out = [9.0; 2];
    let ok = TapeInputs {
        q: &q,
        qd: &[],
        params: &params,
        t: 0.0,
    };
    assert!(jit[0].eval(&ok, &mut out).is_ok());
    assert_eq!(out, [2.0 * 0.5f64.sin(), 0.5]);
    let mut out = [9.0; 2];
    let short_q = TapeInputs { q: &q[..2], ..ok };
    assert_eq!(
        jit[0].eval(&short_q, &mut out),
        Err(JitError::ShortSlice {
            which: "q",
            needed: 3,
            given: 2
        })
    );
    let short_p = TapeInputs {
        params: &params[..1],
        ..ok
    };
    assert!(matches!(
        jit[0].eval(&short_p, &mut out),
        Err(JitError::ShortSlice {
            which: "params",
            ..
        })
    ));
    assert!(matches!(
        jit[0].eval(&ok, &mut out[..1]),
        Err(JitError::ShortSlice {
            which: "outputs",
            ..
        })
    ));
    assert_eq!(out, [9.0; 2]);
}

/// Compiled code outlives the tapes and is shared by clones; dropping
/// every clone frees it (no crash when many modules come and go).
#[test]
fn code_is_shared_and_freed() {
    let mut a = Arena::new();
    let x = a.coordinate("x", 0);
    let c = a.cos(x);
    let e = a.add(c, x);
    for _ in 0..50 {
        let jit = {
            let tape = Tape::compile(&a, &[e]);
            compile(&[&tape]).expect("the host is supported")
        };
        let clone = jit[0].clone();
        drop(jit);
        let mut out = [0.0];
        let inputs = TapeInputs {
            q: &[0.25],
            qd: &[],
            params: &[],
            t: 0.0,
        };
        assert!(clone.eval(&inputs, &mut out).is_ok());
        assert_eq!(out[0].to_bits(), (0.25f64.cos() + 0.25).to_bits());
    }
}

/// Compiled tapes go to other threads (sweeps clone a system per worker).
#[test]
fn compiled_tapes_are_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<kinema_jit::JitTape>();
}
