//! Runs one benchmark mechanism's grid many times, for `perf` and
//! `valgrind --tool=callgrind`:
//! `cargo run --release -p kinema-bench --example profile -- slider_crank generated same 2000`
//! (mechanism: slider_crank, four_bar, chain2, chain10, chain100, and with
//! `--features large` chain200 and chain1000; back end:
//! generated, tape, jit (the model compiled at load time), handwritten, dynamics (generated with inertia and
//! inverse dynamics at every step: slider_crank, chain10, and with
//! `--features large-dynamics` chain1000), dynamics-kinematics (the same
//! solvers with inertia, the kinematic step alone); mode: same, default
//! (predictor, full Newton), same-positions and positions (either,
//! positions only), predictor-modified, modified (no predictor);
//! repetitions).

use kinema::{Dynamics, InverseDynamics, LinearSolver, Options, Solver, System};
use kinema_bench::{generated, grid, handwritten, jit, steps, tape};

fn run<S: System, L: LinearSolver>(mut solver: Solver<S, L>, reps: usize) {
    let times = grid();
    let mut acc = 0.0;
    for _ in 0..reps {
        acc += steps(&mut solver, std::hint::black_box(&times));
    }
    let run = kinema_bench::run_grid(&mut solver);
    eprintln!(
        "{acc}: {:.3} Newton updates and {:.3} factorizations per step",
        run.mean_updates, run.mean_factorizations
    );
}

/// The grid with inverse dynamics at every step (generated solvers with
/// inertia: back end `dynamics`).
fn run_dynamics<S: Dynamics, L: LinearSolver>(mut solver: Solver<S, L>, reps: usize) {
    let times = grid();
    let mut id = InverseDynamics::new(solver.system());
    let mut acc = 0.0;
    for _ in 0..reps {
        solver.reset();
        for &t in std::hint::black_box(&times) {
            solver.step(t).unwrap_or_else(|e| panic!("{e}"));
            solver
                .inverse_dynamics(&mut id)
                .unwrap_or_else(|e| panic!("{e}"));
            acc += id.lambda()[0];
        }
    }
    eprintln!("{acc}");
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |i: usize, d: &str| args.get(i).cloned().unwrap_or_else(|| d.to_owned());
    let (name, backend, mode) = (get(0, "slider_crank"), get(1, "generated"), get(2, "same"));
    let reps: usize = get(3, "1000").parse().unwrap_or(1000);
    let options = match mode.as_str() {
        "same" => Options::same_algorithm(),
        // Predictor with full Newton: the defaults.
        "default" => Options::default(),
        // Either, positions only (no velocity or acceleration solve).
        "same-positions" => Options::same_algorithm().with_positions_only(true),
        "positions" => Options::default().with_positions_only(true),
        // Predictor with modified Newton.
        "predictor-modified" => Options::default().with_modified_newton(true),
        // Modified Newton without the predictor.
        "modified" => Options::default()
            .with_predictor(false)
            .with_modified_newton(true),
        other => panic!(
            "unknown mode {other:?}: same, default, same-positions, positions, \
             predictor-modified or modified"
        ),
    };
    let ok = |e: kinema::Error| -> ! { panic!("{e}") };
    match (name.as_str(), backend.as_str()) {
        ("slider_crank", "generated") => run(
            generated::slider_crank::SliderCrank::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        ("four_bar", "generated") => run(
            generated::four_bar::FourBar::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        ("chain2", "generated") => run(
            generated::chain2::Chain2::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        ("chain10", "generated") => run(
            generated::chain10::Chain10::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        ("chain100", "generated") => run(
            generated::chain100::Chain100::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        #[cfg(feature = "large")]
        ("chain200", "generated") => run(
            generated::chain200::Chain200::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        #[cfg(feature = "large")]
        ("chain1000", "generated") => run(
            generated::chain1000::Chain1000::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        ("chain1000", "handwritten") => run(
            kinema_bench::solver(handwritten::Chain::new(1000), options),
            reps,
        ),
        ("slider_crank", "handwritten") => run(
            kinema_bench::solver(handwritten::SliderCrank::default(), options),
            reps,
        ),
        ("four_bar", "handwritten") => run(
            kinema_bench::solver(handwritten::FourBar::default(), options),
            reps,
        ),
        ("chain10", "handwritten") => run(
            kinema_bench::solver(handwritten::Chain::new(10), options),
            reps,
        ),
        ("slider_crank", "dynamics") => run_dynamics(
            kinema_bench::generated_dynamics::slider_crank::SliderCrank::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        ("chain10", "dynamics") => run_dynamics(
            kinema_bench::generated_dynamics::chain10::Chain10::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        ("slider_crank", "dynamics-kinematics") => run(
            kinema_bench::generated_dynamics::slider_crank::SliderCrank::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        ("chain10", "dynamics-kinematics") => run(
            kinema_bench::generated_dynamics::chain10::Chain10::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        #[cfg(feature = "large-dynamics")]
        ("chain1000", "dynamics") => run_dynamics(
            kinema_bench::generated_dynamics::chain1000::Chain1000::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        #[cfg(feature = "large-dynamics")]
        ("chain1000", "dynamics-kinematics") => run(
            kinema_bench::generated_dynamics::chain1000::Chain1000::default()
                .solver(options)
                .unwrap_or_else(|e| ok(e)),
            reps,
        ),
        (name, "tape") => run(kinema_bench::solver(tape(name), options), reps),
        (name, "jit") => run(kinema_bench::solver(jit(name), options), reps),
        other => panic!("unknown {other:?}"),
    }
}
