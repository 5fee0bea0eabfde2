//! The hand-written slider-crank against its closed-form solution and the
//! worked example of docs/src/constraints.md (the slider-crank).

mod common;

use common::{assert_close, benchmark_grid};
use kinema_runtime::handwritten::SliderCrank;
use kinema_runtime::{
    Auto, Body, DenseLu, DynDenseLu, Error, LinearSolverFor, Options, Solver, SparseLu, System,
};
use std::f64::consts::{FRAC_PI_4, TAU};

/// Exact q, q̇, q̈ of the slider-crank at t.
///
/// With φ₁ = φ₀ + ωt, k = l₁/l₂: sin φ₂ = −k sin φ₁ (branch cos φ₂ > 0),
/// φ̇₂ = −k cos φ₁ ω / cos φ₂, φ̈₂ = (k sin φ₁ ω² + sin φ₂ φ̇₂²) / cos φ₂;
/// crank centre (l₁/2)(cos φ₁, sin φ₁); rod centre A + (l₂/2)(cos φ₂, sin φ₂)
/// with the crank pin A = l₁(cos φ₁, sin φ₁); slider x = l₁ cos φ₁ + l₂ cos φ₂.
fn closed_form(m: &SliderCrank, t: f64) -> [[f64; 9]; 3] {
    let (l1, l2, w) = (m.crank, m.rod, m.omega);
    let p1 = m.phi0 + w * t;
    let (s1, c1) = p1.sin_cos();
    let k = l1 / l2;
    let s2 = -k * s1;
    let p2 = s2.asin();
    let c2 = p2.cos();
    let w2 = -k * c1 * w / c2;
    let a2 = (k * s1 * w * w + s2 * w2 * w2) / c2;
    let (h1, h2) = (l1 / 2.0, l2 / 2.0);
    let q = [
        h1 * c1,
        h1 * s1,
        p1,
        l1 * c1 + h2 * c2,
        l1 * s1 + h2 * s2,
        p2,
        l1 * c1 + l2 * c2,
        0.0,
        0.0,
    ];
    let qd = [
        -h1 * s1 * w,
        h1 * c1 * w,
        w,
        -l1 * s1 * w - h2 * s2 * w2,
        l1 * c1 * w + h2 * c2 * w2,
        w2,
        -l1 * s1 * w - l2 * s2 * w2,
        0.0,
        0.0,
    ];
    let qdd = [
        -h1 * c1 * w * w,
        -h1 * s1 * w * w,
        0.0,
        -l1 * c1 * w * w - h2 * (s2 * a2 + c2 * w2 * w2),
        -l1 * s1 * w * w + h2 * (c2 * a2 - s2 * w2 * w2),
        a2,
        -l1 * c1 * w * w - l2 * (c2 * w2 * w2 + s2 * a2),
        0.0,
        0.0,
    ];
    [q, qd, qdd]
}

fn check_revolution<L: LinearSolverFor<SliderCrank>>(options: Options) -> Result<(), Error> {
    let mut solver = Solver::<SliderCrank, L>::with_options(SliderCrank::default(), options)?;
    let trajectory = solver.run(&benchmark_grid())?;
    assert_eq!(trajectory.len(), 1001);
    for state in &trajectory {
        let [q, qd, qdd] = closed_form(solver.system(), state.t());
        let at = format!("t = {}", state.t());
        assert_close(&format!("q at {at}"), state.q(), &q, 1e-10);
        assert_close(&format!("q̇ at {at}"), state.qd(), &qd, 1e-10);
        assert_close(&format!("q̈ at {at}"), state.qdd(), &qdd, 1e-10);
    }
    Ok(())
}

#[test]
fn one_revolution_matches_closed_form_in_every_mode_and_solver() -> Result<(), Error> {
    for options in [
        Options::default(),
        Options::same_algorithm(),
        Options::default().with_modified_newton(true),
        Options::default().with_predictor(false),
        Options::default()
            .with_predictor(false)
            .with_modified_newton(true),
    ] {
        check_revolution::<DenseLu<9>>(options)?;
        check_revolution::<DynDenseLu>(options)?;
        check_revolution::<SparseLu>(options)?;
        check_revolution::<Auto>(options)?;
    }
    Ok(())
}

#[test]
fn same_algorithm_reproduces_the_peers_newton_counts() -> Result<(), Error> {
    let mut solver = Solver::<SliderCrank, DenseLu<9>>::with_options(
        SliderCrank::default(),
        Options::same_algorithm(),
    )?;
    let trajectory = solver.run(&benchmark_grid())?;
    let total: usize = trajectory.iter().map(|s| s.stats().iterations).sum();
    // The peers' mean 2.762 over 1001 analyses.
    assert_eq!(total, 2765, "mean {}", trajectory.mean_iterations());
    assert_eq!(format!("{:.3}", trajectory.mean_iterations()), "2.762");
    Ok(())
}

