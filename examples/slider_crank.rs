//! The slider-crank through the `mechanism!` macro: one crank revolution,
//! printed as a table of the crank angle and the slider's position, velocity
//! and acceleration.
//!
//! `cargo run --example slider_crank`

use kinema::{Options, System};

kinema::mechanism! {
    /// A crank pinned to ground drives a slider on the x axis through a rod.
    mechanism SliderCrank {
        /// crank length [m]
        param l1 = 0.3;
        /// rod length [m]
        param l2 = 1.0;
        /// crank speed [rad/s]
        param omega = 2 * pi;

        body crank  { guess: (0.1, 0.1, 0.8) }
        body rod    { guess: (0.7, 0.1, -0.2) }
        body slider { guess: (1.2, 0.0, 0.0) }

        point crank.o = (-l1 / 2, 0);

        joint pivot: revolute(crank.o, ground(0, 0));
        joint pin:   revolute(crank(l1 / 2, 0), rod(-l2 / 2, 0));
        joint wrist: revolute(rod(l2 / 2, 0), slider(0, 0));
        constraint on_axis: slider.y == 0;
        constraint no_turn: abs_angle(slider, 0);
        driver crank_angle: crank.phi == pi / 4 + omega * t;
    }
}

fn main() -> Result<(), kinema::Error> {
    let mut solver = SliderCrank::default().solver(Options::default())?;
    let times: Vec<f64> = (0..=16).map(|k| f64::from(k) / 16.0).collect();
    let trajectory = solver.run(&times)?;

    let slider_x = 6; // q index of slider.x
    println!(
        "{:>6}  {:>10}  {:>10}  {:>10}  {:>10}  {:>5}",
        "t [s]", "crank [°]", "x [m]", "ẋ [m/s]", "ẍ [m/s²]", "iter"
    );
    for state in trajectory.iter() {
        println!(
            "{:>6.4}  {:>10.3}  {:>10.6}  {:>10.6}  {:>10.5}  {:>5}",
            state.t(),
            state.q()[2].to_degrees(),
            state.q()[slider_x],
            state.qd()[slider_x],
            state.qdd()[slider_x],
            state.stats().iterations,
        );
    }
    println!(
        "\n{} coordinates ({}), mean Newton iterations per step {:.2}",
        solver.system().len(),
        SliderCrank::COORDINATE_NAMES.join(", "),
        trajectory.mean_iterations()
    );
    Ok(())
}
