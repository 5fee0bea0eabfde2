//! The benchmark mechanisms of BENCHMARKS.md through every kinema back end,
//! and the peers' analysis loop, for the criterion benches and the
//! comparison tests.

use kinema::{Auto, Options, Solver, System};

/// Solvers generated at build time (see build.rs).
#[allow(missing_docs, clippy::all)]
pub mod generated {
    /// The benchmark slider-crank (models/slider_crank.kin).
    pub mod slider_crank {
        include!(concat!(env!("OUT_DIR"), "/slider_crank.rs"));
    }
    /// The benchmark four-bar (models/four_bar.kin).
    pub mod four_bar {
        include!(concat!(env!("OUT_DIR"), "/four_bar.rs"));
    }
    /// The serial chain, N = 2.
    pub mod chain2 {
        include!(concat!(env!("OUT_DIR"), "/chain2.rs"));
    }
    /// The serial chain, N = 10.
    pub mod chain10 {
        include!(concat!(env!("OUT_DIR"), "/chain10.rs"));
    }
    /// The serial chain, N = 50.
    pub mod chain50 {
        include!(concat!(env!("OUT_DIR"), "/chain50.rs"));
    }
    /// The serial chain, N = 100.
    pub mod chain100 {
        include!(concat!(env!("OUT_DIR"), "/chain100.rs"));
    }
    /// The serial chain, N = 200.
    #[cfg(feature = "large")]
    pub mod chain200 {
        include!(concat!(env!("OUT_DIR"), "/chain200.rs"));
    }
    /// The serial chain, N = 1000.
    #[cfg(feature = "large")]
    pub mod chain1000 {
        include!(concat!(env!("OUT_DIR"), "/chain1000.rs"));
    }
}

/// Generated with every param's sensitivities (`SensitivitySystem`), for
/// benches/sensitivity.rs.
#[allow(missing_docs, clippy::all)]
pub mod generated_sensitivity {
    /// The benchmark slider-crank (models/slider_crank.kin): l1, l2, omega.
    pub mod slider_crank {
        include!(concat!(env!("OUT_DIR"), "/slider_crank_sensitivity.rs"));
    }
    /// The serial chain N = 50 with params l and a ([`chain_kin_params`]).
    pub mod chain50 {
        include!(concat!(env!("OUT_DIR"), "/chain50_sensitivity.rs"));
    }
}

mod param_chain;
pub use param_chain::chain_kin_params;

/// Solvers with inertia generated at build time, for the inverse-dynamics
/// benchmark (benches/dynamics.rs).
#[allow(missing_docs, clippy::all)]
pub mod generated_dynamics {
    /// The slider-crank with inertia, gravity and a gas force
    /// (tests/dynamics/slider_crank.kin).
    pub mod slider_crank {
        include!(concat!(env!("OUT_DIR"), "/slider_crank_dynamics.rs"));
    }
    /// The serial chain N = 10 with inertia and gravity.
    pub mod chain10 {
        include!(concat!(env!("OUT_DIR"), "/chain10_dynamics.rs"));
    }
    /// The serial chain N = 1000 with inertia and gravity.
    #[cfg(feature = "large-dynamics")]
    pub mod chain1000 {
        include!(concat!(env!("OUT_DIR"), "/chain1000_dynamics.rs"));
    }
}

/// Forward dynamics generated at build time (`{Name}Forward`), for
/// benches/forward.rs: the lead's forward-dynamics benchmark mechanisms
/// (BENCHMARKS.md).
#[allow(missing_docs, clippy::all)]
pub mod generated_forward {
    /// fd_slider_crank: the benchmark slider-crank without its driver.
    pub mod fd_slider_crank {
        include!(concat!(env!("OUT_DIR"), "/fd_slider_crank.rs"));
    }
    /// fd_chain10: ten pendulum links.
    pub mod fd_chain10 {
        include!(concat!(env!("OUT_DIR"), "/fd_chain10.rs"));
    }
    /// fd_chain100: a hundred pendulum links.
    pub mod fd_chain100 {
        include!(concat!(env!("OUT_DIR"), "/fd_chain100.rs"));
    }
}

/// The model files of the forward-dynamics benchmark mechanisms
/// (`fd_slider_crank`, `fd_chain10`, `fd_chain100`), relative to this
/// crate.
pub const FORWARD_MODELS: [(&str, &str); 3] = [
    (
        "fd_slider_crank",
        "../../tests/forward_backends/fd_slider_crank.kin",
    ),
    ("fd_chain10", "../../tests/forward_backends/fd_chain10.kin"),
    (
        "fd_chain100",
        "../../tests/forward_backends/fd_chain100.kin",
    ),
];

