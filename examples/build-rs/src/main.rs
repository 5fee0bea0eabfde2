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
    use kinema::{LinearSolver, System};

    /// docs/src/constraints.md, the driven pendulum at t = 0.5: q = (cos 1, sin 1, 1), q̈ = (−15.376605, −9.141117, 8).
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

    /// The chain of ten links generated with chunked evaluation methods
    /// (the refreshes of its cache too), initial guess and LU
    /// solves (by build.rs) and in one body each (by
    /// the macro): the same trajectory and the same linear algebra, to the
    /// bit, and the chunked source really has chunks.
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
        for chunk in [
            "fn __kinema_phi_and_jacobian_",
            "fn __kinema_phi_and_jacobian_angles_",
            "fn __kinema_refresh_time_",
            "fn __kinema_initial_guess_",
            "fn __kinema_solve_",
            "fn __kinema_solve_transpose_",
        ] {
            assert!(source.matches(chunk).count() > 1, "{chunk}");
        }
        same_trajectory(
            chunked::Chain10::default().solver(kinema::Options::same_algorithm())?,
            whole::Chain10::default().solver(kinema::Options::same_algorithm())?,
        )?;
        same_linear_algebra::<_, _, chunked::Chain10Lu, whole::Chain10Lu>(
            &chunked::Chain10::default(),
            &whole::Chain10::default(),
        )
    }

    /// The four-bar, whose generated LU's factorization computes (the
    /// chain's folds away), with everything cut into chunks of three nodes
    /// or operations: the same as in one body, to the bit.
    #[test]
    fn chunked_factorization_is_the_same_code() -> Result<(), kinema::Error> {
        #[allow(dead_code)]
        mod chunked {
            include!(concat!(env!("OUT_DIR"), "/four_bar_chunked.rs"));
        }
        #[allow(dead_code)]
        mod whole {
            kinema::mechanism!(file = "../../models/four_bar.kin");
        }
        let source = include_str!(concat!(env!("OUT_DIR"), "/four_bar_chunked.rs"));
        for chunk in [
            "fn __kinema_factor_",
            "fn __kinema_initial_guess_",
            "fn __kinema_solve_",
            "fn __kinema_solve_transpose_",
        ] {
            assert!(source.matches(chunk).count() > 1, "{chunk}");
        }
        same_trajectory(
            chunked::FourBar::default().solver(kinema::Options::same_algorithm())?,
            whole::FourBar::default().solver(kinema::Options::same_algorithm())?,
        )?;
        same_linear_algebra::<_, _, chunked::FourBarLu, whole::FourBarLu>(
            &chunked::FourBar::default(),
            &whole::FourBar::default(),
        )
    }

    /// Fifty-one steps over t ∈ [0, 1] of two solvers: equal states.
    fn same_trajectory<A, B, LA, LB>(
        mut a: kinema::Solver<A, LA>,
        mut b: kinema::Solver<B, LB>,
    ) -> Result<(), kinema::Error>
    where
        A: System,
        B: System,
        LA: LinearSolver,
        LB: LinearSolver,
    {
        for k in 0..=50 {
            let t = f64::from(k) / 50.0;
            let (sa, sb) = (a.step(t)?, b.step(t)?);
            assert_eq!(sa, sb, "t = {t}");
        }
        Ok(())
    }

    /// The two systems' initial guesses, then their generated LUs on the
    /// Jacobian at points around the guess: factorization accepted alike,
    /// A x = b and Aᵀ x = b solved to the same bits.
    fn same_linear_algebra<A, B, LA, LB>(a: &A, b: &B) -> Result<(), kinema::Error>
    where
        A: System,
        B: System,
        LA: LinearSolver,
        LB: LinearSolver,
    {
        let n = a.len();
        let (mut qa, mut qb) = (vec![0.0; n], vec![0.0; n]);
        a.initial_guess(&mut qa);
        b.initial_guess(&mut qb);
        assert_eq!(bits(&qa), bits(&qb));
        let (mut la, mut lb) = (LA::analyze_system(a)?, LB::analyze_system(b)?);
        let nnz = a.jacobian_pattern().len();
        let (mut sa, mut sb) = (a.scratch(), b.scratch());
        for k in 0..20 {
            let shift = 0.05 * f64::from(k);
            let q: Vec<f64> = qa
                .iter()
                .enumerate()
                .map(|(i, x)| x + shift * (i as f64 + 1.0).sin())
                .collect();
            let (mut ja, mut jb) = (vec![0.0; nnz], vec![0.0; nnz]);
            a.jacobian(&mut sa, &q, 0.0, &mut ja);
            b.jacobian(&mut sb, &q, 0.0, &mut jb);
            let fa = la.factor(&ja, 1e-12);
            assert_eq!(fa, lb.factor(&jb, 1e-12), "k = {k}");
            if fa.is_err() {
                continue;
            }
            let rhs: Vec<f64> = (0..n).map(|i| (1.7 * i as f64 + shift).cos()).collect();
            let (mut xa, mut xb) = (rhs.clone(), rhs.clone());
            la.solve_in_place(&mut xa)?;
            lb.solve_in_place(&mut xb)?;
            assert_eq!(bits(&xa), bits(&xb), "solve, k = {k}");
            let (mut xa, mut xb) = (rhs.clone(), rhs);
            la.solve_transpose_in_place(&mut xa)?;
            lb.solve_transpose_in_place(&mut xb)?;
            assert_eq!(bits(&xa), bits(&xb), "transposed solve, k = {k}");
        }
        Ok(())
    }

    fn bits(x: &[f64]) -> Vec<u64> {
        x.iter().map(|v| v.to_bits()).collect()
    }
}
