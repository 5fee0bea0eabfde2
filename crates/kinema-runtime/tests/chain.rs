//! The serial chain through the sparse and dense paths, against its exact
//! forward kinematics; the four-bar's Newton counts.

mod common;

use common::{assert_close, benchmark_grid};
use kinema_runtime::handwritten::{Chain, FourBar};
use kinema_runtime::{
    Auto, Body, DenseLu, DynDenseLu, Error, LinearSolverFor, Options, Solver, SparseLu,
};

fn run<L: LinearSolverFor<Chain>>(
    links: usize,
    options: Options,
    times: &[f64],
) -> Result<kinema_runtime::Trajectory, Error> {
    Solver::<Chain, L>::with_options(Chain::new(links), options)?.run(times)
}

fn check_exact(links: usize, trajectory: &kinema_runtime::Trajectory, tol: f64) {
    let chain = Chain::new(links);
    for state in trajectory {
        let [q, qd, qdd] = chain.exact(state.t());
        let at = format!("N = {links}, t = {}", state.t());
        assert_close(&format!("q at {at}"), state.q(), &q, tol);
        assert_close(&format!("q̇ at {at}"), state.qd(), &qd, tol);
        assert_close(&format!("q̈ at {at}"), state.qdd(), &qdd, tol);
    }
}

#[test]
fn chain_10_sparse_equals_dense_and_exact() -> Result<(), Error> {
    let grid = benchmark_grid();
    for options in [Options::same_algorithm(), Options::default()] {
        let sparse = run::<SparseLu>(10, options, &grid)?;
        let dense = run::<DenseLu<30>>(10, options, &grid)?;
        let dyn_dense = run::<DynDenseLu>(10, options, &grid)?;
        for ((s, d), e) in sparse.iter().zip(&dense).zip(&dyn_dense) {
            let at = format!("t = {}", s.t());
            for (what, a, b, c) in [
                ("q", s.q(), d.q(), e.q()),
                ("q̇", s.qd(), d.qd(), e.qd()),
                ("q̈", s.qdd(), d.qdd(), e.qdd()),
            ] {
                assert_close(
                    &format!("SparseLu vs DenseLu<30>: {what} at {at}"),
                    a,
                    b,
                    1e-12,
                );
                assert_close(
                    &format!("SparseLu vs DynDenseLu: {what} at {at}"),
                    a,
                    c,
                    1e-12,
                );
            }
            assert_eq!(s.stats().iterations, d.stats().iterations, "at {at}");
        }
        check_exact(10, &sparse, 1e-10);
    }
    Ok(())
}

#[test]
fn chain_same_algorithm_reproduces_the_peers_newton_counts() -> Result<(), Error> {
    let trajectory = run::<SparseLu>(10, Options::same_algorithm(), &benchmark_grid())?;
    assert_eq!(format!("{:.3}", trajectory.mean_iterations()), "1.998");
    Ok(())
}

#[test]
fn chain_1000_sparse_matches_forward_kinematics() -> Result<(), Error> {
    // The first 21 times of the benchmark grid keep the (debug-build) test
    // quick; the benchmarks run the whole grid.
    let grid: Vec<f64> = (0..=20).map(|k| k as f64 / 1000.0).collect();
    let solver = Solver::<Chain>::new(Chain::new(1000))?;
    assert!(
        solver.linear_solver().is_sparse(),
        "Auto picks the sparse LU at n = 3000"
    );
    for options in [Options::same_algorithm(), Options::default()] {
        let trajectory = run::<Auto>(1000, options, &grid)?;
        // The chain's tip is 1000 links out: positions carry 1000 rounding
        // errors of the link vectors, accelerations ~(2π)² more.
        check_exact(1000, &trajectory, 1e-9);
    }
    Ok(())
}

#[test]
fn four_bar_same_algorithm_reproduces_the_peers_newton_counts() -> Result<(), Error> {
    let mut solver =
        Solver::<FourBar, DenseLu<9>>::with_options(FourBar::default(), Options::same_algorithm())?;
    let trajectory = solver.run(&benchmark_grid())?;
    assert_eq!(format!("{:.3}", trajectory.mean_iterations()), "3.000");
    // Loop closure: the rocker's pin at B coincides with the coupler's, and
    // the coupler keeps its length between A and B.
    for state in &trajectory {
        let b_coupler = state.point(Body::new(1), [0.5, 0.0]);
        let b_rocker = state.point(Body::new(2), [0.4, 0.0]);
        let (Some(p), Some(r)) = (b_coupler, b_rocker) else {
            unreachable!("bodies 1 and 2 exist");
        };
        assert_close("B position", &p.position, &r.position, 1e-11);
        assert_close("B velocity", &p.velocity, &r.velocity, 1e-9);
        assert_close("B acceleration", &p.acceleration, &r.acceleration, 1e-8);
    }
    Ok(())
}

#[test]
fn chain_phi_and_jacobian_equals_the_separate_evaluations() {
    use kinema_runtime::System;
    let chain = Chain::new(7);
    let n = chain.len();
    let q: Vec<f64> = (0..n)
        .map(|i| (i as f64 * 0.7).sin() + 0.1 * i as f64)
        .collect();
    let nnz = chain.jacobian_pattern().len();
    assert_eq!(nnz, 9 * 7 - 4);
    let (mut phi, mut values) = (vec![0.0; n], vec![0.0; nnz]);
    let (mut phi2, mut values2) = (vec![0.0; n], vec![0.0; nnz]);
    chain.phi_and_jacobian(&mut chain.scratch(), &q, 0.3, &mut phi, &mut values);
    chain.phi(&mut chain.scratch(), &q, 0.3, &mut phi2);
    chain.jacobian(&mut chain.scratch(), &q, 0.3, &mut values2);
    assert_eq!(phi, phi2);
    assert_eq!(values, values2);
}
