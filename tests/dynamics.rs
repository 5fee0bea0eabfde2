//! Inverse dynamics against closed forms: a driven pendulum's pin reaction
//! and driving torque by Newton–Euler by hand, and the slider-crank's
//! power balance (effort × driven velocity = d(KE + PE)/dt) at every row.

use kinema::{Error, InverseDynamics, Model, Options};

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1.0)
}

const PENDULUM: &str = "
mechanism Pendulum {
    param L = 0.7;
    param m = 2.5;
    param J = 0.4;
    gravity = (0, -9.81);
    body bar { mass: m, inertia: J, guess: (0.5, 0.4, 0.9) }
    joint pin: revolute(bar(-L, 0), ground(0, 0));
    driver swing: bar.phi == 0.3 + 1.5 * t + 2 * t * t;
}";

#[test]
fn pendulum_pin_reaction_and_torque_by_newton_euler() -> Result<(), Error> {
    let model = Model::from_source(PENDULUM, "pendulum.kin")?;
    let mut solver = model.solver(Options::default())?;
    let mut id = InverseDynamics::new(solver.system());
    let names = solver.system().reaction_names().to_vec();
    let pin = names
        .iter()
        .position(|r| r.element == "pin" && r.body == "bar")
        .expect("a reaction of the pin on the bar");
    let (l, m, j, g) = (0.7, 2.5, 0.4, 9.81);
    for k in 0..=40 {
        let t = 0.05 * f64::from(k);
        solver.step(t)?;
        solver.inverse_dynamics(&mut id)?;
        // By hand: φ, φ̇, φ̈ of the drive; the centroid r = L e.
        let (phi, w, a) = (0.3 + 1.5 * t + 2.0 * t * t, 1.5 + 4.0 * t, 4.0);
        let (c, s) = (phi.cos(), phi.sin());
        let acc = [l * (-s * a - c * w * w), l * (c * a - s * w * w)];
        // m r̈ = F_pin + m g.
        let f = [m * acc[0], m * acc[1] + m * g];
        // J φ̈ = τ + (r_pin − r) × F_pin, r_pin − r = −L e.
        let tau = j * a + l * (c * f[1] - s * f[0]);
        let r = id.reactions()[pin];
        assert!(rel(r[0], f[0]) < 1e-9, "t = {t}: Fx {} vs {}", r[0], f[0]);
        assert!(rel(r[1], f[1]) < 1e-9, "t = {t}: Fy {} vs {}", r[1], f[1]);
        assert!(
            r[2].abs() < 1e-9 * f[0].hypot(f[1]),
            "t = {t}: T at the pin {}",
            r[2]
        );
        let effort = id.efforts()[0];
        assert!(rel(effort, tau) < 1e-9, "t = {t}: torque {effort} vs {tau}");
        // λ of the driver row is −effort.
        assert_eq!(id.lambda()[2], -effort);
    }
    Ok(())
}

/// KE and PE rates of a state: q̇ᵀ M q̈ and −Σ m gᵀ ṙ.
fn power(masses: &[f64], g: [f64; 2], qd: &[f64], qdd: &[f64]) -> f64 {
    let kinetic: f64 = masses
        .iter()
        .zip(qd)
        .zip(qdd)
        .map(|((m, v), a)| m * v * a)
        .sum();
    let potential: f64 = masses
        .chunks(3)
        .zip(qd.chunks(3))
        .map(|(m, v)| -(m[0] * g[0] * v[0] + m[1] * g[1] * v[1]))
        .sum();
    kinetic + potential
}

fn slider_crank_with_inertia() -> String {
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/models/slider_crank.kin"
    ))
    .expect("models/slider_crank.kin");
    src.replace(
        "body crank  { guess: (0.1, 0.1, 0.8) }",
        "body crank  { guess: (0.1, 0.1, 0.8), mass: 2, inertia: 0.015 }",
    )
    .replace(
        "body rod    { guess: (0.7, 0.1, -0.2) }",
        "body rod    { guess: (0.7, 0.1, -0.2), mass: 3, inertia: 0.25 }",
    )
    .replace(
        "body slider { guess: (1.2, 0.0, 0.0) }",
        "body slider { guess: (1.2, 0.0, 0.0), mass: 5, inertia: 0.5 }\n    gravity = (0, -9.81);",
    )
}

#[test]
fn slider_crank_power_balance_at_every_row() -> Result<(), Error> {
    let src = slider_crank_with_inertia();
    assert!(
        src.matches("mass:").count() == 3 && src.contains("gravity"),
        "{src}"
    );
    let model = Model::from_source(&src, "slider_crank.kin")?;
    let masses = [2.0, 2.0, 0.015, 3.0, 3.0, 0.25, 5.0, 5.0, 0.5];
    let mut solver = model.solver(Options::default())?;
    let mut id = InverseDynamics::new(solver.system());
    let omega = 2.0 * std::f64::consts::PI;
    let mut largest: f64 = 0.0;
    for k in 0..=200 {
        let t = 0.005 * f64::from(k);
        let state = solver.step(t)?;
        let rate = power(&masses, [0.0, -9.81], state.qd(), state.qdd());
        solver.inverse_dynamics(&mut id)?;
        let supplied = id.efforts()[0] * omega;
        largest = largest.max(rate.abs());
        assert!(
            (supplied - rate).abs() <= 1e-9 * rate.abs().max(1.0),
            "t = {t}: effort × ω = {supplied}, d(KE + PE)/dt = {rate}"
        );
    }
    // The check is not vacuous: the crank does work.
    assert!(largest > 1.0, "{largest}");
    Ok(())
}

