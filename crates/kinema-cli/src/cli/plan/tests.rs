//! Unit tests of the plan: what `kinema run`'s arguments resolve to, and
//! that refusals found from the arguments alone come before the model is
//! read.

use clap::Parser;

use super::*;
use crate::cli::args::{Cli, Command};

/// A model of the repository's `models/` directory.
fn model(name: &str) -> String {
    format!("{}/../../models/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// `kinema run` with `args` after the subcommand, resolved.
fn resolve(args: &[&str]) -> Result<RunPlan, Failure> {
    let cli = Cli::try_parse_from(["kinema", "run"].iter().chain(args)).expect("valid grammar");
    let Command::Run(run) = &cli.command else {
        panic!("not a run");
    };
    RunPlan::resolve(run)
}

/// The message of a failure that must be a usage error.
fn usage_message(result: Result<RunPlan, Failure>) -> String {
    match result {
        Err(Failure::Input(m)) => m,
        Err(other) => panic!("expected a usage error, got {other:?}"),
        Ok(_) => panic!("expected a usage error, got a plan"),
    }
}

#[test]
fn a_kinematic_run_resolves_its_grid_options_and_outputs() {
    let four_bar = model("four_bar.kin");
    let plan = resolve(&[
        &four_bar,
        "--t-end",
        "2",
        "--steps",
        "10",
        "--stop-at-singular",
        "--out",
        "-",
        "--animate",
        "page.html",
    ])
    .unwrap_or_else(|f| panic!("{f:?}"));
    let Motion::Kinematic(k) = &plan.motion else {
        panic!("four_bar.kin runs kinematics");
    };
    assert_eq!(k.grid.times.len(), 11);
    assert_eq!(k.grid.times.last().copied(), Some(2.0));
    assert!(k.options.stop_at_singular && !k.options.positions_only);
    assert_eq!(plan.outputs.csv, Destination::Stdout);
    assert_eq!(plan.outputs.animate, Some(PathBuf::from("page.html")));
    assert_eq!(plan.outputs.plot, None);
}

#[test]
fn a_model_with_inertia_and_free_dof_resolves_to_forward_dynamics() {
    let pendulum = model("iftomm/a01_pendulum.kin");
    let plan = resolve(&[&pendulum, "--steps", "4"]).unwrap_or_else(|f| panic!("{f:?}"));
    let Motion::Forward(f) = &plan.motion else {
        panic!("a pendulum with inertia integrates");
    };
    assert_eq!(f.kind, DynamicsRun::Forward);
    assert_eq!((f.step, f.rtol), (DEFAULT_STEP, DEFAULT_RTOL));
    assert_eq!(f.times.len(), 5);
    assert_eq!(f.integrator, Integrator::Hht);

    let plan = resolve(&[&pendulum, "--equilibrium"]).unwrap_or_else(|f| panic!("{f:?}"));
    assert!(matches!(plan.motion, Motion::Equilibrium));
}

#[test]
fn option_combinations_are_refused_while_planning() {
    let pendulum = model("iftomm/a01_pendulum.kin");
    let four_bar = model("four_bar.kin");
    let m = usage_message(resolve(&[
        &pendulum,
        "--integrator",
        "accurate",
        "--step",
        "1e-3",
    ]));
    assert!(m.contains("--step is HHT's"), "{m}");
    let m = usage_message(resolve(&[&four_bar, "--energy"]));
    assert!(m.contains("are for forward dynamics"), "{m}");
    let m = usage_message(resolve(&[&pendulum, "--positions-only"]));
    assert!(
        m.contains("--positions-only cannot be used with forward dynamics"),
        "{m}"
    );
}

#[test]
fn argument_errors_come_before_the_model_is_read() {
    // No such file: the argument's error is the one reported.
    let missing = model("no_such_model.kin");
    let m = usage_message(resolve(&[&missing, "--steps", "0"]));
    assert!(m.contains("--steps must be at least 1"), "{m}");
    let m = usage_message(resolve(&[&missing, "--equilibrium", "--t-end", "1"]));
    assert!(m.contains("--t-end describes a motion"), "{m}");
    let m = usage_message(resolve(&[&missing, "--positions-only", "--plot", "f.svg"]));
    assert!(
        m.contains("--positions-only cannot be used with --plot"),
        "{m}"
    );
}
