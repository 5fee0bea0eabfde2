//! The embedder's API of generated code: the parameter struct is plain
//! data (no hidden field: struct literals, destructuring, equality), the
//! solver has a named type, and a slice of the wrong length gives NaN, never
//! a panic.

use kinema::{Error, Options, System};

kinema::mechanism!(file = "models/slider_crank.kin");

#[test]
fn parameters_are_plain_data() -> Result<(), Error> {
    let tau = std::f64::consts::TAU;
    let params = SliderCrank {
        l1: 0.3,
        l2: 1.0,
        omega: tau,
    };
    assert_eq!(params, SliderCrank::default());
    let SliderCrank { l1, l2, omega } = params.clone();
    assert_eq!((l1, l2, omega), (0.3, 1.0, tau));

    // A parameter changed between steps gives what a fresh solver gives:
    // the cache (the solver's scratch) holds nothing of the parameters.
    let mut solver: SliderCrankSolver = params.clone().solver(Options::default())?;
    solver.step(0.25)?;
    solver.system_mut().l1 = 0.2;
    let changed = solver.step(0.3)?.q().to_vec();
    let mut fresh = SliderCrank { l1: 0.2, ..params }.solver(Options::default())?;
    let expected = fresh.step(0.3)?.q().to_vec();
    for (a, b) in changed.iter().zip(&expected) {
        assert!((a - b).abs() < 1e-9, "{changed:?} against {expected:?}");
    }
    Ok(())
}

#[test]
fn wrong_slice_lengths_give_nan() {
    let system = SliderCrank::default();
    let mut scratch = system.scratch();
    let mut phi = [0.0; 9];
    system.phi(&mut scratch, &[0.0; 8], 0.0, &mut phi);
    assert!(phi.iter().all(|x| x.is_nan()), "{phi:?}");
    let mut short = [0.0; 4];
    system.nu(&mut scratch, &[0.0; 9], 0.0, &mut short);
    assert!(short.iter().all(|x| x.is_nan()), "{short:?}");
    let mut values = [0.0; 21];
    let mut phi = [0.0; 9];
    system.phi_and_jacobian(&mut scratch, &[0.0; 9], 0.0, &mut phi, &mut values[..20]);
    assert!(phi.iter().chain(&values[..20]).all(|x| x.is_nan()));
    let mut guess = [0.0; 10];
    system.initial_guess(&mut guess);
    assert!(guess.iter().all(|x| x.is_nan()));
    // The right lengths give numbers again, with the same scratch.
    system.phi(&mut scratch, &[0.0; 9], 0.0, &mut phi);
    assert!(phi.iter().all(|x| x.is_finite()));
}

/// A model file named relative to the invoking source file (here tests/),
/// not to the crate root: found, and tracked for rebuilds by an absolute
/// path (a relative `include_bytes!` would resolve against this file's
/// directory a second time).
mod relative_to_the_source_file {
    kinema::mechanism!(file = "singular/change_point.kin");
}

#[test]
fn a_model_file_relative_to_the_invoking_source_file_compiles() -> Result<(), Error> {
    use relative_to_the_source_file::ChangePoint;
    let mut solver = ChangePoint::default().solver(Options::default())?;
    let state = solver.step(0.0)?;
    assert_eq!(state.q().len(), ChangePoint::default().len());
    Ok(())
}
