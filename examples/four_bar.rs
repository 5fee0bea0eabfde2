//! The four-bar linkage (a Grashof crank-rocker) through the `mechanism!`
//! macro, with the model read from `models/four_bar.kin`: the rocker's angle
//! and angular velocity over one crank revolution, and the path of the
//! coupler's midpoint, as a table.
//!
//! `cargo run --example four_bar`

use kinema::{Axis, Body, Options};

kinema::mechanism!(file = "models/four_bar.kin");

fn main() -> Result<(), kinema::Error> {
    let mut solver = FourBar::default().solver(Options::default())?;
    let times: Vec<f64> = (0..=12).map(|k| f64::from(k) / 12.0).collect();
    let trajectory = solver.run(&times)?;

    // Body order in the model: crank, coupler, rocker.
    let (coupler, rocker) = (Body::new(1), Body::new(2));
    println!(
        "{:>6}  {:>10}  {:>11}  {:>13}  {:>22}",
        "t [s]", "crank [°]", "rocker [°]", "rocker [°/s]", "coupler midpoint [m]"
    );
    for (k, state) in trajectory.iter().enumerate() {
        let mid = trajectory
            .point(k, coupler, [0.0, 0.0])
            .map_or([f64::NAN; 2], |p| p.position);
        println!(
            "{:>6.4}  {:>10.3}  {:>11.4}  {:>13.3}  ({:>9.6}, {:>9.6})",
            state.t(),
            state.q()[2].to_degrees(),
            state.q()[rocker.coord(Axis::Phi).index()].to_degrees(),
            state.qd()[rocker.coord(Axis::Phi).index()].to_degrees(),
            mid[0],
            mid[1],
        );
    }
    Ok(())
}
