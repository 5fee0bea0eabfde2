//! The schedule's tests: the scale-and-finiteness passes agree with each
//! other and see every non-finite value, and every solver repivots when the
//! recorded order fails.

use super::*;
use crate::linalg::{DenseLu, DynDenseLu, LinalgError, LinearSolver, SparseLu};

#[test]
fn both_norm_passes_agree() {
    for n in [0, 1, 5, 9, 31, 32, 33, 100] {
        let v: Vec<f64> = (0..n).map(|i| ((i * 7919) % 13) as f64 - 6.5).collect();
        assert_eq!(scale_and_finite_bits(&v), scale_and_finite_lanes(&v), "{n}");
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for at in (0..n).step_by(3) {
                let mut w = v.clone();
                w[at] = bad;
                assert!(!scale_and_finite_bits(&w).1 && !scale_and_finite_lanes(&w).1);
            }
        }
    }
}

#[test]
fn the_array_form_agrees_with_the_slice_form() {
    fn check<const N: usize>() {
        let v: [f64; N] = std::array::from_fn(|i| ((i * 7919) % 13) as f64 - 6.5);
        assert_eq!(scale_and_finite_array(v), scale_and_finite(&v), "{N}");
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for at in 0..N {
                let mut w = v;
                w[at] = bad;
                assert!(!scale_and_finite_array(w).1, "{N} at {at}");
            }
        }
    }
    check::<0>();
    check::<1>();
    check::<5>();
    check::<8>();
    check::<13>();
    check::<32>();
}

#[test]
fn the_masked_pass_agrees_with_the_bits() {
    for n in [0, 1, 3, 4, 5, 9, 33, 100] {
        let v: Vec<f64> = (0..n)
            .map(|i| ((i * 7919) % 13) as f64 - 6.5 + (i as f64) * 1e-3)
            .collect();
        for pick in [0, 1, 2, 3, 7] {
            // Every value, none, or every pick-th.
            let mask: Vec<u64> = (0..n)
                .map(|i| {
                    if pick != 0 && i % pick == 0 {
                        MASK_ALL
                    } else {
                        0
                    }
                })
                .collect();
            let bits_max = v
                .iter()
                .zip(&mask)
                .map(|(x, m)| x.to_bits() & m & MAGNITUDE_MASK)
                .max()
                .unwrap_or(0);
            let (scale, most, finite) = scale_and_masked_max(&v, &mask);
            assert_eq!((scale, finite), scale_and_finite_bits(&v), "{n} {pick}");
            assert_eq!(most.to_bits(), bits_max, "{n} {pick}");
            // A short mask leaves the rest out of the masked maximum
            // but not out of the scale.
            let short = &mask[..n / 2];
            let (s2, m2, f2) = scale_and_masked_max(&v, short);
            assert_eq!((s2, f2), (scale, finite));
            assert!(m2 <= most);
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                for at in (0..n).step_by(2) {
                    let mut w = v.clone();
                    w[at] = bad;
                    assert!(!scale_and_masked_max(&w, &mask).2, "{n} {pick} {at}");
                    assert!(!scale_and_masked_max(&w, short).2, "{n} {pick} {at}");
                }
            }
        }
    }
}

#[test]
fn scale_and_finite_at_agrees_with_gathering() {
    let values: Vec<f64> = (0..50).map(|i| (i as f64 * 0.37).sin() * 1e3).collect();
    for len in [0, 3, 4, 17, 40] {
        let at: Vec<usize> = (0..len).map(|i| (i * 7) % 50).collect();
        let gathered: Vec<f64> = at.iter().map(|&k| values[k]).collect();
        assert_eq!(
            scale_and_finite_at(&values, &at),
            scale_and_finite(&gathered)
        );
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut v = values.clone();
            if let Some(&k) = at.last() {
                v[k] = bad;
                assert!(!scale_and_finite_at(&v, &at).1);
            }
        }
    }
}

#[test]
fn scale_and_finite_sees_every_non_finite() {
    assert_eq!(scale_and_finite(&[]), (0.0, true));
    assert_eq!(
        scale_and_finite(&[1.0, -3.5, 2.0, 0.0, -0.0, 1e-300]),
        (3.5, true)
    );
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for at in 0..6 {
            let mut v = [1.0; 6];
            v[at] = bad;
            assert!(!scale_and_finite(&v).1, "{bad} at {at}");
        }
    }
}

/// A factorization whose recorded pivot order stops being acceptable
/// (a₀₀ shrinks to 1e-3 ≪ a₁₀) must repivot and still solve exactly.
fn repivots<L: LinearSolver>() -> Result<(), LinalgError> {
    let pattern = [(0, 0), (0, 1), (1, 0), (1, 1)];
    let mut lu = L::analyze(2, &pattern)?;
    for a in [
        [2.0, 1.0, 1.0, 2.0],
        [1e-3, 1.0, 1.0, 1.0],
        [2.0, 1.0, 1.0, 2.0],
        [1.0, 1.0, 1e-3, 1.0],
    ] {
        lu.factor(&a, 1e-12)?;
        let x = [0.25, -4.0];
        let mut b = [a[0] * x[0] + a[1] * x[1], a[2] * x[0] + a[3] * x[1]];
        lu.solve_in_place(&mut b)?;
        assert!(
            (b[0] - x[0]).abs() < 1e-13 && (b[1] - x[1]).abs() < 1e-13,
            "{a:?}: {b:?}"
        );
    }
    Ok(())
}

#[test]
fn every_solver_repivots_when_the_recorded_order_fails() -> Result<(), LinalgError> {
    repivots::<DenseLu<2>>()?;
    repivots::<DynDenseLu>()?;
    repivots::<SparseLu>()
}