/// The predictor leaves one full Newton update per step where the peers'
/// loop needs 2.762; modified Newton trades factorizations for updates.
#[test]
fn predictor_and_modified_newton_save_work() -> Result<(), Error> {
    let grid = benchmark_grid();
    let run = |options: Options| -> Result<(usize, usize), Error> {
        let mut solver =
            Solver::<SliderCrank, DenseLu<9>>::with_options(SliderCrank::default(), options)?;
        let tr = solver.run(&grid)?;
        let updates = tr.iter().map(|s| s.stats().iterations).sum();
        let factorizations = tr.iter().map(|s| s.stats().factorizations).sum();
        Ok((updates, factorizations))
    };
    let (same_updates, same_factors) = run(Options::same_algorithm())?;
    let (updates, factors) = run(Options::default())?;
    // One update per step (and a few more at assembly).
    assert!(updates <= grid.len() + 10, "{updates} updates");
    assert!(2 * updates < same_updates, "{updates} vs {same_updates}");
    assert_eq!(factors, updates, "full Newton factors once per update");
    let (_, modified_factors) = run(Options::default().with_modified_newton(true))?;
    assert!(
        modified_factors * 4 < same_factors,
        "{modified_factors} vs {same_factors}"
    );
    Ok(())
}

/// docs/src/constraints.md, the slider-crank's state at t = 0, to the printed 6 decimals.
#[test]
fn worked_example_at_t0() -> Result<(), Error> {
    let mut solver = Solver::<SliderCrank, DenseLu<9>>::new(SliderCrank::default())?;
    let state = solver.assemble(0.0)?.clone();
    let tol = 1e-6;
    assert_close(
        "q",
        state.q(),
        &[
            0.106066, 0.106066, FRAC_PI_4, 0.700753, 0.106066, -0.213756, 1.189373, 0.0, 0.0,
        ],
        tol,
    );
    assert_close(
        "q̇",
        state.qd(),
        &[
            -0.666432, 0.666432, TAU, -1.477529, 0.666432, -1.363906, -1.622193, 0.0, 0.0,
        ],
        tol,
    );
    assert_close(
        "q̈",
        state.qdd(),
        &[
            -4.187319, -4.187319, 0.0, -8.417467, -4.187319, 8.165867, -8.460297, 0.0, 0.0,
        ],
        tol,
    );
    let system = solver.system_mut();
    let mut nu = [0.0; 9];
    system.nu(&mut system.scratch(), state.q(), 0.0, &mut nu);
    assert_close(
        "ν",
        &nu,
        &[
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            2.0 * std::f64::consts::PI,
        ],
        1e-15,
    );
    let mut gamma = [0.0; 9];
    system.gamma(
        &mut system.scratch(),
        state.q(),
        state.qd(),
        0.0,
        &mut gamma,
    );
    assert_close(
        "γ",
        &gamma,
        &[
            -4.187319, -4.187319, 5.096270, 3.990010, 0.908951, -0.197308, 0.0, 0.0, 0.0,
        ],
        tol,
    );
    // Φ_q rows 1–6 as printed; rows 7–9 unit rows on y₃, φ₃, φ₁.
    let mut values = vec![0.0; system.jacobian_pattern().len()];
    system.jacobian(&mut system.scratch(), state.q(), 0.0, &mut values);
    let mut dense = [[0.0; 9]; 9];
    for (&(r, c), v) in system.jacobian_pattern().iter().zip(&values) {
        dense[r as usize][c as usize] = *v;
    }
    let expected: [[f64; 9]; 9] = [
        [1.0, 0.0, 0.106066, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, -0.106066, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [1.0, 0.0, -0.106066, -1.0, 0.0, 0.106066, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.106066, 0.0, -1.0, 0.488621, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.106066, -1.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 1.0, 0.488621, 0.0, -1.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ];
    for (i, (row, want)) in dense.iter().zip(&expected).enumerate() {
        assert_close(&format!("Φ_q row {}", i + 1), row, want, tol);
    }
    Ok(())
}

/// The Jacobian and γ agree with central differences of Φ (docs/src/constraints.md, "How the equations are tested")
/// at an arbitrary off-manifold point.
#[test]
fn jacobian_and_gamma_agree_with_finite_differences() {
    let mut m = SliderCrank::default();
    let q = [0.3, -0.2, 1.1, 0.4, 0.9, -0.7, 1.5, 0.2, 0.3];
    let qd = [0.5, -1.0, 2.0, 0.1, 0.3, -1.5, 0.7, 0.2, -0.4];
    let t = 0.37;
    let n = 9;
    let mut values = vec![0.0; m.jacobian_pattern().len()];
    m.jacobian(&mut m.scratch(), &q, t, &mut values);
    let jac = |m: &mut SliderCrank, q: &[f64]| {
        let mut v = vec![0.0; 21];
        m.jacobian(&mut m.scratch(), q, t, &mut v);
        let mut d = vec![0.0; n * n];
        for (&(r, c), x) in m.jacobian_pattern().iter().zip(&v) {
            d[r as usize * n + c as usize] = *x;
        }
        d
    };
    let d = jac(&mut m, &q);
    let h = 1e-6;
    for j in 0..n {
        let (mut qp, mut qm) = (q, q);
        qp[j] += h;
        qm[j] -= h;
        let (mut fp, mut fm) = ([0.0; 9], [0.0; 9]);
        m.phi(&mut m.scratch(), &qp, t, &mut fp);
        m.phi(&mut m.scratch(), &qm, t, &mut fm);
        for i in 0..n {
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            assert!(
                (fd - d[i * n + j]).abs() < 1e-8,
                "∂Φ{i}/∂q{j}: {fd} vs {}",
                d[i * n + j]
            );
        }
    }
    // γ = −(Φ_q q̇)_q q̇ (no Φ_qt, Φ_tt for this driver).
    let eps = 1e-6;
    let qp: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a + eps * b).collect();
    let qm: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a - eps * b).collect();
    let (jp, jm) = (jac(&mut m, &qp), jac(&mut m, &qm));
    let mut gamma = [0.0; 9];
    m.gamma(&mut m.scratch(), &q, &qd, t, &mut gamma);
    for i in 0..n {
        let fd: f64 = -(0..n)
            .map(|j| (jp[i * n + j] - jm[i * n + j]) * qd[j])
            .sum::<f64>()
            / (2.0 * eps);
        assert!((fd - gamma[i]).abs() < 1e-6, "γ{i}: {fd} vs {}", gamma[i]);
    }
}