mod generated {
    kinema::mechanism!(file = "tests/dynamics/slider_crank.kin");
}

/// The generated solver (its own LU, solved transposed) gives the tape
/// back end's λ, reactions and efforts, and the power balance with the gas
/// force holds: effort × ω = d(KE + PE)/dt − F_gas ẋ_slider.
#[test]
fn generated_inverse_dynamics_matches_the_tapes() -> Result<(), Error> {
    let model = Model::from_file("tests/dynamics/slider_crank.kin")?;
    let mut tape = model.solver(Options::default())?;
    let mut tape_id = InverseDynamics::new(tape.system());
    let mut generated = generated::SliderCrank::default().solver(Options::default())?;
    let mut gen_id = InverseDynamics::new(generated.system());
    assert_eq!(
        generated::SliderCrank::REACTION_NAMES.len(),
        tape.system().reaction_names().len()
    );
    let masses = [2.0, 2.0, 0.015, 3.0, 3.0, 0.25, 5.0, 5.0, 0.5];
    let omega = 2.0 * std::f64::consts::PI;
    for k in 0..=100 {
        let t = 0.01 * f64::from(k);
        let s = tape.step(t)?;
        let gas = (-40.0 - 3.0 * s.qd()[6]) * s.qd()[6];
        let rate = power(&masses, [0.0, -9.81], s.qd(), s.qdd()) - gas;
        generated.step(t)?;
        tape.inverse_dynamics(&mut tape_id)?;
        generated.inverse_dynamics(&mut gen_id)?;
        let pairs = tape_id.lambda().iter().zip(gen_id.lambda()).chain(
            tape_id
                .reactions()
                .iter()
                .flatten()
                .zip(gen_id.reactions().iter().flatten()),
        );
        for (a, b) in pairs {
            assert!(rel(*a, *b) < 1e-11, "t = {t}: tape {a}, generated {b}");
        }
        let supplied = gen_id.efforts()[0] * omega;
        assert!(
            (supplied - rate).abs() <= 1e-9 * rate.abs().max(1.0),
            "t = {t}: {supplied} vs {rate}"
        );
    }
    // The generated LU's own (static) factorization did the transposed
    // solves, not its fallback.
    assert_eq!(generated.linear_solver().fallback_count(), 0);
    Ok(())
}

/// The reactions and efforts of given multipliers
/// (`InverseDynamics::of_multipliers`, what forward dynamics and the
/// equilibrium report with) equal inverse dynamics' own at the same state
/// and λ, bit for bit; `DynamicsRow` lays them out as the CSV does; a
/// wrong length is an error, not a panic.
#[test]
fn given_multipliers_give_inverse_dynamics_reactions() -> Result<(), Error> {
    let model = Model::from_source(PENDULUM, "pendulum.kin")?;
    let mut solver = model.solver(Options::default())?;
    let system = solver.system().clone();
    let mut id = InverseDynamics::new(&system);
    let mut given = InverseDynamics::with_rows(&system, 3);
    let mut row = kinema::dynamics::DynamicsRow::new(&system, 3);
    let mut jac = vec![0.0; kinema::System::jacobian_pattern(&system).len()];
    let mut scratch = kinema::System::scratch(&system);
    for k in 0..=10 {
        let t = 0.1 * f64::from(k);
        solver.step(t)?;
        solver.inverse_dynamics(&mut id)?;
        let state = solver.state().expect("a state after a step");
        let (q, qd, qdd) = (
            state.q().to_vec(),
            state.qd().to_vec(),
            state.qdd().to_vec(),
        );
        given.of_multipliers(&system, &mut scratch, (t, &q, &qd), id.lambda(), &mut jac)?;
        assert_eq!(given.reactions(), id.reactions(), "t = {t}");
        assert_eq!(given.efforts(), id.efforts(), "t = {t}");
        let at = kinema::Motion {
            t,
            q: &q,
            qd: &qd,
            qdd: &qdd,
        };
        row.fill(&system, at, id.lambda())?;
        let flat: Vec<f64> = id
            .lambda()
            .iter()
            .chain(id.reactions().iter().flatten())
            .chain(id.efforts())
            .copied()
            .collect();
        assert_eq!(row.dynamics(), flat.as_slice(), "t = {t}");
        assert_eq!(
            row.dynamics().len(),
            system.dynamics_column_names(3, false).len()
        );
    }
    let short = given.of_multipliers(
        &system,
        &mut scratch,
        (0.0, &[0.0; 3], &[0.0; 3]),
        &[0.0; 2],
        &mut jac,
    );
    assert!(short.is_err(), "{short:?}");
    Ok(())
}
