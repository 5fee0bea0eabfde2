//! A constraint the library lacks, written by hand in the model language: the
//! end P of a rod runs in an elliptical slot fixed to ground,
//! ((P.x − cx)/a)² + (P.y/b)² = 1. kinema differentiates it like any library
//! joint: Φ_q, ν and γ come from the engine, never from the user.
//!
//! `cargo run --example custom_constraint`

use kinema::{Body, Options};

kinema::mechanism! {
    mechanism EllipticSlot {
        /// crank length [m]
        param l1 = 0.3;
        /// rod length [m]
        param l2 = 1.0;
        /// slot centre x [m] and semi-axes [m]
        param cx = 0.8;
        param a = 0.5;
        param b = 0.2;

        body crank { guess: (0.1, 0.1, 0.8) }
        body rod   { guess: (0.7, 0.17, -0.09) }

        /// the rod's end that runs in the slot
        point rod.p = (l2 / 2, 0);

        joint pivot: revolute(crank(-l1 / 2, 0), ground(0, 0));
        joint pin:   revolute(crank(l1 / 2, 0), rod(-l2 / 2, 0));
        /// P stays on the ellipse (not in the library: written by hand)
        constraint in_slot: powi((rod.p.x - cx) / a, 2) + powi(rod.p.y / b, 2) == 1;
        /// the crank rocks around 45°
        driver crank_angle: crank.phi == pi / 4 + 0.6 * sin(2 * pi * t);
    }
}

fn main() -> Result<(), kinema::Error> {
    let mechanism = EllipticSlot::default();
    let (cx, a, b) = (mechanism.cx, mechanism.a, mechanism.b);
    let half_rod = mechanism.l2 / 2.0;
    let mut solver = mechanism.solver(Options::default())?;
    let times: Vec<f64> = (0..=10).map(|k| f64::from(k) / 10.0).collect();
    let trajectory = solver.run(&times)?;

    println!("The derived acceleration right-hand side of the hand-written row:");
    for line in EllipticSlot::derivation()
        .lines()
        .skip_while(|l| !l.starts_with("gamma"))
    {
        if line.contains("in_slot") {
            println!("{}\n", line.trim());
        }
    }
    println!(
        "{:>5}  {:>10}  {:>22}  {:>22}  {:>10}",
        "t", "crank [°]", "P [m]", "P velocity [m/s]", "slot eq."
    );
    for (k, state) in trajectory.iter().enumerate() {
        let rod = Body::new(1);
        let Some(p) = trajectory.point(k, rod, [half_rod, 0.0]) else {
            continue;
        };
        let on_slot = ((p.position[0] - cx) / a).powi(2) + (p.position[1] / b).powi(2);
        println!(
            "{:>5.2}  {:>10.3}  ({:>9.6}, {:>9.6})  ({:>9.5}, {:>9.5})  {:>10.2e}",
            state.t(),
            state.q()[2].to_degrees(),
            p.position[0],
            p.position[1],
            p.velocity[0],
            p.velocity[1],
            on_slot - 1.0,
        );
    }
    Ok(())
}
