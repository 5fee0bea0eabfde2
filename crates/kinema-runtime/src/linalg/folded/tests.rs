use super::*;
use crate::linalg::DynDenseLu;

/// A scan survives its raw form, each flag on its own index (a
/// swapped index would swap two flags here).
#[test]
fn raw_scan_round_trips() {
    for bits in 0..8u8 {
        let scan = FactorScan {
            scale: 2.5,
            finite: bits & 1 != 0,
            same: bits & 2 != 0,
            negative: bits & 4 != 0,
            min_pivot: 0.125,
            max_multiplier: f64::INFINITY,
        };
        assert_eq!(FactorScan::from_raw(&scan.to_raw()), scan);
    }
    let raw = [1.0, 1.0, 0.0, 1.0, 3.0, 4.0];
    let scan = FactorScan::from_raw(&raw);
    assert!(scan.finite && !scan.same && scan.negative);
    assert_eq!(
        (scan.scale, scan.min_pivot, scan.max_multiplier),
        (1.0, 3.0, 4.0)
    );
}

/// A slider-crank-like Jacobian: unit entries (constant) on the x and y
/// coordinates of two joints, run-time entries on the angle columns,
/// one driver row. 5 × 5.
fn pattern() -> (Vec<(u32, u32)>, Vec<Option<f64>>) {
    let entries = [
        (0, 0, Some(1.0)),
        (0, 2, None),
        (1, 1, Some(1.0)),
        (1, 2, None),
        (2, 0, Some(-1.0)),
        (2, 3, Some(1.0)),
        (2, 2, None),
        (2, 4, None),
        (3, 1, Some(-1.0)),
        (3, 2, None),
        (3, 4, None),
        (4, 2, Some(1.0)),
    ];
    (
        entries.iter().map(|&(r, c, _)| (r, c)).collect(),
        entries.iter().map(|&(_, _, k)| k).collect(),
    )
}

/// Values for angle θ: the constants, and trigonometric run-time entries.
fn values(constants: &[Option<f64>], theta: f64) -> Vec<f64> {
    let mut run = [
        -theta.sin(),
        theta.cos(),
        0.7 * theta.sin(),
        -(theta * 0.3).sin(),
        -0.7 * theta.cos(),
        (theta * 0.3).cos(),
    ]
    .into_iter();
    constants
        .iter()
        .map(|c| c.unwrap_or_else(|| run.next().unwrap_or(0.0)))
        .collect()
}

fn dense(pattern: &[(u32, u32)], values: &[f64], n: usize) -> Vec<Vec<f64>> {
    let mut a = vec![vec![0.0; n]; n];
    for (&(r, c), &v) in pattern.iter().zip(values) {
        a[r as usize][c as usize] = v;
    }
    a
}

/// ‖A x − b‖∞ and ‖Aᵀ y − b‖∞ of the solver's two solves.
fn residuals(lu: &mut FoldedLu, a: &[Vec<f64>]) -> (f64, f64) {
    let n = a.len();
    let b: Vec<f64> = (0..n).map(|i| 1.0 + i as f64 * 0.25).collect();
    let (mut x, mut y) = (b.clone(), b.clone());
    lu.solve_in_place(&mut x).expect("factored");
    lu.solve_transpose_in_place(&mut y).expect("factored");
    let mut worst = (0.0f64, 0.0f64);
    for i in 0..n {
        let ax: f64 = (0..n).map(|j| a[i][j] * x[j]).sum();
        let aty: f64 = (0..n).map(|j| a[j][i] * y[j]).sum();
        worst.0 = worst.0.max((ax - b[i]).abs());
        worst.1 = worst.1.max((aty - b[i]).abs());
    }
    worst
}

#[test]
fn the_folded_order_solves_both_ways_and_reports_the_determinants_sign() {
    let (pattern, constants) = pattern();
    let mut lu =
        FoldedLu::new(5, &pattern, &constants, &values(&constants, 0.3)).expect("a valid pattern");
    assert!(lu.is_planned());
    let mut reference = DynDenseLu::analyze(5, &pattern).expect("a valid pattern");
    for theta in [0.3, 1.0, 2.0, -0.8] {
        let v = values(&constants, theta);
        lu.factor(&v, 1e-10).expect("regular");
        assert_eq!(lu.current, Current::Folded, "θ = {theta}");
        let (r, rt) = residuals(&mut lu, &dense(&pattern, &v, 5));
        assert!(r < 1e-13 && rt < 1e-13, "θ = {theta}: {r:e} {rt:e}");
        reference.factor(&v, 1e-10).expect("regular");
        let (mine, theirs) = (lu.pivot_report(), reference.pivot_report());
        assert_eq!(
            mine.map(|p| p.det_sign),
            theirs.map(|p| p.det_sign),
            "θ = {theta}"
        );
        // The ratio from the scan's smallest pivot is, bit for bit, the
        // one from every 1 / u_kk.
        let f = lu.folded.as_ref().expect("planned");
        let inverse = f.inv.iter().map(|&x| match x {
            Val::Const(c) => c,
            Val::Var(s) => f.v[s as usize],
        });
        let from_inverse =
            PivotReport::from_inverse_pivot_values(inverse, f.scan[FactorScan::SCALE], 1.0);
        assert_eq!(
            mine.map(|p| p.ratio.to_bits()),
            Some(from_inverse.ratio.to_bits()),
            "θ = {theta}"
        );
    }
}

