//! Named points and measures (`output NAME: EXPR;`) as results, through
//! both back ends: generated code and tapes agree to 1e-12; the
//! slider-crank's crank pin and the four-bar's coupler point match their
//! closed forms to 1e-10; the four-bar's transmission angle's derivatives
//! match finite differences of its values on a fine grid.

use std::f64::consts::{FRAC_PI_4, PI};

use kinema::{Auto, Motion, Options, Outputs, Solver, System, Trajectory};

mod generated {
    pub mod slider_crank {
        kinema::mechanism!(file = "models/slider_crank.kin");
    }
    pub mod four_bar {
        kinema::mechanism!(file = "models/four_bar.kin");
    }
}
use generated::four_bar::FourBar;
use generated::slider_crank::SliderCrank;

fn run<S: System>(system: S, times: &[f64]) -> (Trajectory, S) {
    let mut solver = Solver::<S, Auto>::with_options(system, Options::default())
        .unwrap_or_else(|e| panic!("solver: {e}"));
    let trajectory = solver
        .run(times)
        .unwrap_or_else(|e| panic!("analysis failed: {e}"));
    let system = solver.into_system();
    (trajectory, system)
}

fn tape(path: &str, times: &[f64]) -> (Trajectory, kinema::TapeSystem) {
    let model = kinema::Model::from_file(path).unwrap_or_else(|e| panic!("{e}"));
    run(model.system(), times)
}

/// 201 times over [0, 2]: two crank revolutions.
fn grid() -> Vec<f64> {
    (0..=200).map(|k| f64::from(k) / 100.0).collect()
}

/// Slider-crank: the crank pin A = l1 (cos φ1, sin φ1), φ1 = π/4 + 2πt, and
/// the ground pivot O = 0; both by name, on both back ends.
#[test]
fn slider_crank_crank_pin_closed_form() {
    let times: Vec<f64> = (0..=100).map(|k| f64::from(k) / 100.0).collect();
    let (gt, gs) = run(SliderCrank::default(), &times);
    let (tt, ts) = tape("models/slider_crank.kin", &times);
    let (l1, w) = (0.3, 2.0 * PI);
    let mut worst = 0.0_f64;
    for table in [gt.table(&gs), tt.table(&ts)] {
        let col = |n: &str| {
            table
                .column(n)
                .unwrap_or_else(|| panic!("no column `{n}`"))
                .to_vec()
        };
        let t = col("t");
        let got = [
            col("crank.pin.x"),
            col("crank.pin.y"),
            col("crank.pin.x_dot"),
            col("crank.pin.y_dot"),
            col("crank.pin.x_ddot"),
            col("crank.pin.y_ddot"),
            col("crank.o.x"),
            col("crank.o.y_dot"),
            col("crank.o.x_ddot"),
        ];
        for (k, &t) in t.iter().enumerate() {
            let (s, c) = (FRAC_PI_4 + w * t).sin_cos();
            let exact = [
                l1 * c,
                l1 * s,
                -l1 * w * s,
                l1 * w * c,
                -l1 * w * w * c,
                -l1 * w * w * s,
                0.0,
                0.0,
                0.0,
            ];
            for (g, e) in got.iter().zip(exact) {
                worst = worst.max((g[k] - e).abs());
            }
        }
    }
    println!("slider-crank crank pin: worst error {worst:e}");
    assert!(worst <= 1e-10, "{worst:e}");
    // The generated constants index the same columns.
    let state = &gt[10];
    let [y, yd, ydd] = SliderCrank::default().results(state);
    let (s, c) = (FRAC_PI_4 + w * state.t()).sin_cos();
    assert!((y[SliderCrank::OUT_CRANK_PIN_X] - l1 * c).abs() < 1e-10);
    assert!((yd[SliderCrank::OUT_CRANK_PIN_Y] - l1 * w * c).abs() < 1e-10);
    assert!((ydd[SliderCrank::OUT_CRANK_PIN_Y] + l1 * w * w * s).abs() < 1e-10);
    assert!((state.q()[SliderCrank::CRANK_PHI] - (FRAC_PI_4 + w * state.t())).abs() < 1e-12);
}

