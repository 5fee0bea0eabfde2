//! Forward dynamics does not allocate per step: a counting allocator
//! (this thread's allocations only, as in the runtime's allocation test)
//! around HHT's and the accurate mode's steps on the tape back end.

use kinema::{Accurate, Hht, HhtOptions, Model};

#[path = "../crates/kinema-runtime/tests/common/counting.rs"]
mod counting;
use counting::allocations;

const SLIDER_CRANK: &str = "
mechanism SliderCrankFree {
    body crank  { guess: (0.106066, 0.106066, 0.785398), mass: 2, inertia: 0.015 }
    body rod    { guess: (0.7, 0.1, -0.2), mass: 3, inertia: 0.25 }
    body slider { guess: (1.2, 0.0, 0.0), mass: 5, inertia: 0.5 }
    gravity = (0, -9.81);
    force gas: point_force(slider(0, 0), (-40 - 3 * slider.x_dot, 0));
    force spring: tsda(slider(0, 0), ground(2, 0), 100, 1, 0.8);
    joint pivot: revolute(crank(-0.15, 0), ground(0, 0));
    joint pin:   revolute(crank(0.15, 0), rod(-0.5, 0));
    joint wrist: revolute(rod(0.5, 0), slider(0, 0));
    constraint on_axis: abs_y(slider(0, 0), 0);
    constraint no_turn: abs_angle(slider, 0);
}";

#[test]
fn steps_do_not_allocate() {
    let m = Model::from_source(SLIDER_CRANK, "sc.kin").expect("model");
    let q0 = m.initial_configuration();
    let qd0 = vec![0.0; q0.len()];
    let sys = m.forward_system().expect("inertia");
    let (mut hht, _) = Hht::new(sys.clone(), &q0, &qd0, 0.0, HhtOptions::default()).expect("start");
    hht.step(1e-3).expect("first step");
    let before = allocations();
    for _ in 0..200 {
        hht.step(1e-3).expect("step");
    }
    hht.advance_to(0.5, 1e-3).expect("advance");
    let hht_allocations = allocations() - before;

    let mut acc = Accurate::new(sys, hht.q(), hht.qd(), hht.t(), 1e-9).expect("start");
    acc.advance_to(0.55).expect("first");
    let before = allocations();
    for k in 1..=20 {
        acc.advance_to(0.55 + 0.01 * f64::from(k)).expect("advance");
    }
    let accurate_allocations = allocations() - before;
    // The counter counts.
    let before = allocations();
    let probe = std::hint::black_box(vec![1u8; 16]);
    assert!(allocations() > before && probe.len() == 16);
    assert_eq!(hht_allocations, 0, "HHT steps allocated");
    assert_eq!(accurate_allocations, 0, "accurate steps allocated");
}
