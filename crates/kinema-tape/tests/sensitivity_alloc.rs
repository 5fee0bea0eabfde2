//! Sensitivities after each step do not allocate (issue 40): a counting
//! allocator (this thread's allocations only, the runtime's) around steps
//! each followed by `Sensitivity::compute`, on both back ends, for a
//! closed-form slider-crank, a Newton-solved four-bar and Jansen's linkage.

use std::path::PathBuf;

use kinema_runtime::Options;
use kinema_tape::{Backend, Model};

#[path = "../../kinema-runtime/tests/common/counting.rs"]
mod counting;
use counting::allocations;

#[test]
fn steps_with_sensitivities_do_not_allocate() {
    for name in ["slider_crank.kin", "four_bar.kin", "jansen.kin"] {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../models")
            .join(name);
        for backend in [Backend::Jit, Backend::Tape] {
            let model = Model::from_file(&path)
                .unwrap_or_else(|e| panic!("{}", e.render()))
                .with_backend(backend);
            let mut sens = model
                .sensitivity_to_every_param()
                .unwrap_or_else(|e| panic!("{e}"));
            let system = model.system();
            system.wait_for_jit();
            let mut solver = kinema_runtime::Solver::<_, kinema_runtime::Auto>::with_options(
                system,
                Options::default(),
            )
            .unwrap_or_else(|e| panic!("{e}"));
            let dt = 1e-2;
            for k in 0..3 {
                solver
                    .step(f64::from(k) * dt)
                    .unwrap_or_else(|e| panic!("{e}"));
                sens.compute(&mut solver).unwrap_or_else(|e| panic!("{e}"));
            }
            let before = allocations();
            for k in 3..200 {
                solver
                    .step(f64::from(k) * dt)
                    .unwrap_or_else(|e| panic!("{e}"));
                sens.compute(&mut solver).unwrap_or_else(|e| panic!("{e}"));
            }
            let n = allocations() - before;
            assert_eq!(n, 0, "{name}, {backend:?}: {n} allocations in 197 steps");
        }
    }
}