/// The four-bar in closed form (crank l1 = 0.3 at O, coupler l2 = 1,
/// rocker l3 = 0.8 at D = (1, 0), elbow up): B from the two circles, then
/// the loop l1 e1 + l2 e2 = D + l3 e3 differentiated by hand, projected on
/// e3 to eliminate the rocker. Returns P, Ṗ, P̈ of the coupler point
/// P = A + (l2/2 + 0.2) e2 + 0.3 e2⊥, and the transmission angle.
fn four_bar_closed_form(t: f64) -> ([[f64; 2]; 3], f64) {
    let (l1, l2, l3, l0, w) = (0.3, 1.0, 0.8, 1.0, 2.0 * PI);
    let th1 = FRAC_PI_4 + w * t;
    let a = [l1 * th1.cos(), l1 * th1.sin()];
    let d = [l0 - a[0], -a[1]];
    let dist = d[0].hypot(d[1]);
    let u = [d[0] / dist, d[1] / dist];
    let along = (l2 * l2 - l3 * l3 + dist * dist) / (2.0 * dist);
    let h = (l2 * l2 - along * along).sqrt();
    let b = [
        a[0] + along * u[0] - h * u[1],
        a[1] + along * u[1] + h * u[0],
    ];
    let th2 = (b[1] - a[1]).atan2(b[0] - a[0]);
    let th3 = b[1].atan2(b[0] - l0);
    let w2 = -l1 * w * (th3 - th1).sin() / (l2 * (th3 - th2).sin());
    let w3 = l1 * w * (th2 - th1).sin() / (l3 * (th2 - th3).sin());
    // e3 · (−l1 ω² e1 + l2 α2 e2⊥ − l2 ω2² e2) = −l3 ω3²
    let a2 = (-l3 * w3 * w3 + l1 * w * w * (th1 - th3).cos() + l2 * w2 * w2 * (th2 - th3).cos())
        / (l2 * (th3 - th2).sin());
    let e = |th: f64| [th.cos(), th.sin()];
    let p = |th: f64| [-th.sin(), th.cos()];
    let (e1, p1, e2, p2) = (e(th1), p(th1), e(th2), p(th2));
    let (ca, cb) = (l2 / 2.0 + 0.2, 0.3);
    let mut out = [[0.0; 2]; 3];
    for i in 0..2 {
        out[0][i] = l1 * e1[i] + ca * e2[i] + cb * p2[i];
        out[1][i] = l1 * w * p1[i] + w2 * (ca * p2[i] - cb * e2[i]);
        out[2][i] = -l1 * w * w * e1[i] + a2 * (ca * p2[i] - cb * e2[i])
            - w2 * w2 * (ca * e2[i] + cb * p2[i]);
    }
    (out, (th2 - th3).cos().acos())
}

#[test]
fn four_bar_coupler_point_closed_form() {
    let times = grid();
    let (gt, gs) = run(FourBar::default(), &times);
    let (tt, ts) = tape("models/four_bar.kin", &times);
    let mut worst = 0.0_f64;
    for table in [gt.table(&gs), tt.table(&ts)] {
        let col = |n: &str| {
            table
                .column(n)
                .unwrap_or_else(|| panic!("no column `{n}`"))
                .to_vec()
        };
        let t = col("t");
        let got = [
            [col("coupler.p.x"), col("coupler.p.y")],
            [col("coupler.p.x_dot"), col("coupler.p.y_dot")],
            [col("coupler.p.x_ddot"), col("coupler.p.y_ddot")],
        ];
        let mu = col("transmission");
        for (k, &t) in t.iter().enumerate() {
            let (exact, mu_exact) = four_bar_closed_form(t);
            for order in 0..3 {
                for i in 0..2 {
                    worst = worst.max((got[order][i][k] - exact[order][i]).abs());
                }
            }
            worst = worst.max((mu[k] - mu_exact).abs());
        }
    }
    println!("four-bar coupler point: worst error {worst:e}");
    assert!(worst <= 1e-10, "{worst:e}");
}

