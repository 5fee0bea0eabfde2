//! Degenerate models and undefined drivers through the binary (issue 42):
//! an empty mechanism is refused with a clear error (exit 2) by `check`,
//! `run`, `derive` and `codegen`; a driver undefined or unbounded at an
//! instant names the equation, the function and the time (exit 1); a
//! library call given the wrong kind of argument says which parameter it
//! is and what the call takes.

mod common;

use std::path::Path;

use common::{HERE, assert_status, kinema_in, stderr, stdout};

fn kinema(args: &[&str]) -> std::process::Output {
    kinema_in(Path::new(HERE), args)
}

const EMPTY: &str = "\
error: mechanism `Empty` has no coordinates: there is nothing to analyse
 --> tests/cli/models/empty.kin:1:11
  |
1 | mechanism Empty { }
  |           ^^^^^
  |
  = help: declare a body (`body b { guess: (0, 0, 0) }`), the joints that connect it and the drivers that move it

error: could not check `tests/cli/models/empty.kin` due to 1 previous error
";

#[test]
fn an_empty_mechanism_is_refused_by_every_command() {
    let model = "tests/cli/models/empty.kin";
    for args in [
        vec!["check", model],
        vec!["run", "--steps", "3", "--out", "-", model],
        vec!["derive", model],
        vec!["codegen", model],
    ] {
        let o = kinema(&args);
        assert_status(&o, 2);
        assert_eq!(stderr(&o), EMPTY, "{args:?}");
        assert_eq!(stdout(&o), "", "{args:?}");
    }
}

#[test]
fn a_driver_undefined_at_the_start_names_the_equation_and_the_function() {
    let model = "tests/cli/models/undefined_driver.kin";
    let o = kinema(&["run", "--steps", "100", "--out", "-", model]);
    assert_status(&o, 1);
    assert_eq!(
        stderr(&o),
        "error: equation `swing` is undefined at t = 0: atan2(0, 0) has no angle\n"
    );
    assert!(!stderr(&o).contains("cannot follow"));
    // `check` assembles at t = 0 and says the same.
    let o = kinema(&["check", model]);
    assert_status(&o, 1);
    assert_eq!(
        stderr(&o),
        "error: equation `swing` is undefined at t = 0: atan2(0, 0) has no angle\n"
    );
    assert!(stdout(&o).contains("assembly at t = 0 from the guess: failed"));
}

#[test]
fn an_unbounded_driver_names_the_driver_and_the_time() {
    let model = "tests/cli/models/unbounded_driver.kin";
    let o = kinema(&["run", "--steps", "4", "--out", "-", model]);
    assert_status(&o, 1);
    assert_eq!(
        stderr(&o),
        "error: equation `swing` is unbounded at t = 0.5: division by 0 (the divisor is 0)\n"
    );
    // The rows before the pole are written.
    assert_eq!(stdout(&o).lines().count(), 3, "{}", stdout(&o));
    // Between two grid times (five steps: 0.4, 0.6) the pole is found too,
    // within roundoff of 0.5.
    let o = kinema(&["run", "--steps", "5", "--out", "-", model]);
    assert_status(&o, 1);
    let err = stderr(&o);
    assert!(
        err.starts_with("error: equation `swing` is unbounded at t = 0.4999999"),
        "{err}"
    );
    assert!(err.contains(": division by 0 (the divisor is "), "{err}");
}

const TRANSLATIONAL: &str = "\
error: coordinates and points cannot appear in a body-fixed vector: expected a constant expression of params
 --> tests/cli/models/translational_points.kin:6:45
  |
6 |     joint slide: translational(block(0, 0), block(1, 0), rocker(0, 0), rocker(1, 0));
  |                                             ^^^^^^^^^^^
  |
  = help: `vi` is argument 2 of `translational(Pi, vi, Pj, vj)`, which takes Pi, Pj: points (`B(sx, sy)` in body B's frame, `B.name`, or `ground(x, y)`); vi, vj: directions in their bodies' frames, constant vectors of params such as `(1, 0)`

error: coordinates and points cannot appear in a body-fixed vector: expected a constant expression of params
 --> tests/cli/models/translational_points.kin:6:72
  |
6 |     joint slide: translational(block(0, 0), block(1, 0), rocker(0, 0), rocker(1, 0));
  |                                                                        ^^^^^^^^^^^^
  |
  = help: `vj` is argument 4 of `translational(Pi, vi, Pj, vj)`, which takes Pi, Pj: points (`B(sx, sy)` in body B's frame, `B.name`, or `ground(x, y)`); vi, vj: directions in their bodies' frames, constant vectors of params such as `(1, 0)`

error: could not check `tests/cli/models/translational_points.kin` due to 2 previous errors
";

#[test]
fn a_library_call_with_points_for_directions_shows_its_signature() {
    let o = kinema(&["check", "tests/cli/models/translational_points.kin"]);
    assert_status(&o, 2);
    assert_eq!(stderr(&o), TRANSLATIONAL);
}
