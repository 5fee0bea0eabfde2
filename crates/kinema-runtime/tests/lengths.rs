//! The `System` trait's one rule for slices of the wrong length: never a
//! panic; every output given is filled with NaN, so the caller sees
//! non-finite values. The hand-written reference systems follow it.

#![cfg(feature = "handwritten")]

use kinema_runtime::System;
use kinema_runtime::handwritten::{Chain, FourBar, SliderCrank};

fn wrong_lengths_give_nan<S: System>(system: &S) {
    let n = system.len();
    let nnz = system.jacobian_pattern().len();
    let mut scratch = system.scratch();
    let good = vec![0.1; n];
    let short = vec![0.1; n - 1];
    let mut out = vec![0.0; n];
    system.phi(&mut scratch, &short, 0.0, &mut out);
    assert!(
        out.iter().all(|x| x.is_nan()),
        "phi with a short q: {out:?}"
    );
    let mut long = vec![0.0; n + 1];
    system.nu(&mut scratch, &good, 0.0, &mut long);
    assert!(long.iter().all(|x| x.is_nan()), "nu into a long output");
    let mut values = vec![0.0; nnz - 1];
    system.jacobian(&mut scratch, &good, 0.0, &mut values);
    assert!(values.iter().all(|x| x.is_nan()), "short Jacobian values");
    let (mut phi, mut values) = (vec![0.0; n], vec![0.0; nnz + 2]);
    system.phi_and_jacobian(&mut scratch, &good, 0.0, &mut phi, &mut values);
    assert!(phi.iter().chain(&values).all(|x| x.is_nan()));
    let mut gamma = vec![0.0; n];
    system.gamma(&mut scratch, &good, &short, 0.0, &mut gamma);
    assert!(gamma.iter().all(|x| x.is_nan()), "gamma with a short qd");
    let mut guess = vec![0.0; n + 3];
    system.initial_guess(&mut guess);
    assert!(guess.iter().all(|x| x.is_nan()));
    // The right lengths give numbers, with the same scratch.
    system.phi(&mut scratch, &good, 0.0, &mut out);
    assert!(out.iter().all(|x| x.is_finite()));
}

#[test]
fn hand_written_systems_give_nan_for_wrong_lengths() {
    wrong_lengths_give_nan(&SliderCrank::default());
    wrong_lengths_give_nan(&FourBar::default());
    wrong_lengths_give_nan(&Chain::new(4));
}
