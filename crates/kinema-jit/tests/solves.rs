//! A folded LU's factorization and solves compiled (kinema-jit) against
//! the interpreted ones on random sparse matrices with folded constants:
//! the same verdicts, the same pivot reports, the same bits in both
//! directions, and the same fallback (a changed constant, a NaN entry).

use kinema_jit::{compile_factor, compile_factor_chunked, compile_solves, compile_solves_chunked};
use kinema_runtime::{FoldedLu, LinearSolver};
use proptest::prelude::*;

/// An n × n pattern: the diagonal and random off-diagonal entries, some
/// of them constants ±1 or 2.5; values at the "initial guess". Half the
/// matrices have a constant unit diagonal and small run-time entries (as
/// a mechanism's x and y rows): their pivots are constants and their
/// multipliers the run-time entries themselves.
/// (n, pattern, constants, values).
type Matrix = (usize, Vec<(u32, u32)>, Vec<Option<f64>>, Vec<f64>);

fn matrix() -> impl Strategy<Value = Matrix> {
    (2usize..12).prop_flat_map(|n| {
        let cells = n * n;
        (
            Just(n),
            proptest::collection::vec((0..cells, 0u8..6, -2.0f64..2.0), n..3 * n),
            proptest::collection::vec(1.0f64..3.0, n),
            any::<bool>(),
        )
            .prop_map(|(n, extra, diag, unit)| {
                let mut entries: std::collections::BTreeMap<(u32, u32), (Option<f64>, f64)> =
                    std::collections::BTreeMap::new();
                for (i, d) in diag.iter().enumerate() {
                    let entry = if unit {
                        (Some(1.0), 1.0)
                    } else {
                        (None, 4.0 + d)
                    };
                    entries.insert((i as u32, i as u32), entry);
                }
                for (cell, kind, v) in extra {
                    let (r, c) = ((cell / n) as u32, (cell % n) as u32);
                    let constant = match kind {
                        0 => Some(1.0),
                        1 => Some(-1.0),
                        2 => Some(2.5),
                        _ => None,
                    };
                    entries
                        .entry((r, c))
                        .or_insert((constant, constant.unwrap_or(if unit { 0.2 * v } else { v })));
                }
                let pattern = entries.keys().copied().collect();
                let constants = entries.values().map(|e| e.0).collect();
                let values = entries.values().map(|e| e.1).collect();
                (n, pattern, constants, values)
            })
    })
}

