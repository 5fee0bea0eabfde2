//! The kinematic step does not allocate on either back end of a model
//! file, the tapes compiled to native code (kinema-jit) or the tape
//! interpreter, nor where a run switches from one to the other when the
//! background compilation finishes: a counting allocator (this thread's
//! allocations only, as in the runtime's allocation test) around the steps
//! of a running solver.

use kinema::{Backend, Model, Options, Solver};

#[path = "../crates/kinema-runtime/tests/common/counting.rs"]
mod counting;
use counting::allocations;

#[test]
fn model_steps_do_not_allocate_on_either_back_end() {
    // The chain N = 100: tapes and folded LU compiled in chunks (stepped
    // finer: its far links move fast).
    let chain = kinema_model::chain::chain_kin(100);
    for path in [
        "models/slider_crank.kin",
        "models/four_bar.kin",
        "models/chain10.kin",
        "chain100",
    ] {
        let dt = if path == "chain100" { 1e-3 } else { 1e-2 };
        for backend in [Backend::Jit, Backend::Tape] {
            let model = if path == "chain100" {
                Model::from_source(&chain, path)
            } else {
                Model::from_file(path)
            }
            .unwrap_or_else(|e| panic!("{e}"))
            .with_backend(backend);
            let system = model.system();
            assert_eq!(
                system.wait_for_jit(),
                backend,
                "{path}: {:?}",
                system.jit_fallback()
            );
            for (options, fresh) in [
                (Options::default(), false),
                (Options::default().with_positions_only(true), false),
                // A system still compiling: the run starts on the tape and
                // goes over to the compiled code when it is ready.
                (Options::default(), true),
            ] {
                let system = if fresh {
                    model.system()
                } else {
                    system.clone()
                };
                let mut solver: Solver<_, kinema::Auto> =
                    Solver::with_options(system, options).unwrap_or_else(|e| panic!("{e}"));
                // The first steps size what they reuse.
                for k in 0..3 {
                    solver
                        .step(f64::from(k) * dt)
                        .unwrap_or_else(|e| panic!("{e}"));
                }
                let before = allocations();
                for k in 3..300 {
                    solver
                        .step(f64::from(k) * dt)
                        .unwrap_or_else(|e| panic!("{e}"));
                }
                let n = allocations() - before;
                assert_eq!(
                    n, 0,
                    "{path}, {backend:?}, {options:?}: {n} allocations in 297 steps"
                );
            }
        }
    }
}
