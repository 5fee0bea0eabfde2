//! Zero heap allocations per step, counted with a global allocator (in its
//! own test binary). Only the test's own thread is counted: the test
//! harness's threads allocate at times of their own.

use kinema_runtime::handwritten::{Chain, FourBar, SliderCrank};
use kinema_runtime::{
    DenseLu, DynDenseLu, Error, LinearSolverFor, Options, Solver, SparseLu, System,
};

#[path = "common/counting.rs"]
mod counting;
use counting::allocations;

/// Allocations made by 1000 steps after assembly.
fn allocations_per_1000_steps<S: System, L: LinearSolverFor<S>>(
    system: S,
    options: Options,
) -> Result<usize, Error> {
    let mut solver = Solver::<S, L>::with_options(system, options)?;
    solver.assemble(0.0)?;
    solver.step(0.001)?;
    let before = allocations();
    for k in 2..=1001 {
        let state = solver.step(k as f64 / 1000.0)?;
        std::hint::black_box(state.qdd());
    }
    Ok(allocations() - before)
}

#[test]
fn steps_do_not_allocate() -> Result<(), Error> {
    for options in [Options::default(), Options::same_algorithm()] {
        let cases = [
            (
                "slider-crank, DenseLu<9>",
                allocations_per_1000_steps::<_, DenseLu<9>>(SliderCrank::default(), options)?,
            ),
            (
                "slider-crank, DynDenseLu",
                allocations_per_1000_steps::<_, DynDenseLu>(SliderCrank::default(), options)?,
            ),
            (
                "four-bar, DenseLu<9>",
                allocations_per_1000_steps::<_, DenseLu<9>>(FourBar::default(), options)?,
            ),
            (
                "chain 10, DenseLu<30>",
                allocations_per_1000_steps::<_, DenseLu<30>>(Chain::new(10), options)?,
            ),
            (
                "chain 10, DynDenseLu",
                allocations_per_1000_steps::<_, DynDenseLu>(Chain::new(10), options)?,
            ),
            // Not promised (faer may grow its L/U storage when the pivot
            // sequence changes), but true here.
            (
                "chain 10, SparseLu",
                allocations_per_1000_steps::<_, SparseLu>(Chain::new(10), options)?,
            ),
            (
                "chain 50, SparseLu",
                allocations_per_1000_steps::<_, SparseLu>(Chain::new(50), options)?,
            ),
        ];
        for (case, count) in cases {
            assert_eq!(
                count, 0,
                "{case} with {options:?}: {count} allocations in 1000 steps"
            );
        }
    }
    Ok(())
}
