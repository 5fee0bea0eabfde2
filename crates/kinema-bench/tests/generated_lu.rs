//! The LU that kinema-codegen generates for each mechanism's Jacobian
//! pattern (`SliderCrankLu`, …): it solves what the runtime's dense LU
//! solves, falls back to it when the generated pivot order does not suit a
//! matrix, and keeps the singular-Jacobian diagnostics.

use kinema::{DenseLu, Error, LinalgError, LinearSolver, Options, SingularKind, System};
use kinema_bench::generated::{chain10::Chain10, four_bar::FourBar, slider_crank::SliderCrank};
use kinema_bench::grid;

/// A small deterministic generator (xorshift), uniform in [lo, hi).
struct Rng(u64);

impl Rng {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        lo + (hi - lo) * (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Φ_q at many random q (not on the constraint manifold: any q gives a
/// Jacobian of the right shape), solved by the generated LU and by
/// `DenseLu`; returns how often the generated LU fell back.
fn agrees_with_dense_lu<S: System, L: LinearSolver, const N: usize>(
    system: S,
    fallback_count: impl Fn(&L) -> u64,
) -> Result<u64, LinalgError> {
    let pattern = system.jacobian_pattern().to_vec();
    let mut generated = L::analyze(N, &pattern)?;
    let mut dense = DenseLu::<N>::analyze(N, &pattern)?;
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut values = vec![0.0; pattern.len()];
    let mut solved = 0;
    for _ in 0..2000 {
        let q: Vec<f64> = (0..N).map(|_| rng.uniform(-4.0, 4.0)).collect();
        system.jacobian(&mut system.scratch(), &q, 0.0, &mut values);
        let Ok(()) = dense.factor(&values, 1e-10) else {
            // Singular here: the generated LU must say so too.
            assert!(matches!(
                generated.factor(&values, 1e-10),
                Err(LinalgError::Singular { .. })
            ));
            continue;
        };
        generated.factor(&values, 1e-10)?;
        for _ in 0..2 {
            let b: Vec<f64> = (0..N).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let (mut x, mut y) = (b.clone(), b);
            dense.solve_in_place(&mut x)?;
            generated.solve_in_place(&mut y)?;
            let scale = x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            for (u, v) in x.iter().zip(&y) {
                assert!((u - v).abs() <= 1e-9 * scale, "{x:?} vs {y:?}");
            }
        }
        solved += 1;
    }
    assert!(solved > 1000, "{solved} regular matrices");
    Ok(fallback_count(&generated))
}

#[test]
fn generated_lu_solves_what_dense_lu_solves_and_falls_back_when_needed() -> Result<(), LinalgError>
{
    use kinema_bench::generated::{
        chain10::Chain10Lu, four_bar::FourBarLu, slider_crank::SliderCrankLu,
    };
    let slider = agrees_with_dense_lu::<_, SliderCrankLu, 9>(
        SliderCrank::default(),
        SliderCrankLu::fallback_count,
    )?;
    let four_bar =
        agrees_with_dense_lu::<_, FourBarLu, 9>(FourBar::default(), FourBarLu::fallback_count)?;
    let chain =
        agrees_with_dense_lu::<_, Chain10Lu, 30>(Chain10::default(), Chain10Lu::fallback_count)?;
    // At random q the four-bar's generated pivots are sometimes poor (the
    // fallback takes over); the slider-crank's and the chain's are constants
    // or ±l·cos φ of the rod, and only fail near singular matrices.
    assert!(four_bar > 0, "the fallback path was exercised");
    assert!(slider < 100 && chain == 0, "{slider} {chain}");
    Ok(())
}

#[test]
fn solve_before_factor_and_wrong_lengths_are_errors() -> Result<(), LinalgError> {
    use kinema_bench::generated::slider_crank::SliderCrankLu;
    let system = SliderCrank::default();
    let mut lu = SliderCrankLu::analyze(9, system.jacobian_pattern())?;
    assert_eq!(lu.dim(), 9);
    assert_eq!(
        lu.solve_in_place(&mut [0.0; 9]),
        Err(LinalgError::NotFactored)
    );
    assert!(matches!(
        lu.factor(&[1.0; 3], 1e-10),
        Err(LinalgError::Dimension { .. })
    ));
    let mut values = vec![0.0; system.jacobian_pattern().len()];
    let s = system.clone();
    s.jacobian(
        &mut s.scratch(),
        &[0.0, 0.0, 0.8, 0.5, 0.3, -0.2, 1.0, 0.0, 0.0],
        0.0,
        &mut values,
    );
    lu.factor(&values, 1e-10)?;
    assert!(matches!(
        lu.solve_in_place(&mut [0.0; 4]),
        Err(LinalgError::Dimension { .. })
    ));
    // Analysed for another pattern: everything goes through the fallback.
    let pattern: Vec<(u32, u32)> = (0..9).map(|i| (i, i)).collect();
    let mut other = SliderCrankLu::analyze(9, &pattern)?;
    other.factor(&[2.0; 9], 1e-10)?;
    let mut b = [1.0; 9];
    other.solve_in_place(&mut b)?;
    assert_eq!(b, [0.5; 9]);
    assert_eq!(other.fallback_count(), 1);
    Ok(())
}

/// The slider-crank with its rod as long as its crank: at crank angle π/2
/// (t = 0.125) and 3π/2 (t = 0.625) the rod folds over the crank and two
/// branches cross. The generated LU's pivot (the rod's l₂ cos φ) vanishes
/// there; its pivot report must let the runtime pass both bifurcations on
/// the analytic branch and diagnose them as the runtime's solvers do, and
/// stop at the first one on request.
#[test]
fn bifurcation_is_passed_and_diagnosed_through_the_generated_lu() -> Result<(), Error> {
    let grid = grid();
    for options in [Options::default(), Options::same_algorithm()] {
        let system = SliderCrank {
            l2: 0.3,
            ..SliderCrank::default()
        };
        let mut solver = system.clone().solver(options)?;
        let trajectory = solver.run(&grid)?;
        let events = trajectory.events();
        assert_eq!(events.len(), 2, "{events:?}");
        for (event, t_star) in events.iter().zip([0.125, 0.625]) {
            assert_eq!(event.kind, SingularKind::Bifurcation);
            assert!((event.t - t_star).abs() < 1e-8, "{event}");
            assert_eq!(
                event.dependency.equations,
                ["pivot.y", "pin.y", "wrist.y", "on_axis"]
            );
        }
        let mut solver = system.solver(options.with_stop_at_singular(true))?;
        let err = solver.run(&grid).err();
        assert!(
            matches!(err, Some(Error::SingularConfiguration { .. })),
            "{err:?}"
        );
        let last = solver.state().map(|s| (s.t(), s.near_singular()));
        assert_eq!(last, Some((0.125, true)));
    }
    Ok(())
}
