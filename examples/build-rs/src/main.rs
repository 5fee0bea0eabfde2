//! A solver generated at build time (see build.rs) from `models/pendulum.kin`,
//! the driven pendulum of ME451 Example 3.1.1, with the formatted source in
//! `OUT_DIR/pendulum.rs` for anyone who wants to read it.
//!
//! `cargo run -p kinema-example-build-rs`

include!(concat!(env!("OUT_DIR"), "/pendulum.rs"));

fn main() -> Result<(), kinema::Error> {
    let mut solver = Pendulum::default().solver(kinema::Options::default())?;
    println!(
        "{:>5}  {:>9}  {:>9}  {:>9}  {:>11}",
        "t", "x", "y", "phi", "phi_ddot"
    );
    for k in 0..=10 {
        let t = f64::from(k) / 10.0;
        let s = solver.step(t)?;
        println!(
            "{t:>5.2}  {:>9.5}  {:>9.5}  {:>9.5}  {:>11.5}",
            s.q()[0],
            s.q()[1],
            s.q()[2],
            s.qdd()[2]
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::Pendulum;

    /// CONSTRAINTS.md §8 at t = 0.5: q = (cos 1, sin 1, 1), q̈ = (−15.376605, −9.141117, 8).
    #[test]
    fn worked_example() -> Result<(), kinema::Error> {
        let mut solver = Pendulum::default().solver(kinema::Options::default())?;
        let s = solver.step(0.5)?;
        let q = [1f64.cos(), 1f64.sin(), 1.0];
        for (a, b) in s.q().iter().zip(q) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
        // ẍ = d²/dt² cos(4t²) = −64t² cos 4t² − 8 sin 4t²
        let want = [
            -16.0 * 1f64.cos() - 8.0 * 1f64.sin(),
            -16.0 * 1f64.sin() + 8.0 * 1f64.cos(),
            8.0,
        ];
        for (a, b) in s.qdd().iter().zip(want) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
        Ok(())
    }
}