/// The transmission angle's `_dot` and `_ddot` columns against Richardson-
/// extrapolated central differences of its values on a grid of step 1e-3.
#[test]
fn transmission_angle_derivatives_match_finite_differences() {
    let h = 1e-3;
    let times: Vec<f64> = (0..=1000).map(|k| f64::from(k) * h).collect();
    let (trajectory, system) = tape("models/four_bar.kin", &times);
    let table = trajectory.table(&system);
    let col = |n: &str| table.column(n).unwrap_or_else(|| panic!("no column `{n}`"));
    let (mu, dot, ddot) = (
        col("transmission"),
        col("transmission_dot"),
        col("transmission_ddot"),
    );
    let (mut worst_dot, mut worst_ddot) = (0.0_f64, 0.0_f64);
    for k in 2..mu.len() - 2 {
        let d1 = |s: usize| (mu[k + s] - mu[k - s]) / (2.0 * s as f64 * h);
        let d2 = |s: usize| (mu[k + s] - 2.0 * mu[k] + mu[k - s]) / (s as f64 * h).powi(2);
        let fd_dot = (4.0 * d1(1) - d1(2)) / 3.0;
        let fd_ddot = (4.0 * d2(1) - d2(2)) / 3.0;
        worst_dot = worst_dot.max((dot[k] - fd_dot).abs() / (1.0 + dot[k].abs()));
        worst_ddot = worst_ddot.max((ddot[k] - fd_ddot).abs() / (1.0 + ddot[k].abs()));
    }
    println!("transmission angle vs finite differences: _dot {worst_dot:e}, _ddot {worst_ddot:e}");
    assert!(worst_dot <= 1e-8, "{worst_dot:e}");
    assert!(worst_ddot <= 1e-8, "{worst_ddot:e}");
}

/// Results of the wrong length are NaN, never a panic.
#[test]
fn wrong_lengths_give_nan() {
    let mech = FourBar::default();
    let mut scratch = mech.scratch();
    let (mut y, mut yd, mut ydd) = ([0.0; 3], [0.0; 3], [0.0; 3]);
    let at = Motion {
        t: 0.0,
        q: &[0.0; 2],
        qd: &[0.0; 9],
        qdd: &[0.0; 9],
    };
    mech.outputs(&mut scratch, at, [&mut y, &mut yd, &mut ydd]);
    assert!(y.iter().chain(&yd).chain(&ydd).all(|v| v.is_nan()));
    let model = kinema::Model::from_file("models/four_bar.kin").unwrap_or_else(|e| panic!("{e}"));
    let system = model.system();
    let mut scratch = system.scratch();
    let (mut y, mut yd, mut ydd) = ([0.0; 2], [0.0; 3], [0.0; 3]);
    let at = Motion {
        t: 0.0,
        q: &[0.0; 9],
        qd: &[0.0; 9],
        qdd: &[0.0; 9],
    };
    system.outputs(&mut scratch, at, [&mut y, &mut yd, &mut ydd]);
    assert!(y.iter().chain(&yd).chain(&ydd).all(|v| v.is_nan()));
}

/// The table's CSV has `kinema run`'s columns: coordinates, then results.
#[test]
fn table_csv_has_the_run_columns() {
    let (trajectory, system) = tape("models/slider_crank.kin", &[0.0, 0.1]);
    let table = trajectory.table(&system);
    let mut text = Vec::new();
    table.write_csv(&mut text).unwrap_or_else(|e| panic!("{e}"));
    let text = String::from_utf8(text).unwrap_or_default();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    assert_eq!(header.len(), 1 + 27 + 15);
    assert_eq!(header[28], "crank.o.x");
    assert_eq!(header[42], "reach_ddot");
    let row: Vec<f64> = lines
        .nth(1)
        .unwrap_or_default()
        .split(',')
        .map(|v| v.parse().unwrap_or(f64::NAN))
        .collect();
    assert_eq!(row[0], 0.1);
    let reach = table.column("reach").unwrap_or_default()[1];
    assert_eq!(row[32].to_bits(), reach.to_bits());
}