/// The model of a forward-dynamics benchmark mechanism (see
/// [`FORWARD_MODELS`]), for the tape back end.
///
/// # Panics
/// On an unknown name, a missing file or a model that does not derive
/// (benchmark set-up only).
#[must_use]
pub fn forward_model(name: &str) -> kinema::Model {
    let Some((_, file)) = FORWARD_MODELS.iter().find(|m| m.0 == name) else {
        panic!("unknown forward model {name}")
    };
    let path = format!("{}/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    kinema::Model::from_source(&text, name).unwrap_or_else(|e| panic!("{e}"))
}

pub use kinema_runtime::handwritten;

/// The time grid of the benchmarks: t_k = k/1000, k = 0..=1000.
#[must_use]
pub fn grid() -> Vec<f64> {
    (0..=1000).map(|k| f64::from(k) / 1000.0).collect()
}

/// The model text of a benchmark mechanism (`slider_crank`, `four_bar`,
/// `chainN`).
///
/// # Panics
/// On an unknown name or a missing model file (benchmark set-up only).
#[must_use]
pub fn model_text(name: &str) -> String {
    if let Some(n) = name.strip_prefix("chain") {
        let n: usize = n
            .parse()
            .unwrap_or_else(|_| panic!("bad chain name {name}"));
        return kinema_model::chain::chain_kin(n);
    }
    let path = format!("{}/../../models/{name}.kin", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The tape back end of a benchmark mechanism.
///
/// # Panics
/// If the model does not derive (benchmark set-up only).
#[must_use]
pub fn tape(name: &str) -> kinema::TapeSystem {
    on(name, kinema::Backend::Tape)
}

/// The benchmark mechanism's model compiled to native code at load time
/// (kinema-jit); panics if the JIT fell back to the tape.
pub fn jit(name: &str) -> kinema::TapeSystem {
    let system = on(name, kinema::Backend::Jit);
    // Compiled before it is measured (a solver built from it then compiles
    // its LU at once).
    system.wait_for_jit();
    if let Some(why) = system.jit_fallback() {
        panic!("{name}: no JIT: {why}");
    }
    system
}

/// The benchmark mechanism's model compiled to native code at load time,
/// or `None` where the JIT leaves it on the tape (above its size bounds:
/// what [`kinema::Backend::Jit`] then runs is [`tape`]).
#[must_use]
pub fn jit_if_compiled(name: &str) -> Option<kinema::TapeSystem> {
    let system = on(name, kinema::Backend::Jit);
    system.wait_for_jit();
    system.jit_fallback().is_none().then_some(system)
}

fn on(name: &str, backend: kinema::Backend) -> kinema::TapeSystem {
    kinema::Model::from_source(&model_text(name), name)
        .unwrap_or_else(|e| panic!("{e}"))
        .with_backend(backend)
        .system()
}

/// The state at one checkpoint.
#[derive(Debug, Clone)]
pub struct Checkpoint {
    /// Time.
    pub t: f64,
    /// q.
    pub q: Vec<f64>,
    /// q̇.
    pub qd: Vec<f64>,
    /// q̈.
    pub qdd: Vec<f64>,
}

/// What one run over the grid produced.
#[derive(Debug, Clone)]
pub struct Run {
    /// Mean Newton updates per step.
    pub mean_updates: f64,
    /// Mean factorizations of Φ_q per step inside the Newton iteration (the
    /// one at the converged q, for velocity and acceleration, not counted).
    pub mean_factorizations: f64,
    /// The checkpoints t = 0, 0.05, …, 1 (every 50th step).
    pub checkpoints: Vec<Checkpoint>,
}

/// A solver for `system` with the automatic linear solver.
///
/// # Panics
/// If the runtime rejects the system (benchmark set-up only).
pub fn solver<S: System>(system: S, options: Options) -> Solver<S, Auto> {
    Solver::with_options(system, options).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs the grid step by step, as the peers do: the solver assembles at
/// t = 0 from the initial guess, then each step starts from the previous one.
///
/// # Panics
/// If the analysis fails (it does not on the benchmark mechanisms).
pub fn run_grid<S: System, L: kinema::LinearSolver>(solver: &mut Solver<S, L>) -> Run {
    solver.reset();
    let mut updates = 0usize;
    let mut factorizations = 0usize;
    let mut checkpoints = Vec::new();
    let times = grid();
    let steps = times.len() as f64;
    for (k, t) in times.into_iter().enumerate() {
        let state = solver.step(t).unwrap_or_else(|e| panic!("{e}"));
        updates += state.stats().iterations;
        factorizations += state.stats().factorizations;
        if k.is_multiple_of(50) {
            checkpoints.push(Checkpoint {
                t,
                q: state.q().to_vec(),
                qd: state.qd().to_vec(),
                qdd: state.qdd().to_vec(),
            });
        }
    }
    Run {
        mean_updates: updates as f64 / steps,
        mean_factorizations: factorizations as f64 / steps,
        checkpoints,
    }
}

/// The same loop with nothing recorded: what the benchmarks time.
///
/// # Panics
/// If the analysis fails (it does not on the benchmark mechanisms).
pub fn steps<S: System, L: kinema::LinearSolver>(solver: &mut Solver<S, L>, times: &[f64]) -> f64 {
    solver.reset();
    let mut acc = 0.0;
    for &t in times {
        let state = solver.step(t).unwrap_or_else(|e| panic!("{e}"));
        acc += state.qdd()[0];
    }
    acc
}