/// The CSV contract of docs/src/cli.md: `t`, names, `_dot`, `_ddot`; N + 1 rows for
/// N steps; numbers that parse back to the very same f64.
#[test]
fn csv_follows_the_command_line_contract() -> Result<(), Box<dyn std::error::Error>> {
    let mut solver = Solver::<SliderCrank, DenseLu<9>>::new(SliderCrank::default())?;
    let times: Vec<f64> = (0..=10).map(|k| k as f64 / 10.0).collect();
    let trajectory = solver.run(&times)?;
    let mut out = Vec::new();
    trajectory.write_csv(&mut out)?;
    let text = String::from_utf8(out)?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().ok_or("header")?.split(',').collect();
    assert_eq!(header.len(), 1 + 3 * 9);
    assert_eq!(&header[..4], ["t", "crank.x", "crank.y", "crank.phi"]);
    assert_eq!(header[10], "crank.x_dot");
    assert_eq!(header[27], "slider.phi_ddot");
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 11);
    for (row, state) in rows.iter().zip(&trajectory) {
        let numbers: Vec<f64> = row.split(',').map(str::parse).collect::<Result<_, _>>()?;
        let expected: Vec<f64> = std::iter::once(state.t())
            .chain(state.q().iter().copied())
            .chain(state.qd().iter().copied())
            .chain(state.qdd().iter().copied())
            .collect();
        assert_eq!(numbers, expected);
    }
    Ok(())
}

/// Body-point kinematics along the trajectory: the rod's end B (s′ = (½, 0))
/// is the slider's pin, whose closed-form motion is x = l₁ cos φ₁ + l₂ cos φ₂.
#[test]
fn rod_end_follows_the_slider() -> Result<(), Error> {
    let mut solver = Solver::<SliderCrank, DenseLu<9>>::new(SliderCrank::default())?;
    let trajectory = solver.run(&benchmark_grid())?;
    for (k, state) in trajectory.iter().enumerate() {
        let [q, qd, qdd] = closed_form(solver.system(), state.t());
        let Some(b) = trajectory.point(k, Body::new(1), [0.5, 0.0]) else {
            unreachable!("body 1 exists");
        };
        assert_close("B", &b.position, &[q[6], 0.0], 1e-10);
        assert_close("Ḃ", &b.velocity, &[qd[6], 0.0], 1e-10);
        assert_close("B̈", &b.acceleration, &[qdd[6], 0.0], 1e-9);
    }
    Ok(())
}
