//! A published mechanism against its closed form: Theo Jansen's Strandbeest
//! leg with his "holy numbers" (`models/jansen.kin`), over one crank turn.
//! Every joint point of the leg is a circle–circle intersection of points
//! found before it (a chain of RRR dyads), so its positions have a closed
//! form that shares nothing with kinema's Newton solve of the 21
//! absolute-coordinate equations; the rates are that closed form's central
//! differences.

use kinema::{Model, Options};

/// Jansen's lengths: a, b, c, d, e, f, g, h, i, j, k, l, m.
const A: f64 = 38.0;
const B: f64 = 41.5;
const C: f64 = 39.3;
const D: f64 = 40.1;
const E: f64 = 55.8;
const F: f64 = 39.4;
const G: f64 = 36.7;
const H: f64 = 65.7;
const I: f64 = 49.0;
const J: f64 = 50.0;
const K: f64 = 61.9;
const L: f64 = 7.8;
const M: f64 = 15.0;

type P = [f64; 2];

/// The two intersections of the circle about `p` of radius `rp` and the
/// circle about `q` of radius `rq`.
fn intersections(p: P, rp: f64, q: P, rq: f64) -> [P; 2] {
    let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
    let dist = dx.hypot(dy);
    let along = (rp * rp - rq * rq + dist * dist) / (2.0 * dist);
    let across = (rp * rp - along * along).sqrt();
    let (ux, uy) = (dx / dist, dy / dist);
    let base = [p[0] + along * ux, p[1] + along * uy];
    [
        [base[0] - across * uy, base[1] + across * ux],
        [base[0] + across * uy, base[1] - across * ux],
    ]
}

fn distance(p: P, q: P) -> f64 {
    (p[0] - q[0]).hypot(p[1] - q[1])
}

/// The leg's joint points A, C, D, E, F and the foot G at crank angle
/// `theta`, each intersection the one nearer the same point of `near`
/// (the motion is continuous).
fn leg(theta: f64, near: &[P; 6]) -> [P; 6] {
    let pick = |p: P, rp: f64, q: P, rq: f64, near: P| {
        let [u, v] = intersections(p, rp, q, rq);
        if distance(u, near) <= distance(v, near) {
            u
        } else {
            v
        }
    };
    let b = [-A, -L];
    let a = [M * theta.cos(), M * theta.sin()];
    let c = pick(a, J, b, B, near[1]);
    let d = pick(a, K, b, C, near[2]);
    let e = pick(b, D, c, E, near[3]);
    let f = pick(e, F, d, G, near[4]);
    let g = pick(d, I, f, H, near[5]);
    [a, c, d, e, f, g]
}

/// The model's named points for A, C, D, E, F and the foot G.
const POINTS: [&str; 6] = [
    "crank.a", "link_j.c", "link_k.d", "rocker.e", "link_f.f", "foot.g",
];

#[test]
fn jansen_leg_follows_its_closed_form_over_a_turn() {
    let model = Model::from_file("models/jansen.kin").unwrap_or_else(|e| panic!("{e}"));
    let mut solver = model
        .solver(Options::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let omega = std::f64::consts::TAU;
    let times: Vec<f64> = (0..=360).map(|k| f64::from(k) / 360.0).collect();
    let trajectory = solver.run(&times).unwrap_or_else(|e| panic!("{e}"));
    assert!(trajectory.events().is_empty(), "{:?}", trajectory.events());
    assert!(
        trajectory
            .iter()
            .all(|s| !s.near_singular() && s.kink().is_none())
    );
    // The points' columns (x, y; ẋ, ẏ; ẍ, ÿ), from the model's results.
    let table = trajectory.table(solver.system());
    let column = |name: String| {
        table
            .column(&name)
            .unwrap_or_else(|| panic!("no column {name}"))
    };
    let at = |point: &str, suffix: &str, row: usize| {
        [
            column(format!("{point}.x{suffix}"))[row],
            column(format!("{point}.y{suffix}"))[row],
        ]
    };
    // The closed form starts on kinema's assembled branch.
    let mut near = POINTS.map(|point| at(point, "", 0));
    let (mut position, mut velocity, mut acceleration) = (0.0f64, 0.0f64, 0.0f64);
    for (row, &t) in times.iter().enumerate() {
        let exact = leg(omega * t, &near);
        for (point, x) in POINTS.iter().zip(&exact) {
            position = position.max(distance(at(point, "", row), *x));
        }
        // Every point's rates against central differences of the closed
        // form in t (h = 1e-6 for the velocity, 1e-4 for the acceleration).
        let moved = |dt: f64| leg(omega * (t + dt), &exact);
        let (h, ahead, behind) = (1e-6, moved(1e-6), moved(-1e-6));
        let (h2, ahead2, behind2) = (1e-4, moved(1e-4), moved(-1e-4));
        for (k, point) in POINTS.iter().enumerate() {
            let v = [0, 1].map(|c| (ahead[k][c] - behind[k][c]) / (2.0 * h));
            let a = [0, 1].map(|c| (ahead2[k][c] - 2.0 * exact[k][c] + behind2[k][c]) / (h2 * h2));
            let relative = |x: P, y: P| distance(x, y) / y[0].hypot(y[1]).max(1.0);
            velocity = velocity.max(relative(at(point, "_dot", row), v));
            acceleration = acceleration.max(relative(at(point, "_ddot", row), a));
        }
        near = exact;
    }
    // Newton's tolerance (‖Φ‖∞ ≤ 1e-12 at lengths of 8 to 66) against
    // the closed form's rounding; the differences' truncation and
    // rounding (≈ 1e-9 relative for the velocity, ≈ 1e-5 for the
    // acceleration).
    assert!(position < 1e-10, "points differ by up to {position:e}");
    assert!(
        velocity < 1e-7,
        "velocities differ by up to {velocity:e} (relative)"
    );
    assert!(
        acceleration < 1e-4,
        "accelerations differ by up to {acceleration:e} (relative)"
    );
}
