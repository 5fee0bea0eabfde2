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

    /// The chain of ten links generated with chunked evaluation methods (by
    /// build.rs) and in one body each (by the macro): the same trajectory,
    /// to the bit, and the chunked source really has chunks.
    #[test]
    fn chunked_evaluation_is_the_same_code() -> Result<(), kinema::Error> {
        // Each model's items that this test does not use are dead code here.
        #[allow(dead_code)]
        mod chunked {
            include!(concat!(env!("OUT_DIR"), "/chain10_chunked.rs"));
        }
        #[allow(dead_code)]
        mod whole {
            kinema::mechanism!(file = "../../models/chain10.kin");
        }
        let source = include_str!(concat!(env!("OUT_DIR"), "/chain10_chunked.rs"));
        assert!(source.matches("fn __kinema_phi_and_jacobian_").count() > 3);
        let options = kinema::Options::same_algorithm();
        let mut a = chunked::Chain10::default().solver(options)?;
        let mut b = whole::Chain10::default().solver(options)?;
        for k in 0..=50 {
            let t = f64::from(k) / 50.0;
            let (sa, sb) = (a.step(t)?, b.step(t)?);
            assert_eq!(sa, sb, "t = {t}");
        }
        Ok(())
    }
}