fn same(a: &[f64], b: &[f64]) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn compiled_solves_equal_interpreted((n, pattern, constants, values) in matrix(),
                                         rhs in proptest::collection::vec(-3.0f64..3.0, 12),
                                         moved in -0.5f64..0.5,
                                         chunk in 1usize..12,
                                         register in 0usize..12,
                                         looped in 0usize..40) {
        let mut plain = FoldedLu::new(n, &pattern, &constants, &values).expect("analysis");
        let mut jit = FoldedLu::new(n, &pattern, &constants, &values).expect("analysis");
        // And one compiled in chunks of at most `chunk` items, so values
        // cross the chunks' boundaries (through the value array, the scan
        // and the solve's scratch).
        let mut chunked = FoldedLu::new(n, &pattern, &constants, &values).expect("analysis");
        prop_assume!(plain.is_planned());
        let plan = chunked.solves().expect("a plan");
        let compiled = compile_solves_chunked(&plan, chunk, register).expect("the host is supported");
        chunked.set_compiled_solves(Box::new(compiled));
        let factor = chunked.factorization().expect("a plan");
        let compiled = compile_factor_chunked(&factor, chunk, looped).expect("the host is supported");
        chunked.set_compiled_factor(Box::new(compiled));
        let plan = jit.solves().expect("a plan");
        let compiled = compile_solves(&plan).expect("the host is supported");
        jit.set_compiled_solves(Box::new(compiled));
        prop_assert!(jit.has_compiled_solves());
        let factor = jit.factorization().expect("a plan");
        let compiled = compile_factor(&factor).expect("the host is supported");
        jit.set_compiled_factor(Box::new(compiled));
        prop_assert!(jit.has_compiled_factor());
        // At the guess and at moved run-time values (constants kept).
        let moved: Vec<f64> = values
            .iter()
            .zip(&constants)
            .map(|(v, c)| c.unwrap_or(v + moved * v.abs()))
            .collect();
        // Run-time entries 30 times larger: multipliers over 1/θ where a
        // constant pivots, so the multipliers' fold decides the verdict.
        let boosted: Vec<f64> = values
            .iter()
            .zip(&constants)
            .map(|(v, c)| c.unwrap_or(30.0 * v))
            .collect();
        for vals in [&values, &moved, &boosted] {
            // The acceptance test at tolerances up to its limits: the same
            // verdict (the folded order's report or the fallback's) each time.
            for tol in [0.5, 0.2, 0.1, 0.05, 0.02, 1e-3] {
                let (a, b) = (plain.factor(vals, tol), jit.factor(vals, tol));
                prop_assert_eq!(a.is_ok(), b.is_ok());
                prop_assert_eq!(plain.pivot_report(), jit.pivot_report(), "tolerance {}", tol);
                let c = chunked.factor(vals, tol);
                prop_assert_eq!(a.is_ok(), c.is_ok());
                prop_assert_eq!(plain.pivot_report(), chunked.pivot_report(), "chunked, tolerance {}", tol);
            }
            let (a, b) = (plain.factor(vals, 1e-12), jit.factor(vals, 1e-12));
            prop_assert_eq!(a.is_ok(), b.is_ok());
            prop_assert_eq!(plain.pivot_report(), jit.pivot_report());
            let c = chunked.factor(vals, 1e-12);
            prop_assert_eq!(a.is_ok(), c.is_ok());
            prop_assert_eq!(plain.pivot_report(), chunked.pivot_report());
            if a.is_err() {
                continue;
            }
            let mut x = rhs[..n].to_vec();
            let mut y = rhs[..n].to_vec();
            let mut z = rhs[..n].to_vec();
            prop_assert!(plain.solve_in_place(&mut x).is_ok());
            prop_assert!(jit.solve_in_place(&mut y).is_ok());
            prop_assert!(chunked.solve_in_place(&mut z).is_ok());
            prop_assert!(same(&x, &y), "solve: {x:?} vs {y:?}");
            prop_assert!(same(&x, &z), "chunked solve: {x:?} vs {z:?}");
            let mut x = rhs[..n].to_vec();
            let mut y = rhs[..n].to_vec();
            let mut z = rhs[..n].to_vec();
            prop_assert!(plain.solve_transpose_in_place(&mut x).is_ok());
            prop_assert!(jit.solve_transpose_in_place(&mut y).is_ok());
            prop_assert!(chunked.solve_transpose_in_place(&mut z).is_ok());
            prop_assert!(same(&x, &y), "transposed: {x:?} vs {y:?}");
            prop_assert!(same(&x, &z), "chunked transposed: {x:?} vs {z:?}");
        }
        // A changed constant, a NaN or an infinite entry: both fall back to
        // the general solver alike.
        let constant = constants.iter().position(Option::is_some);
        for (k, change) in [(constant, 0.25), (Some(0), f64::NAN), (Some(values.len() - 1), f64::INFINITY)] {
            let Some(k) = k else { continue };
            let mut changed = values.clone();
            changed[k] += change;
            let (a, b) = (plain.factor(&changed, 1e-12), jit.factor(&changed, 1e-12));
            prop_assert_eq!(a.is_ok(), b.is_ok());
            prop_assert_eq!(plain.pivot_report(), jit.pivot_report());
            let c = chunked.factor(&changed, 1e-12);
            prop_assert_eq!(a.is_ok(), c.is_ok());
            prop_assert_eq!(plain.pivot_report(), chunked.pivot_report());
            if a.is_ok() {
                let mut x = rhs[..n].to_vec();
                let mut y = rhs[..n].to_vec();
                prop_assert!(plain.solve_in_place(&mut x).is_ok());
                prop_assert!(jit.solve_in_place(&mut y).is_ok());
                prop_assert!(same(&x, &y), "fallback: {x:?} vs {y:?}");
            }
        }
        // Constants trusted, factored as written (the constants' check
        // skipped, by the prologue too): the same verdicts and solutions.
        for lu in [&mut plain, &mut jit, &mut chunked] {
            lu.trust_constants();
        }
        // A changed constant included: trusted, it is not read (each
        // factorization uses the planned constant), so the compiled
        // factorization must skip the check as the interpreter does.
        let mut changed = moved.clone();
        if let Some(k) = constant {
            changed[k] += 0.25;
        }
        for vals in [&values, &moved, &boosted, &changed] {
            let a = plain.factor_as_written(vals, 1e-12);
            let (b, c) = (jit.factor_as_written(vals, 1e-12), chunked.factor_as_written(vals, 1e-12));
            prop_assert_eq!(a.is_ok(), b.is_ok());
            prop_assert_eq!(a.is_ok(), c.is_ok());
            prop_assert_eq!(plain.pivot_report(), jit.pivot_report());
            prop_assert_eq!(plain.pivot_report(), chunked.pivot_report());
            if a.is_ok() {
                let (mut x, mut y, mut z) = (rhs[..n].to_vec(), rhs[..n].to_vec(), rhs[..n].to_vec());
                prop_assert!(plain.solve_in_place(&mut x).is_ok());
                prop_assert!(jit.solve_in_place(&mut y).is_ok());
                prop_assert!(chunked.solve_in_place(&mut z).is_ok());
                prop_assert!(same(&x, &y), "trusted: {x:?} vs {y:?}");
                prop_assert!(same(&x, &z), "trusted, chunked: {x:?} vs {z:?}");
            }
        }
    }
}
