// Two mechanisms with the same Jacobian pattern: only the driver row's
// constant entry differs (1 against 2). The LU generated for `Swing` folds
// Swing's constants into its code, so it must not factor `Other`'s Jacobian:
// a solver pairing them does not compile.
kinema::mechanism! {
    mechanism Swing {
        param l = 1.0;
        body bar { guess: (0.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-l, 0));
        driver swing: bar.phi == t;
    }
}

kinema::mechanism! {
    mechanism Other {
        param l = 1.0;
        body bar { guess: (0.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-l, 0));
        driver swing: 2 * bar.phi == t;
    }
}

fn main() {
    assert_eq!(Swing::JACOBIAN_PATTERN, Other::JACOBIAN_PATTERN);
    // Swing's own solver is fine.
    let _ = kinema::Solver::<Swing, SwingLu>::new(Swing::default());
    let _ = kinema::Solver::<Other, SwingLu>::new(Other::default());
}
