//! The emitted `.kin` text, read back by kinema's own model parser: it
//! parses and validates, and the Φ it derives equals the engine's equations
//! of docs/src/simengine2d.md, evaluated here directly from the ADM data, at random
//! configurations and times, row by row in the engine's order.

#![allow(clippy::unwrap_used)] // tests: a failure should stop the test

mod common;

use kinema_adm::{ConstraintKind, Counts, Model, Names, to_kin};

/// Φ(q, t) of docs/src/simengine2d.md, computed from the ADM model.
fn engine_phi(m: &Model, q: &[f64], t: f64) -> Vec<f64> {
    let r = |i: usize| [q[3 * i], q[3 * i + 1]];
    let a = |i: usize, s: [f64; 2]| {
        let (sn, c) = q[3 * i + 2].sin_cos();
        [c * s[0] - sn * s[1], sn * s[0] + c * s[1]]
    };
    let point = |i: usize, s: [f64; 2]| {
        let (ri, v) = (r(i), a(i, s));
        [ri[0] + v[0], ri[1] + v[1]]
    };
    let perp = |v: [f64; 2]| [-v[1], v[0]];
    let dot = |u: [f64; 2], v: [f64; 2]| u[0] * v[0] + u[1] * v[1];
    let sub = |u: [f64; 2], v: [f64; 2]| [u[0] - v[0], u[1] - v[1]];
    let unit = |v: [f64; 2]| {
        let n = dot(v, v).sqrt();
        [v[0] / n, v[1] / n]
    };
    let mut phi = Vec::new();
    for c in &m.constraints {
        match &c.kind {
            ConstraintKind::AbsoluteX { body1, sp1, fun } => {
                phi.push(point(*body1, *sp1)[0] - fun.eval(t));
            }
            ConstraintKind::AbsoluteY { body1, sp1, fun } => {
                phi.push(point(*body1, *sp1)[1] - fun.eval(t));
            }
            ConstraintKind::AbsoluteAngle { body1, fun } => {
                phi.push(q[3 * body1 + 2] - fun.eval(t))
            }
            ConstraintKind::Revolute {
                body1,
                sp1,
                body2,
                sp2,
                ..
            } => {
                let d = sub(point(*body1, *sp1), point(*body2, *sp2));
                phi.extend(d);
            }
            ConstraintKind::Translational {
                body1,
                sp1,
                vp1,
                body2,
                sp2,
                vp2,
                ..
            } => {
                let n1 = perp(a(*body1, unit(*vp1)));
                let d = sub(point(*body2, *sp2), point(*body1, *sp1));
                phi.push(dot(n1, d));
                phi.push(dot(n1, a(*body2, unit(*vp2))));
            }
            ConstraintKind::RackPinion {
                body1,
                body2,
                sp1,
                sq1,
                sp2,
                r2,
                theta1,
                theta2,
                ..
            } => {
                let u = sub(*sq1, *sp1);
                let l = dot(u, u).sqrt();
                let au = a(*body1, u);
                let alpha = q[3 * body1 + 2] + theta1 - q[3 * body2 + 2] - theta2
                    + 3.0 * std::f64::consts::PI / 2.0;
                let centre = point(*body2, *sp2);
                phi.push(dot(sub(centre, point(*body1, *sq1)), au) - l * r2 * alpha);
                phi.push(dot(sub(centre, point(*body1, *sp1)), perp(au)) - l * r2);
            }
        }
    }
    phi
}

/// What kinema's row is of the engine's, row by row in the engine's order:
/// a RackPinion's rows are the engine's divided by the pitch line's length
/// L = |sQ1 − sP1| (kinema's `rack_pinion` is unit-scaled), the others
/// equal.
fn row_divisors(m: &Model) -> Vec<f64> {
    let mut out = Vec::new();
    for c in &m.constraints {
        match &c.kind {
            ConstraintKind::RackPinion { sp1, sq1, .. } => {
                let l = (sq1[0] - sp1[0]).hypot(sq1[1] - sp1[1]);
                out.extend([l, l]);
            }
            ConstraintKind::Revolute { .. } | ConstraintKind::Translational { .. } => {
                out.extend([1.0, 1.0]);
            }
            _ => out.push(1.0),
        }
    }
    out
}

/// Parses the emitted text with kinema-model; for NDOF = 0 models also
/// validates and derives it and compares Φ with [`engine_phi`].
fn check(name: &str, m: &Model) {
    let kin = to_kin(m);
    let parsed = kinema_model::ParsedModel::parse_str(&kin)
        .unwrap_or_else(|d| panic!("{name}: {}\n{kin}", d.render(&kin, name)));
    if Counts::of(m).ndof() != 0 {
        return; // validation refuses NDOF != 0, as it should
    }
    let checked = parsed
        .check()
        .unwrap_or_else(|d| panic!("{name}: {}\n{kin}", d.render(&kin, name)));
    let d = kinema_model::Derivation::new(&checked)
        .unwrap_or_else(|d| panic!("{name}: {}\n{kin}", d.render(&kin, name)));
    assert_eq!(d.bodies.len(), m.bodies.len(), "{name}");
    assert_eq!(d.phi.len(), Counts::of(m).m, "{name}");
    // Guesses are the q0 of the file.
    let guess: Vec<f64> = d.coordinates.iter().map(|c| c.guess_value).collect();
    assert_eq!(guess, m.q0(), "{name}");
    let scale = m.q0().iter().fold(1.0f64, |acc, x| acc.max(x.abs()));
    let engine_rows: Vec<String> = Names::of(m).rows(m).into_iter().map(|r| r.row).collect();
    assert_eq!(engine_rows.len(), d.rows.len(), "{name}");
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut random = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..20 {
        let q: Vec<f64> = (0..d.coordinates.len())
            .map(|k| {
                let x = 4.0 * random() - 2.0;
                if k % 3 == 2 { x } else { x * scale }
            })
            .collect();
        let t = 2.0 * random();
        let ours = d.arena.eval_many(&d.phi, |s| {
            if s == d.time {
                return t;
            }
            d.coordinates
                .iter()
                .position(|c| c.sym == s)
                .map_or(f64::NAN, |k| q[k])
        });
        let engine = engine_phi(m, &q, t);
        // kinema orders kinematic rows before driving rows; match by name.
        for ((row, b), divisor) in engine_rows.iter().zip(&engine).zip(row_divisors(m)) {
            let b = b / divisor;
            let k = d
                .rows
                .iter()
                .position(|r| r.name == *row)
                .unwrap_or_else(|| panic!("{name}: no row {row} in kinema's derivation"));
            let a = ours[k];
            let tol = 1e-12 * scale * scale.max(10.0);
            assert!(
                (a - b).abs() <= tol,
                "{name}: row {row}: kinema {a} vs engine {b} at q = {q:?}, t = {t}\n{kin}"
            );
        }
    }
}

#[test]
fn own_files_round_trip_through_kinema_model() {
    for name in [
        "absolute_pendulum.adm",
        "slider_crank.adm",
        "four_bar.adm",
        "translational.adm",
        "rack_pinion.adm",
        "rack_pinion_tilting.adm",
        "free_pendulum.adm",
    ] {
        let m = Model::parse(&common::source(name)).unwrap();
        check(name, &m);
    }
}

#[test]
fn real_files_round_trip_through_kinema_model() {
    let Some(paths) = common::shared_models() else {
        return;
    };
    for path in paths {
        let m = Model::read(&path).unwrap().0;
        check(&path.display().to_string(), &m);
    }
}