#[test]
fn folding_leaves_less_work_than_treating_every_entry_as_run_time() {
    let (pattern, constants) = pattern();
    let v = values(&constants, 0.3);
    let folded = FoldedLu::new(5, &pattern, &constants, &v).expect("valid");
    let general = FoldedLu::new(5, &pattern, &[None; 12], &v).expect("valid");
    assert!(folded.operations() < general.operations());
}

#[test]
fn a_constant_that_changes_or_a_failing_order_goes_to_the_general_solver() {
    let (pattern, constants) = pattern();
    let mut lu = FoldedLu::new(5, &pattern, &constants, &values(&constants, 0.3)).expect("valid");
    // Entry 0 is declared constant 1: another value is not folded away.
    let mut v = values(&constants, 0.3);
    v[0] = 2.0;
    lu.factor(&v, 1e-10).expect("regular");
    assert_eq!(lu.current, Current::Fallback);
    let (r, rt) = residuals(&mut lu, &dense(&pattern, &v, 5));
    assert!(r < 1e-13 && rt < 1e-13, "{r:e} {rt:e}");
    // Non-finite values: refused by both.
    v[1] = f64::NAN;
    assert!(lu.factor(&v, 1e-10).is_err());
    assert!(matches!(
        lu.solve_in_place(&mut [0.0; 5]),
        Err(LinalgError::NotFactored)
    ));
    // Row 3 = −row 1 (entry (3, 4) zero, (3, 2) = −(1, 2)): singular,
    // reported as partial pivoting reports it.
    let mut a = values(&constants, 0.4);
    a[10] = 0.0;
    a[9] = -a[3];
    let mut reference = DynDenseLu::analyze(5, &pattern).expect("valid");
    assert!(matches!(
        lu.factor(&a, 1e-10),
        Err(LinalgError::Singular { .. })
    ));
    assert!(matches!(
        reference.factor(&a, 1e-10),
        Err(LinalgError::Singular { .. })
    ));
}

/// Trusted constants are not checked when factored as written (a
/// changed constant then goes unseen: the caller's promise), still are
/// by `factor` (equilibrated values); on values that keep them the
/// trusting LU factors and solves as the checking one, bit for bit.
#[test]
fn trusted_constants_are_checked_only_when_not_as_written() {
    let (pattern, constants) = pattern();
    let start = values(&constants, 0.3);
    let mut checking = FoldedLu::new(5, &pattern, &constants, &start).expect("valid");
    let mut trusting = FoldedLu::new(5, &pattern, &constants, &start).expect("valid");
    trusting.trust_constants();
    for theta in [0.1, 0.7, 2.0] {
        let v = values(&constants, theta);
        checking.factor_as_written(&v, 1e-10).expect("regular");
        trusting.factor_as_written(&v, 1e-10).expect("regular");
        assert_eq!(trusting.current, Current::Folded);
        let b: Vec<f64> = (0..5).map(|i| 1.0 + f64::from(i) * 0.25).collect();
        let (mut x, mut y) = (b.clone(), b);
        checking.solve_in_place(&mut x).expect("factored");
        trusting.solve_in_place(&mut y).expect("factored");
        assert_eq!(x, y, "θ = {theta}");
    }
    let mut v = values(&constants, 0.3);
    v[0] = 2.0;
    trusting.factor_as_written(&v, 1e-10).expect("regular");
    assert_eq!(trusting.current, Current::Folded);
    trusting.factor(&v, 1e-10).expect("regular");
    assert_eq!(trusting.current, Current::Fallback);
    checking.factor_as_written(&v, 1e-10).expect("regular");
    assert_eq!(checking.current, Current::Fallback);
}

#[test]
fn analysis_without_the_system_plans_on_ones() {
    let (pattern, constants) = pattern();
    let mut lu = FoldedLu::analyze(5, &pattern).expect("valid");
    let v = values(&constants, 1.0);
    lu.factor(&v, 1e-10).expect("regular");
    let (r, rt) = residuals(&mut lu, &dense(&pattern, &v, 5));
    assert!(r < 1e-13 && rt < 1e-13, "{r:e} {rt:e}");
}
