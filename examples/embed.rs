//! The generated solver embedded in an application loop: a fixed-timestep
//! "controller" steps the slider-crank frame by frame, changes the crank
//! speed while running, and reads the slider's state and the crank pin's
//! velocity by name — with no allocation per step.
//!
//! `cargo run --example embed`

use kinema::Options;

kinema::mechanism!(file = "models/slider_crank.kin");

/// What the app keeps per frame.
struct Frame {
    t: f64,
    slider_x: f64,
    slider_v: f64,
    /// speed of the crank pin A (a named point of the model) [m/s]
    pin_speed: f64,
    newton: usize,
}

fn main() -> Result<(), kinema::Error> {
    // Default options: predictor from the previous step, full Newton.
    let mut solver = SliderCrank::default().solver(Options::default())?;
    solver.assemble(0.0)?;

    let dt = 1.0 / 60.0; // a 60 Hz loop
    let mut frames: Vec<Frame> = Vec::with_capacity(120);
    let mut t = 0.0;
    for frame in 1..=120 {
        t += dt;
        // Half-way through, the app speeds the crank up. The driver is
        // φ = π/4 + ω t, so a new ω moves the target angle; the solver follows
        // from the previous configuration.
        if frame == 60 {
            solver.system_mut().omega = 3.0 * std::f64::consts::PI;
        }
        solver.step(t)?;
        let Some(state) = solver.state() else { break };
        // Named points and outputs with their derivatives, on the stack.
        let [_, velocity, _] = solver.system().results(state);
        let pin_speed =
            velocity[SliderCrank::OUT_CRANK_PIN_X].hypot(velocity[SliderCrank::OUT_CRANK_PIN_Y]);
        frames.push(Frame {
            t: state.t(),
            slider_x: state.q()[SliderCrank::SLIDER_X],
            slider_v: state.qd()[SliderCrank::SLIDER_X],
            pin_speed,
            newton: state.stats().iterations,
        });
    }

    println!(
        "{:>8}  {:>10}  {:>10}  {:>10}  {:>6}",
        "t [s]", "x [m]", "ẋ [m/s]", "|v_A| [m/s]", "newton"
    );
    for f in frames.iter().step_by(10) {
        println!(
            "{:>8.4}  {:>10.6}  {:>10.5}  {:>10.5}  {:>6}",
            f.t, f.slider_x, f.slider_v, f.pin_speed, f.newton
        );
    }
    let max_newton = frames.iter().map(|f| f.newton).max().unwrap_or(0);
    println!(
        "\n{} frames, at most {max_newton} Newton updates in a frame",
        frames.len()
    );
    Ok(())
}
